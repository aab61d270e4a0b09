"""Shared fixtures, the hypothesis profile, and the CI rule: a test that
cannot run fails in CI instead of being skipped (ci_rules.py)."""

from __future__ import annotations

import os

import pytest
from hypothesis import HealthCheck, settings

import hpctl

# Hooks: under CI a skip is reported as a failure (ci_rules.py).
from ci_rules import pytest_make_collect_report, pytest_runtest_makereport  # noqa: F401


def pytest_configure(config: pytest.Config) -> None:
    # The slowest randomised draws with their seeds in the summary
    # (draws.py); a plugin of its own, as its report hook has ci_rules's name.
    import draws

    if not config.pluginmanager.is_registered(draws):
        config.pluginmanager.register(draws, "hpctl-draws")


settings.register_profile("ci", max_examples=200, deadline=None, suppress_health_check=[HealthCheck.too_slow])
settings.register_profile("thorough", max_examples=2000, deadline=None, suppress_health_check=[HealthCheck.too_slow])
settings.load_profile(os.environ.get("HYPOTHESIS_PROFILE", "ci"))


@pytest.fixture(scope="session")
def seed_unit() -> hpctl.Unit:
    return hpctl.Unit.seed()

"""Shared fixtures, the hypothesis profile, and the CI rule: a test that
cannot run fails in CI instead of being skipped (ci_rules.py)."""

from __future__ import annotations

import os

import pytest
from hypothesis import HealthCheck, settings

import hpctl

# Hooks: under CI a skip is reported as a failure (ci_rules.py).
from ci_rules import pytest_make_collect_report, pytest_runtest_makereport  # noqa: F401

settings.register_profile("ci", max_examples=200, deadline=None, suppress_health_check=[HealthCheck.too_slow])
settings.register_profile("thorough", max_examples=2000, deadline=None, suppress_health_check=[HealthCheck.too_slow])
settings.load_profile(os.environ.get("HYPOTHESIS_PROFILE", "ci"))


@pytest.fixture(scope="session")
def seed_unit() -> hpctl.Unit:
    return hpctl.Unit.seed()


#: Test files collected first. scripts/test.sh gives each file to one
#: pytest-xdist worker, in collection order (its --no-loadscope-reorder).
#: A file that runs far longer than the others should start at once, so
#: that the other worker runs the rest meanwhile. This is
#: longest-processing-time-first scheduling. Measured from CI's
#: --durations (stop 44, one worker per core on 2 cores): this file took
#: about 1,250 s of the pytest run's 1,676 s, and its worker started it
#: midway through the alphabet.
LONGEST_FIRST = ("test_diagnose_foreign.py",)


def pytest_collection_modifyitems(items: list[pytest.Item]) -> None:
    items.sort(key=lambda item: item.path.name not in LONGEST_FIRST)  # stable: every file's own order kept

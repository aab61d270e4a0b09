"""Shared fixtures, the hypothesis profile, and the CI rule: a test that
cannot run fails in CI instead of being skipped (ci_rules.py)."""

from __future__ import annotations

import os
from typing import TYPE_CHECKING

import pytest
from hypothesis import HealthCheck, settings

import hpctl

if TYPE_CHECKING:
    from hpctl.identify.fit import FitResult

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


@pytest.fixture(scope="session")
def at_noise() -> FitResult:
    """The seed unit fitted to its own SDOF step (hpctl's virtual rig, 5 s
    at 200 Hz, the damper off), at the noise: what the judgement's tests
    (test_judge_jitter.py, test_judge_colour.py) add a clock's jitter, a
    correlated noise or a misfit to. The damper off: under-damped, so the
    body passes its fastest speeds (0.4 m/s) several times, and a jitter's
    3 standard errors are reached from about 30 us (with the damper on, its
    one fast rise holds about 3.5 errors at most, and hpctl's own fit
    leaves 1.44 x the noise there: the base's noise through the damper,
    which the weights of an SDOF record do not carry; noted in
    docs/foreign-rig.md)."""
    from hpctl.identify import virtual_rig
    from hpctl.identify.dataset import prepare
    from hpctl.identify.fit import fit
    from hpctl.sim.run import Step

    step = virtual_rig.Test("sdof_step", Step(0.043, 0.5, 0.05), 5.0, 1000, sdof=True, damper_on=False, excitation="step")
    records = virtual_rig.make_records(hpctl.Unit.seed(), tests=[step], seed=3)
    return fit(prepare(records), ("heat_transfer", "real_gas"), input_noise=False)

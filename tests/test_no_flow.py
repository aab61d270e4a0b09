"""A flexible fit without friction whose damper took a seal's force into its
curve says so (:mod:`hpctl.identify.no_flow`); a model with friction, or
without the damper's characteristic, is never asked. Records of hp-core's
virtual rig, the seed's unit with seal friction, the sweep's slow sines
(tests/test_diagnose_foreign.py has the foreign rig's case)."""

from __future__ import annotations

import pytest

from hpctl.identify import MAX_NFEV_FLEXIBLE
from hpctl.identify.dataset import Dataset, prepare
from hpctl.identify.fit import FitResult, fit
from hpctl.identify.no_flow import NO_FLOW_NOISES, force_at_no_flow
from hpctl.identify.virtual_rig import Noise, make_records, sweep_tests, truth_unit

SLOW = [t for t in sweep_tests() if t.name in ("sine_0.03hz", "sine_0.1hz")]
#: A seal of 400 N smoothed over 1 mm/s: at 2 mm/s about 390 N, against a
#: force noise of 30 N.
SEAL = {"friction_coulomb_n": 400.0, "friction_viscous_n_s_per_m": 500.0}


@pytest.fixture(scope="module")
def records() -> list[Dataset]:
    return prepare(make_records(truth_unit(("friction",), SEAL), tests=SLOW, noise=Noise(force_n=30.0), seed=5))


def fitted(records: list[Dataset], effects: tuple[str, ...], flexible: bool = True) -> FitResult:
    return fit(records, effects, flexible=flexible, max_nfev=MAX_NFEV_FLEXIBLE, errors=False)


def test_a_damper_that_took_the_seal_says_so(records: list[Dataset]) -> None:
    r = fitted(records, ("heat_transfer", "real_gas"))
    found = force_at_no_flow(r)
    assert {f.branch for f in found} == {"off_compression", "off_rebound"}, (r.rms_ratio, found)
    for f in found:
        assert f.force_n - f.template_n > NO_FLOW_NOISES * f.noise_n and f.noise_n > 0.0


def test_with_friction_in_the_model_or_no_characteristic_it_is_never_asked(records: list[Dataset]) -> None:
    assert force_at_no_flow(fitted(records, ("heat_transfer", "real_gas", "friction"))) == []
    assert force_at_no_flow(fitted(records, ("heat_transfer", "real_gas"), flexible=False)) == []


def test_without_a_seal_the_damper_makes_none() -> None:
    quiet = prepare(make_records(truth_unit((), {}), tests=SLOW, noise=Noise(force_n=30.0), seed=5))
    assert force_at_no_flow(fitted(quiet, ("heat_transfer", "real_gas"))) == []

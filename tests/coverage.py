"""Coverage of the fit's standard errors on randomised hp-core virtual-rig
runs: each run draws the truth (the registry's random ranges) and the
noise anew, fits, and records for every parameter with a known truth
whether it lies within 2 standard errors of the estimate. Used by
tests/test_coverage.py and scripts/coverage_stderr.py."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from hpctl.identify import virtual_rig
from hpctl.identify.dataset import prepare
from hpctl.identify.fit import fit

#: The model fitted: the seed's gas plus friction, on the 5-sine sweep.
EFFECTS = ("heat_transfer", "real_gas", "friction")
DRAWN = ("heat_transfer", "friction")
#: Truths the draw does not set: the unit's declared charge and damper.
FIXED_TRUTH = {"charge_scale": 1.0, "damper_gain": 1.0}


@dataclass(frozen=True)
class Run:
    seed: int
    truth: dict[str, float]
    values: dict[str, float]
    stderr: dict[str, float]
    rms_ratio: float

    def z(self, name: str) -> float:
        """(estimate - truth) / standard error."""
        return (self.values[name] - self.truth[name]) / self.stderr[name]


def run(seed: int, flexible: bool = False) -> Run:
    rng = np.random.default_rng(seed)
    truth = virtual_rig.effect_values(DRAWN, rng)
    unit = virtual_rig.truth_unit(("friction",), truth)
    records = virtual_rig.make_records(unit, "sweep", seed=int(rng.integers(2**31)))
    r = fit(prepare(records), EFFECTS, flexible=flexible)
    known = {**truth, **{k: v for k, v in FIXED_TRUTH.items() if k in r.values}}
    return Run(seed, known, dict(r.values), dict(r.stderr), r.rms_ratio)


def inside(runs: Sequence[Run], name: str, k: float = 2.0) -> int:
    """How many runs have the truth of ``name`` within ``k`` standard errors."""
    return sum(abs(r.z(name)) <= k for r in runs)

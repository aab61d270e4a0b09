"""A static damper fit's problem and its solution from one start: what
a worker process needs of :mod:`hpctl.identify.damper_start` (which builds
the problem from the records, keeps the fits and starts them in workers).

Why a module of its own: a worker imports what its tasks need before the
first of them runs, and :mod:`~hpctl.identify.damper_start` reads records
with SciPy's signal filters (with the rest of hpctl's identification
behind them): 0.9 s of CPU a worker against about 0.45 s for this module
(NumPy, SciPy's optimiser, hp-core's damper), paid by the static fits of
``hpctl fit --flexible`` and of a diagnosis's first round, which wait for
the workers while the CPU is busiest (stop 61).
"""

from __future__ import annotations

import dataclasses
import warnings

import numpy as np
from numpy.typing import NDArray
from scipy.optimize import least_squares

from hpctl import _core
from hpctl.model.effects import Param, shaped_damper
from hpctl.model.unit import Damper

FloatArray = NDArray[np.float64]

#: Robust loss scale, in noise units: a sample further off (an end stop's
#: force, a valve's transient) counts linearly, not squared.
LOSS_SCALE = 3.0
#: Evaluations per start (each costs a few milliseconds).
MAX_NFEV = 200


@dataclasses.dataclass(frozen=True)
class Samples:
    """One branch's samples: the flow out of the strut, m^3/s (signed), the
    force to explain, N, its noise, N, and the piston area, m^2 (per sample)."""

    q_m3_s: FloatArray
    force_n: FloatArray
    sigma_n: FloatArray
    area_m2: FloatArray
    transducer: FloatArray


@dataclasses.dataclass(frozen=True)
class StaticProblem:
    """One static fit as its starts need it (:func:`hpctl.identify.damper_start.fit_static_damper`),
    picklable: a worker process solves a start (:func:`solve_start`).
    ``x`` is the fit's vector: the branches' shape parameters (in the fit's
    coordinates), the shared constants (N), the friction's shape."""

    nominal: Damper
    branches: tuple[str, ...]
    samples: tuple[Samples, ...]
    shape: tuple[Param, ...]
    constants: tuple[str, ...]
    friction_shape: tuple[Param, ...]
    lo: FloatArray
    hi: FloatArray
    prior: tuple[tuple[int, float, float], ...]
    smoothing_m_s: float
    sparsity: NDArray[np.bool_]
    starts: tuple[FloatArray, ...] = ()


class StaticResidual:
    """A :class:`StaticProblem`'s residual, in noise units."""

    def __init__(self, problem: StaticProblem) -> None:
        self.p = problem
        self.n_shape = len(problem.shape)
        self.n_fixed = self.n_shape + len(problem.constants)
        self.speeds = [s.q_m3_s / s.area_m2 for s in problem.samples]
        # The branches' flows by valve 5's state, each state's in one call of
        # the core: a call reads the whole damper and picks each sample's branch
        # by its flow's sign, so one call per state gives every branch's drop
        # (the same per sample) for half the calls' overhead.
        samples = problem.samples
        self.by_state = [(bypass, ks, np.concatenate([samples[k].q_m3_s for k in ks]), np.cumsum([len(samples[k].q_m3_s) for k in ks])[:-1])
                         for bypass, ks in ((0.0, [k for k, b in enumerate(problem.branches) if b.startswith("on_")]),
                                            (1.0, [k for k, b in enumerate(problem.branches) if not b.startswith("on_")])) if ks]

    def columns(self, x: FloatArray) -> list[FloatArray]:
        # hp-core's friction law (`Friction::force_n`) per newton of Coulomb
        # force, written out here: through `_core.friction_force_n` the
        # static fit's values move in their last bits, and those of a fit
        # started from them by 6e-5 in the residual after one step (the
        # shape parameters these records leave unidentified follow the
        # rounding: tests/test_fit_output_only.py).
        p = self.p
        level, smooth = [np.ones(len(v)) for v in self.speeds], p.smoothing_m_s
        if p.friction_shape:
            ratio, velocity_m_s, smooth = (q.from_x(float(xi)) for q, xi in zip(p.friction_shape, x[self.n_fixed:]))
            level = [1.0 + (ratio - 1.0) * np.exp(-((v / velocity_m_s) ** 2)) for v in self.speeds]
        return [np.array([s.transducer if c == "offset" else lv * np.tanh(v / smooth) for c in p.constants])
                .reshape(len(p.constants), len(v)).T for v, lv, s in zip(self.speeds, level, p.samples)]

    def residual(self, x: FloatArray) -> FloatArray:
        p = self.p
        values = {q.name: q.from_x(float(xi)) for q, xi in zip(p.shape, x[:self.n_shape])}
        damper = shaped_damper(p.nominal, values).to_dict()
        drops: list[FloatArray] = [np.empty(0)] * len(p.samples)
        for bypass, ks, q, cuts in self.by_state:
            for k, dp in zip(ks, np.split(_core.damper_pressure_drop_pa(damper, q, bypass), cuts)):
                drops[k] = dp
        rows = []
        for s, cols, dp in zip(p.samples, self.columns(x), drops):
            force = s.area_m2 * dp + cols @ x[self.n_shape:self.n_fixed]
            rows.append((force - s.force_n) / s.sigma_n)
        return np.concatenate(rows + [np.array([(x[i] - c) / sd for i, c, sd in p.prior])])


def solve_start(problem: StaticProblem, k: int) -> tuple[FloatArray, float] | None:
    """The static fit from ``problem``'s start ``k``: where it ends and its
    cost, or None where the curve cannot be evaluated there (or it ends
    off the finite numbers)."""
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            sol = least_squares(StaticResidual(problem).residual, problem.starts[k], bounds=(problem.lo, problem.hi), method="trf", loss="soft_l1",
                                f_scale=LOSS_SCALE, x_scale="jac", jac_sparsity=problem.sparsity, max_nfev=MAX_NFEV)
    except (ValueError, _core.HpctlError):
        return None
    return (sol.x, float(sol.cost)) if np.all(np.isfinite(sol.x)) else None

"""Whether seal friction's Coulomb force can be told apart from the damper
at all, without noise or dynamics: the foreign rig's true steady force
beyond the gas (its friction plus its damper with valve 5 open, at the
five-sine sweep's speeds, weighted as the sines sample them) fitted by
hp-core's friction (Coulomb, Stribeck ratio and velocity, smoothing,
viscous) plus hpctl's damper-curve family per direction (bleed beside the
orifice, blow-off, knee, second stage), and again with the friction held
at the truth. Multi-start least squares on the curves alone: what the
model's shapes let the split be (docs/foreign-rig.md, stop 35).

    python scripts/foreign_friction_split.py --seeds 1 4 5 10 14 16 19 20
    python scripts/foreign_friction_split.py --family transition --seeds 1 2 4 5 8 10 14
    python scripts/foreign_friction_split.py --family hpctl --seeds 3 5 10 14
    python scripts/foreign_friction_split.py --family hpctl --max-speed 0.1 --seeds 1 2 3 5 8 10 14

``--family``: ``parallel`` (the default, stop 35's table) is the bleed
beside a turbulent orifice; ``transition`` the bleed beside an orifice
laminar below a fitted pressure and turbulent above it (valve 6's law in
hp-core, ``foreign_damper_family._curve_transition``); ``hpctl`` the
flexible model's own damper parameters for valve 5 open
(``hpctl.model.effects.DAMPER_SHAPE``: a bleed in series with the orifice
and a share of it beside, the knee, two stages), evaluated by hp-core's
curve on the draw's record template, without their priors (stop 66).

Run from the repository root (``tests/`` holds the foreign rig). Prints per
seed the RMS error of the best fit, N, its Coulomb force, breakaway force
(Coulomb times Stribeck ratio), Stribeck velocity and smoothing against the
truth, and the RMS error with the friction at the truth.
"""

from __future__ import annotations

import argparse
import sys
import warnings
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

import numpy as np
from scipy.optimize import OptimizeResult, least_squares

sys.path.insert(0, str(Path(__file__).resolve().parent.parent / "tests"))
sys.path.insert(0, str(Path(__file__).resolve().parent))

from foreign_damper_family import _curve, _curve_transition  # noqa: E402
from foreign_rig import generate  # noqa: E402
from foreign_rig.damper import Damper  # noqa: E402
from foreign_rig.draw import draw_case  # noqa: E402
from foreign_rig.programs import SWEEP_FREQUENCIES_HZ  # noqa: E402
from foreign_rig.unit import Friction as ForeignFriction  # noqa: E402
from hpctl import _core  # noqa: E402
from hpctl.identify.dataset import prepare  # noqa: E402
from hpctl.identify.fit import model_for  # noqa: E402

AMPLITUDE_M = 0.06
#: The damper-curve parameters' bounds (logs but the knee): as foreign_damper_family.
CURVE_LO = [-np.inf] * 4 + [0.0] + [-np.inf] * 2
CURVE_HI = [np.inf] * 4 + [2.0] + [np.inf] * 2
#: Friction's bounds: hpctl's fit ranges (Coulomb, ratio, log Stribeck velocity, log smoothing, viscous).
FRICTION_LO = [0.0, 1.0, np.log(1e-3), np.log(1e-4), 0.0]
FRICTION_HI = [5000.0, 3.0, np.log(0.1), np.log(2e-2), 20000.0]
#: The transition pressure's bounds (log Pa) and starts, ``--family transition``.
TRANSITION_LO, TRANSITION_HI = np.log(1e2), np.log(1e8)
TRANSITION_STARTS_PA = (1e4, 1e6)


def friction(v: np.ndarray, fc: float, ratio: float, vs: float, ve: float, c: float) -> np.ndarray:
    # hp-core's Friction::force (unit.rs) for v >= 0.
    return np.asarray(fc * (1.0 + (ratio - 1.0) * np.exp(-((v / vs) ** 2))) * np.tanh(v / ve) + c * v)


def sweep_speeds(max_speed_m_s: float = np.inf) -> np.ndarray:
    """The sweep's speeds (each sine's half cycle evenly in time), those
    below ``max_speed_m_s`` only."""
    v = np.concatenate([AMPLITUDE_M * 2 * np.pi * f * np.abs(np.sin(np.linspace(0.0, np.pi, 200))) for f in SWEEP_FREQUENCIES_HZ])
    return v[(v > 1e-6) & (v < max_speed_m_s)]


def truth_curves(seed: int, max_speed_m_s: float) -> tuple[ForeignFriction, np.ndarray, float, list[np.ndarray]]:
    """The draw's friction, the speeds, its piston area and the true force
    beyond the gas (damper with valve 5 open plus friction, magnitudes) in
    compression and in rebound."""
    case = draw_case("friction", seed)
    f = case.unit.effects.friction
    assert f is not None
    damper, area, v = Damper(case.unit.damper), case.unit.piston_area_m2, sweep_speeds(max_speed_m_s)
    true_f = friction(v, f.coulomb_n, f.static_ratio, f.stribeck_velocity_m_s, f.smoothing_velocity_m_s, f.viscous_n_s_per_m)
    return f, v, area, [np.array([s * damper.drop(s * area * x, 1.0) * area for x in v]) + true_f for s in (1.0, -1.0)]


def solve(fun: Callable[[np.ndarray], np.ndarray], p0: Sequence[float], lo: Sequence[float], hi: Sequence[float],
          max_nfev: int = 3000, **kw: Any) -> OptimizeResult | None:
    """Bounded least squares, None where the model refused the parameters."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        try:
            return least_squares(fun, p0, bounds=(lo, hi), max_nfev=max_nfev, **kw)
        except ValueError:  # hp-core refuses a curve out of its range (a second stage)
            return None


def row(seed: int, f: ForeignFriction, best: OptimizeResult, held: OptimizeResult | None) -> str:
    """The printed line: ``best.x`` starts with the friction (Coulomb,
    ratio, log Stribeck velocity, log smoothing, viscous)."""
    p = best.x
    rms = np.sqrt(2.0 * best.cost / best.fun.size)
    rms_held = np.sqrt(2.0 * held.cost / held.fun.size) if held is not None else float("nan")
    fs_true = f.coulomb_n * f.static_ratio
    return (f"{seed} | {rms:.2f} | {p[0]:.0f} / {f.coulomb_n:.0f} ({p[0] / f.coulomb_n - 1:+.1%}) | "
            f"{p[0] * p[1]:.0f} / {fs_true:.0f} ({p[0] * p[1] / fs_true - 1:+.1%}) | "
            f"{np.exp(p[2]) * 1e3:.1f} / {f.stribeck_velocity_m_s * 1e3:.1f} | {np.exp(p[3]) * 1e3:.2f} / {f.smoothing_velocity_m_s * 1e3:.2f} | "
            f"{rms_held:.2f}")


def fit_split(seed: int, family: str = "parallel", max_speed_m_s: float = np.inf) -> str:
    if family == "hpctl":
        return fit_split_hpctl(seed, max_speed_m_s)
    transition = family == "transition"
    f, v, area, target = truth_curves(seed, max_speed_m_s)

    n = 8 if transition else 7
    lo_curve = CURVE_LO + [TRANSITION_LO] if transition else CURVE_LO
    hi_curve = CURVE_HI + [TRANSITION_HI] if transition else CURVE_HI

    def curve(p: np.ndarray) -> np.ndarray:
        return _curve_transition(p, area * v) if transition else _curve(p, area * v, True)

    def residual(p: np.ndarray) -> np.ndarray:
        fp = friction(v, p[0], p[1], np.exp(p[2]), np.exp(p[3]), p[4])
        return np.concatenate([curve(p[5 + n * i:5 + n * (i + 1)]) * area + fp - target[i] for i in range(2)])

    best = None
    for share in (0.5, 1.0, 1.5):
        for pb0 in (1e6, 3e6):
            for dt0 in TRANSITION_STARTS_PA if transition else (None,):
                curve0 = [np.log(3e10), np.log(1e14), np.log(pb0), np.log(3e9), 0.5, 0.0, np.log(3e9)] + ([np.log(dt0)] if dt0 else [])
                p0 = [f.coulomb_n * share, 1.2, np.log(0.01), np.log(1e-3), 500.0, *curve0, *curve0]
                sol = solve(residual, p0, FRICTION_LO + lo_curve * 2, FRICTION_HI + hi_curve * 2)
                if sol is not None and (best is None or sol.cost < best.cost):
                    best = sol
    if best is None:
        return f"{seed} | no fit"
    truth = [f.coulomb_n, f.static_ratio, np.log(f.stribeck_velocity_m_s), np.log(f.smoothing_velocity_m_s), f.viscous_n_s_per_m]
    held = solve(lambda c: residual(np.concatenate([truth, c])), list(best.x[5:]), lo_curve * 2, hi_curve * 2)
    return row(seed, f, best, held)


def fit_split_hpctl(seed: int, max_speed_m_s: float = np.inf) -> str:
    """:func:`fit_split` with the flexible model's damper parameters of the
    valve-5-open branches on the draw's record template (hp-core's curve)."""
    f, v, _, targets = truth_curves(seed, max_speed_m_s)
    target = np.concatenate(targets)
    datasets = prepare(generate("friction", seed).read())
    model = model_for(datasets, ("heat_transfer", "real_gas", "friction"), flexible=True)
    shape = [p for p in model.params if p.name.startswith("damper_off_")]
    values = {p.name: p.initial for p in model.params}
    area_model = datasets[0].base.piston_area_m2
    q = np.concatenate([area_model * v, -area_model * v])

    def force(x: np.ndarray, fc: float, ratio: float, vs: float, ve: float, c: float) -> np.ndarray:
        unit = model.unit_for(datasets[0], {**values, **{p.name: p.from_x(float(xi)) for p, xi in zip(shape, x)}})
        drop = np.abs(np.asarray(_core.damper_pressure_drop_pa(unit.damper.to_dict(), q, 1.0)))
        return np.asarray(drop * area_model + np.tile(friction(v, fc, ratio, vs, ve, c), 2))

    lo = [p.x_bounds()[0] for p in shape]
    hi = [p.x_bounds()[1] for p in shape]

    def inside(fun: Callable[[np.ndarray], np.ndarray], p0: np.ndarray, lo_: list[float], hi_: list[float]) -> OptimizeResult | None:
        # Starts off the bounds (hp-core's knee and share sit on theirs).
        return solve(fun, np.clip(p0, np.add(lo_, 1e-9), np.subtract(hi_, 1e-9)), lo_, hi_, max_nfev=2000, x_scale="jac")

    truth = (f.coulomb_n, f.static_ratio, f.stribeck_velocity_m_s, f.smoothing_velocity_m_s, f.viscous_n_s_per_m)
    x0 = np.array([p.to_x(p.initial) for p in shape])
    held = None
    for start in (x0, x0 + 0.5, x0 - 0.5):
        sol = inside(lambda x: force(x, *truth) - target, start, lo, hi)
        if sol is not None and (held is None or sol.cost < held.cost):
            held = sol
    if held is None:
        return f"{seed} | no fit"
    best = None
    for share in (0.5, 1.0, 1.5):
        p0 = np.concatenate([[f.coulomb_n * share, 1.2, np.log(0.01), np.log(1e-3), 500.0], held.x])
        sol = inside(lambda p: force(p[5:], p[0], p[1], np.exp(p[2]), np.exp(p[3]), p[4]) - target, p0, FRICTION_LO + lo, FRICTION_HI + hi)
        if sol is not None and (best is None or sol.cost < best.cost):
            best = sol
    if best is None:
        return f"{seed} | no fit"
    return row(seed, f, best, held)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--seeds", type=int, nargs="+", default=[14])
    ap.add_argument("--family", choices=("parallel", "transition", "hpctl"), default="parallel",
                    help="the damper family (above)")
    ap.add_argument("--max-speed", type=float, default=np.inf, metavar="M_S",
                    help="only the sweep's speeds below this, m/s (stop 66: below 0.1 m/s hpctl's family follows the foreign damper)")
    a = ap.parse_args()
    print("seed | RMS N | Coulomb fit / truth | breakaway fit / truth | Stribeck velocity mm/s | smoothing mm/s | RMS N, friction at the truth")
    for seed in a.seeds:
        print(fit_split(seed, a.family, a.max_speed), flush=True)


if __name__ == "__main__":
    main()

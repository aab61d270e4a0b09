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
    python scripts/foreign_friction_split.py --orifice transition --seeds 1 2 4 5 8 10 14

``--orifice transition`` replaces the damper family's orifice by a laminar
one turning turbulent above a fitted pressure (valve 6's law in hp-core,
``foreign_damper_family._curve_transition``; stop 66: no better split).

Run from the repository root (``tests/`` holds the foreign rig). Prints per
seed the RMS error of the best fit, N, its Coulomb force, breakaway force
(Coulomb times Stribeck ratio), Stribeck velocity and smoothing against the
truth, and the RMS error with the friction at the truth.
"""

from __future__ import annotations

import argparse
import sys
import warnings
from pathlib import Path

import numpy as np
from scipy.optimize import OptimizeResult, least_squares

sys.path.insert(0, str(Path(__file__).resolve().parent.parent / "tests"))
sys.path.insert(0, str(Path(__file__).resolve().parent))

from foreign_damper_family import _curve, _curve_transition  # noqa: E402
from foreign_rig.damper import Damper  # noqa: E402
from foreign_rig.draw import draw_case  # noqa: E402
from foreign_rig.programs import SWEEP_FREQUENCIES_HZ  # noqa: E402

AMPLITUDE_M = 0.06
#: The damper-curve parameters' bounds (logs but the knee): as foreign_damper_family.
CURVE_LO = [-np.inf] * 4 + [0.0] + [-np.inf] * 2
CURVE_HI = [np.inf] * 4 + [2.0] + [np.inf] * 2
#: Friction's bounds: hpctl's fit ranges (Coulomb, ratio, log Stribeck velocity, log smoothing, viscous).
FRICTION_LO = [0.0, 1.0, np.log(1e-3), np.log(1e-4), 0.0]
FRICTION_HI = [5000.0, 3.0, np.log(0.1), np.log(2e-2), 20000.0]
#: The transition pressure's bounds (log Pa) and starts, ``--orifice transition``.
TRANSITION_LO, TRANSITION_HI = np.log(1e2), np.log(1e8)
TRANSITION_STARTS_PA = (1e4, 1e6)


def friction(v: np.ndarray, fc: float, ratio: float, vs: float, ve: float, c: float) -> np.ndarray:
    # hp-core's Friction::force (unit.rs) for v >= 0.
    return np.asarray(fc * (1.0 + (ratio - 1.0) * np.exp(-((v / vs) ** 2))) * np.tanh(v / ve) + c * v)


def sweep_speeds() -> np.ndarray:
    v = np.concatenate([AMPLITUDE_M * 2 * np.pi * f * np.abs(np.sin(np.linspace(0.0, np.pi, 200))) for f in SWEEP_FREQUENCIES_HZ])
    return v[v > 1e-6]


def fit_split(seed: int, transition: bool = False) -> str:
    case = draw_case("friction", seed)
    unit, f = case.unit, case.unit.effects.friction
    assert f is not None
    damper, area, v = Damper(unit.damper), unit.piston_area_m2, sweep_speeds()
    true_f = friction(v, f.coulomb_n, f.static_ratio, f.stribeck_velocity_m_s, f.smoothing_velocity_m_s, f.viscous_n_s_per_m)
    target = [np.array([s * damper.drop(s * area * x, 1.0) * area for x in v]) + true_f for s in (1.0, -1.0)]

    n = 8 if transition else 7
    lo_curve = CURVE_LO + [TRANSITION_LO] if transition else CURVE_LO
    hi_curve = CURVE_HI + [TRANSITION_HI] if transition else CURVE_HI

    def curve(p: np.ndarray) -> np.ndarray:
        return _curve_transition(p, area * v) if transition else _curve(p, area * v, True)

    def residual(p: np.ndarray) -> np.ndarray:
        fp = friction(v, p[0], p[1], np.exp(p[2]), np.exp(p[3]), p[4])
        return np.concatenate([curve(p[5 + n * i:5 + n * (i + 1)]) * area + fp - target[i] for i in range(2)])

    def solve(fun: object, p0: list[float], lo: list[float], hi: list[float]) -> OptimizeResult | None:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            try:
                return least_squares(fun, p0, bounds=(lo, hi), max_nfev=3000)
            except ValueError:
                return None

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
    p = best.x
    truth = [f.coulomb_n, f.static_ratio, np.log(f.stribeck_velocity_m_s), np.log(f.smoothing_velocity_m_s), f.viscous_n_s_per_m]
    held = solve(lambda c: residual(np.concatenate([truth, c])), list(p[5:]), lo_curve * 2, hi_curve * 2)
    rms = np.sqrt(2.0 * best.cost / best.fun.size)
    rms_held = np.sqrt(2.0 * held.cost / held.fun.size) if held is not None else float("nan")
    return (f"{seed} | {rms:.2f} | {p[0]:.0f} / {f.coulomb_n:.0f} ({p[0] / f.coulomb_n - 1:+.1%}) | "
            f"{p[0] * p[1]:.0f} / {f.coulomb_n * f.static_ratio:.0f} ({p[0] * p[1] / (f.coulomb_n * f.static_ratio) - 1:+.1%}) | "
            f"{np.exp(p[2]) * 1e3:.1f} / {f.stribeck_velocity_m_s * 1e3:.1f} | {np.exp(p[3]) * 1e3:.2f} / {f.smoothing_velocity_m_s * 1e3:.2f} | "
            f"{rms_held:.2f}")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--seeds", type=int, nargs="+", default=[14])
    ap.add_argument("--orifice", choices=("series", "transition"), default="series",
                    help="the damper family's orifice: R q + K q^2 beside a bleed (hp-core's), or laminar-turbulent")
    a = ap.parse_args()
    print("seed | RMS N | Coulomb fit / truth | breakaway fit / truth | Stribeck velocity mm/s | smoothing mm/s | RMS N, friction at the truth")
    for seed in a.seeds:
        print(fit_split(seed, a.orifice == "transition"), flush=True)


if __name__ == "__main__":
    main()

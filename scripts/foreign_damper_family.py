"""How closely hpctl's damper-curve family can follow the foreign rig's
damper at all: the best static fit of one branch (bleed, orifice, blow-off
and its slope, knee, second stage: hp-core's `DamperCurve`) to the foreign
rig's true damper-on force over the heat run's speeds (0.06 m at 0.5 Hz,
weighted as a sine samples them), with the bleed in series with the
orifice and with it beside the orifice (``bleed_parallel_m3_per_s_pa``).
Multi-start least squares on the curve alone, no records, no noise: the
family's own approximation error (docs/foreign-rig.md, "The bleed beside
the orifice").

    python scripts/foreign_damper_family.py --seeds 7 8 9 10 1942323016 100 106 109

Run from the repository root (``tests/`` holds the foreign rig). Prints per
seed the RMS error, N, of each form in compression and rebound. The
curve's formulas are written out here with numpy (the fit needs them
vectorised); ``crates/hp-core/tests/damper_parallel_bleed.rs`` checks the
core's against the same definitions.
"""

from __future__ import annotations

import argparse
import sys
import warnings
from pathlib import Path

import numpy as np
from scipy.optimize import least_squares

sys.path.insert(0, str(Path(__file__).resolve().parent.parent / "tests"))

from foreign_rig.damper import Damper  # noqa: E402
from foreign_rig.draw import draw_case  # noqa: E402

AMPLITUDE_M, FREQUENCY_HZ = 0.06, 0.5


def _ramp(q: np.ndarray, q_b: float, w: float) -> np.ndarray:
    # hp-core's rounded_ramp (damper.rs), vectorised.
    a = q - q_b
    s_a, s_b = np.sqrt(a * a + w * w), np.sqrt(q_b * q_b + w * w)
    s = s_a + s_b
    return np.asarray(q * q * (s_a * s_b + w * w + q_b * a) / (s * s * (s_b + q_b)))


def _curve(p: np.ndarray, q: np.ndarray, parallel: bool) -> np.ndarray:
    """Pressure drop of the two-stage curve with parameters ``p`` (logs of
    R or 1/G, K, p_b, S, S2; the knee; log of p_b2 / p_b - 1)."""
    r, k, pb, s, knee, pb2, s2 = p
    r, k, pb, s, s2 = np.exp([r, k, pb, s, s2])
    pb2 = pb * (1.0 + np.exp(pb2))
    if parallel:
        # Bleed conductance 1/r beside the orifice: q = dp / r + sqrt(dp / k).
        q_b = pb / r + np.sqrt(pb / k)
    else:
        q_b = 2.0 * pb / (r + np.sqrt(r * r + 4.0 * k * pb))
    r1 = _ramp(q, q_b, knee * q_b)
    x2 = (pb2 - pb) / s
    r2 = _ramp(r1, x2, knee * x2)
    inner = q - r1
    if parallel:
        a, b = 1.0 / r, 1.0 / np.sqrt(k)
        root = 2.0 * inner / (b + np.sqrt(b * b + 4.0 * a * inner))
        below = root * root
    else:
        below = inner * (r + k * np.abs(inner))
    return np.asarray(below + s * (r1 - r2) + s2 * r2)


def _curve_transition(p: np.ndarray, q: np.ndarray) -> np.ndarray:
    """:func:`_curve` with the bleed beside an orifice that is laminar below
    a transition pressure ``dp_t`` and turbulent above it, valve 6's law in
    hp-core (``damper::Orifice``): ``q = dp / r + dp / (sqrt(k) (dp^2 +
    dp_t^2)^(1/4))``; ``p`` is :func:`_curve`'s with the log of ``dp_t``
    last. A form the foreign rig's Wu orifices come closer to than the
    series ``R q + K q^2`` (no laminar term left at high flow); tried for
    friction's split at stop 66 (docs/foreign-rig.md), not in hp-core."""
    r, k, pb, s, knee, pb2, s2, dt = p
    r, k, pb, s, s2, dt = np.exp([r, k, pb, s, s2, dt])
    pb2 = pb * (1.0 + np.exp(pb2))
    g, c = 1.0 / r, 1.0 / np.sqrt(k)

    def flow(dp: np.ndarray) -> np.ndarray:
        return np.asarray(g * dp + c * dp / (dp * dp + dt * dt) ** 0.25)

    q_b = float(flow(np.array(pb)))
    r1 = _ramp(q, q_b, knee * q_b)
    x2 = (pb2 - pb) / s
    r2 = _ramp(r1, x2, knee * x2)
    inner = q - r1
    # The drop at the flow `inner`: Newton from above (the orifice alone,
    # in closed form, or the bleed alone, whichever is lower); `flow` is
    # concave, so the iterates fall below the root once and then rise to it.
    y = inner * np.sqrt(k / dt)
    dp = np.minimum(dt * y * np.sqrt((y * y + np.sqrt(y**4 + 4.0)) / 2.0), inner * r)
    for _ in range(30):
        ss = dp * dp + dt * dt
        slope = g + c * (0.5 * dp * dp + dt * dt) / ss**1.25
        dp = np.maximum(dp - (flow(dp) - inner) / slope, 0.0)
    return np.asarray(dp + s * (r1 - r2) + s2 * r2)


def best_error(q: np.ndarray, force: np.ndarray, area: float, parallel: bool) -> float:
    """RMS force error, N, of the best fit over a grid of starts."""
    best = None
    lo, hi = [-np.inf] * 4 + [0.0] + [-np.inf] * 2, [np.inf] * 4 + [2.0] + [np.inf] * 2
    for pb0 in (2e6, 3e6, 4e6, 5e6, 6e6):
        for knee in (0.1, 0.5, 1.0, 1.9):
            for r0 in ((3e10, 3e11) if parallel else (3e10,)):
                p0 = [np.log(r0), np.log(1e14 if parallel else 1e15), np.log(pb0), np.log(3e9), knee, 0.0, np.log(3e9)]
                try:
                    with warnings.catch_warnings():
                        warnings.simplefilter("ignore")
                        sol = least_squares(lambda p: _curve(p, q, parallel) * area - force, p0, bounds=(lo, hi), max_nfev=2000)
                except ValueError:
                    continue
                if best is None or sol.cost < best.cost:
                    best = sol
    if best is None:
        return float("nan")
    return float(np.sqrt(2.0 * best.cost / len(q)))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--seeds", type=int, nargs="+", default=[7])
    ap.add_argument("--effect", default="heat_buildup", help="the foreign rig's case drawn (the unit and damper)")
    a = ap.parse_args()
    phase = np.linspace(0.0, np.pi, 400)
    speeds = AMPLITUDE_M * 2.0 * np.pi * FREQUENCY_HZ * np.abs(np.sin(phase))
    speeds = speeds[speeds > 1e-4]
    print("seed | compression: series / parallel | rebound: series / parallel (RMS N)")
    for seed in a.seeds:
        case = draw_case(a.effect, seed)
        damper, area = Damper(case.unit.damper), case.unit.piston_area_m2
        row = []
        for sign in (1.0, -1.0):
            force = np.array([sign * damper.drop(sign * area * v, 0.0) * area for v in speeds])
            row += [best_error(area * speeds, force, area, parallel) for parallel in (False, True)]
        print(f"{seed} | {row[0]:.1f} / {row[1]:.1f} | {row[2]:.1f} / {row[3]:.1f}", flush=True)


if __name__ == "__main__":
    main()

"""Python benchmark: hpctl against the same SDOF step simulation written
plainly in Python, in one run, as ratios: SciPy's adaptive ``solve_ivp``
with the reference nitrogen (Span et al. 2000, the default model) from
CoolProp through its low-level ``AbstractState`` (the fast way to call
it), and with the same equation of state written with numpy; optionally
through CoolProp's ``PropsSI`` (``--propssi``, slow). Each is compared with
a reference solution (hpctl's fixed-step RK4 at 10 us) so that the ratios
are at the same accuracy: the largest difference of each is printed. Also
the parallel sweep's scaling from one thread to two.

    python scripts/bench_python.py [--repeat 3] [--propssi]

This is a benchmark, not a test: it prints numbers and never fails because
the machine is slow.
"""

from __future__ import annotations

import argparse
import importlib.util
import math
import os
import time
from collections.abc import Callable

import numpy as np
from scipy.integrate import solve_ivp

import hpctl
from hpctl import _core
from hpctl.sim.run import Case, Step, sdof_rig, uniform_times

Eos = Callable[[float, float], tuple[float, float, float]]

# Span et al. (2000) nitrogen, CoolProp's constants (dev/fluids/Nitrogen.json,
# as transcribed in hp-core's gas::span): the reduced Helmholtz energy's
# residual power terms n delta^d tau^t exp(-delta^l), its Gaussian terms, and
# the ideal part's second tau derivative.
SPAN_N = np.array([
    0.924803575275, -0.492448489428, 0.661883336938, -1.92902649201, -0.0622469309629, 0.349943957581, 0.564857472498,
    -1.61720005987, -0.481395031883, 0.421150636384, -0.0161962230825, 0.172100994165, 0.00735448924933, 0.0168077305479,
    -0.00107626664179, -0.0137318088513, 0.000635466899859, 0.00304432279419, -0.0435762336045, -0.0723174889316,
    0.0389644315272, -0.021220136391, 0.00408822981509, -5.51990017984e-05, -0.0462016716479, -0.00300311716011,
    0.0368825891208, -0.0025585684622, 0.00896915264558, -0.0044151337035, 0.00133722924858, 0.000264832491957,
])
SPAN_D = np.array([1, 1, 2, 2, 3, 3, 1, 1, 1, 3, 3, 4, 6, 6, 7, 7, 8, 8, 1, 2, 3, 4, 5, 8, 4, 5, 5, 8, 3, 5, 6, 9], float)
SPAN_T = np.array([0.25, 0.875, 0.5, 0.875, 0.375, 0.75, 0.5, 0.75, 2, 1.25, 3.5, 1, 0.5, 3, 0, 2.75, 0.75, 2.5, 4, 6, 6, 3,
                   3, 6, 16, 11, 15, 12, 12, 7, 4, 16], float)
SPAN_L = np.array([0] * 6 + [1] * 12 + [2] * 6 + [3] * 4 + [4] * 4, float)
GAUSS = np.array([  # n, d, t, eta, beta, gamma
    [19.6688194015, 1, 0, 20, 325, 1.16], [-20.911560073, 1, 1, 20, 325, 1.16],
    [0.0167788306989, 3, 2, 15, 300, 1.13], [2627.67566274, 2, 3, 25, 275, 1.25],
])
T_C, RHO_C, R_SPEC = 126.192, 11183.901464580624 * 0.02801348, 8.31451 / 0.02801348


def span_numpy(rho: float, t: float) -> tuple[float, float, float]:
    """p, (dp/dT)_rho, c_v of the reference equation of state, vectorised
    over its terms with numpy."""
    delta, tau = rho / RHO_C, T_C / t
    dl = delta**SPAN_L
    term = SPAN_N * delta**SPAN_D * tau**SPAN_T * np.where(SPAN_L > 0, np.exp(-dl), 1.0)
    fd = SPAN_D - np.where(SPAN_L > 0, SPAN_L * dl, 0.0)  # delta d/d(delta) of each term, over the term
    n, d, tt, eta, beta, gamma = GAUSS.T
    g = n * delta**d * tau**tt * np.exp(-eta * (delta - 1) ** 2 - beta * (tau - gamma) ** 2)
    gd = d - 2 * eta * delta * (delta - 1)
    gt = tt - 2 * beta * tau * (tau - gamma)
    ar_d = float(term @ fd + g @ gd)
    ar_dt = float(term @ (SPAN_T * fd) + g @ (gd * gt))
    ar_tt = float(term @ (SPAN_T * (SPAN_T - 1)) + g @ (gt * gt - tt - 2 * beta * tau * tau))
    # Ideal part: 2.5 - sum n_k t_k (t_k - 1) tau^t_k + Planck-Einstein.
    x = 3364.011 / t
    cv0_r = 2.5 - (2 * -0.0001934819 / tau + 6 * -1.247742e-05 / tau**2 + 12 * 6.678326e-08 / tau**3) + 1.012941 * x * x * math.exp(-x) / (1 - math.exp(-x)) ** 2
    return rho * R_SPEC * t * (1 + ar_d), rho * R_SPEC * (1 + ar_d - ar_dt), R_SPEC * (cv0_r - ar_tt)


_COOLPROP: list[object] = []


def coolprop(rho: float, t: float) -> tuple[float, float, float]:
    """p, (dp/dT)_rho, c_v of CoolProp's reference nitrogen (AbstractState)."""
    import CoolProp

    if not _COOLPROP:
        _COOLPROP.append(CoolProp.AbstractState("HEOS", "Nitrogen"))
    s = _COOLPROP[0]
    s.update(CoolProp.DmassT_INPUTS, rho, t)  # type: ignore[attr-defined]
    return s.p(), s.first_partial_deriv(CoolProp.iP, CoolProp.iT, CoolProp.iDmass), s.cvmass()  # type: ignore[attr-defined]


def coolprop_propssi(rho: float, t: float) -> tuple[float, float, float]:
    """The same through CoolProp's high-level PropsSI, as it is mostly called."""
    import CoolProp.CoolProp as CP

    return (
        CP.PropsSI("P", "Dmass", rho, "T", t, "Nitrogen"),
        CP.PropsSI("d(P)/d(T)|Dmass", "Dmass", rho, "T", t, "Nitrogen"),
        CP.PropsSI("Cvmass", "Dmass", rho, "T", t, "Nitrogen"),
    )


def python_sdof(unit: hpctl.Unit, duration_s: float, eos: Eos) -> np.ndarray:
    """The seed's 43 mm step, hard spring (S only), damper off: body
    displacement at 1 kHz from solve_ivp (RK45) with its dense output."""
    a = unit.piston_area_m2
    mass_gas, _ = unit.gas_masses_kg()
    c = unit.damper.off_compression
    r = unit.damper.off_rebound
    tau, t_wall, m, g = unit.tau_s, unit.static_temperature_k, hpctl.SEED_SPRUNG_MASS_KG, 9.80665

    def base(t: float) -> tuple[float, float]:
        u = (t - 0.5) / 0.05
        if u <= 0:
            return 0.0, 0.0
        if u >= 1:
            return 0.043, 0.0
        return 0.043 * 0.5 * (1 - math.cos(math.pi * u)), 0.043 * 0.5 * math.pi * math.sin(math.pi * u) / 0.05

    def drop(curve: hpctl.DamperCurve, q: float) -> float:
        dp = q * (curve.bleed_pa_s_per_m3 + curve.orifice_pa_s2_per_m6 * q)
        if dp <= curve.blowoff_pa:
            return dp
        rr, kk = curve.bleed_pa_s_per_m3, curve.orifice_pa_s2_per_m6
        qb = 2 * curve.blowoff_pa / (rr + math.sqrt(rr * rr + 4 * kk * curve.blowoff_pa))
        return curve.blowoff_pa + curve.blowoff_slope_pa_s_per_m3 * (q - qb)

    def rhs(t: float, y: np.ndarray) -> list[float]:
        temp, vol, z, v = y
        _, vb = base(t)
        q = a * (vb - v)
        p, dpdt, cv = eos(mass_gas / vol, temp)
        dp = drop(c, q) if q >= 0 else -drop(r, -q)
        force = a * (p + dp - unit.ambient_pressure_pa)
        dvol = -q
        dtemp = (t_wall - temp) / tau - temp / cv * dpdt * dvol / mass_gas
        return [dtemp, dvol, v, force / m - g]

    y0 = [t_wall, unit.small_acc_volume_m3, 0.0, 0.0]
    t_eval = np.arange(0.0, duration_s + 1e-9, 1e-3)
    sol = solve_ivp(rhs, (0.0, duration_s), y0, method="RK45", t_eval=t_eval, rtol=1e-7, atol=[1e-6, 1e-12, 1e-9, 1e-9], max_step=1e-2)
    return np.asarray(sol.y[2])


def best_of(repeat: int, f: Callable[[], object]) -> float:
    times = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        f()
        times.append(time.perf_counter() - t0)
    return min(times)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--duration-s", type=float, default=6.0)
    ap.add_argument("--propssi", action="store_true", help="also CoolProp through PropsSI (about a second per run)")
    args = ap.parse_args()
    unit = hpctl.Unit.seed()
    dur = args.duration_s

    # The numpy transcription must be the model hpctl runs.
    for rho, t in ((166.96, 293.15), (420.0, 240.0)):
        ours = _core.gas_props("span", np.array([rho]), np.array([t]))
        p, dpdt, cv = span_numpy(rho, t)
        assert abs(p / ours["p_pa"][0] - 1) < 1e-12 and abs(cv / ours["cv_j_per_kg_k"][0] - 1) < 1e-12, (rho, t)
        assert abs(dpdt / ours["dp_dt_pa_per_k"][0] - 1) < 1e-12, (rho, t)

    def hpctl_run(**kw: object) -> np.ndarray:
        r = hpctl.run_sdof(unit, Step(0.043), dur, spring_hard=True, damper_on=False, channels=("body_disp_m",), **kw)  # type: ignore[arg-type]
        return r["body_disp_m"]

    z_ref = hpctl_run(rtol=None, dt_s=1e-5)
    z_rs = hpctl_run()
    t_rs = best_of(max(args.repeat, 10), hpctl_run)
    z_rk = hpctl_run(rtol=None, dt_s=1e-3)
    t_rk = best_of(max(args.repeat, 10), lambda: hpctl_run(rtol=None, dt_s=1e-3))

    def err(z: np.ndarray) -> str:
        return f"{float(np.max(np.abs(z - z_ref))) * 1e6:.3f} um"

    print(f"SDOF 43 mm step, hard spring, damper off, {dur:g} s simulated, body displacement at 1 kHz;")
    print("error = largest difference from hpctl's fixed-step RK4 at 10 us")
    print(f"  hpctl (adaptive, rtol {hpctl.sim.run.DEFAULT_RTOL:g}):                  {t_rs * 1e3:9.3f} ms  "
          f"(real-time factor {dur / t_rs:,.0f}; error {err(z_rs)})")
    print(f"  hpctl (fixed RK4, 1 ms steps):                      {t_rk * 1e3:9.3f} ms  (error {err(z_rk)})")
    variants: list[tuple[Eos, str]] = [
        (coolprop, "SciPy solve_ivp + CoolProp (AbstractState)"),
        (span_numpy, "SciPy solve_ivp + the same EOS with numpy"),
    ]
    if args.propssi:
        variants.append((coolprop_propssi, "SciPy solve_ivp + CoolProp (PropsSI)"))
    have_coolprop = importlib.util.find_spec("CoolProp") is not None
    for eos, label in variants:
        if eos in (coolprop, coolprop_propssi) and not have_coolprop:
            print(f"  {label + ':':51} skipped: CoolProp is not installed (pip install CoolProp, or hpctl[test])")
            continue
        z_py = python_sdof(unit, dur, eos)
        t_py = best_of(args.repeat, lambda: python_sdof(unit, dur, eos))
        agree = float(np.max(np.abs(z_py - z_rs)))
        print(f"  {label + ':':51} {t_py * 1e3:9.1f} ms  -> hpctl {t_py / t_rs:,.0f} x faster "
              f"(error {err(z_py)}; largest difference from hpctl {agree * 1e6:.3f} um)")

    cases = [
        Case(unit.replace(static_pressure_pa=p, tau_s=tau), sdof_rig(Step(0.043)), uniform_times(dur, 1e-3), spring_hard=True, damper_on=on,
             channels=("body_disp_m",))
        for p in np.linspace(12e6, 18e6, 8) for tau in (0.5, 2.0) for on in (True, False)
    ]
    t1 = best_of(args.repeat, lambda: hpctl.run_many(cases, threads=1))
    t2 = best_of(args.repeat, lambda: hpctl.run_many(cases, threads=2))
    print(f"sweep of {len(cases)} SDOF step tests: 1 thread {t1 * 1e3:.1f} ms, 2 threads {t2 * 1e3:.1f} ms")
    print(f"  scaling 1 -> 2 threads: {t1 / t2:.2f} x (target >= 1.8; this machine has {os.cpu_count()} cores)")


if __name__ == "__main__":
    main()

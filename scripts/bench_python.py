"""Python benchmark: hpctl against the same SDOF step simulation written
plainly in Python, in one run, as ratios: the same RK4 with a BWR in
Python's math module, SciPy's adaptive solve_ivp with that BWR, and
solve_ivp with CoolProp's reference nitrogen (through its low-level
AbstractState, the fast way to call it). Also the parallel sweep's scaling
from one thread to two.

    python scripts/bench_python.py [--repeat 3]

This is a benchmark, not a test: it prints numbers and never fails because
the machine is slow.
"""

from __future__ import annotations

import argparse
import importlib.util
import math
import os
import time

import numpy as np
from scipy.integrate import solve_ivp

import hpctl
from hpctl.sim.run import Case, Step, sdof_rig, uniform_times

# The same physics as hp-core for this case: hard spring (S only), damper
# off, BWR "textbook" nitrogen, thermal time constant, 43 mm smooth step.
M_G_PER_MOL = 28.0134
R_UNIV = 8.314462618
BWR = dict(r=8.314, a0=106.73, b0=0.04074, c0=8.164e5, a=2.54, b=0.002328, c=7.379e4, alpha=1.272e-4, gamma=0.0053, unit=1000.0)


def cv0(t: float) -> float:
    a, b, c, d, e = 28.98641, 1.853978, -9.647459, 16.63537, 0.000117
    x = t * 1e-3
    return (a + x * (b + x * (c + x * d)) + e / (x * x) - R_UNIV) / (M_G_PER_MOL * 1e-3)


_COOLPROP: list[object] = []


def coolprop(rho: float, t: float) -> tuple[float, float, float]:
    """p, (dp/dT)_rho, c_v of CoolProp's reference nitrogen."""
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


def bwr(rho: float, t: float) -> tuple[float, float, float]:
    k = BWR
    d = rho / M_G_PER_MOL
    e = math.exp(-k["gamma"] * d * d)
    rt = k["r"] * t
    p = (rt * d + (k["b0"] * rt - k["a0"] - k["c0"] / t**2) * d**2 + (k["b"] * rt - k["a"]) * d**3
         + k["a"] * k["alpha"] * d**6 + k["c"] * d**3 / t**2 * (1 + k["gamma"] * d * d) * e)
    dpdt = (k["r"] * d + (k["b0"] * k["r"] + 2 * k["c0"] / t**3) * d**2 + k["b"] * k["r"] * d**3
            - 2 * k["c"] * d**3 / t**3 * (1 + k["gamma"] * d * d) * e)
    cv_res = 6 * k["c0"] * d / t**3 - 6 * k["c"] / (k["gamma"] * t**3) * (1 - (1 + 0.5 * k["gamma"] * d * d) * e)
    return p * k["unit"], dpdt * k["unit"], cv0(t) + cv_res * k["unit"] * 1e-3 / (M_G_PER_MOL * 1e-3)


def python_sdof(unit: hpctl.Unit, duration_s: float, method: str, eos: object = None) -> np.ndarray:
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
        zb, vb = base(t)
        xdot = vb - v
        q = a * xdot
        p, dpdt, cv = (eos or bwr)(mass_gas / vol, temp)  # type: ignore[operator]
        dp = drop(c, q) if q >= 0 else -drop(r, -q)
        force = a * (p + dp - unit.ambient_pressure_pa)
        dvol = -q
        dtemp = (t_wall - temp) / tau - temp / cv * dpdt * dvol / mass_gas
        return [dtemp, dvol, v, force / m - g]

    y0 = [t_wall, unit.small_acc_volume_m3, 0.0, 0.0]
    t_eval = np.arange(0.0, duration_s + 1e-9, 1e-3)
    if method == "rk4":
        # The same algorithm as hp-core: classical RK4 at 1 ms.
        y = np.array(y0)
        out = np.empty(len(t_eval))
        h = 1e-3
        for i, t in enumerate(t_eval):
            out[i] = y[2]
            k1 = np.array(rhs(t, y))
            k2 = np.array(rhs(t + h / 2, y + h / 2 * k1))
            k3 = np.array(rhs(t + h / 2, y + h / 2 * k2))
            k4 = np.array(rhs(t + h, y + h * k3))
            y = y + h / 6 * (k1 + 2 * k2 + 2 * k3 + k4)
        return out
    sol = solve_ivp(rhs, (0.0, duration_s), y0, method="RK45", t_eval=t_eval, rtol=1e-7, atol=[1e-6, 1e-12, 1e-9, 1e-9], max_step=1e-2)
    return np.asarray(sol.y[2])


def best_of(repeat: int, f: object) -> float:
    times = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        f()  # type: ignore[operator]
        times.append(time.perf_counter() - t0)
    return min(times)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--duration-s", type=float, default=6.0)
    args = ap.parse_args()
    unit = hpctl.Unit.seed()
    dur = args.duration_s

    def hpctl_run() -> np.ndarray:
        return hpctl.run_sdof(unit, Step(0.043), dur, spring_hard=True, damper_on=False, channels=("body_disp_m",))["body_disp_m"]

    z_rs = hpctl_run()
    t_rs = best_of(max(args.repeat, 10), hpctl_run)
    print(f"SDOF 43 mm step, hard spring, damper off, {dur:g} s simulated, body displacement at 1 kHz")
    print(f"  hpctl (Rust RK4, 1 ms steps):                       {t_rs * 1e3:9.2f} ms  (real-time factor {dur / t_rs:,.0f})")
    variants = (
        ("rk4", None, "plain Python, same RK4 at 1 ms + math BWR"),
        ("solve_ivp", None, "SciPy solve_ivp (adaptive RK45) + math BWR"),
        ("solve_ivp", coolprop, "SciPy solve_ivp + CoolProp (AbstractState)"),
        ("solve_ivp", coolprop_propssi, "SciPy solve_ivp + CoolProp (PropsSI)"),
    )
    have_coolprop = importlib.util.find_spec("CoolProp") is not None
    for method, eos, label in variants:
        if eos in (coolprop, coolprop_propssi) and not have_coolprop:
            print(f"  {label + ':':51} skipped: CoolProp is not installed (pip install CoolProp, or hpctl[test])")
            continue
        z_py = python_sdof(unit, dur, method, eos)
        t_py = best_of(args.repeat, lambda: python_sdof(unit, dur, method, eos))
        agree = float(np.max(np.abs(z_py - z_rs)))
        print(f"  {label + ':':51} {t_py * 1e3:9.1f} ms  -> hpctl {t_py / t_rs:,.0f} x faster (largest difference {agree * 1e6:.2f} um)")

    cases = [
        Case(unit.replace(static_pressure_pa=p, tau_s=tau), sdof_rig(Step(0.043)), uniform_times(dur, 1e-3), spring_hard=True, damper_on=on,
             channels=("body_disp_m",))
        for p in np.linspace(12e6, 18e6, 8) for tau in (0.5, 2.0) for on in (True, False)
    ]
    t1 = best_of(args.repeat, lambda: hpctl.run_many(cases, threads=1))
    t2 = best_of(args.repeat, lambda: hpctl.run_many(cases, threads=2))
    print(f"sweep of {len(cases)} SDOF step tests: 1 thread {t1 * 1e3:.0f} ms, 2 threads {t2 * 1e3:.0f} ms")
    print(f"  scaling 1 -> 2 threads: {t1 / t2:.2f} x (target >= 1.8; this machine has {os.cpu_count()} cores)")


if __name__ == "__main__":
    main()

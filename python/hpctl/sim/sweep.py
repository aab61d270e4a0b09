"""The offline tuning loop: a grid of SDOF step tests run in parallel in
Rust, summarised row by row (``hpctl simulate --sweep`` writes the rows as
``sweep.csv`` and plots them with :func:`hpctl.report.plots.sweep_plot`)."""

from __future__ import annotations

import itertools
from collections.abc import Callable
from typing import Any

from hpctl.caveats import Caveat
from hpctl.model.unit import Unit
from hpctl.sim import checks, metrics
from hpctl.sim.run import Case, Step, run_many, sdof_rig, uniform_times

START_S, RISE_S, DURATION_S = 0.5, 0.05, 6.0
COLUMNS = (
    "static_pressure_pa", "tau_s", "damper_on", "spring_hard", "static_disp_m", "natural_frequency_hz",
    "damping_ratio", "overshoot_m", "settling_time_s", "peak_p_gas_pa", "error",
)


def grid(unit: Unit, pressures_pa: list[float] | None, taus_s: list[float] | None, damper: str) -> list[tuple[float, float, bool]]:
    """The cases: (static pressure, tau, damper on)."""
    pressures = pressures_pa or [unit.static_pressure_pa * f for f in (0.8, 0.9, 1.0, 1.1, 1.2)]
    taus = taus_s or [0.5, 2.0, 8.0]
    dampers = [True, False] if damper == "both" else [damper == "on"]
    return list(itertools.product(pressures, taus, dampers))


def run_sweep(
    unit: Unit,
    *,
    spring_hard: bool,
    mass_kg: float,
    pressures_pa: list[float] | None,
    taus_s: list[float] | None,
    damper: str,
    height_m: float,
    threads: int | None,
    say: Callable[[str], None] | None = None,
) -> tuple[dict[str, Any], list[Caveat]]:
    """Runs the grid; returns the summary with one row per case
    (:data:`COLUMNS`) and the caveats: one per failed case, and what the
    checks of :mod:`hpctl.sim.checks` find in the others."""
    cases = grid(unit, pressures_pa, taus_s, damper)
    times = uniform_times(DURATION_S, 1e-3)
    rig = sdof_rig(Step(height_m, START_S, RISE_S), mass_kg)
    sims = [
        Case(unit.replace(static_pressure_pa=p, tau_s=tau), rig, times, spring_hard=spring_hard, damper_on=on,
             channels=("time_s", "disp_m", "vel_m_s", "body_disp_m", "p_gas_true_pa", "p_gas2_true_pa", "t_gas_k", "t_gas2_k"))
        for p, tau, on in cases
    ]
    if say is not None:
        say(f"sweep: {len(sims)} SDOF step tests on {threads or 'all'} thread(s)")
    results = run_many(sims, threads=threads)
    rows = []
    caveats: list[Caveat] = []
    failed: dict[str, str] = {}
    for (p, tau, on), sim, r in zip(cases, sims, results):
        name = f"p = {p / 1e6:.4g} MPa, tau = {tau:g} s, damper {'on' if on else 'off'}"
        row: dict[str, Any] = {"static_pressure_pa": p, "tau_s": tau, "damper_on": int(on), "spring_hard": int(spring_hard)}
        if isinstance(r, Exception):
            row["error"] = str(r)
            failed[name] = str(r)
        else:
            row.update(metrics.step_response(r["time_s"], r["body_disp_m"], r["disp_m"], r["p_gas_true_pa"], height_m, START_S, RISE_S))
            row["error"] = ""
            caveats += checks.channels(sim.unit, r.channels, f"sweep case {name}")
        rows.append(row)
    caveats = checks.failed_cases(failed, "sweep case") + caveats
    return {"test": "sweep", "cases": len(rows), "failed": len(failed), "rows": rows}, caveats

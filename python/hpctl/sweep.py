"""The offline tuning loop: a grid of SDOF step tests run in parallel in
Rust, summarised in one CSV table and one plot."""

from __future__ import annotations

import csv
import itertools
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from hpctl import metrics
from hpctl.sim import Case, Step, sdof_rig, uniform_times
from hpctl.unit import Unit

if TYPE_CHECKING:
    from hpctl.cli import Reporter

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
    out_dir: Path,
    *,
    spring_hard: bool,
    mass_kg: float,
    pressures_pa: list[float] | None,
    taus_s: list[float] | None,
    damper: str,
    height_m: float,
    threads: int | None,
    reporter: Reporter | None = None,
) -> dict[str, Any]:
    """Runs the grid, writes ``sweep.csv`` and ``sweep.png``; returns the summary."""
    from hpctl.sim import run_many

    cases = grid(unit, pressures_pa, taus_s, damper)
    times = uniform_times(DURATION_S, 1e-3)
    rig = sdof_rig(Step(height_m, START_S, RISE_S), mass_kg)
    sims = [
        Case(unit.replace(static_pressure_pa=p, tau_s=tau), rig, times, spring_hard=spring_hard, damper_on=on,
             channels=("time_s", "disp_m", "body_disp_m", "p_gas_true_pa"))
        for p, tau, on in cases
    ]
    if reporter is not None:
        reporter.err.print(f"sweep: {len(sims)} SDOF step tests on {threads or 'all'} thread(s)")
    results = run_many(sims, threads=threads)
    rows = []
    for (p, tau, on), r in zip(cases, results):
        row: dict[str, Any] = {"static_pressure_pa": p, "tau_s": tau, "damper_on": int(on), "spring_hard": int(spring_hard)}
        if isinstance(r, Exception):
            row["error"] = str(r)
        else:
            row.update(metrics.step_response(r["time_s"], r["body_disp_m"], r["disp_m"], r["p_gas_true_pa"], height_m, START_S, RISE_S))
            row["error"] = ""
        rows.append(row)
    with (out_dir / "sweep.csv").open("w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=COLUMNS, lineterminator="\n")
        w.writeheader()
        for row in rows:
            w.writerow({k: ("" if row.get(k) is None else row.get(k)) for k in COLUMNS})
    _plot(rows, out_dir / "sweep.png", spring_hard)
    return {"test": "sweep", "cases": len(rows), "failed": sum(1 for r in rows if r["error"]), "rows": rows}


def _plot(rows: list[dict[str, Any]], path: Path, spring_hard: bool) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from hpctl.plots import save

    fig, (a1, a2) = plt.subplots(1, 2, figsize=(11, 4.5))
    keys = sorted({(r["tau_s"], r["damper_on"]) for r in rows})
    for tau, on in keys:
        sel = [r for r in rows if r["tau_s"] == tau and r["damper_on"] == on and not r["error"]]
        p = np.array([r["static_pressure_pa"] for r in sel]) / 1e6
        f = np.array([np.nan if r["natural_frequency_hz"] is None else r["natural_frequency_hz"] for r in sel])
        o = np.array([r["overshoot_m"] for r in sel]) * 1e3
        label = f"tau {tau:g} s, damper {'on' if on else 'off'}"
        style = "-o" if on else "--s"
        a1.plot(p, f, style, label=label)
        a2.plot(p, o, style, label=label)
    a1.set_xlabel("static charge pressure [MPa]")
    a1.set_ylabel("natural frequency [Hz]")
    a2.set_xlabel("static charge pressure [MPa]")
    a2.set_ylabel("overshoot [mm]")
    for a in (a1, a2):
        a.grid(True, alpha=0.3)
    a2.legend(fontsize=8)
    fig.suptitle(f"Sweep: 43 mm SDOF step, {'hard' if spring_hard else 'soft'} spring")
    save(fig, path, dpi=110)


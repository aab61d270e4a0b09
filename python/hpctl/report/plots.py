"""Plots of simulated or measured tests (PNG, matplotlib without a display)."""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import Any

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from matplotlib.figure import Figure  # noqa: E402

from hpctl.sim import metrics  # noqa: E402


def save(fig: Figure, path: Path, dpi: int = 110) -> Path:
    """Lays out, writes and closes a figure (closing frees its memory:
    pyplot keeps every open figure alive)."""
    fig.tight_layout()
    fig.savefig(path, dpi=dpi)
    plt.close(fig)
    return path
from hpctl.sim.experiments import Experiment  # noqa: E402


def force_displacement(experiments: Sequence[Experiment], path: Path, title: str = "Spring characteristics") -> Path:
    """Force over strut compression, one loop per experiment (last cycle of a sine)."""
    fig, ax = plt.subplots(figsize=(7, 5))
    for e in experiments:
        r = e.result
        t = r["time_s"]
        freq = e.record.test.frequency_hz
        m = metrics.last_cycle(t, freq) if freq and freq * (t[-1] - t[0]) >= 1 else np.ones_like(t, bool)
        label = f"{e.summary['spring']} spring, damper {e.summary['damper']}"
        if "loop_area_j" in e.summary:
            label += f" (loop {e.summary['loop_area_j']:.0f} J)"
        ax.plot(1e3 * r["disp_m"][m], 1e-3 * r["force_n"][m], label=label)
    ax.set_xlabel("strut compression from static position [mm]")
    ax.set_ylabel("strut force [kN]")
    ax.set_title(title)
    ax.grid(True, alpha=0.3)
    ax.legend()
    save(fig, path, dpi=110)
    return path


def step_responses(experiments: Sequence[Experiment], path: Path, title: str = "SDOF step response") -> Path:
    """Body displacement over time, one line per spring/damper combination."""
    fig, ax = plt.subplots(figsize=(8, 5))
    base_drawn = False
    for e in experiments:
        r = e.result
        if not base_drawn:
            ax.plot(r["time_s"], 1e3 * r["base_disp_m"], "k--", lw=1, label="base")
            base_drawn = True
        f = e.summary.get("natural_frequency_hz")
        label = f"{e.summary['spring']} spring, damper {e.summary['damper']}" + (f" ({f:.2f} Hz)" if f else "")
        ax.plot(r["time_s"], 1e3 * r["body_disp_m"], label=label)
    ax.set_xlabel("time [s]")
    ax.set_ylabel("sprung-mass displacement [mm]")
    ax.set_title(title)
    ax.grid(True, alpha=0.3)
    ax.legend()
    save(fig, path, dpi=110)
    return path


def time_series(series: Sequence[tuple[str, np.ndarray, np.ndarray, str]], path: Path, title: str) -> Path:
    """Stacked time series: (label, t, y, y-axis label) per panel."""
    fig, axes = plt.subplots(len(series), 1, figsize=(8, 2.2 * len(series)), sharex=True, squeeze=False)
    for ax, (label, t, y, ylabel) in zip(axes[:, 0], series):
        ax.plot(t, y, label=label)
        ax.set_ylabel(ylabel)
        ax.grid(True, alpha=0.3)
        ax.legend(loc="best")
    axes[-1, 0].set_xlabel("time [s]")
    axes[0, 0].set_title(title)
    save(fig, path, dpi=110)
    return path


def sweep_plot(rows: list[dict[str, Any]], path: Path, spring_hard: bool) -> Path:
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
    return save(fig, path, dpi=110)

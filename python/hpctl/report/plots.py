"""Plots of simulated or measured tests (matplotlib without a display).

Every plot function returns its :class:`~matplotlib.figure.Figure` (to
show in a notebook) and, given a ``path``, writes it there in the format
its extension names (``.png``, ``.svg``, ``.pdf``: :data:`hpctl.report.figures.FORMATS`). One
unit per axis; titles carry the test conditions."""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from matplotlib.axes import Axes  # noqa: E402
from matplotlib.figure import Figure  # noqa: E402

from hpctl.errors import ParameterError  # noqa: E402
from hpctl.report.figures import write  # noqa: E402
from hpctl.sim import metrics  # noqa: E402
from hpctl.sim.experiments import SEED_HEAT_BUILDUP, CharacterisationSummary, Experiment, HeatBuildupSummary, StepSummary  # noqa: E402
from hpctl.sim.sweep import SweepRow  # noqa: E402


def save(fig: Figure, path: str | Path, dpi: int = 110) -> Path:
    """Lays out, writes (in the format of the extension:
    :data:`~hpctl.report.figures.FORMATS`, :func:`hpctl.report.figures.write`)
    and closes a figure (closing frees its memory: pyplot keeps every open
    figure alive; the returned figure can still be drawn or saved)."""
    try:
        return write(fig, path, dpi)
    finally:
        plt.close(fig)


def finish(fig: Figure, path: str | Path | None, dpi: int = 110) -> Figure:
    """Writes the figure if a path is given; returns it."""
    if path is None:
        fig.tight_layout()
        plt.close(fig)
    else:
        save(fig, path, dpi)
    return fig


def _mm(x: float | None) -> str:
    return "-" if x is None else f"{1e3 * x:g} mm"


def conditions(e: Experiment) -> str:
    """The test conditions of an experiment, for a title: the excitation,
    the spring and damper states and, on the SDOF rig, the sprung mass."""
    t = e.record.test
    if t.excitation == "sine" and t.frequency_hz:
        what = f"sine {_mm(t.amplitude_m)} at {t.frequency_hz:.3g} Hz"
    elif t.excitation == "step":
        what = f"{_mm(t.amplitude_m)} step"
    else:
        what = t.excitation
    mass = f", {e.record.sprung_mass_kg:g} kg" if e.record.sprung_mass_kg else ""
    return f"{what}{mass}"


def _common(texts: Sequence[str]) -> str:
    return texts[0] if texts and all(x == texts[0] for x in texts) else ""


def force_displacement(experiments: Sequence[Experiment], path: str | Path | None = None, title: str = "Spring characteristics") -> Figure:
    """Force over strut compression, one loop per experiment (last cycle of a sine)."""
    fig, ax = plt.subplots(figsize=(7, 5))
    for e in experiments:
        r = e.result
        t = r["time_s"]
        freq = e.record.test.frequency_hz
        m = metrics.last_cycle(t, freq) if freq and freq * (t[-1] - t[0]) >= 1 else np.ones_like(t, bool)
        label = f"{e.summary.spring} spring, damper {e.summary.damper}"
        if isinstance(e.summary, CharacterisationSummary) and e.summary.loop_area_j is not None:
            label += f" (loop {e.summary.loop_area_j:.0f} J)"
        ax.plot(1e3 * r["disp_m"][m], 1e-3 * r["force_n"][m], label=label)
    ax.set_xlabel("strut compression from static position [mm]")
    ax.set_ylabel("strut force [kN]")
    common = _common([conditions(e) for e in experiments])
    ax.set_title(f"{title}: {common}" if common else title)
    ax.grid(True, alpha=0.3)
    ax.legend()
    return finish(fig, path)


def step_responses(experiments: Sequence[Experiment], path: str | Path | None = None, title: str = "SDOF step response") -> Figure:
    """Body displacement over time, one line per spring/damper combination."""
    fig, ax = plt.subplots(figsize=(8, 5))
    base_drawn = False
    for e in experiments:
        r = e.result
        if not base_drawn:
            ax.plot(r["time_s"], 1e3 * r["base_disp_m"], "k--", lw=1, label="base")
            base_drawn = True
        f = e.summary.natural_frequency_hz if isinstance(e.summary, StepSummary) else None
        label = f"{e.summary.spring} spring, damper {e.summary.damper}" + (f" ({f:.2f} Hz)" if f else "")
        ax.plot(r["time_s"], 1e3 * r["body_disp_m"], label=label)
    ax.set_xlabel("time [s]")
    ax.set_ylabel("sprung-mass displacement [mm]")
    common = _common([conditions(e) for e in experiments])
    ax.set_title(f"{title}: {common}" if common else title)
    ax.grid(True, alpha=0.3)
    ax.legend()
    return finish(fig, path)


def time_series(series: Sequence[tuple[str, np.ndarray, np.ndarray, str]], path: str | Path | None, title: str) -> Figure:
    """Stacked time series: (label, t, y, y-axis label with its unit) per panel."""
    fig, axes = plt.subplots(len(series), 1, figsize=(8, 2.2 * len(series)), sharex=True, squeeze=False)
    for ax, (label, t, y, ylabel) in zip(axes[:, 0], series):
        ax.plot(t, y, label=label)
        ax.set_ylabel(ylabel)
        ax.grid(True, alpha=0.3)
        ax.legend(loc="best")
    axes[-1, 0].set_xlabel("time [s]")
    axes[0, 0].set_title(title)
    return finish(fig, path)


def heat_buildup(e: Experiment, path: str | Path | None = None) -> Figure:
    """The damper heat build-up run as its story: gas and oil temperature
    (cycle means; the gas's band within a cycle), the force envelope, the
    ride height the warmer gas gives at rest, and the headline numbers
    beside the seed's."""
    s, x = e.summary, e.series
    if "cycle_time_s" not in x or not isinstance(s, HeatBuildupSummary):
        raise ParameterError(f"{e.name}: not a heat build-up run (no cycle series); see hpctl.sim.experiments.heat_buildup")
    minutes = x["cycle_time_s"] / 60.0
    # The lines start where the run did: at rest, the gas at ambient.
    start_min = np.r_[0.0, minutes]
    fig, ax = plt.subplots(3, 1, figsize=(9, 9), sharex=True, gridspec_kw={"height_ratios": [3, 2, 2]})
    gas_c = x["t_gas_mean_k"] - 273.15
    ax[0].fill_between(minutes, x["t_gas_min_k"] - 273.15, x["t_gas_max_k"] - 273.15, color="tab:blue", alpha=0.15, lw=0, label="gas, range within a cycle")
    ax[0].plot(start_min, np.r_[s.ambient_k - 273.15, gas_c], color="tab:blue", lw=1.6, label="gas, cycle mean")
    ax[0].plot(minutes, x["t_oil_mean_k"] - 273.15, color="tab:red", lw=1.6, label="oil, cycle mean")
    seed = SEED_HEAT_BUILDUP
    # The seed's numbers where the seed measured them: at the end of its run.
    seed_min = seed["duration_s"] / 60.0
    ax[0].plot([seed_min], [seed["gas_temperature_end_c"]], "o", color="tab:blue", mfc="none", ms=8, label=f"seed: gas {seed['gas_temperature_end_c']:.0f} °C after {seed_min:g} min")
    ax[0].plot([seed_min], [seed["oil_temperature_end_c"]], "s", color="tab:red", mfc="none", ms=8, label=f"seed: oil {seed['oil_temperature_end_c']:.0f} °C after {seed_min:g} min")
    ax[0].set_ylabel("temperature [°C]")
    ax[0].legend(loc="upper left", fontsize=8, ncol=2)
    ax[1].fill_between(minutes, 1e-3 * x["force_min_n"], 1e-3 * x["force_max_n"], color="tab:gray", alpha=0.5, lw=0, label="force range within a cycle")
    ax[1].set_ylabel("strut force [kN]")
    ax[1].legend(loc="upper left", fontsize=8)
    ax[2].plot(start_min, 1e3 * np.r_[0.0, x["ride_height_change_m"]], color="tab:green", lw=1.6, label="ride height at rest with the gas at its cycle mean")
    ax[2].plot([seed_min], [1e3 * seed["ride_height_change_m"]], "o", color="tab:green", mfc="none", ms=8,
               label=f"seed: +{1e3 * seed['ride_height_change_m']:.0f} mm after {seed_min:g} min")
    ax[2].set_ylabel("ride height change [mm]")
    ax[2].set_xlabel("time [min]")
    ax[2].legend(loc="upper left", fontsize=8)
    for a in ax:
        a.grid(True, alpha=0.3)
    headline = (f"gas {s.gas_temperature_start_k - 273.15:.0f} → {s.gas_temperature_end_k - 273.15:.0f} °C, "
                f"oil → {s.oil_temperature_end_k - 273.15:.0f} °C, spring rate {100 * s.static_spring_rate_change:+.0f} %, "
                f"ride height {1e3 * s.ride_height_change_m:+.1f} mm, mean damper power {s.mean_damper_power_w:.0f} W\n"
                f"seed ({seed_min:g} min): gas {seed['gas_temperature_start_c']:.0f} → {seed['gas_temperature_end_c']:.0f} °C, oil → {seed['oil_temperature_end_c']:.0f} °C, "
                f"spring rate {100 * seed['spring_rate_change']:+.0f} %, ride height +{1e3 * seed['ride_height_change_m']:.0f} mm")
    _headline(ax[0], headline)
    ax[0].set_title(f"Damper heat build-up: sine {1e3 * s.amplitude_m:g} mm at {s.frequency_hz:g} Hz for {s.duration_s / 60:g} min, "
                    f"{s.spring} spring, damper on, {s.sprung_mass_kg:g} kg, ambient {s.ambient_k - 273.15:.0f} °C", fontsize=10)
    return finish(fig, path)


def _headline(ax: Axes, text: str) -> None:
    ax.text(0.99, 0.03, text, transform=ax.transAxes, ha="right", va="bottom", fontsize=8,
            bbox={"boxstyle": "round", "facecolor": "white", "alpha": 0.85, "edgecolor": "0.7"})


def sweep_plot(rows: Sequence[SweepRow], path: str | Path | None, spring_hard: bool, height_m: float = 0.043, mass_kg: float | None = None) -> Figure:
    fig, (a1, a2) = plt.subplots(1, 2, figsize=(11, 4.5))
    keys = sorted({(r.tau_s, r.damper_on) for r in rows})
    for tau, on in keys:
        sel = [(r.static_pressure_pa, r.response) for r in rows if r.tau_s == tau and r.damper_on == on and r.response is not None]
        p = np.array([pa for pa, _ in sel]) / 1e6
        f = np.array([np.nan if m.natural_frequency_hz is None else m.natural_frequency_hz for _, m in sel])
        o = np.array([m.overshoot_m for _, m in sel]) * 1e3
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
    mass = f", {mass_kg:g} kg" if mass_kg else ""
    fig.suptitle(f"Sweep: {1e3 * height_m:g} mm SDOF step{mass}, {'hard' if spring_hard else 'soft'} spring")
    return finish(fig, path)

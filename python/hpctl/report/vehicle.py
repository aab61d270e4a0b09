"""Figures and tables of the vehicle comparison and tuning."""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import matplotlib.pyplot as plt
import numpy as np
from matplotlib.axes import Axes
from matplotlib.figure import Figure

from hpctl.report.plots import finish
from hpctl.vehicle.comparison import HANDLING_SECTION, CaseResult, Evaluation, mode_share
from hpctl.vehicle.tuning import TuneResult


def _pareto(points: list[tuple[float, float, str]]) -> list[tuple[float, float, str]]:
    """The passive settings no other beats on both axes, by comfort."""
    front = [p for p in points if not any(q[0] <= p[0] and q[1] <= p[1] and q != p for q in points)]
    return sorted(front)


def ride_handling_plot(evaluation: Evaluation, path: Path | None = None) -> Figure:
    """Comfort on the rough track against roll in the lane change, one
    panel per vehicle: the passive settings and their compromise front,
    the semi-active point beside it (PNG)."""
    groups = evaluation.by_vehicle()
    fig, axes = plt.subplots(1, len(groups), figsize=(6.2 * len(groups), 5.2), squeeze=False)
    for ax, (name, results) in zip(axes[0], groups.items()):
        ok = [r for r in results if r.error is None]
        passive = [(r.comfort_m_s2, math.degrees(r.roll_peak_rad), r.case.setting.name) for r in ok if not r.case.setting.semi_active]
        semi = [(r.comfort_m_s2, math.degrees(r.roll_peak_rad), r.case.setting.name) for r in ok if r.case.setting.semi_active]
        front = _pareto(passive)
        if len(front) > 1:
            ax.plot([p[0] for p in front], [p[1] for p in front], "-", color="tab:gray", lw=1.2, label="passive compromise front")
        for x, y, label in passive:
            ax.plot(x, y, "o", color="tab:blue", ms=8)
            ax.annotate(label, (x, y), textcoords="offset points", xytext=(6, 4), fontsize=8)
        for x, y, label in semi:
            ax.plot(x, y, "*", color="tab:red", ms=16, label=label)
            ax.annotate(label, (x, y), textcoords="offset points", xytext=(6, -12), fontsize=9, color="tab:red")
        ax.set_xlabel("seat a_v on the rough track, ISO 2631-1 [m/s²]  (more comfortable ←)")
        ax.set_ylabel("peak roll in the double lane change [deg]  (flatter ↓)")
        ax.set_title(f"{name}: ride versus handling")
        ax.grid(True, alpha=0.3)
        _legend(ax, loc="upper right", fontsize=8)
    return finish(fig, path)


def lane_change_plot(results: list[CaseResult], path: Path | None = None) -> Figure:
    """Roll angle, lateral acceleration and the semi-active mode through the
    lane change, every setting of one vehicle (PNG)."""
    fig, ax = plt.subplots(3, 1, figsize=(10, 9), sharex=True, gridspec_kw={"height_ratios": [3, 2, 1]})
    for r in results:
        if r.trace is None or r.route is None:
            continue
        s = next(x for x in r.route.sections if x.kind == HANDLING_SECTION)
        tr = r.trace
        m = (tr.distance_m >= s.start_m) & (tr.distance_m < s.end_m)
        x = tr.distance_m[m] - s.start_m
        style = dict(lw=2.0, color="tab:red") if r.case.setting.semi_active else dict(lw=1.0)
        ax[0].plot(x, np.degrees(tr.signals["roll_rad"][m]), label=r.case.setting.name, **style)
        if r.case.setting.semi_active:
            ax[1].plot(x, tr.signals["lat_acc_m_s2"][m], color="k", lw=1.0, label="lateral acceleration")
            ax[2].step(x, tr.controller["drive_mode"][m].max(axis=1), where="post", color="tab:red", label="semi-active: handling (1) / ride (0)")
    ax[0].set_ylabel("roll [deg]")
    _legend(ax[0], fontsize=8, ncol=2)
    ax[1].set_ylabel("[m/s²]")
    _legend(ax[1], fontsize=8)
    ax[2].set_ylabel("mode")
    ax[2].set_xlabel("distance into the lane-change segment [m]")
    _legend(ax[2], fontsize=8)
    for a in ax:
        a.grid(True, alpha=0.3)
    name = results[0].case.vehicle.name if results else ""
    ax[0].set_title(f"{name}: double lane change (ISO 3888-2 style)")
    return finish(fig, path)


def _legend(ax: Axes, **kwargs: Any) -> None:
    """A legend only where something is labelled: with every case of a
    setting failed (or no semi-active case) the axes may have none, and
    matplotlib would warn about an empty legend."""
    if ax.get_legend_handles_labels()[0]:
        ax.legend(**kwargs)


def _f(v: float, scale: float = 1.0, digits: int = 3) -> str:
    return "-" if v is None or not math.isfinite(v) else f"{v * scale:.{digits}f}"


def comparison_rows(evaluation: Evaluation) -> list[dict[str, str]]:
    """The comparison table, one row per vehicle and setting."""
    rows = []
    for r in evaluation.results:
        rough, lc, hw, ob = (r.section(k) for k in ("rough", "lane_change", "highway", "obstacles"))
        if r.error is not None or rough is None or lc is None:
            rows.append({"vehicle": r.case.vehicle.name, "setting": r.case.setting.name, "note": f"failed: {r.error}"})
            continue
        hits = sum(s.wheels.end_stop_hits for s in r.sections)
        lift = sum(s.wheels.lift_off_s for s in r.sections)
        rows.append({
            "vehicle": r.case.vehicle.name,
            "setting": r.case.setting.name,
            "rough a_v [m/s²]": _f(rough.ride.a_v_m_s2),
            "rough a_wz [m/s²]": _f(rough.ride.a_wz_m_s2),
            "rough VDV [m/s^1.75]": _f(rough.ride.vdv_total_m_s175, digits=2),
            "highway a_v [m/s²]": _f(hw.ride.a_v_m_s2) if hw else "-",
            "lane change roll [deg]": _f(lc.handling.roll_peak_rad, 180 / math.pi, 2),
            "roll rate [deg/s]": _f(lc.handling.roll_rate_peak_rad_s, 180 / math.pi, 1),
            "tyre load DLC, lane change": _f(lc.wheels.dynamic_load_coefficient),
            "tyre load DLC, rough": _f(rough.wheels.dynamic_load_coefficient),
            "travel used, rough [%]": _f(max(rough.wheels.compression_used, rough.wheels.extension_used), 100, 0),
            "end-stop hits": str(hits),
            "lift-off [s]": _f(lift, digits=2),
            "handling share in lane change": _f(mode_share(r, "lane_change"), digits=2) if r.case.setting.semi_active else "-",
        })
    return rows


def markdown_table(rows: list[dict[str, str]]) -> str:
    cols: list[str] = []
    for r in rows:
        cols += [c for c in r if c not in cols]
    lines = ["| " + " | ".join(cols) + " |", "|" + "---|" * len(cols)]
    for r in rows:
        lines.append("| " + " | ".join(r.get(c, "") for c in cols) + " |")
    return "\n".join(lines) + "\n"


def tuning_plot(result: TuneResult, path: Path | None = None) -> Figure:
    """The best objective per generation (PNG)."""
    fig, ax = plt.subplots(figsize=(7, 4))
    g = np.arange(1, len(result.history) + 1)
    ax.plot(g, result.history, "o-", label="best of the population")
    ax.axhline(result.default.j, color="tab:gray", ls="--", label="default configuration")
    ax.axhline(2.0, color="tab:green", ls=":", label="goal: soft's comfort + hard's roll")
    ax.set_xlabel("generation")
    ax.set_ylabel("objective J")
    ax.legend(fontsize=8)
    ax.grid(True, alpha=0.3)
    return finish(fig, path)

"""Plots of closed-loop runs: the pump-free ride-height change and the
mode switching."""

from __future__ import annotations

from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np
from matplotlib.figure import Figure

from hpctl.control.closed_loop import ClosedLoop
from hpctl.report.plots import finish


def plot_height_change(r: ClosedLoop, path: Path | None, title: str) -> Figure:
    """Ride height, pressures and valve commands over time (PNG)."""
    t = r.time_s
    o = r.outputs
    fig, ax = plt.subplots(4, 1, figsize=(10, 11), sharex=True, gridspec_kw={"height_ratios": [3, 3, 1.6, 2]})
    request = r.inputs["ride_height_request_m"]
    ax[0].plot(t, 1e3 * request, "k--", lw=1.2, label="request")
    ax[0].plot(t, 1e3 * o["ride_height_m"], lw=0.8, alpha=0.8, label="controller estimate (L's oil)")
    closed = ~o["valve6_open"].astype(bool)
    held = np.where(closed, 1e3 * r.held_offset_m(), np.nan)
    ax[0].plot(t, held, lw=1.4, label="plant: offset held in L (valve 6 closed)")
    ax[0].set_ylabel("ride height [mm]")
    ax[0].legend(loc="lower left", fontsize=8)
    ax[1].plot(t, 1e-6 * r.plant["p_gas_pa"], lw=0.5, alpha=0.7, label="p_S")
    ax[1].plot(t, 1e-6 * r.plant["p_gas2_pa"], lw=1.2, label="p_L")
    ax[1].plot(t, 1e-6 * o["p_gas2_target_pa"], "k--", lw=1.0, label="target p_L")
    ax[1].plot(t, 1e-6 * o["p_load_pa"], ":", color="tab:red", lw=1.2, label="load pressure estimate")
    ax[1].set_ylabel("gas pressure [MPa]")
    ax[1].legend(loc="upper left", fontsize=8, ncol=2)
    ax[2].step(t, o["valve6_open"].astype(float), where="post", lw=0.8, label="valve 6 open")
    ax[2].step(t, 1.2 + 0.25 * o["sequencer"].astype(float), where="post", lw=1.0, color="tab:purple", label="sequencer")
    ax[2].set_yticks([0, 1, 1.2, 1.45, 1.7, 1.95, 2.2], ["closed", "open", "idle", "lowering", "raising", "holding", "blocked"], fontsize=7)
    ax[2].legend(loc="upper right", fontsize=8)
    ax[3].plot(t, 1e3 * r.plant["base_disp_m"], lw=0.6, label="road (base)")
    ax[3].plot(t, 1e3 * r.plant["disp_m"], lw=0.6, label="strut compression")
    window = max(1, int(round(5.0 / float(np.median(np.diff(t))))) if t.size > 1 else 1)
    if t.size > window:
        mean = np.convolve(r.plant["disp_m"], np.ones(window) / window, mode="valid")
        ax[3].plot(t[window - 1:], 1e3 * mean, "k", lw=1.4, label="strut compression, mean of 5 s")
    ax[3].set_ylabel("[mm]")
    ax[3].set_xlabel("time [s]")
    ax[3].legend(loc="upper left", fontsize=8)
    for a in ax:
        a.grid(True, alpha=0.3)
    ax[0].set_title(title)
    return finish(fig, path)


def plot_modes(r: ClosedLoop, path: Path | None, title: str) -> Figure:
    """Vehicle signals, the selected mode, the valve commands and the body's
    response, one unit per axis."""
    t = r.time_s
    i = r.inputs
    o = r.outputs
    fig, ax = plt.subplots(7, 1, figsize=(10, 14), sharex=True, gridspec_kw={"height_ratios": [2.2, 1.3, 1.3, 1.0, 1.2, 1.8, 1.8]})
    ax[0].plot(t, i["lat_acc_m_s2"], label="lateral")
    ax[0].plot(t, i["long_acc_m_s2"], label="longitudinal")
    ax[0].set_ylabel("vehicle acc. [m/s²]")
    ax[0].legend(loc="upper right", fontsize=8)
    ax[1].plot(t, i["steer_rate_rad_s"], lw=0.8, color="tab:green")
    ax[1].set_ylabel("steering rate [rad/s]")
    ax[2].plot(t, i["speed_m_s"], "k", lw=1.0)
    ax[2].set_ylabel("speed [m/s]")
    ax[3].step(t, o["drive_mode"].astype(float), where="post", color="tab:red", label="mode")
    ax[3].step(t, i["brake_pressed"].astype(float) * 0.5, where="post", color="tab:gray", lw=0.8, label="brake pedal (pressed = 0.5)")
    ax[3].set_yticks([0, 0.5, 1], ["ride", "brake", "handling"], fontsize=7)
    ax[3].legend(loc="upper right", fontsize=8)
    ax[4].step(t, o["valve6_open"].astype(float) + 1.5, where="post", lw=0.8, label="valve 6 (open = soft)")
    ax[4].step(t, o["valve5_open"].astype(float), where="post", lw=0.5, label="valve 5 (open = low damping)")
    ax[4].set_yticks([0, 1, 1.5, 2.5], ["v5 closed", "v5 open", "v6 closed", "v6 open"], fontsize=7)
    ax[4].legend(loc="upper right", fontsize=8)
    ax[5].plot(t, 1e3 * r.plant["body_disp_m"], lw=0.8, color="tab:blue")
    ax[5].set_ylabel("body displ. [mm]")
    ax[6].plot(t, r.plant["body_acc_m_s2"], lw=0.4, color="tab:orange")
    ax[6].set_ylabel("body acc. [m/s²]")
    ax[6].set_xlabel("time [s]")
    for a in ax:
        a.grid(True, alpha=0.3)
    ax[0].set_title(title, fontsize=10)
    return finish(fig, path)

"""Writing figures, and a fit's record figure drawn from plain arrays.

Why a module of its own: the record figures of ``hpctl fit --flexible``
and of a diagnosis are drawn in worker processes beside this one
(:func:`hpctl.report.calibration.draw_record_plots`), and a worker
imports what its task needs. Drawn from a whole fit result, a task needed
hpctl's identification with SciPy (0.6-0.9 s of a worker's CPU, while the
fit's runs wanted the cores) and pickled the result, 3.9 MB a figure on
the bundled campaign (stop 63). A :class:`RecordFigure` holds the arrays
and words the figure shows, and this module needs NumPy and matplotlib
alone (no pyplot: a figure drawn here is not kept by pyplot either).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any

import matplotlib
import numpy as np
from matplotlib.axes import Axes
from matplotlib.figure import Figure
from numpy.typing import NDArray

from hpctl.errors import ParameterError

FloatArray = NDArray[np.float64]

#: The file formats a figure is written in (by the path's extension).
FORMATS = ("png", "svg", "pdf")


def write(fig: Figure, path: str | Path, dpi: int = 110) -> Path:
    """Lays out and writes a figure in the format of the extension
    (:data:`FORMATS`)."""
    path = Path(path)
    fmt = path.suffix.lstrip(".").lower()
    if fmt not in FORMATS:
        raise ParameterError(f"{path}: cannot write a figure as {fmt or 'a file without an extension'!r}; use one of {', '.join('.' + f for f in FORMATS)}")
    fig.tight_layout()
    # No timestamps and no random ids in SVG/PDF: the same figure gives
    # the same bytes (outputs can be compared and versioned).
    metadata: dict[str, Any] = {"Date": None} if fmt in ("svg", "pdf") else {}
    with matplotlib.rc_context({"svg.hashsalt": "hpctl"}):
        fig.savefig(path, dpi=dpi, format=fmt, metadata=metadata)
    return path


def valve_states(ax: Axes, t: FloatArray, spring_hard: NDArray[Any], damper_on: NDArray[Any]) -> None:
    """The valve states of a record on an axis of their own: valve 6
    (closed = hard spring) and valve 5 (closed = damper on), as steps."""
    ax.step(t, 2.0 + np.asarray(spring_hard, float), where="post", color="tab:purple", lw=1.0)
    ax.step(t, np.asarray(damper_on, float), where="post", color="tab:brown", lw=1.0)
    ax.set_yticks([0, 1, 2, 3], ["damper off", "damper on", "soft", "hard"], fontsize=7)
    ax.set_ylim(-0.4, 3.4)
    ax.set_ylabel("valves")


@dataclass(frozen=True)
class Valves:
    """A record's logged valve states at its own sample times."""

    time_s: FloatArray
    spring_hard: NDArray[np.bool_]
    damper_on: NDArray[np.bool_]


@dataclass(frozen=True)
class RecordFigure:
    """What a fit's figure of one record shows (:func:`record_figure`), in
    the units it is drawn in: the channel measured and modelled over time,
    the residual over time, strut displacement and velocity, and the valve
    states where they switch (None where they hold)."""

    title: str
    time_s: FloatArray
    measured: FloatArray
    model: FloatArray
    residual: FloatArray
    disp_mm: FloatArray
    vel_m_s: FloatArray
    #: The channel's axis label (name and unit) and the residual's unit.
    channel_label: str
    unit: str
    disp_label: str
    valves: Valves | None = None


def record_figure(spec: RecordFigure) -> Figure:
    """The figure of :class:`RecordFigure` ``spec``: measured vs modelled
    over time (with the valve states under it when they switch), and the
    residual over time, displacement and velocity."""
    if spec.valves is not None:
        # The valve states under the time plot, on an axis of their own.
        fig = Figure(figsize=(11, 8))
        grid = fig.add_gridspec(3, 2, height_ratios=[3, 1, 3])
        top = fig.add_subplot(grid[0, 0])
        valves = fig.add_subplot(grid[1, 0], sharex=top)
        ax = np.array([[top, fig.add_subplot(grid[0:2, 1])], [fig.add_subplot(grid[2, 0]), fig.add_subplot(grid[2, 1])]])
        valve_states(valves, spec.valves.time_s, spec.valves.spring_hard, spec.valves.damper_on)
        valves.set_xlabel("time [s]")
        valves.grid(True, alpha=0.3)
        top.tick_params(labelbottom=False)
    else:
        fig = Figure(figsize=(11, 7))
        ax = fig.subplots(2, 2)
    ax[0, 0].plot(spec.time_s, spec.measured, ".", ms=2, label="measured")
    ax[0, 0].plot(spec.time_s, spec.model, "-", lw=1, label="model")
    ax[0, 0].set_xlabel("" if spec.valves is not None else "time [s]")
    ax[0, 0].set_ylabel(spec.channel_label)
    ax[0, 0].legend()
    ax[0, 1].plot(spec.time_s, spec.residual, ".", ms=2)
    ax[0, 1].set_xlabel("time [s]")
    ax[1, 0].plot(spec.disp_mm, spec.residual, ".", ms=2)
    ax[1, 0].set_xlabel(spec.disp_label)
    ax[1, 1].plot(spec.vel_m_s, spec.residual, ".", ms=2)
    ax[1, 1].set_xlabel("velocity [m/s]")
    for a in (ax[0, 1], ax[1, 0], ax[1, 1]):
        a.set_ylabel(f"residual (model - measured) [{spec.unit}]")
        a.axhline(0, color="k", lw=0.5)
    for a in ax.ravel():
        a.grid(True, alpha=0.3)
    fig.suptitle(spec.title)
    return fig


def record_png(spec: RecordFigure, path: Path) -> Path:
    """:func:`record_figure` written to ``path``; a worker process's task
    (:func:`hpctl.report.calibration.draw_record_plots`)."""
    return write(record_figure(spec), path, dpi=90)

"""Plots that tell the story (issue 15, item 4): the figure comes back,
one unit per axis, titles with the test conditions, the heat build-up as
cycle means with its headline, valve states under switching records, and
PNG, SVG and PDF by extension."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from matplotlib.figure import Figure

import hpctl
from hpctl.cli._ui import FIGURE_FORMATS
from hpctl.control import closed_loop
from hpctl.identify import virtual_rig
from hpctl.identify.dataset import prepare
from hpctl.identify.fit import fit
from hpctl.report import calibration, figures, plots
from hpctl.report.closed_loop import plot_modes
from hpctl.sim import experiments, metrics

MAGIC = {"png": b"\x89PNG", "svg": b"<?xml", "pdf": b"%PDF"}


@pytest.fixture(scope="module")
def heat() -> experiments.Experiment:
    # A short run (4 min): the same plot as the 75 min one.
    return experiments.heat_buildup(hpctl.Unit.seed(), duration_s=240.0)


def texts(fig: Figure) -> str:
    return "\n".join([t.get_text() for ax in fig.axes for t in ax.texts] + [ax.get_title() for ax in fig.axes])


def test_cycle_stats_against_a_known_sine() -> None:
    t = np.linspace(0.0, 10.0, 10001)
    y = 3.0 + 2.0 * np.sin(2 * np.pi * 0.5 * t) + 0.1 * t
    s = metrics.cycle_stats(t, y, 0.5)
    assert len(s["time_s"]) == 5 and np.allclose(s["time_s"], [1, 3, 5, 7, 9])
    # The mean of a whole period of the sine is 0: the trend remains.
    assert np.allclose(s["mean"], 3.0 + 0.1 * s["time_s"], atol=2e-4)
    assert np.all(s["max"] - s["min"] > 3.9) and np.all(s["max"] - s["min"] < 4.3)
    assert len(metrics.cycle_stats(t, y, 0.5, every=2)["time_s"]) == 2


def test_heat_buildup_is_drawn_as_cycle_means_with_its_headline(heat: experiments.Experiment, tmp_path: Path) -> None:
    fig = plots.heat_buildup(heat, tmp_path / "heat.png")
    assert isinstance(fig, Figure) and (tmp_path / "heat.png").read_bytes().startswith(MAGIC["png"])
    s = heat.summary
    words = texts(fig)
    # The headline on the figure: the gas temperature from start to end, the ride height.
    assert f"gas {s.gas_temperature_start_k - 273.15:.0f} → {s.gas_temperature_end_k - 273.15:.0f} °C" in words
    assert f"ride height {1e3 * s.ride_height_change_m:+.1f} mm" in words
    assert "seed (75 min): gas 23 → 68 °C" in words
    # Test conditions in the title.
    assert "60 mm at 0.5 Hz for 4 min" in fig.axes[0].get_title() and "damper on" in fig.axes[0].get_title()
    # One unit per axis, and the ride height has an axis of its own.
    assert [ax.get_ylabel() for ax in fig.axes] == ["temperature [°C]", "strut force [kN]", "ride height change [mm]"]
    # Cycle means, not every sample: 120 cycles, one point each (plus the start).
    gas_line = next(line for line in fig.axes[0].get_lines() if line.get_label() == "gas, cycle mean")
    assert len(gas_line.get_xdata()) == 121 < len(heat.result.time_s) / 10
    ride = fig.axes[2].get_lines()[0].get_ydata()
    assert ride[0] == 0.0 and ride[-1] == pytest.approx(1e3 * s.ride_height_change_m, rel=0.05)


def test_figures_are_written_in_the_format_of_their_extension(heat: experiments.Experiment, tmp_path: Path) -> None:
    assert FIGURE_FORMATS == figures.FORMATS  # the CLI's --format choices
    for fmt in figures.FORMATS:
        fig = plots.heat_buildup(heat, tmp_path / f"heat.{fmt}")
        data = (tmp_path / f"heat.{fmt}").read_bytes()
        assert data.lstrip().startswith(MAGIC[fmt]), fmt
        assert isinstance(fig, Figure)
    with pytest.raises(hpctl.ParameterError, match="jpg"):
        plots.heat_buildup(heat, tmp_path / "heat.jpg")
    # SVG and PDF carry no timestamp: the same figure, the same bytes.
    plots.heat_buildup(heat, tmp_path / "again.svg")
    assert (tmp_path / "again.svg").read_bytes() == (tmp_path / "heat.svg").read_bytes()


def test_step_and_loop_plots_return_the_figure_with_conditions(tmp_path: Path) -> None:
    unit = hpctl.Unit.seed()
    steps = [experiments.sdof_step(unit, spring_hard=True, damper_on=on, duration_s=1.5) for on in (True, False)]
    fig = plots.step_responses(steps)  # no path: only the figure
    (ax,) = fig.axes
    assert ax.get_xlabel() == "time [s]" and ax.get_ylabel() == "sprung-mass displacement [mm]"
    assert "43 mm step, 3000 kg" in ax.get_title()
    loops = [experiments.characterisation(unit, hpctl.Sine(0.05, 0.5), 2.0, spring_hard=True, damper_on=True)]
    fig = plots.force_displacement(loops, tmp_path / "loops.pdf")
    assert "sine 50 mm at 0.5 Hz" in fig.axes[0].get_title() and fig.axes[0].get_ylabel() == "strut force [kN]"


def test_mode_plot_has_one_unit_per_axis() -> None:
    height, modes = closed_loop.demo_cases(road_class="B", speed_m_s=10.0, lower_m=0.03, seed=1)
    short = closed_loop.Case(closed_loop.Scenario(10.0, 10.0, manoeuvres=(closed_loop.LaneChange(6.0),)), "B", 1, record_every=10)
    r = closed_loop.run(short)
    fig = plot_modes(r, None, "lane change")
    units = [ax.get_ylabel() for ax in fig.axes if ax.get_ylabel()]
    assert units == ["vehicle acc. [m/s²]", "steering rate [rad/s]", "speed [m/s]", "body displ. [mm]", "body acc. [m/s²]"]
    for label in units:  # one unit each
        assert label.count("[") == 1


def test_switching_records_show_their_valve_states(tmp_path: Path) -> None:
    import matplotlib.pyplot as plt

    from hpctl.data.output import OutputDir

    tests = [virtual_rig.effect_tests()["switching"], virtual_rig.sweep_tests()[2]]
    records = virtual_rig.make_records(virtual_rig.truth_unit((), {}), tests=tests, seed=2)
    result = fit(prepare(records), ("heat_transfer", "real_gas"), max_nfev=3)
    switching, sine = (calibration.record_figure(result, i) for i in range(2))
    assert switching is not None and sine is not None
    valves = [ax for ax in switching.axes if ax.get_ylabel() == "valves"]
    assert len(valves) == 1 and {t.get_text() for t in valves[0].get_yticklabels()} == {"damper off", "damper on", "soft", "hard"}
    assert "valves switching" in switching.texts[0].get_text() or "valves switching" in switching._suptitle.get_text()  # type: ignore[union-attr]
    assert not [ax for ax in sine.axes if ax.get_ylabel() == "valves"]
    assert "sine 60 mm at 0.1 Hz, hard spring, damper off" in sine._suptitle.get_text()  # type: ignore[union-attr]
    plt.close("all")
    with OutputDir(tmp_path, "test") as out:
        paths = calibration.record_plots(result, out, "fit")
        assert [p.name for p in paths] == ["fit_valve_switching.png", "fit_sine_0.1hz.png"]
    assert not plt.get_fignums()  # every figure was closed after writing
    assert (tmp_path / "fit_valve_switching.png").read_bytes().startswith(MAGIC["png"])


def test_record_figures_drawn_in_worker_processes_are_the_same_bytes_and_a_failed_worker_is_drawn_here(tmp_path: Path) -> None:
    # draw_record_plots: the figures of two results, shared between two
    # worker processes and this one, byte for byte the ones drawn here
    # alone; a pool that fails every task, or one shut down, leaves them
    # all drawn here.
    from concurrent.futures import Executor, Future
    from typing import Any

    from hpctl.data.output import OutputDir
    from hpctl.identify.workers import WorkerError, WorkerPool

    tests = [virtual_rig.effect_tests()["switching"], *virtual_rig.sweep_tests()[:3]]
    records = virtual_rig.make_records(virtual_rig.truth_unit((), {}), tests=tests, seed=2)
    result = fit(prepare(records), ("heat_transfer", "real_gas"), max_nfev=3)
    pairs = [(result, "declared"), (result, "final")]

    class Failing(Executor):
        def submit(self, fn: Any, /, *args: Any, **kwargs: Any) -> Future[Any]:
            f: Future[Any] = Future()
            f.set_running_or_notify_cancel()  # taken up, then failed: not one this process can take back
            f.set_exception(WorkerError("worker process failed: test"))
            return f

    class Counted(Executor):
        # The futures handed out: those not cancelled were drawn by a worker.
        def __init__(self, pool: WorkerPool) -> None:
            self.pool, self.futures = pool, list[Future[Any]]()

        def submit(self, fn: Any, /, *args: Any, **kwargs: Any) -> Future[Any]:
            self.futures.append(self.pool.submit(fn, *args, **kwargs))
            return self.futures[-1]

    shut = WorkerPool(1)
    shut.shutdown()
    pool = WorkerPool(2, preload=("hpctl.report.figures",))
    counted = Counted(pool)
    drawn: dict[str, dict[str, bytes]] = {}
    try:
        # Both workers up (started, the report imported) before the figures.
        assert [f.result(timeout=120) for f in [pool.submit(abs, -1), pool.submit(abs, -2)]] == [1, 2]
        for name, workers in (("here", None), ("workers", counted), ("failing", Failing()), ("shut", shut)):
            with OutputDir(tmp_path / name, "test") as out:
                paths = calibration.draw_record_plots(pairs, out, workers)
            assert [[p.name for p in ps] for ps in paths] == [[f"{prefix}_{d.name}.png" for d in result.datasets] for _, prefix in pairs]
            drawn[name] = {p.name: p.read_bytes() for p in (tmp_path / name).glob("*.png")}
    finally:
        pool.shutdown()
    assert len(drawn["here"]) == 2 * len(records)
    assert len(counted.futures) == 2 * len(records) and 0 < sum(not f.cancelled() for f in counted.futures) < len(counted.futures)
    assert drawn["workers"] == drawn["here"] and drawn["failing"] == drawn["here"] and drawn["shut"] == drawn["here"]

"""Simulations through the Python API: physical sense, parallel runs,
determinism, progress and the GIL."""

from __future__ import annotations

import math
import threading
import time

import numpy as np
import pytest

import hpctl
from hpctl.sim import metrics
from hpctl.sim.run import DEFAULT_RTOL, Case, characterisation_rig, sdof_rig, uniform_times


def test_step_frequencies_match_the_seed_within_the_volume_ratio_limit(seed_unit: hpctl.Unit) -> None:
    f = {}
    for hard in (True, False):
        r = hpctl.run_sdof(seed_unit, hpctl.Step(0.043), 6.0, spring_hard=hard, damper_on=False)
        f[hard] = metrics.natural_frequency_hz(r.time_s, r["body_disp_m"], 0.043, 0.55)
    assert f[True] is not None and f[False] is not None
    assert 1.35 < f[True] < 1.8 and 0.8 < f[False] < 1.1


def test_hard_spring_loop_is_stiffer_and_dissipates_positive_work(seed_unit: hpctl.Unit) -> None:
    slopes = {}
    for hard in (True, False):
        r = hpctl.run_characterisation(seed_unit, hpctl.Sine(0.02, 0.1), 20.0, spring_hard=hard, damper_on=False)
        m = metrics.last_cycle(r.time_s, 0.1)
        assert metrics.loop_area_j(r["disp_m"][m], r["force_n"][m]) > 0
        slopes[hard] = np.polyfit(r["disp_m"][m], r["force_n"][m], 1)[0]
    # Linear theory: stiffness ratio = total volume / small volume = 3.33.
    assert slopes[True] / slopes[False] == pytest.approx(1.0 / 0.3, rel=0.1)


def test_run_many_equals_run_and_is_deterministic(seed_unit: hpctl.Unit) -> None:
    times = uniform_times(2.0, 1e-3)
    cases = [
        Case(seed_unit.replace(static_pressure_pa=p), sdof_rig(hpctl.Step(0.02)), times, spring_hard=True, damper_on=on)
        for p in (13e6, 15e6) for on in (True, False)
    ]
    many = hpctl.run_many(cases, threads=2)
    again = hpctl.run_many(cases, threads=1)
    for c, a, b in zip(cases, many, again):
        assert not isinstance(a, Exception) and not isinstance(b, Exception)
        single = hpctl.run(c.unit, c.rig, c.times_s, spring_hard=c.spring_hard, damper_on=c.damper_on)
        for name in ("body_disp_m", "force_n", "t_gas_k"):
            np.testing.assert_array_equal(a[name], single[name])
            np.testing.assert_array_equal(a[name], b[name])


def test_run_many_returns_errors_in_place(seed_unit: hpctl.Unit) -> None:
    good = Case(seed_unit, sdof_rig(hpctl.Step(0.02)), uniform_times(0.5, 1e-3))
    bad = Case(seed_unit, sdof_rig(hpctl.Step(0.02), sprung_mass_kg=0.0), uniform_times(0.5, 1e-3))
    out = hpctl.run_many([good, bad, good])
    assert not isinstance(out[0], Exception) and not isinstance(out[2], Exception)
    assert isinstance(out[1], hpctl.ParameterError) and "sprung_mass_kg = 0" in str(out[1])


def test_valve_schedule_per_sample_switches_the_spring(seed_unit: hpctl.Unit) -> None:
    times = uniform_times(4.0, 1e-3)
    hard = times >= 2.0
    r = hpctl.run(seed_unit, characterisation_rig(hpctl.Sine(0.03, 1.0)), times, spring_hard=hard, damper_on=False)
    np.testing.assert_array_equal(r["spring_hard"], hard.astype(float))
    # Valve 6 closed: no flow to L, L's volume frozen.
    later = times > 2.01
    assert np.all(r["flow_valve6_m3_s"][later] == 0)
    assert np.ptp(r["v_gas2_m3"][later]) == 0
    assert np.ptp(r["v_gas2_m3"][~hard]) > 1e-5


def test_progress_is_reported_and_gil_is_released(seed_unit: hpctl.Unit) -> None:
    calls: list[tuple[int, int]] = []
    ticks = 0
    done = threading.Event()

    def other_thread() -> None:
        nonlocal ticks
        while not done.is_set():
            ticks += 1
            time.sleep(0.001)

    th = threading.Thread(target=other_thread)
    th.start()
    try:
        hpctl.run_characterisation(seed_unit, hpctl.Sine(0.06, 0.5), 600.0, sample_dt_s=0.01, dt_s=1e-3, progress=lambda d, n: calls.append((d, n)))
    finally:
        done.set()
        th.join()
    assert calls and all(n == 60001 for _, n in calls)
    assert [d for d, _ in calls] == sorted(d for d, _ in calls)
    # Python kept running beside the simulation.
    assert ticks > 10


def test_progress_callback_exception_stops_the_run(seed_unit: hpctl.Unit) -> None:
    def boom(done: int, total: int) -> None:
        raise RuntimeError("stop here")

    with pytest.raises(RuntimeError, match="stop here"):
        # Fixed 1 ms steps: progress is reported every 100 ms of wall time,
        # and an adaptive run of these 600 s can end before the first report.
        hpctl.run_characterisation(seed_unit, hpctl.Sine(0.06, 0.5), 600.0, sample_dt_s=0.01, rtol=None, dt_s=1e-3, progress=boom)


def test_the_gas_table_follows_the_equation_and_only_for_the_reference_gas(seed_unit: hpctl.Unit) -> None:
    # Case(gas_table=True), what a fit's many runs use: the reference gas
    # through the process's table (pressure within 1.3e-8 of the equation).
    # Against the direct equation at a 100 x finer tolerance, a drive
    # through most of the stroke is as close with the table as with the
    # equation at the fit's tolerance (2026-11-27: 7.7 Pa against 10.3 Pa
    # in the small accumulator's pressure, both the integrator's own error),
    # plus at most the table's own error (the sealed large accumulator:
    # 0.05 Pa, the equation exact there). Another gas is evaluated
    # directly, bit for bit.
    times = uniform_times(6.0, 2e-3)
    rig = characterisation_rig(hpctl.Sine(0.05, 1.0))
    for unit, tabulated_gas in ((seed_unit, True), (seed_unit.replace(gas="ideal"), False), (seed_unit.replace(gas="bwr-textbook"), False)):
        runs = hpctl.run_many([Case(unit, rig, times), Case(unit, rig, times, gas_table=True), Case(unit, rig, times, rtol=DEFAULT_RTOL / 100)])
        direct, tabulated, fine = (r for r in runs if not isinstance(r, Exception))
        for name in ("p_gas_pa", "p_gas2_pa", "force_n"):
            if not tabulated_gas:
                np.testing.assert_array_equal(tabulated[name], direct[name])
                continue
            own = np.max(np.abs(direct[name] - fine[name]))
            table = np.max(np.abs(tabulated[name] - fine[name]))
            assert np.any(tabulated[name] != direct[name]), name  # the table was used
            assert table <= 1.5 * own + 1.3e-8 * np.max(np.abs(fine[name])), (name, table, own)


def test_run_many_refuses_a_gas_table_flag_that_is_not_a_bool(seed_unit: hpctl.Unit) -> None:
    from hpctl import _core
    from hpctl.sim.run import _case

    c = _case(seed_unit, sdof_rig(hpctl.Step(0.02)), uniform_times(0.2, 1e-3), spring_hard=True, damper_on=True, dt_s=None, rtol=1e-6,
              ambient_k=None, channels=None)
    with pytest.raises(hpctl.ParameterError, match=r"cases\[0\]\.gas_table must be a bool") as e:
        _core.simulate_many([{**c, "gas_table": "yes"}])  # type: ignore[typeddict-item]
    assert isinstance(e.value, ValueError)


def test_a_switch_lead_places_the_switch_between_samples_and_a_bad_one_is_refused(seed_unit: hpctl.Unit) -> None:
    # Midway (a record's logged valve state) equals a switch at an output
    # placed there on a grid twice as fine; at the sample it differs.
    rig = characterisation_rig(hpctl.Sine(0.03, 1.0))
    coarse, fine = uniform_times(0.4, 0.01), uniform_times(0.4, 0.005)
    midway = hpctl.run(seed_unit, rig, coarse, spring_hard=coarse < 0.2, damper_on=True, switch_lead=0.5)
    placed = hpctl.run(seed_unit, rig, fine, spring_hard=fine < 0.195, damper_on=True)
    at_sample = hpctl.run(seed_unit, rig, coarse, spring_hard=coarse < 0.2, damper_on=True)
    np.testing.assert_allclose(midway["p_gas_pa"], placed["p_gas_pa"][::2], rtol=1e-9)
    assert np.max(np.abs(at_sample["p_gas_pa"] - placed["p_gas_pa"][::2])) > 1e4
    for lead in (1.0, -0.1, float("nan"), "half"):
        with pytest.raises(hpctl.ParameterError, match="switch_lead") as e:
            hpctl.run(seed_unit, rig, coarse, spring_hard=coarse < 0.2, switch_lead=lead)  # type: ignore[arg-type]
        assert isinstance(e.value, ValueError)
        if isinstance(lead, float) and math.isfinite(lead):
            # The range named is inclusive: its upper end is below 1.
            assert "[0, 0.9999999999999999]" in str(e.value), e.value
        # run_many checks the argument's type up front and returns the
        # core's range error in the failed case's place.
        try:
            out: list[object] = list(hpctl.run_many([Case(seed_unit, rig, coarse, spring_hard=coarse < 0.2, switch_lead=lead)]))  # type: ignore[arg-type]
        except hpctl.ParameterError as err:
            out = [err]
        assert isinstance(out[0], hpctl.ParameterError) and "switch_lead" in str(out[0]), out

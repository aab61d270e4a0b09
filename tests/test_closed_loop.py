"""The controller in closed loop with the plant: ISO 8608 roads, pump-free
lowering on random roads (hypothesis over roads, speeds, seeds and
targets), raising back, mode switching on manoeuvres, and the
``hpctl closed-loop`` command."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner
from hypothesis import example, given, settings
from hypothesis import strategies as st
from scipy.signal import welch

import hpctl
from hpctl.cli import main
from hpctl.control import closed_loop, road
from hpctl.control.controller import Diag, DriveMode, SequencerState, seed_config

# --- the road ------------------------------------------------------------------


@pytest.mark.parametrize("road_class", ["C", "D"])
def test_the_road_has_the_iso_8608_spectrum(road_class: str) -> None:
    # Welch's PSD estimate of a long profile against G_d(n) = G_d(n0) (n/n0)^-2
    # with the class's geometric mean (16e-6 * 4^k m^3), within the scatter
    # of the estimate, over the band where the estimate has enough cycles.
    dx = 0.05
    p = road.profile(road_class, 20_000.0, seed=7, dx_m=dx)
    n, g = welch(p.height_m, fs=1.0 / dx, nperseg=2**14)
    band = (n >= 0.05) & (n <= 2.0)
    gd0 = {"C": 256e-6, "D": 1024e-6}[road_class]
    ratio = g[band] / (gd0 * (n[band] / 0.1) ** -2)
    assert 0.85 < float(np.exp(np.mean(np.log(ratio)))) < 1.15
    assert np.all((ratio > 0.3) & (ratio < 3.0))
    # Height variance against the PSD integrated over the generated band.
    lo, hi = road.BAND_CYCLES_M
    variance = gd0 * 0.1**2 * (1 / lo - 1 / hi)
    assert 0.5 < float(np.var(p.height_m)) / variance < 1.5


def test_the_road_is_seeded_and_classes_scale_by_four() -> None:
    a = road.profile("C", 500.0, seed=1)
    assert np.array_equal(a.height_m, road.profile("C", 500.0, seed=1).height_m)
    assert not np.array_equal(a.height_m, road.profile("C", 500.0, seed=2).height_m)
    d = road.profile("D", 500.0, seed=1)
    # Same phases, four times the PSD: twice the amplitude.
    assert np.allclose(d.height_m, 2.0 * a.height_m)
    assert road.displacement_psd_m3(0.1, "B") == pytest.approx(64e-6)


@pytest.mark.parametrize(("args", "message"), [(("Z", 100.0), "not an ISO 8608 class"), (("C", -1.0), "length_m"), (("C", math.nan), "length_m")])
def test_bad_road_arguments(args: tuple[str, float], message: str) -> None:
    with pytest.raises(hpctl.ParameterError, match=message):
        road.profile(args[0], args[1], seed=0)


def test_the_base_motion_starts_at_rest() -> None:
    p = road.profile("D", 200.0, seed=3)
    t = np.arange(0, 10, 1e-3)
    m = road.base_motion(p, 15.0 * t, t)
    assert m.disp_m[0] == 0.0 and abs(m.disp_m[1]) < 1e-9
    assert np.ptp(m.disp_m) > 0.02


# --- lowering on random roads ----------------------------------------------------

REQUEST_S = 8.0
END_S = 56.0
#: How close the held ride height must end to the target: the sequencer
#: starts a correction only beyond its 3 mm tolerance, and its estimate
#: (the load pressure sampled at strut turning points, about 1 mm; the
#: lagging temperature sensor; the gas table, 0.2 mm) may be off by up to
#: 1 mm more.
TOLERANCE_M = seed_config()["ride_height"]["tolerance_m"] + 0.001
STROKE_M = 0.125

# Roads on which the sequencer gets enough excitation to lower by 40 mm in
# the time given (class C from 10 m/s, class D from 6 m/s) and the strut
# stays off its end stops (class D up to 12 m/s).
roads = st.one_of(
    st.tuples(st.just("C"), st.floats(10.0, 20.0)),
    st.tuples(st.just("D"), st.floats(6.0, 12.0)),
)


@settings(max_examples=25, deadline=None)
@given(roads, st.floats(-0.04, -0.01), st.integers(0, 2**31 - 1))
# The two draws that end still finishing (below), every run.
@example(("D", 7.667879671835465), -0.03679217716694156, 103540854)
@example(("C", 20.0), -0.03, 2**31 - 1)
def test_a_lowering_on_a_random_road_ends_within_tolerance_and_within_the_stroke(road_and_speed: tuple[str, float], target_m: float, seed: int) -> None:
    road_class, speed = road_and_speed
    scenario = closed_loop.Scenario(END_S, speed, requests=(closed_loop.HeightRequest(REQUEST_S, target_m),))
    r = closed_loop.run(closed_loop.Case(scenario, road_class, seed))
    s = closed_loop.height_change_summary(r, REQUEST_S, END_S)
    # At the target within tolerance, measured on the plant: L's gas volume
    # against its volume at the true static load. Done and holding, or
    # still finishing: the sequencer lowers until its estimate crosses the
    # request, and a pump-free unit moves the last millimetres only when the
    # road presses S above L by the margin. Two draws in about 60 runs of
    # this test ended so, within tolerance (road D at 7.7 m/s: 2.9 mm
    # short, no such peak in the 42 s after the last opening; road C at
    # 20 m/s, seed 2147483647: 0.7 mm short by its estimate, valve 6 still
    # opening at 55.9 s); hp-ctrl's `ride_height::step` keeps waiting.
    assert s.sequencer_end == "holding" or (s.sequencer_end == "lowering" and 0.0 < s.estimate_m - target_m <= TOLERANCE_M), s
    assert abs(s.held_offset_m - target_m) < TOLERANCE_M, s
    # Never past the stroke limits.
    assert np.all(np.abs(r.plant["disp_m"]) < STROKE_M), (s.strut_disp_min_m, s.strut_disp_max_m)
    # Valve 6 opened for sequencing only while the pressures, as the
    # controller saw them, pointed the right way by the margin (raising
    # too: a pulse may overshoot a small target by more than the tolerance).
    o, i = r.outputs, r.inputs
    margin = seed_config()["ride_height"]["valve6_margin_pa"]
    lowering = o["valve6_open"] & (o["sequencer"] == SequencerState.LOWERING)
    raising = o["valve6_open"] & (o["sequencer"] == SequencerState.RAISING)
    assert np.all(i["p_gas_pa"][lowering] - i["p_gas2_pa"][lowering] > margin)
    assert np.all(i["p_gas2_pa"][raising] - i["p_gas_pa"][raising] > margin)
    # The plant never gave the controller a reason for the safe state.
    after_recovery = np.flatnonzero((o["diag"] & Diag.SAFE_STATE) == 0)[0]
    assert not np.any(o["diag"][after_recovery:] & Diag.SAFE_STATE)


def test_lowering_and_raising_back_by_30_mm() -> None:
    scenario = closed_loop.Scenario(64.0, 12.0, requests=(closed_loop.HeightRequest(8.0, -0.03), closed_loop.HeightRequest(40.0, 0.0)))
    r = closed_loop.run(closed_loop.Case(scenario, "C", seed=5))
    down = closed_loop.height_change_summary(r, 8.0, 40.0)
    assert abs(down.error_m) < TOLERANCE_M and down.valve6_openings > 0
    assert down.time_to_reach_s is not None and down.time_to_reach_s < 30.0
    # L's pressure ended at its target, within the pressure of the tolerance.
    assert down.p_gas2_pa == pytest.approx(down.p_gas2_target_pa, rel=0.01)
    # Back to zero: sequenced (valve 6 only while p_L > p_S), then released
    # to the soft spring with the offset gone, so the body does not jump.
    up = closed_loop.height_change_summary(r, 40.0, 64.0)
    assert up.released_to_soft_s is not None
    assert abs(up.held_offset_m) < TOLERANCE_M
    o, i = r.outputs, r.inputs
    raising = o["valve6_open"] & (o["sequencer"] == SequencerState.RAISING)
    assert np.any(raising)
    margin = seed_config()["ride_height"]["valve6_margin_pa"]
    assert np.all(i["p_gas2_pa"][raising] - i["p_gas_pa"][raising] > margin)
    assert o["sequencer"][-1] == SequencerState.IDLE and o["valve6_open"][-1]


def test_manoeuvres_switch_to_handling_at_once_and_back_after_the_hold() -> None:
    scenario = closed_loop.Scenario(28.0, 15.0, manoeuvres=(closed_loop.LaneChange(8.0), closed_loop.Braking(18.0)))
    r = closed_loop.run(closed_loop.Case(scenario, "C", seed=9))
    m = closed_loop.mode_summary(r)
    assert len(m.handling_entered_s) == 2 and len(m.ride_returned_s) == 2
    assert {"TRIGGER_LATERAL", "TRIGGER_STEER_RATE", "TRIGGER_LONGITUDINAL", "TRIGGER_BRAKE"} <= set(m.triggers)
    t, i, o = r.time_s, r.inputs, r.outputs
    hold_s = seed_config()["mode"]["handling_hold_s"]
    # The braking burst: Handling in the period the pedal is pressed.
    pressed = int(np.flatnonzero(i["brake_pressed"])[0])
    assert o["drive_mode"][pressed] == DriveMode.HANDLING and o["drive_mode"][pressed - 1] == DriveMode.RIDE
    assert not o["valve5_open"][pressed] and not o["valve6_open"][pressed]
    # Ride returns no sooner than the hold after the last period with the
    # pedal pressed (the deceleration is below its exit threshold by then).
    last_pressed = int(np.flatnonzero(i["brake_pressed"])[-1])
    assert m.ride_returned_s[1] >= t[last_pressed] + hold_s - 1e-9
    assert m.shortest_handling_s >= hold_s


# --- the command ---------------------------------------------------------------------


def test_the_closed_loop_command_writes_plots_and_a_summary(tmp_path: Path) -> None:
    out = tmp_path / "cl"
    result = CliRunner().invoke(main, ["closed-loop", "--out", str(out), "--seed", "4", "--json", "--quiet"])
    assert result.exit_code == 0, result.output
    summary = json.loads(result.output)
    assert json.loads((out / "summary.json").read_text()) == summary
    for name in ("ride_height.png", "modes.png"):
        assert (out / name).read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    down = summary["lowering"]
    assert down["target_m"] == pytest.approx(-0.03)
    assert abs(down["held_offset_m"] + 0.03) < TOLERANCE_M
    assert down["valve6_openings"] > 0 and down["time_to_reach_s"] > 0
    assert summary["modes"]["handling_entered_s"]
    # The file's keys, in order: a format others read (the typed summaries
    # closed_loop.DemoSummary / HeightChange / ModeSwitches write it).
    assert list(summary) == ["hpctl", "road_class", "speed_m_s", "seed", "lowering", "raising", "modes", "plots", "config", "config_source", "warnings"]
    assert list(down) == list(summary["raising"]) == [
        "start_s", "end_s", "request_m", "target_m", "held_offset_m", "error_m", "estimate_m", "time_to_reach_s", "released_to_soft_s",
        "valve6_openings", "blocked_s", "tolerance_m", "reached", "road_mean_change_m", "p_gas_pa", "p_gas2_pa", "p_gas2_target_pa",
        "p_load_estimate_pa", "p_load_true_pa", "sequencer_end", "strut_disp_min_m", "strut_disp_max_m",
    ]
    assert list(summary["modes"]) == ["first_ride_s", "handling_entered_s", "ride_returned_s", "triggers", "shortest_handling_s", "safe_state_after_first_ride"]


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["--lower-m", "-0.01"], "lower_m = -0.01 must be within"),
        (["--lower-m", "nan"], "'nan' is not a finite number"),
        (["--speed-m-s", "0"], "speed_m_s = 0.0 must be within"),
    ],
)
def test_the_closed_loop_command_rejects_bad_input_with_exit_2(tmp_path: Path, args: list[str], message: str) -> None:
    result = CliRunner().invoke(main, ["closed-loop", "--out", str(tmp_path), "--quiet", *args])
    assert result.exit_code == 2
    assert message in result.output


def test_an_unknown_road_class_is_a_usage_error(tmp_path: Path) -> None:
    result = CliRunner().invoke(main, ["closed-loop", "--out", str(tmp_path), "--road-class", "Z"])
    assert result.exit_code == 2 and "road-class" in result.output

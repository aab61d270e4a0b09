"""The vehicles from Python: presets, the stepping plant, runs and their
metrics on a short route, the lane-change geometry, bad input, and the
``hpctl evaluate`` command."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner

import hpctl
from hpctl import _core
from hpctl.cli import main
from hpctl.data.records import read_record
from hpctl.vehicle import comparison, route
from hpctl.vehicle.model import preset


@pytest.fixture(scope="module")
def short_runs() -> comparison.Evaluation:
    """The 4x4 on a short mixed route: soft/low, hard/high and semi-active."""
    return comparison.evaluate([preset("4x4")], route.mixed(scale=0.15), (comparison.PASSIVE[0], comparison.PASSIVE[3], comparison.SEMI_ACTIVE), threads=2)


def test_presets_carry_three_tonnes_per_wheel_on_the_seed_unit() -> None:
    for name, wheels in (("4x4", 4), ("8x8", 8)):
        v = preset(name)
        assert v.corner_count == wheels
        s = v.statics()
        assert np.allclose(s.static_load_n, 3000.0 * 9.80665)
        # The seed unit's charge matches 3 t: it sits at its static position.
        assert np.allclose(s.static_disp_m, 0.0, atol=1e-6)
        assert s.total_mass_kg == pytest.approx(wheels * 3400.0)
        # Round trip through the core's dict form.
        assert type(v).from_core(name, v.to_core()) == v


def test_the_plant_steps_one_period_at_a_time_with_valves_per_wheel() -> None:
    v = preset("8x8")
    flat = {"start_m": 0.0, "dx_m": 1.0, "left_m": np.zeros(2), "right_m": np.zeros(2)}
    plant = _core.VehiclePlant(v.to_core(), flat, 293.15)
    assert plant.corner_count == 8
    s = plant.sample()
    for _ in range(200):
        s = plant.step(1e-3, [False] * 8, [True] * 8, 10.0)
    assert plant.time_s == pytest.approx(0.2)
    assert abs(s["heave_m"]) < 1e-9 and s["valve6_open"] == [1.0] * 8
    with pytest.raises(hpctl.ParameterError, match="8 wheels"):
        plant.step(1e-3, [False] * 4, [True] * 4, 10.0)
    with pytest.raises(hpctl.ParameterError, match="unknown key vehicle.body.colour"):
        d = v.to_core()
        d["body"]["colour"] = "green"
        _core.VehiclePlant(d, flat, 293.15)
    with pytest.raises(hpctl.ParameterError, match="cg_height_m"):
        d = v.to_core()
        d["body"]["cg_height_m"] = -1.0
        _core.VehiclePlant(d, flat, 293.15)


def test_one_wheels_unit_can_be_replaced_for_a_gas_leak() -> None:
    """``corner_units`` gives one wheel its own unit (here the seed unit with
    a leak): that wheel's gas in L, from the plant's own pressure,
    temperature and volume through the equation of state, follows the
    leakage law m(t) = m0 exp(-t / tau) (valve 6 closed: L neither gains
    nor loses oil); the other wheels keep theirs."""
    v = preset("4x4")
    unit = hpctl.Unit.seed()
    tau_s = 5.0
    leaky = unit.with_effects(leakage=hpctl.model.unit.Leakage(tau_s)).to_dict()
    flat = {"start_m": 0.0, "dx_m": 1.0, "left_m": np.zeros(2), "right_m": np.zeros(2)}
    plant = _core.VehiclePlant(v.to_core(), flat, unit.static_temperature_k, corner_units={3: leaky})
    m0 = _core.gas_masses_kg(unit.to_dict())[1]
    for _ in range(1000):
        s = plant.step(1e-3, [False] * 4, [False] * 4, 0.0)
    p, t, vol = (np.asarray(s[c]) for c in ("p_gas2_pa", "t_gas2_k", "v_gas2_m3"))
    mass = np.array([_core.gas_density_kg_m3(unit.gas, p[k], t[k]) * vol[k] for k in range(4)])
    assert mass[3] == pytest.approx(m0 * math.exp(-1.0 / tau_s), rel=1e-3)
    assert mass[:3] == pytest.approx(np.full(3, m0), rel=1e-3)
    with pytest.raises(hpctl.ParameterError, match="wheels 0 to 3"):
        _core.VehiclePlant(v.to_core(), flat, 293.15, corner_units={4: leaky})
    with pytest.raises(hpctl.ParameterError, match="leak_time_constant_s"):
        bad = unit.to_dict()
        bad["effects"]["leakage"] = {"time_constant_s": 0.0}
        _core.VehiclePlant(v.to_core(), flat, 293.15, corner_units={0: bad})
    # A field with a default (the leak's pressure exponent, added later) may
    # be left out of the dict: the same leak as the dataclass's.
    old_style = unit.to_dict()
    old_style["effects"]["leakage"] = {"time_constant_s": tau_s}
    again = _core.VehiclePlant(v.to_core(), flat, unit.static_temperature_k, corner_units={3: old_style})
    for _ in range(1000):
        s2 = again.step(1e-3, [False] * 4, [False] * 4, 0.0)
    np.testing.assert_array_equal(np.asarray(s2["p_gas2_pa"]), p)
    with pytest.raises(hpctl.ParameterError, match="pressure_exponent"):
        old_style["effects"]["leakage"] = {"time_constant_s": tau_s, "pressure_exponent": "high"}
        _core.VehiclePlant(v.to_core(), flat, 293.15, corner_units={0: old_style})


def test_the_lane_change_has_the_iso_3888_2_layout() -> None:
    lc = route.LaneChange(at_m=0.0, length_scale=1.0)
    assert sum(lc.sections_m()) == pytest.approx(61.0)  # the standard's track length
    w = 2.0
    assert lc.offset_m(w) == pytest.approx((1.1 * w + 0.25) / 2 + 1.0 + (w + 1.0) / 2)
    x = np.linspace(-5, 70, 7501)
    y = lc.path_m(x, w)
    assert y[0] == 0.0 and y[-1] == 0.0 and y.max() == pytest.approx(lc.offset_m(w))
    # In section 3 the path is in the middle lane, in 1 and 5 in the entry lane.
    assert np.allclose(y[(x > 25.5) & (x < 36.5)], lc.offset_m(w))
    assert np.allclose(y[(x > 0) & (x < 12)], 0.0) and np.allclose(y[x > 49], 0.0)


def test_the_driver_keeps_to_the_speed_limits_and_accelerations(short_runs: comparison.Evaluation) -> None:
    r = short_runs.results[0].route
    assert r is not None
    d = route.drive(r, preset("4x4"))
    assert np.all(np.abs(d.long_acc_m_s2) <= r.spec.accel_m_s2 * 1.001)
    for s in r.sections:
        m = (d.distance_m >= s.start_m + 1.0) & (d.distance_m < s.end_m)
        assert np.all(d.speed_m_s[m] <= s.speed_m_s + 1e-9)


def test_runs_are_reduced_to_section_metrics_and_the_semi_active_rolls_like_hard(short_runs: comparison.Evaluation) -> None:
    soft, hard, semi = short_runs.results
    assert not short_runs.failed
    assert [s.kind for s in semi.sections] == ["start", "highway", "lane_change", "rough", "obstacles"]
    # Handling: the semi-active unit enters Handling (hard, high) in the
    # lane change and rolls within 10 % of the hard passive setting, far
    # less than the soft one.
    assert semi.roll_peak_rad < 1.1 * hard.roll_peak_rad < 0.5 * soft.roll_peak_rad
    assert comparison.mode_share(semi, "lane_change") > 0.2
    # Comfort: soft/low is the most comfortable passive setting on the rough track.
    assert soft.comfort_m_s2 < hard.comfort_m_s2
    for r in short_runs.results:
        for s in r.sections:
            assert 0 < s.ride.a_v_m_s2 < 5 and 0 <= s.wheels.dynamic_load_coefficient < 1
    # Every warning names its case; lift-off in the metrics is in the warnings.
    lifted = [r for r in short_runs.results if any(s.wheels.lifted_wheels for s in r.sections)]
    assert all(any(w.code == "wheel_lift_off" and "lift-off" in w.message for w in r.warnings) for r in lifted)
    for r in short_runs.results:
        for w in r.warnings:
            assert w.message.startswith(r.case.label) and w.details["vehicle"] == r.case.vehicle.name


def test_a_failed_case_is_kept_as_a_warning_not_raised() -> None:
    # A configuration is merged over the vehicle's (a part is a whole configuration): a value out of range breaks it.
    bad = comparison.Setting("broken", semi_active=True, config={"unit": {"piston_area_m2": -1.0}})
    r = comparison.run_case(comparison.Case(preset("4x4"), route.mixed(scale=0.05), bad))
    assert r.error is not None and r.sections == [] and r.warnings[0].code == "case_failed" and "case failed" in r.warnings[0].message


def test_the_evaluate_command_writes_table_plots_records_and_warnings(tmp_path: Path) -> None:
    out = tmp_path / "ev"
    res = CliRunner().invoke(main, ["evaluate", "--vehicle", "4x4", "--scale", "0.1", "--setting", "soft-low", "--setting", "semi-active",
                                    "--threads", "2", "--out", str(out), "--json"])
    assert res.exit_code == 0, res.output
    summary = json.loads((out / "comparison.json").read_text())
    assert {c["setting"] for c in summary["cases"]} == {"soft, low damping", "semi-active"}
    assert isinstance(summary["warnings"], list) and summary["failed"] == []
    md = (out / "comparison.md").read_text().splitlines()
    assert (out / "ride_handling.png").stat().st_size > 10_000 and md[0].startswith("Written by hpctl ") and md[2].startswith("| vehicle")
    assert summary["hpctl"]["command"].startswith("hpctl evaluate --vehicle 4x4 --scale 0.1")
    # One rig record per wheel of the semi-active run, readable by the record reader.
    assert len(summary["records"]) == 4
    rec = read_record(out / "records" / summary["records"][0])
    assert rec.kind == "sdof" and rec.test.excitation == "drive" and "tyre_force_n" in rec
    assert rec.sprung_mass_kg == pytest.approx(3000.0)
    assert math.isfinite(float(rec["disp_m"].max()))


@pytest.mark.parametrize(("args", "message"), [(["--scale", "2"], "scale"), (["--threads", "0"], "threads")])
def test_the_evaluate_command_rejects_bad_input_with_exit_2(tmp_path: Path, args: list[str], message: str) -> None:
    res = CliRunner().invoke(main, ["evaluate", "--vehicle", "4x4", "--out", str(tmp_path), *args])
    assert res.exit_code == 2 and message in res.output


@pytest.mark.parametrize(("command", "mine"), [("evaluate", "comparison.md"), ("tune", "tuned.json")])
def test_evaluate_and_tune_never_overwrite_a_users_file(tmp_path: Path, command: str, mine: str) -> None:
    # Checked before the drives: the run stops at once, the user's file is
    # untouched and nothing else is written.
    (tmp_path / mine).write_text("the user's notes\n")
    res = CliRunner().invoke(main, [command, "--vehicle", "4x4", "--scale", "0.05", "--out", str(tmp_path)])
    assert res.exit_code == 2, res.output
    assert "would overwrite files hpctl did not write" in res.output and mine in res.output
    assert (tmp_path / mine).read_text() == "the user's notes\n"
    assert sorted(p.name for p in tmp_path.iterdir()) == [mine]


# Its cases fail, so the plots have nothing labelled: no empty-legend warning.
@pytest.mark.filterwarnings("error::UserWarning")
def test_evaluate_warnings_carry_codes_and_strict_exits_3(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    # Whatever the short drive gives, one end-stop warning is added to the
    # reduction, so that the plumbing (codes in the JSON, --strict) is tested.
    from hpctl.caveats import Caveat, Code

    real = comparison._warnings

    def with_end_stop(case: comparison.Case, sections: list) -> list[Caveat]:
        return [*real(case, sections), Caveat(Code.END_STOP, f"{case.label}: 1 end-stop hit(s) (test)", {"hits": 1})]

    monkeypatch.setattr(comparison, "_warnings", with_end_stop)
    args = ["evaluate", "--vehicle", "4x4", "--scale", "0.05", "--setting", "soft-low", "--records", "none", "--threads", "1"]
    lenient = CliRunner().invoke(main, [*args, "--out", str(tmp_path / "a")])
    assert lenient.exit_code == 0, lenient.output
    assert "warning [end_stop]" in lenient.output
    summary = json.loads((tmp_path / "a" / "comparison.json").read_text())
    assert "end_stop" in {w["code"] for w in summary["warnings"]}
    assert all(set(w) == {"code", "message", "details"} for w in summary["warnings"])
    assert summary["cases"][0]["warnings"][-1]["details"] == {"hits": 1}
    strict = CliRunner().invoke(main, [*args, "--strict", "--out", str(tmp_path / "b")])
    assert strict.exit_code == 3, strict.output
    assert (tmp_path / "b" / "comparison.json").exists()  # the outputs are still written

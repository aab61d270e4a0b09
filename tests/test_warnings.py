"""Warnings as data (hpctl.caveats): every command collects what its result
cannot stand behind, prints it, writes it into its JSON under "warnings",
and --strict turns any of it into exit code 3. The checks are tested on
inputs whose answer is known without the code under test: a stroke, the
core's exported ranges, an analytic sine speed."""

from __future__ import annotations

import dataclasses
import json
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from click.testing import CliRunner

import hpctl
from hpctl import _core
from hpctl.caveats import Caveat, Code
from hpctl.cli import main
from hpctl.cli.closed_loop import _height_title
from hpctl.control import closed_loop
from hpctl.control.controller import seed_config
from hpctl.data.records import RecordStatic, RecordTest, RecordUnit, RigRecord, write_record
from hpctl.sim import checks, experiments, metrics
from hpctl.sim.run import Sine


def run(*args: str) -> tuple[int, str, str]:
    r = CliRunner().invoke(main, list(args))
    return r.exit_code, r.stdout, r.stderr


def codes(document: dict[str, Any]) -> list[str]:
    return [w["code"] for w in document["warnings"]]


# ------------------------------------------------------------ the checks


def test_end_stop_contact_is_found_at_the_stroke(seed_unit: hpctl.Unit) -> None:
    t = np.linspace(0.0, 1.0, 101)
    stroke = seed_unit.stroke_compression_m
    inside = {"time_s": t, "disp_m": stroke * np.sin(np.pi * t)}  # touches, never passes
    assert checks.end_stop(seed_unit, inside, "run") == []
    beyond = {"time_s": t, "disp_m": (stroke + 0.01) * np.sin(np.pi * t)}
    (c,) = checks.end_stop(seed_unit, beyond, "run")
    assert c.code == Code.END_STOP and c.details["side"] == "compression"
    assert c.details["max_over_travel_m"] == pytest.approx(0.01)
    (c,) = checks.end_stop(seed_unit, {"time_s": t, "disp_m": -(seed_unit.stroke_extension_m + 0.002) * t}, "run")
    assert c.details["side"] == "extension" and c.details["max_over_travel_m"] == pytest.approx(0.002)


def test_the_gas_range_comes_from_the_core() -> None:
    for gas in ("ideal", "bwr-cg", "bwr-textbook"):
        (p_lo, p_hi), (t_lo, t_hi) = checks.validated_range(gas)
        r = _core.gas_validated_range(gas)
        assert (p_lo, p_hi) == tuple(r["pressure_pa"]) and (t_lo, t_hi) == tuple(r["temperature_k"])
        inside = {"p_gas_true_pa": np.array([p_lo, p_hi]), "t_gas_k": np.array([t_lo, t_hi])}
        assert checks.eos_range(gas, inside, "run") == []
        (c,) = checks.eos_range(gas, {"p_gas_true_pa": np.array([p_hi * 1.01])}, "run")
        assert c.code == Code.EOS_RANGE and c.details["value"] == pytest.approx(p_hi * 1.01)
        (c,) = checks.eos_range(gas, {"t_gas2_k": np.array([t_lo - 1.0])}, "run")
        assert c.details["channel"] == "t_gas2_k"
    with pytest.raises(hpctl.ParameterError, match="gas"):
        _core.gas_validated_range("steam")


def test_rated_speed_of_a_sine_is_its_analytic_peak(seed_unit: hpctl.Unit) -> None:
    t = np.linspace(0.0, 1.0, 20001)
    for amplitude, f in ((0.05, 5.0), (0.05, 7.0)):
        x = amplitude * np.sin(2 * np.pi * f * t)
        found = checks.rated_speed(seed_unit, {"time_s": t, "disp_m": x}, "run")
        peak = 2 * np.pi * f * amplitude
        assert bool(found) == (peak > seed_unit.rated_speed_m_s)
        if found:
            assert found[0].details["max_speed_m_s"] == pytest.approx(peak, rel=1e-3)


def test_the_seed_unit_is_rated_in_the_core(seed_unit: hpctl.Unit) -> None:
    assert seed_unit.rated_speed_m_s == _core.seed_unit()["rated_speed_m_s"] > 0
    with pytest.raises(hpctl.ParameterError, match="rated_speed_m_s = 0 is outside the valid range"):
        seed_unit.replace(rated_speed_m_s=0.0).check()


def test_loop_areas_close_the_cycle() -> None:
    # A single-valued force (an isothermal gas) has no loop, however the
    # samples fall on the period; an open path would report f x gap.
    t = np.linspace(0.0, 1.0, 667, endpoint=False)[:-3]
    x = 0.02 * np.sin(2 * np.pi * t)
    assert metrics.loop_area_j(x, 3e4 + 1e6 * x) == pytest.approx(0.0, abs=1e-9)
    # A viscous loop: pi c omega A^2 per cycle.
    t = np.linspace(0.0, 1.0, 2001)
    v = 0.02 * 2 * np.pi * np.cos(2 * np.pi * t)
    assert metrics.loop_area_j(0.02 * np.sin(2 * np.pi * t), 1e4 * v) == pytest.approx(np.pi * 1e4 * 2 * np.pi * 0.02**2, rel=1e-5)


@pytest.mark.parametrize("tau_s", [0.0, 2.0, float("inf")])
def test_a_gas_absorbs_work_over_a_cycle(seed_unit: hpctl.Unit, tau_s: float) -> None:
    e = experiments.characterisation(seed_unit.replace(tau_s=tau_s), Sine(0.02, 1.0), 3.0, spring_hard=False, damper_on=False,
                                     dt_s=1e-3, sample_dt_s=1e-3)
    r = e.result
    m = metrics.last_cycle(r.time_s, 1.0)
    work = sum(metrics.gas_work_j(r[p][m], r[v][m]) for p, v in (("p_gas_true_pa", "v_gas_m3"), ("p_gas2_true_pa", "v_gas2_m3")))
    assert work > -1e-6 * 50.0  # the second law, to rounding (p dV scale ~50 J)
    if 0 < tau_s < float("inf"):
        assert work > 1.0
    assert not [c for c in e.caveats if c.code in (Code.ENERGY_BALANCE, Code.CAVITATION)]


def test_caveats_are_json(seed_unit: hpctl.Unit) -> None:
    c = Caveat(Code.EOS_RANGE, "m", {"value": float("inf"), "flags": ["A"]})
    assert json.loads(json.dumps(c.to_json())) == {"code": "eos_range", "message": "m", "details": {"value": None, "flags": ["A"]}}


# ------------------------------------------------------------- simulate


def test_a_50_hz_sine_says_why_its_gas_loop_is_negative(tmp_path: Path) -> None:
    code, _, err = run("simulate", "--test", "sine", "--frequency-hz", "50", "--spring", "hard", "--damper", "on", "--out", str(tmp_path), "--quiet")
    assert code == 0
    s = json.loads((tmp_path / "summary.json").read_text())
    (r,) = s["runs"]
    assert r["gas_loop_area_j"] < 0
    assert {"rated_speed", "cavitation"} <= set(codes(s))
    rated = next(w for w in s["warnings"] if w["code"] == "rated_speed")
    assert rated["details"]["max_speed_m_s"] == pytest.approx(2 * np.pi * 50 * 0.05, rel=1e-3)
    assert "warning [rated_speed]" in err and "warning [cavitation]" in err


def test_strict_exits_3_and_still_writes_everything(tmp_path: Path) -> None:
    code, stdout, err = run("simulate", "--test", "sdof-step", "--fixed-steps", "--dt-s", "0.1", "--duration-s", "1", "--spring", "hard", "--damper", "on",
                            "--out", str(tmp_path), "--strict", "--json")
    assert code == 3 and "--strict: exit code 3" in err
    s = json.loads(stdout)
    assert s == json.loads((tmp_path / "summary.json").read_text())
    (w,) = s["warnings"]
    assert w["code"] == "step_replaced" and w["details"]["requested_dt_s"] == 0.1 and w["details"]["used_dt_s"] == pytest.approx(1e-3)
    assert (tmp_path / "records" / "sdof_step_hard_on.csv").exists()


def test_a_clean_run_has_no_warnings_and_strict_passes(tmp_path: Path) -> None:
    code, stdout, err = run("simulate", "--test", "sdof-step", "--duration-s", "2", "--spring", "hard", "--damper", "on",
                            "--out", str(tmp_path), "--strict", "--json")
    assert code == 0, err
    assert json.loads(stdout)["warnings"] == []


def test_sweep_reports_failed_cases_and_fails_when_all_do(tmp_path: Path) -> None:
    code, stdout, err = run("simulate", "--sweep", "--sweep-pressure-pa", "14811300,1e3", "--sweep-tau-s", "2", "--damper", "on", "--spring", "hard",
                            "--out", str(tmp_path / "some"), "--json")
    assert code == 0, err
    s = json.loads(stdout)
    assert s["failed"] == 1 and codes(s) == ["case_failed"]
    assert "static_pressure_pa = 1000 is outside the valid range" in s["warnings"][0]["details"]["error"]
    assert "1 of 2 sweep cases failed" in err
    code, stdout, err = run("simulate", "--sweep", "--sweep-pressure-pa", "1e3", "--out", str(tmp_path / "none"))
    assert code == 2 and "every one of the 6 sweep cases failed" in err
    assert "Wrote" not in stdout and not (tmp_path / "none" / "sweep.csv").exists()


# ----------------------------------------------------------- closed loop


@pytest.fixture(scope="module")
def rough_road() -> tuple[closed_loop.ClosedLoop, closed_loop.ClosedLoop, closed_loop.DemoSummary]:
    return closed_loop.demo(road_class="E", speed_m_s=20.0, lower_m=0.05, seed=1)


def test_a_rough_road_says_what_went_wrong(rough_road: tuple[closed_loop.ClosedLoop, closed_loop.ClosedLoop, closed_loop.DemoSummary]) -> None:
    height, modes, summary = rough_road
    caveats = closed_loop.demo_caveats(height, modes, summary)
    found = {(c.code, c.details.get("run", c.details.get("change"))) for c in caveats}
    for code in (Code.END_STOP, Code.SAFE_STATE, Code.RATED_SPEED):
        assert (code, "ride-height run") in found
    assert (Code.SEQUENCER_BLOCKED, "lowering") in found and (Code.TARGET_MISSED, "lowering") in found
    # The strut's travel and the pressure that the warnings claim are real.
    assert height.plant["disp_m"].max() > height.case.unit.stroke_compression_m
    assert height.plant["p_gas_true_pa"].max() > checks.validated_range("bwr-textbook")[0][1]
    # That pressure is beyond where the BWR sets were validated but inside
    # the reference model's range (checked against CoolProp up to 300 MPa),
    # the unit's gas: no equation-of-state warning, rightly.
    assert height.case.unit.gas == "span"
    assert height.plant["p_gas_true_pa"].max() < checks.validated_range("span")[0][1]
    assert (Code.EOS_RANGE, "ride-height run") not in found
    assert not summary.lowering.reached
    title = _height_title(summary, 0.05, "class E")
    assert "NOT reached" in title and "and back" not in title


def test_the_calm_demo_is_clean_and_claims_its_lowering() -> None:
    height, modes, summary = closed_loop.demo(road_class="C", speed_m_s=10.0, lower_m=0.03, seed=1)
    assert closed_loop.demo_caveats(height, modes, summary) == []
    assert summary.lowering.reached and summary.raising.reached
    assert _height_title(summary, 0.03, "class C") == "Pump-free lowering by 30 mm and back (class C)"


def test_closed_loop_with_another_unit_configures_the_controller_for_it(tmp_path: Path) -> None:
    other = hpctl.Unit.seed().replace(large_acc_volume_m3=0.9e-3, static_temperature_k=303.15)
    config = closed_loop.config_for_unit(other)
    assert config["unit"]["large_acc_volume_m3"] == 0.9e-3 and config["unit"]["static_temperature_k"] == 303.15
    assert {k: v for k, v in config.items() if k != "unit"} == {k: v for k, v in seed_config().items() if k != "unit"}
    assert closed_loop.config_for_unit(hpctl.Unit.seed()) == seed_config()
    path = tmp_path / "other.toml"
    other.to_toml(path)
    code, stdout, err = run("closed-loop", "--unit", str(path), "--out", str(tmp_path / "out"), "--json", "--quiet")
    assert code == 0, err
    s = json.loads(stdout)
    assert s["lowering"]["reached"] and abs(s["lowering"]["error_m"]) <= s["lowering"]["tolerance_m"], s["warnings"]
    assert "target_missed" not in codes(s)


def test_a_config_for_another_unit_is_a_warning() -> None:
    other = hpctl.Unit.seed().replace(large_acc_volume_m3=0.9e-3)
    scenario = closed_loop.Scenario(2.0, 5.0)
    r = closed_loop.run(closed_loop.Case(scenario, unit=other, config=seed_config()))
    (c,) = [c for c in closed_loop.run_caveats(r, "run") if c.code == Code.CONFIG_NOT_DERIVED]
    assert c.details["fields"] == ["large_acc_volume_m3"]
    r = closed_loop.run(closed_loop.Case(scenario, unit=other, config=closed_loop.config_for_unit(other)))
    assert not [c for c in closed_loop.run_caveats(r, "run") if c.code == Code.CONFIG_NOT_DERIVED]


# -------------------------------------------------------- fit, diagnose, rig


def _negative_time_record(tmp: Path) -> Path:
    t = np.linspace(-0.5, 20.0, 206)
    x = 0.02 * np.sin(2 * np.pi * 0.1 * t)
    rec = RigRecord(kind="characterisation", unit=RecordUnit(2e-3, 0.3e-3, 0.7e-3), static=RecordStatic(14811300.0, 293.15, 293.15),
                    test=RecordTest("hard", "off", "sine", 0.02, 0.1), data={"time_s": t, "disp_m": x, "force_n": 3e4 + 1e6 * x}, name="neg")
    write_record(rec, tmp / "neg")
    return tmp / "neg"


def test_a_failed_simulation_in_a_fit_is_an_error_not_a_converged_fit(tmp_path: Path) -> None:
    code, stdout, err = run("fit", str(_negative_time_record(tmp_path)), "--out", str(tmp_path / "fit"), "--json")
    assert code == 2
    assert "record neg: the model cannot be simulated on it: time_s = -0.5 is outside the valid range" in err
    assert stdout == "" and not (tmp_path / "fit" / "fit.json").exists()


def test_fit_and_diagnose_warn_about_what_their_model_misses(tmp_path: Path) -> None:
    rig = tmp_path / "rig"
    code, _, err = run("rig", "--out", str(rig), "--effect", "friction", "--set", "friction_coulomb_n=1500", "--quiet", "--strict")
    assert code == 0, err  # a virtual rig within its ranges: nothing to warn about
    assert json.loads((rig / "truth.json").read_text())["warnings"] == []
    code, stdout, err = run("fit", str(rig), "--model", "seed", "--out", str(tmp_path / "fit"), "--json", "--strict")
    assert code == 3, err
    s = json.loads(stdout)
    assert "residual_structured" in codes(s) and s["rms_ratio"] > 1.5
    assert s == json.loads((tmp_path / "fit" / "fit.json").read_text())
    assert "## Warnings" in (tmp_path / "fit" / "fit.md").read_text()


def test_a_fitted_parameter_on_its_bound_is_warned(tmp_path: Path) -> None:
    # The rig's Coulomb friction (8 kN) is beyond the fit's range (0-5 kN):
    # the estimate stops on the bound, where its standard error means
    # nothing. A bound where the parameter's feature is absent (no
    # friction) is not warned about: the data may well say it is absent.
    rig = tmp_path / "rig"
    code, _, err = run("rig", "--out", str(rig), "--effect", "friction", "--set", "friction_coulomb_n=8000", "--quiet")
    assert code == 0, err
    code, stdout, err = run("fit", str(rig), "--model", "seed,friction", "--out", str(tmp_path / "fit"), "--json", "--strict")
    assert code == 3, err
    (w,) = [w for w in json.loads(stdout)["warnings"] if w["code"] == "param_at_bound"]
    i = w["details"]["params"].index("friction_coulomb_n")
    assert w["details"]["values"][i] == pytest.approx(5000.0) and w["details"]["bounds"][i] == 5000.0
    assert "friction_coulomb_n = 5000" in w["message"] and "on its upper bound 5000" in w["message"]
    assert "param_at_bound" in err

    from hpctl.identify import virtual_rig
    from hpctl.identify.dataset import prepare
    from hpctl.identify.fit import fit

    r = fit(prepare(virtual_rig.make_records(hpctl.Unit.seed(), "sweep", seed=3)), ("heat_transfer", "real_gas", "friction"))
    assert not r.at_bounds(), r.at_bounds()  # no friction in the rig: Coulomb at its null bound 0 says so, no warning
    tau = next(p for p in r.model.params if p.name == "tau_s")
    lo = dataclasses.replace(r, values={**r.values, "tau_s": tau.lower * (1 + 1e-9)})
    (b,) = lo.at_bounds()
    assert (b.name, b.side, b.on, b.bound) == ("tau_s", "lower", True, tau.lower)
    near = dataclasses.replace(r, values={**r.values, "tau_s": tau.upper - 15.0}, stderr={**r.stderr, "tau_s": 10.0})
    (b,) = near.at_bounds()
    assert (b.name, b.side, b.on) == ("tau_s", "upper", False)
    assert not dataclasses.replace(near, stderr={**r.stderr, "tau_s": 7.0}).at_bounds()  # 2.1 standard errors away
    # A log parameter's error is judged in decades, where it is Gaussian:
    # 0.5 +- 0.45 s is 0.45 s from the 0.05 s bound, but 2.6 errors of
    # 0.39 decades.
    assert not dataclasses.replace(r, values={**r.values, "tau_s": 0.5}, stderr={**r.stderr, "tau_s": 0.45}).at_bounds()
    (b,) = dataclasses.replace(r, values={**r.values, "tau_s": 0.5}, stderr={**r.stderr, "tau_s": 0.6}).at_bounds()
    assert (b.name, b.side, b.on) == ("tau_s", "lower", False)


def test_a_parameter_near_both_bounds_is_said_once_as_spanning_its_range() -> None:
    # A flexible fit's poorly pinned shape parameter (the bundled campaign:
    # a rebound orifice scale of 1.2 +- 5.8 in [0.01, 100]) is within two
    # errors of both bounds: one phrase saying so, not "near its lower
    # bound" and "near its upper bound" as if it were at either. The
    # details keep one entry per bound.
    from hpctl.cli.calibrate import _bound_caveats
    from hpctl.identify.fit import AtBound

    class Result:
        def __init__(self, near: list[AtBound]) -> None:
            self.near = near

        def at_bounds(self) -> list[AtBound]:
            return self.near

    name = "damper_on_rebound_orifice_scale"
    (c,) = _bound_caveats(Result([AtBound(name, 1.204, 5.8, 0.01, "lower", False), AtBound(name, 1.204, 5.8, 100.0, "upper", False),
                                  AtBound("tau_s", 0.05, 0.01, 0.05, "lower", True)]))
    assert c.code == "param_at_bound"
    assert f"{name} = 1.204 +- 5.8, two errors spanning its whole range [0.01, 100]" in c.message
    assert c.message.count(name) == 1 and "tau_s = 0.05 +- 0.01 on its lower bound 0.05" in c.message
    assert c.details["params"] == [name, name, "tau_s"] and c.details["bounds"] == [0.01, 100.0, 0.05]
    (c,) = _bound_caveats(Result([AtBound(name, 100.0, 90.0, 0.01, "lower", False), AtBound(name, 100.0, 90.0, 100.0, "upper", True)]))
    assert f"{name} = 100 +- 90 on its upper bound 100, two errors reaching its lower bound 0.01" in c.message
    # Past six parameters (not entries) the rest are counted.
    many = [AtBound(f"p{i}", 1.0, 9.0, b, side, False) for i in range(8) for b, side in ((0.01, "lower"), (100.0, "upper"))]
    (c,) = _bound_caveats(Result(many))
    assert "p5 = 1" in c.message and "p6 = 1" not in c.message and "; 2 more in the details" in c.message


def test_record_gas_states_outside_the_range_are_warned(tmp_path: Path) -> None:
    t = np.linspace(0.0, 10.0, 11)
    data = {"time_s": t, "p_gas_pa": np.full(11, 120e6)}
    (c,) = checks.eos_range("bwr-textbook", data, "record r")
    assert c.details["channel"] == "p_gas_pa" and "record r" in c.message


def test_messages_are_printed_as_text_never_markup(capsys: pytest.CaptureFixture[str]) -> None:
    from hpctl.cli._ui import Reporter

    rep = Reporter(quiet=False, as_json=False)
    rep.warn([Caveat(Code.EOS_RANGE, "record [/x]: [static] [bold]p[/bold] out of range")])
    rep.say("Wrote to out[/x]/")
    captured = capsys.readouterr()
    assert "record [/x]: [static] [bold]p[/bold] out of range" in captured.err
    assert "Wrote to out[/x]/" in captured.out


def test_a_parameter_whose_error_understates_its_band_is_warned_unless_profiled(tmp_path: Path) -> None:
    # Heat build-up's oil heat capacity and wall-to-oil time constant trade
    # along a bending valley: their linear errors missed the foreign rig's
    # truth by up to 13 errors where the profile held it
    # (hpctl.model.effects.HEAT_BUILDUP_VALLEY). Even on hpctl's own rig the
    # wall-to-oil time constant's two-sigma profile interval is several
    # times its linear one, and lopsided. A fit says so for each, unless its
    # profile was asked for (then the interval is in the output).
    rig = tmp_path / "rig"
    code, _, err = run("rig", "--out", str(rig), "--effect", "heat_buildup", "--seed", "3", "--quiet")
    assert code == 0, err
    code, stdout, err = run("fit", str(rig), "--model", "seed,heat_buildup", "--out", str(tmp_path / "fit"), "--json")
    assert code == 0, err
    s = json.loads(stdout)
    band = {w["details"]["param"]: w for w in s["warnings"] if w["code"] == "profile_band"}
    assert set(band) == {"oil_heat_capacity_j_per_k", "wall_to_oil_tau_s"}
    assert "--profile wall_to_oil_tau_s" in band["wall_to_oil_tau_s"]["message"] and "profile_band" in err
    code, stdout, err = run("fit", str(rig), "--model", "seed,heat_buildup", "--out", str(tmp_path / "fit2"), "--json",
                            "--profile", "wall_to_oil_tau_s")
    assert code == 0, err
    s = json.loads(stdout)
    assert [w["details"]["param"] for w in s["warnings"] if w["code"] == "profile_band"] == ["oil_heat_capacity_j_per_k"]
    (iv,) = s["profile_intervals"]
    est, se = iv["estimate"], iv["stderr"]
    # The honest band, wider than the linear one and not symmetric about the estimate.
    assert iv["upper"] - iv["lower"] > 4.0 * se and iv["upper"] - est > 2.0 * (est - iv["lower"])

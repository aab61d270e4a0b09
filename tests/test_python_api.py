"""The Python API's comfort (issue 15, item 3): named channels, a unit
for a load, results as records, partial unit files, record equality,
enums that print as names, controller configuration files."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner

import hpctl
from hpctl import Sine, Step, Unit
from hpctl.cli import main
from hpctl.control import config as ctrl_config
from hpctl.control.closed_loop import config_for_unit
from hpctl.control.controller import Controller, Diag, DriveMode, SequencerState, seed_config
from hpctl.data.records import read_record, write_record
from hpctl.model.unit import STANDARD_GRAVITY_M_S2
from hpctl.sim.run import CHANNELS


def test_result_is_a_mapping_of_named_channels() -> None:
    r = hpctl.run_sdof(Unit.seed(), Step(0.02), 0.5, channels=("time_s", "body_disp_m", "force_n"))
    assert r.names == ("time_s", "body_disp_m", "force_n") and list(r) == list(r.names) and len(r) == 3
    assert r.force_n is r["force_n"] and "force_n" in r and "p_gas_pa" not in r
    assert dict(r.items()).keys() == {"time_s", "body_disp_m", "force_n"}
    with pytest.raises(KeyError, match="it has: time_s, body_disp_m, force_n"):
        r["p_gas_pa"]
    with pytest.raises(AttributeError, match="p_gas_pa"):
        r.p_gas_pa  # noqa: B018
    full = hpctl.run_sdof(Unit.seed(), Step(0.02), 0.1)
    assert full.names == CHANNELS
    assert "body_disp_m" in dir(full)


def test_for_load_charges_the_unit_so_the_load_sits_at_the_static_position() -> None:
    seed = Unit.seed()
    # The seed unit is charged for the seed's mass (an independent check of the one formula).
    assert seed.mass_pressure_pa(hpctl.SEED_SPRUNG_MASS_KG) == pytest.approx(seed.static_pressure_pa, rel=1e-12)
    for mass in (1500.0, 3000.0, 4500.0):
        u = seed.for_load(mass_kg=mass)
        # Force balance at the static position: (p - p_amb) A = m g.
        assert (u.static_pressure_pa - u.ambient_pressure_pa) * u.piston_area_m2 == pytest.approx(mass * STANDARD_GRAVITY_M_S2, rel=1e-9)
        assert u.static_disp_for_load_m(mass * STANDARD_GRAVITY_M_S2, u.static_temperature_k, True) == pytest.approx(0.0, abs=1e-9)
    assert seed.for_load(load_n=3000.0 * STANDARD_GRAVITY_M_S2) == seed.for_load(mass_kg=3000.0)
    with pytest.raises(hpctl.ParameterError, match="exactly one"):
        seed.for_load()
    with pytest.raises(hpctl.ParameterError, match="mass_kg"):
        seed.for_load(mass_kg=math.nan)


def test_a_run_becomes_a_record_that_reads_back_equal(tmp_path: Path) -> None:
    unit = Unit.seed()
    r = hpctl.run_characterisation(unit, Sine(0.05, 0.5), 2.0, spring_hard=False, damper_on=True)
    rec = r.to_record("loop")
    assert rec.kind == "characterisation" and rec.test.spring == "soft" and rec.test.damper == "on"
    assert rec.test.excitation == "sine" and rec.test.amplitude_m == 0.05 and rec.test.frequency_hz == 0.5
    assert np.array_equal(rec["force_n"], r.force_n)
    write_record(rec, tmp_path / "loop")
    assert read_record(tmp_path / "loop") == rec
    s = hpctl.run_sdof(unit, Step(0.043), 1.0, sprung_mass_kg=2500.0).to_record("step")
    assert s.kind == "sdof" and s.sprung_mass_kg == 2500.0 and "body_disp_m" in s
    with pytest.raises(hpctl.ParameterError, match="channels"):
        hpctl.run_sdof(unit, Step(0.043), 0.1, channels=("time_s",)).to_record()


def test_record_equality_compares_contents(tmp_path: Path) -> None:
    rec = hpctl.run_characterisation(Unit.seed(), Sine(0.05, 0.5), 1.0).to_record("a")
    write_record(rec, tmp_path / "a")
    other = read_record(tmp_path / "a")
    other.name = "renamed"
    assert other == rec and not (other != rec)  # the name is the file's, not the record's
    other.data["force_n"] = other.data["force_n"].copy()
    other.data["force_n"][3] += 1e-9
    assert other != rec
    assert rec != "a record"
    with pytest.raises(TypeError):
        hash(rec)


def test_partial_unit_files_are_merged_over_the_preset(tmp_path: Path) -> None:
    seed = Unit.seed()
    path = tmp_path / "u.toml"
    path.write_text('[unit]\npreset = "seed"\nstatic_pressure_pa = 16e6\ntau_s = "inf"\n'
                    "[unit.damper.on_rebound]\nblowoff_pa = 3e6\n[unit.effects.friction]\ncoulomb_n = 40.0\n")
    u = Unit.from_toml(path)
    assert u.static_pressure_pa == 16e6 and math.isinf(u.tau_s)
    assert u.damper.on_rebound.blowoff_pa == 3e6 and u.damper.on_rebound.bleed_pa_s_per_m3 == seed.damper.on_rebound.bleed_pa_s_per_m3
    assert u.effects.friction is not None and u.effects.friction.coulomb_n == 40.0
    assert u.replace(static_pressure_pa=seed.static_pressure_pa, tau_s=seed.tau_s, damper=seed.damper, effects=seed.effects) == seed
    # A whole file written by hpctl reads back; a partial one without a preset says how.
    seed.to_toml(tmp_path / "whole.toml")
    assert Unit.from_toml(tmp_path / "whole.toml") == seed
    (tmp_path / "part.toml").write_text("[unit]\nstatic_pressure_pa = 16e6\n")
    with pytest.raises(hpctl.ParameterError, match='preset = "seed"'):
        Unit.from_toml(tmp_path / "part.toml")
    (tmp_path / "bad.toml").write_text('[unit]\npreset = "tank"\n')
    with pytest.raises(hpctl.ParameterError, match="'tank'.*'seed'"):
        Unit.from_toml(tmp_path / "bad.toml")


def test_controller_enums_print_as_names() -> None:
    assert str(DriveMode.HANDLING) == "HANDLING" and f"{SequencerState.LOWERING}" == "LOWERING"
    assert f"{DriveMode.HANDLING:d}" == "1" == str(int(DriveMode.HANDLING))
    assert str(Diag.SAFE_STATE | Diag.STALE) == "SAFE_STATE|STALE" and str(Diag(0)) == "0"
    assert DriveMode.HANDLING == 1 and json.dumps(DriveMode.HANDLING) == "1"  # still the controller's numbers


def test_controller_config_files(tmp_path: Path) -> None:
    unit = Unit.seed().for_load(mass_kg=3500.0)
    base = config_for_unit(unit)
    path = tmp_path / "c.toml"
    path.write_text("[mode]\nlat_acc_enter_m_s2 = 2.5\nlat_acc_exit_m_s2 = 1.5\n[monitor.timeouts]\nbody_s = 0.2\n")
    c = ctrl_config.read_config(path, base)
    assert c["mode"]["lat_acc_enter_m_s2"] == 2.5 and c["monitor"]["timeouts"]["body_s"] == 0.2
    assert c["unit"] == base["unit"] and c["ride_height"] == base["ride_height"]
    # Written by hpctl, read back the same; a whole file needs no base's values.
    ctrl_config.write_config(c, tmp_path / "whole.toml")
    assert ctrl_config.read_config(tmp_path / "whole.toml", seed_config()) == c
    # tuned.json from hpctl tune reads the same way.
    (tmp_path / "tuned.json").write_text(json.dumps({"config": {"mode": {"handling_hold_s": 1.5}}}))
    assert ctrl_config.read_config(tmp_path / "tuned.json", base)["mode"]["handling_hold_s"] == 1.5
    Controller(c)


@pytest.mark.parametrize(("text", "message"), [
    ("[mode]\nlat_acc_enter_m_s2 = 99.0\n", r"mode\.lat_acc_enter_m_s2 = 9\.9e1 is outside the valid range \[1e-1, 3e1\]"),
    ("[mode]\nlat_acc_entr_m_s2 = 2.0\n", r"config\.mode\.lat_acc_entr_m_s2: unknown key \(known in config\.mode: .*lat_acc_enter_m_s2"),
    ("[brakes]\nx = 1.0\n", r"config\.brakes: unknown key"),
    ("[mode]\nlat_acc_enter_m_s2 = \"fast\"\n", r"lat_acc_enter_m_s2"),
    ("mode = 3\n", r"config\.mode = 3: expected a table"),
    ("[mode\n", r"not valid TOML"),
])
def test_bad_controller_config_names_key_value_and_range(tmp_path: Path, text: str, message: str) -> None:
    path = tmp_path / "c.toml"
    path.write_text(text)
    with pytest.raises(hpctl.ParameterError, match=message) as e:
        ctrl_config.read_config(path, config_for_unit(Unit.seed()))
    assert str(path) in str(e.value)
    # The command line: exit 2 with the same message, before any run.
    r = CliRunner().invoke(main, ["closed-loop", "--config", str(path), "--out", str(tmp_path / "out"), "--quiet"])
    assert r.exit_code == 2 and str(path) in r.stderr
    assert not (tmp_path / "out" / "summary.json").exists()


def test_closed_loop_runs_the_configuration_file(tmp_path: Path) -> None:
    path = tmp_path / "c.toml"
    path.write_text("[ride_height]\ntolerance_m = 0.004\n")
    r = CliRunner().invoke(main, ["closed-loop", "--config", str(path), "--out", str(tmp_path / "out"), "--json", "--quiet", "--format", "svg"])
    assert r.exit_code == 0, r.stderr
    s = json.loads(r.stdout)
    assert s["config_source"] == str(path) and s["config"]["ride_height"]["tolerance_m"] == 0.004
    assert s["lowering"]["tolerance_m"] == 0.004  # the run used it
    assert s["config"]["unit"] == config_for_unit(Unit.seed())["unit"]
    assert s["plots"] == ["ride_height.svg", "modes.svg"] and (tmp_path / "out" / "modes.svg").exists()
    assert not any(w["code"] == "config_not_derived" for w in s["warnings"])

"""The unit description: preset, TOML round trip, strict keys."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

import hpctl
from hpctl.model.unit import Friction, OilNode


def test_seed_unit_carries_the_load_at_the_static_position(seed_unit: hpctl.Unit) -> None:
    # p_static A = m g + p_atm A: the unit is charged for 3000 kg.
    force = seed_unit.static_force_n(0.0, seed_unit.static_temperature_k, spring_hard=True)
    assert force == pytest.approx(hpctl.SEED_SPRUNG_MASS_KG * 9.80665, rel=1e-9)
    assert seed_unit.small_acc_volume_m3 == 0.3e-3 and seed_unit.large_acc_volume_m3 == 0.7e-3


def test_gas_masses_follow_the_static_charge(seed_unit: hpctl.Unit) -> None:
    ms, ml = seed_unit.gas_masses_kg()
    assert ml / ms == pytest.approx(0.7 / 0.3)
    # N2 at 14.8 MPa, 293 K is about 167 kg/m^3 (CoolProp: 166.96).
    assert ms / seed_unit.small_acc_volume_m3 == pytest.approx(166.96, rel=0.02)


@pytest.mark.parametrize("tau_s", [0.0, 2.0, math.inf])
def test_toml_round_trip(tmp_path: Path, seed_unit: hpctl.Unit, tau_s: float) -> None:
    unit = seed_unit.replace(tau_s=tau_s).with_effects(friction=Friction(350.0, 120.0), oil_node=OilNode(1.8e4, 3000.0, 5800.0, 2e4))
    path = tmp_path / "unit.toml"
    unit.to_toml(path)
    assert hpctl.Unit.from_toml(path) == unit


def test_unknown_key_in_unit_file_is_named(tmp_path: Path, seed_unit: hpctl.Unit) -> None:
    path = tmp_path / "unit.toml"
    seed_unit.to_toml(path)
    path.write_text(path.read_text().replace("piston_area_m2", "piston_area_cm2"))
    with pytest.raises(hpctl.ParameterError, match="piston_area"):
        hpctl.Unit.from_toml(path)


def test_bad_value_names_parameter_value_and_range(seed_unit: hpctl.Unit) -> None:
    with pytest.raises(hpctl.ParameterError) as e:
        seed_unit.replace(static_temperature_k=0.0).check()
    assert "static_temperature_k = 0 is outside the valid range [200, 600]" in str(e.value)
    assert isinstance(e.value, ValueError)


def test_unknown_gas_model_is_rejected(seed_unit: hpctl.Unit) -> None:
    with pytest.raises(hpctl.ParameterError, match='gas = .helium. is not a known model .one of: span, ideal, bwr-cg, bwr-textbook'):
        seed_unit.replace(gas="helium").check()


@pytest.mark.parametrize(
    ("where", "value", "name"),
    [("knee", 3.0, "blowoff_knee"), ("knee", math.nan, "blowoff_knee"), ("stribeck_ratio", 0.5, "stribeck_ratio"),
     ("stribeck_velocity", 0.0, "stribeck_velocity_m_s")],
)
def test_flexible_damper_and_stribeck_values_out_of_range_are_named(seed_unit: hpctl.Unit, where: str, value: float, name: str) -> None:
    # The flexible model's new parameters go through the core's ranges like every other: a ParameterError naming them.
    from dataclasses import replace

    if where == "knee":
        d = seed_unit.damper
        bad = seed_unit.replace(damper=replace(d, on_compression=replace(d.on_compression, blowoff_knee=value)))
    elif where == "stribeck_ratio":
        bad = seed_unit.with_effects(friction=Friction(200.0, stribeck_ratio=value))
    else:
        bad = seed_unit.with_effects(friction=Friction(200.0, stribeck_velocity_m_s=value))
    with pytest.raises(hpctl.ParameterError, match=name):
        bad.check()


def test_each_pressure_transducer_has_its_own_offset(seed_unit: hpctl.Unit) -> None:
    # S's and L's transducers are two instruments with two zero errors
    # (the foreign rig draws them apart); the force's is a third.
    from hpctl.model.unit import Sensor
    from hpctl.sim.run import characterisation_rig, uniform_times

    unit = seed_unit.with_effects(sensor=Sensor(force_offset_n=300.0, pressure_offset_pa=2e4, pressure2_offset_pa=-1.5e4))
    r = hpctl.run(unit, characterisation_rig(hpctl.Sine(0.01, 0.5)), uniform_times(2.0, 0.01), spring_hard=False, damper_on=True)
    np.testing.assert_allclose(r["p_gas_pa"] - r["p_gas_true_pa"], 2e4, atol=1e-6)
    np.testing.assert_allclose(r["p_gas2_pa"] - r["p_gas2_true_pa"], -1.5e4, atol=1e-6)
    # The older positional form keeps its meaning: force, pressure, lag.
    assert Sensor(1.0, 2.0, 0.03).time_constant_s == 0.03 and Sensor(1.0, 2.0, 0.03).pressure2_offset_pa == 0.0


def test_the_core_dict_is_asdicts_without_the_copies(seed_unit: hpctl.Unit) -> None:
    """Unit.to_dict and Damper.to_dict build the dict per run without
    dataclasses.asdict's deep copies (hpctl.model.unit.plain): the same
    dict as asdict, for a unit with every effect set and a two-stage
    damper branch."""
    import dataclasses

    from hpctl import _core
    from hpctl.model import unit as um

    effects = {}
    for t in _core.EFFECT_PARAMETERS:
        cls = getattr(um, t["name"])
        values = {g["field"]: g["default"] if g["default"] is not None else max(g["range"][0], min(0.5, g["range"][1])) for g in t["fields"]}
        effects[t["key"]] = cls(**values)
    branch = dataclasses.replace(seed_unit.damper.on_rebound, blowoff2_pa=3e6, blowoff2_slope_pa_s_per_m3=1e9, blowoff_knee=0.2)
    u = seed_unit.replace(damper=dataclasses.replace(seed_unit.damper, on_rebound=branch), polytropic_exponent=1.3).with_effects(**effects)
    expected = dataclasses.asdict(u)
    assert set(expected["effects"]) == set(effects)  # every effect is set, so none is left out
    assert u.to_dict() == expected
    assert u.damper.to_dict() == dataclasses.asdict(u.damper)
    assert u.to_dict()["damper"]["on_rebound"]["blowoff2_pa"] == 3e6
    # Absent effects are left out, as before.
    assert seed_unit.to_dict()["effects"] == {k: v for k, v in dataclasses.asdict(seed_unit)["effects"].items() if v is not None}
    # A new dict each time: a caller's change to one never reaches the unit's next.
    d = u.to_dict()
    d["damper"]["on_rebound"]["blowoff_pa"] = -1.0
    assert u.to_dict()["damper"]["on_rebound"]["blowoff_pa"] == branch.blowoff_pa


@pytest.mark.parametrize("flags", [np.array([True, False, True]), np.array([1, 0, 1]), np.array([1.0, 0.0, 1.0]), [1, 0, 1], [True, False, True]])
def test_flags_arrays_become_python_bools(flags: object) -> None:
    from hpctl.errors import check_flags

    out = check_flags(flags, "spring_hard")
    assert out == [True, False, True]
    assert isinstance(out, list) and all(type(x) is bool for x in out)

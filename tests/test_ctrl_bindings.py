"""The controller's bindings: the config as a strict dict, inputs and
outputs, bad calls as ParameterError, bad values as the safe state."""

from __future__ import annotations

import copy
import math
from typing import Any

import numpy as np
import pytest

import hpctl
from hpctl import _core
from hpctl.control.controller import (
    INPUT_DTYPES,
    Controller,
    DamperMode,
    Diag,
    DriveMode,
    DriverMode,
    InputGroup,
    Inputs,
    Outputs,
    SequencerState,
    SpringMode,
    input_arrays,
    seed_config,
)


def calm(config: dict[str, Any]) -> Inputs:
    u = config["unit"]
    return Inputs(p_gas_pa=u["static_pressure_pa"], p_gas2_pa=u["static_pressure_pa"], t_gas_k=u["static_temperature_k"], speed_m_s=10.0)


def test_the_config_round_trips_and_is_the_seed_unit() -> None:
    config = seed_config()
    assert Controller(config).config == config
    assert Controller().config == config
    # The controller and the plant share the unit's numbers.
    unit = hpctl.Unit.seed()
    for key in ("piston_area_m2", "large_acc_volume_m3", "static_pressure_pa", "static_temperature_k", "stroke_compression_m", "stroke_extension_m"):
        assert config["unit"][key] == getattr(unit, key), key
    assert config["unit"]["gas"] == unit.gas


@pytest.mark.parametrize(
    ("spoil", "message"),
    [
        (lambda c: c.update(extra=1), "unknown key config.extra"),
        (lambda c: c["mode"].update(handling_hold=2.0), "unknown key config.mode.handling_hold"),
        (lambda c: c["monitor"]["timeouts"].pop("body_s"), "missing key config.monitor.timeouts.body_s"),
        (lambda c: c.pop("damper"), "missing key config.damper"),
        (lambda c: c["ride_height"].update(tolerance_m="3 mm"), "config.ride_height.tolerance_m must be a number"),
        (lambda c: c["unit"].update(gas="helium"), "gas = \"helium\" is not a known model"),
        (lambda c: c.update(mode=[1, 2]), "config.mode must be a dict"),
    ],
)
def test_structurally_wrong_configs_are_parameter_errors(spoil: Any, message: str) -> None:
    config = copy.deepcopy(seed_config())
    spoil(config)
    with pytest.raises(hpctl.ParameterError, match=message):
        Controller(config)


@pytest.mark.parametrize(
    ("block", "key", "value", "message"),
    [
        ("mode", "handling_hold_s", -1.0, r"mode.handling_hold_s = -1e0 is outside the valid range \[0e0, 6e1\]"),
        ("ride_height", "valve6_margin_pa", math.nan, "ride_height.valve6_margin_pa = NaN"),
        ("mode", "lat_acc_exit_m_s2", 3.0, "mode.lat_acc_exit_m_s2 = 3e0 must be below mode.lat_acc_enter_m_s2"),
        ("ride_height", "load_settle_s", 100.0, "ride_height.load_settle_s"),
    ],
)
def test_invalid_values_name_the_field_and_its_range(block: str, key: str, value: float, message: str) -> None:
    config = copy.deepcopy(seed_config())
    config[block][key] = value
    with pytest.raises(hpctl.ParameterError, match=message):
        Controller(config)


def test_step_and_step_many_agree() -> None:
    config = seed_config()
    n = 9000
    base = calm(config).to_dict()
    arrays = input_arrays(base | {"p_gas_pa": base["p_gas_pa"] + 2e6 * np.sin(np.arange(n) * 0.01),
                                  "ride_height_request_m": np.where(np.arange(n) > 2000, -0.03, 0.0),
                                  "lat_acc_m_s2": np.where((np.arange(n) > 7000) & (np.arange(n) < 7300), 3.0, 0.0)})
    dt = np.full(n, 1e-3)
    many = Controller(config).step_many(arrays, dt)
    one = Controller(config)
    for k in range(n):
        out = one.step(Inputs(**{name: arrays[name][k].item() for name in INPUT_DTYPES}), 1e-3)
        for name, value in vars(out).items():
            assert many[name][k] == value, (k, name)
    # The sequence did something: Ride, Handling, lowering.
    assert set(np.unique(many["drive_mode"]).tolist()) == {0, 1}
    assert np.any(many["sequencer"] == SequencerState.LOWERING)


def test_nan_inf_and_stale_inputs_are_legal_and_give_the_safe_state() -> None:
    config = seed_config()
    c = Controller(config)
    good = calm(config)
    for _ in range(3000):
        out = c.step(good, 1e-3)
    assert not out.safe and out.drive_mode == DriveMode.RIDE and out.valve6_open
    for bad in (
        Inputs(**(vars(good) | {"p_gas2_pa": math.nan})),
        Inputs(**(vars(good) | {"t_gas_k": math.inf})),
        Inputs(**(vars(good) | {"speed_m_s": -math.inf})),
        Inputs(**(vars(good) | {"ride_height_request_m": math.nan})),
    ):
        out = c.step(bad, 1e-3)
        assert out.safe and not out.valve5_open and not out.valve6_open
        assert out.drive_mode == DriveMode.HANDLING and out.sequencer == SequencerState.BLOCKED
        assert out.diag & Diag.NOT_FINITE
        assert all(math.isfinite(x) for x in (out.ride_height_m, out.p_gas2_target_pa, out.p_load_pa, out.strut_vel_m_s, out.body_vel_m_s))
    # A bad step size too.
    assert c.step(good, math.nan).diag & Diag.BAD_DT
    # Stale: the pressures stop updating for longer than their timeout.
    c.reset()
    for _ in range(3000):
        c.step(good, 1e-3)
    no_pressures = Inputs(**(vars(good) | {"fresh": InputGroup.ALL & ~InputGroup.PRESSURES}))
    timeout_periods = round(config["monitor"]["timeouts"]["pressures_s"] / 1e-3)
    outs = [c.step(no_pressures, 1e-3) for _ in range(timeout_periods + 1)]
    assert not any(o.safe for o in outs[:-1])
    assert outs[-1].safe and outs[-1].diag & Diag.STALE and outs[-1].diag & Diag.GROUP_PRESSURES


@pytest.mark.parametrize(
    ("change", "message"),
    [
        ({"extra_pa": 1.0}, "unknown key inputs.extra_pa"),
        ({"p_gas_pa": "high"}, "inputs.p_gas_pa must be a number"),
        ({"brake_pressed": "yes"}, "inputs.brake_pressed must be a bool"),
        ({"driver_mode": 3}, "inputs.driver_mode = 3 is not a driver mode"),
        ({"driver_mode": 1.5}, "inputs.driver_mode must be an int"),
        ({"fresh": 128}, "inputs.fresh = 128 is not a set of input groups"),
    ],
)
def test_structurally_wrong_inputs_are_parameter_errors(change: dict[str, Any], message: str) -> None:
    c = _core.Controller(None)
    inputs = calm(seed_config()).to_dict() | change
    with pytest.raises(hpctl.ParameterError, match=message):
        c.step(inputs, 1e-3)


def test_missing_inputs_and_bad_arrays_are_parameter_errors() -> None:
    c = _core.Controller(None)
    inputs = calm(seed_config()).to_dict()
    del inputs["t_gas_k"]
    with pytest.raises(hpctl.ParameterError, match="missing key inputs.t_gas_k"):
        c.step(inputs, 1e-3)
    arrays = input_arrays(calm(seed_config()).to_dict() | {"speed_m_s": np.zeros(5)})
    with pytest.raises(hpctl.ParameterError, match="inputs.lat_acc_m_s2 has 4 values; the other arrays have 5"):
        c.step_many(arrays | {"lat_acc_m_s2": np.zeros(4)}, 1e-3)
    with pytest.raises(hpctl.ParameterError, match="inputs.driver_mode must be a 1-D numpy array of int64"):
        c.step_many(arrays | {"driver_mode": np.zeros(5)}, 1e-3)
    with pytest.raises(hpctl.ParameterError, match="dt_s has 3 values; the inputs have 5"):
        c.step_many(arrays, np.full(3, 1e-3))
    with pytest.raises(hpctl.ParameterError, match="unequal lengths"):
        input_arrays({"p_gas_pa": np.zeros(3), "p_gas2_pa": np.zeros(4), "t_gas_k": 300.0})
    with pytest.raises(hpctl.ParameterError, match="missing input field p_gas_pa"):
        input_arrays({"p_gas2_pa": 1e7, "t_gas_k": 300.0})


def test_the_python_enums_and_flags_are_the_bindings() -> None:
    assert [m.name.lower() for m in DriverMode] == _core.CTRL_DRIVER_MODES
    assert [m.name.lower() for m in DriveMode] == _core.CTRL_DRIVE_MODES
    assert [m.name.lower() for m in SpringMode] == _core.CTRL_SPRING_MODES
    assert [m.name.lower() for m in DamperMode] == _core.CTRL_DAMPER_MODES
    assert [m.name.lower() for m in SequencerState] == _core.CTRL_SEQUENCER_STATES
    assert {f.name: int(f) for f in Diag} == _core.CTRL_DIAG_FLAGS
    assert {g.name: int(g) for g in InputGroup if g is not InputGroup.ALL} == _core.CTRL_INPUT_GROUPS
    assert set(INPUT_DTYPES) == set(_core.CTRL_INPUT_FIELDS)


def test_outputs_convert_to_typed_values() -> None:
    out = Controller().step(calm(seed_config()), 1e-3)
    assert isinstance(out, Outputs)
    assert out.drive_mode is DriveMode.HANDLING and out.sequencer is SequencerState.BLOCKED
    assert out.safe and out.diag & Diag.RECOVERING

"""Bad input gives a ValueError subclass naming the parameter, its value
and the valid range; no Rust panic reaches Python."""

from __future__ import annotations

import math
from typing import Any

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

import hpctl
from hpctl import _core
from hpctl.sim.run import characterisation_rig, sdof_rig

NASTY = [math.nan, math.inf, -math.inf, 0.0, -0.0, -1.0, 1e300, -1e300, 5e-324]


@pytest.mark.parametrize(
    ("field", "value", "expected"),
    [
        ("small_acc_volume_m3", -0.3e-3, "small_acc_volume_m3 = -3e-4 is outside the valid range [1e-6, 1]"),
        ("large_acc_volume_m3", math.nan, "large_acc_volume_m3 = NaN is outside the valid range [1e-6, 1]"),
        ("static_temperature_k", 0.0, "static_temperature_k = 0 is outside the valid range [200, 600]"),
        ("piston_area_m2", math.inf, "piston_area_m2 = inf is outside the valid range [1e-5, 1]"),
        ("tau_s", -2.0, "tau_s = -2 is outside the valid range [0, 1e9]"),
        ("static_pressure_pa", 1e9, "static_pressure_pa = 1e9 is outside the valid range [200000, 3e8]"),
    ],
)
def test_unit_parameter_errors(seed_unit: hpctl.Unit, field: str, value: float, expected: str) -> None:
    with pytest.raises(hpctl.ParameterError) as e:
        hpctl.run_sdof(seed_unit.replace(**{field: value}), hpctl.Step(0.043), 1.0)
    assert expected in str(e.value)


def test_zero_mass(seed_unit: hpctl.Unit) -> None:
    with pytest.raises(hpctl.ParameterError, match=r"sprung_mass_kg = 0 is outside the valid range \[1, 1e6\]"):
        hpctl.run_sdof(seed_unit, hpctl.Step(0.043), 1.0, sprung_mass_kg=0.0)


@pytest.mark.parametrize("dt_s", [0.0, -1e-3, math.nan, math.inf, 1e3, 1e-12])
def test_absurd_fixed_step_sizes(seed_unit: hpctl.Unit, dt_s: float) -> None:
    with pytest.raises(hpctl.HpctlError, match="dt_s"):
        hpctl.run_sdof(seed_unit, hpctl.Step(0.043), 1.0, dt_s=dt_s, rtol=None)


@pytest.mark.parametrize("dt_s", [0.0, -1e-3, 1e-12])
def test_absurd_largest_adaptive_steps(seed_unit: hpctl.Unit, dt_s: float) -> None:
    with pytest.raises(hpctl.ParameterError, match=r"dt_s = .* is outside the valid range \[1e-9, inf\]"):
        hpctl.run_sdof(seed_unit, hpctl.Step(0.043), 1.0, dt_s=dt_s)


@pytest.mark.parametrize("rtol", [0.0, -1e-6, math.nan, math.inf, 0.5])
def test_absurd_tolerances(seed_unit: hpctl.Unit, rtol: float) -> None:
    with pytest.raises(hpctl.ParameterError, match=r"rtol = .* is outside the valid range \[1e-14, 0\.01\]"):
        hpctl.run_sdof(seed_unit, hpctl.Step(0.043), 1.0, rtol=rtol)


def test_unstable_step_size_is_a_simulation_error_not_garbage(seed_unit: hpctl.Unit) -> None:
    # Fixed RK4 steps of 0.2 s with valve 6 open (its orifice has a time
    # constant of about 1 ms): an error, not garbage ...
    with pytest.raises(hpctl.SimulationError, match="a fixed step too long for the model's fastest dynamics"):
        hpctl.run_sdof(seed_unit, hpctl.Step(0.043), 20.0, dt_s=0.2, sample_dt_s=0.2, spring_hard=False, rtol=None)
    # ... while the error-controlled steps, however long they may be, follow it.
    r = hpctl.run_sdof(seed_unit, hpctl.Step(0.043), 20.0, dt_s=0.2, sample_dt_s=0.2, spring_hard=False)
    assert abs(r["body_disp_m"][-1] - 0.043) < 1e-3


def test_empty_and_broken_arrays(seed_unit: hpctl.Unit) -> None:
    with pytest.raises(hpctl.ParameterError, match="times_s is empty"):
        hpctl.run(seed_unit, sdof_rig(hpctl.Step(0.043)), np.array([]))
    with pytest.raises(hpctl.ParameterError, match="time_s"):
        hpctl.run(seed_unit, sdof_rig(hpctl.Step(0.043)), np.array([0.0, 0.1, 0.05]))
    with pytest.raises(hpctl.ParameterError, match="time_s"):
        hpctl.run(seed_unit, sdof_rig(hpctl.Step(0.043)), np.array([0.0, math.nan]))
    with pytest.raises(hpctl.ParameterError, match="spring_hard has 2 values; expected 1 or one per output time"):
        hpctl.run(seed_unit, sdof_rig(hpctl.Step(0.043)), np.array([0.0, 0.1, 0.2]), spring_hard=[True, False])
    empty = hpctl.Sampled(np.array([]), np.array([]))
    with pytest.raises(hpctl.ParameterError, match="time_s.len = 0"):
        hpctl.run_characterisation(seed_unit, empty, 1.0)


def test_sampled_motion_with_nan_is_rejected(seed_unit: hpctl.Unit) -> None:
    m = hpctl.Sampled(np.array([0.0, 1.0, 2.0]), np.array([0.0, math.nan, 0.0]))
    with pytest.raises(hpctl.ParameterError, match="disp_m = NaN"):
        hpctl.run_characterisation(seed_unit, m, 1.0)


def test_unknown_and_missing_keys_in_core_dicts(seed_unit: hpctl.Unit) -> None:
    d = seed_unit.to_dict()
    d["colour"] = "red"
    with pytest.raises(hpctl.ParameterError, match="unknown key unit.colour"):
        _core.gas_masses_kg(d)
    d = seed_unit.to_dict()
    del d["piston_area_m2"]
    with pytest.raises(hpctl.ParameterError, match="missing key unit.piston_area_m2"):
        _core.gas_masses_kg(d)
    # Rigs are typed (CharacterisationRig, SdofRig); anything else is named.
    with pytest.raises(hpctl.ParameterError, match=r"rig = \{'kind': 'trampoline'\}: expected a rig"):
        hpctl.run(seed_unit, {"kind": "trampoline"}, np.array([0.0, 1.0]))  # type: ignore[arg-type]
    with pytest.raises(hpctl.ParameterError, match="rig.kind"):
        _core.simulate(seed_unit.to_dict(), {"kind": "trampoline"}, np.array([0.0, 1.0]), 1e-3, 293.15, True, True)  # type: ignore[arg-type, typeddict-item]


def test_gas_props_with_mismatched_arrays() -> None:
    with pytest.raises(hpctl.ParameterError, match="rho_kg_m3 has 2 values but t_k has 1"):
        _core.gas_props("bwr-textbook", np.array([1.0, 2.0]), np.array([300.0]))


def test_density_solve_out_of_range() -> None:
    with pytest.raises(hpctl.ParameterError, match="t_k = 0 is outside"):
        _core.gas_density_kg_m3("bwr-textbook", 1e7, 0.0)


floats = st.one_of(st.sampled_from(NASTY), st.floats(allow_nan=True, allow_infinity=True))


@given(field=st.sampled_from(["piston_area_m2", "small_acc_volume_m3", "large_acc_volume_m3", "static_pressure_pa", "static_temperature_k", "tau_s",
                              "valve6_flow_area_m2", "oil_density_kg_m3", "stroke_compression_m", "end_stop_stiffness_n_per_m"]),
       value=floats, mass=floats, dt=floats, height=floats)
def test_no_input_crashes_the_core(field: str, value: float, mass: float, dt: float, height: float) -> None:
    unit_d: dict[str, Any] = hpctl.Unit.seed().to_dict()
    unit_d[field] = value
    times = np.linspace(0.0, 0.3, 4)
    for rig in (sdof_rig(hpctl.Step(height, 0.0, 0.1), sprung_mass_kg=mass), characterisation_rig(hpctl.Sine(height, 1.0))):
        try:
            out = _core.simulate(unit_d, rig, times, dt, 293.15, True, True)
        except hpctl.HpctlError as e:
            assert str(e)  # a message, and a ValueError subclass by construction
        else:
            assert all(np.all(np.isfinite(v)) for v in out.values())


def test_a_leak_that_empties_the_gas_is_a_simulation_error(seed_unit: hpctl.Unit) -> None:
    # A leak whose rate does not fall with the gas left (mass exponent 0)
    # empties the accumulators at its time constant: the run stops with a
    # SimulationError naming the state that left its range and when (the
    # Rust side: adaptive_rig.rs, a_leak_that_empties_an_accumulator_...).
    from hpctl.identify.virtual_rig import Noise, effect_tests, record_test
    from hpctl.model.unit import Leakage

    leaky = seed_unit.with_effects(leakage=Leakage(100.0, 0.0, 0.0))
    with pytest.raises(hpctl.SimulationError, match=r"state \w+ = \S+ left the valid range \[\S+, \S+\] at t = 9\d\.\d+ s .*a leak that emptied the gas"):
        record_test(leaky, effect_tests()["hold"], Noise(), np.random.default_rng(0))

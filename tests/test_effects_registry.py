"""The effect registry is the one place an effect is declared: its
parameters are the core's, inside the core's ranges; the tests it names
exist; the docs are generated from it; the controller's enums carry the
controller's own values."""

from __future__ import annotations

import math
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from hpctl import _core
from hpctl.control.controller import DamperMode, Diag, DriveMode, DriverMode, InputGroup, SequencerState, SpringMode
from hpctl.identify import virtual_rig
from hpctl.model import effects
from hpctl.model.effects import LIBRARY, Param, RecordTraits
from hpctl.model.unit import Damper, Unit
from hpctl.report.effects import markdown

ROOT = Path(__file__).resolve().parents[1]


def test_every_parameter_is_the_cores_and_nests_in_its_range() -> None:
    for e in LIBRARY.values():
        for p in e.params:
            lo, hi = _core.PARAMETER_RANGES[p.name]
            assert lo <= p.lower <= p.initial <= p.upper <= hi, p.name
            assert lo <= p.typical <= hi, p.name


def test_a_parameter_outside_the_cores_range_is_refused(monkeypatch: pytest.MonkeyPatch) -> None:
    bad = effects.Effect("bad", "", (Param("valve_time_constant_s", 1e-9, 1.0, 0.01, 0.01, (0.01, 0.02)),), lambda u, p: u, "")
    monkeypatch.setitem(LIBRARY, "bad", bad)
    with pytest.raises(ValueError, match="valve_time_constant_s.*core's range"):
        effects._check_against_core()
    monkeypatch.setitem(LIBRARY, "bad", effects.Effect("bad", "", (Param("no_such_n", 0, 1, 0.5, 0.5, (0, 1)),), lambda u, p: u, ""))
    with pytest.raises(ValueError, match="not a parameter of the core"):
        effects._check_against_core()


def test_the_tests_each_effect_names_exist_in_the_virtual_rig() -> None:
    known = set(virtual_rig.effect_tests())
    for e in LIBRARY.values():
        assert set(e.tests) <= known, (e.name, e.tests)


def test_random_draws_stay_in_the_declared_range() -> None:
    rng = np.random.default_rng(1)
    for e in LIBRARY.values():
        for p in e.params:
            for _ in range(50):
                v = p.draw(rng)
                mag = abs(v) if p.signed else v
                assert p.random[0] <= mag <= p.random[1], (p.name, v)


def test_applicability_follows_the_traits() -> None:
    short = RecordTraits(longest_s=30.0, longest_damper_on_s=0.0, switches_valves=False, damper_works=False)
    assert not LIBRARY["valve_lag"].applies(short)
    assert not LIBRARY["heat_buildup"].applies(short)
    assert not LIBRARY["leakage"].applies(short)
    assert not LIBRARY["oil_compliance"].applies(short)
    assert LIBRARY["friction"].applies(short)
    # The oil is a spring in series with the gas's whatever valve 5 does:
    # damper-off records that move the strut fast can show it.
    fast_off = RecordTraits(longest_s=30.0, longest_damper_on_s=0.0, switches_valves=False, damper_works=True)
    assert LIBRARY["oil_compliance"].applies(fast_off)
    assert not LIBRARY["heat_buildup"].applies(fast_off)
    rich = RecordTraits(longest_s=900.0, longest_damper_on_s=600.0, switches_valves=True, damper_works=True)
    assert all(e.applies(rich) for e in LIBRARY.values())


def test_max_step_is_the_fastest_time_constant_of_the_units_effects() -> None:
    u = Unit.seed()
    assert effects.max_step_s(u) == math.inf
    v = {"valve_time_constant_s": 0.02, "oil_bulk_modulus_pa": 3e8, "sensor_time_constant_s": 0.005}
    lagged = LIBRARY["valve_lag"].apply(u, v)
    assert effects.max_step_s(lagged) == pytest.approx(0.02)
    both = LIBRARY["sensor_lag"].apply(lagged, v)
    assert effects.max_step_s(both) == pytest.approx(0.005)
    compliant = LIBRARY["oil_compliance"].apply(u, v)
    bleed = min(c.bleed_pa_s_per_m3 for c in vars(u.damper).values())
    assert effects.max_step_s(compliant) == pytest.approx(effects.OIL_VOLUME_M3 * bleed / 3e8)
    # A bleed beside the orifice lowers the no-flow resistance to R / (1 + R G)
    # (the oil relaxes through both passages): the step follows it. The
    # flexible model's parallel share moves conductance from the series
    # bleed to the parallel one and leaves the no-flow resistance, and so
    # the step, where it was.
    shares = {f"damper_{b}_parallel_share": 0.6 for b in effects.DAMPER_BRANCHES}
    shaped = compliant.replace(damper=effects.shaped_damper(compliant.damper, shares))
    assert all(c.bleed_parallel_m3_per_s_pa > 0 for c in vars(shaped.damper).values())
    assert min(c.bleed_pa_s_per_m3 for c in vars(shaped.damper).values()) == pytest.approx(bleed / 0.4)
    assert effects.max_step_s(shaped) == pytest.approx(effects.OIL_VOLUME_M3 * bleed / 3e8)
    added = compliant.replace(damper=Damper(*(replace(c, bleed_parallel_m3_per_s_pa=1.0 / c.bleed_pa_s_per_m3) for c in vars(compliant.damper).values())))
    assert effects.max_step_s(added) == pytest.approx(0.5 * effects.OIL_VOLUME_M3 * bleed / 3e8)


def test_effects_doc_is_generated_from_the_registry() -> None:
    doc = (ROOT / "docs" / "effects.md").read_text()
    assert doc == markdown(), "docs/effects.md is stale: python -m hpctl.report.effects > docs/effects.md"


def _generator() -> object:
    import importlib.util

    spec = importlib.util.spec_from_file_location("gen_effect_params", ROOT / "scripts" / "gen_effect_params.py")
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_the_effect_parameter_classes_are_generated_from_the_cores_tables() -> None:
    # Each effect's parameters are declared once, in hp-core (effect_params!);
    # the Python classes and dict types are generated from the exported table.
    source = _generator().source()  # type: ignore[attr-defined]
    assert (ROOT / "python" / "hpctl" / "_effect_params.py").read_text() == source, (
        "python/hpctl/_effect_params.py is stale: python scripts/gen_effect_params.py > python/hpctl/_effect_params.py")


def test_no_hand_written_copy_of_an_effects_parameters_in_python() -> None:
    import dataclasses
    import re

    from hpctl import _effect_params
    from hpctl.model import unit

    tables = _core.EFFECT_PARAMETERS
    # The public classes are the generated ones, field for field the core's.
    for t in tables:
        cls = getattr(unit, t["name"])
        assert cls is getattr(_effect_params, t["name"])
        assert [f.name for f in dataclasses.fields(cls)] == [f["field"] for f in t["fields"]]
    assert [f.name for f in dataclasses.fields(unit.Effects)] == [t["key"] for t in tables]
    # No other module declares one of them.
    names = "|".join(t["name"] for t in tables)
    for path in (ROOT / "python" / "hpctl").rglob("*.py"):
        if path.name != "_effect_params.py":
            assert not re.search(rf"^class ({names})(Dict)?\b", path.read_text(), flags=re.M), path
    # Every parameter once, with its range: the core's ranges are the table's.
    parameters = [f["parameter"] for t in tables for f in t["fields"]]
    assert len(parameters) == len(set(parameters))
    for t in tables:
        for f in t["fields"]:
            assert _core.PARAMETER_RANGES[f["parameter"]] == f["range"]
    # The registry's effect parameters are among them (or the gas law's).
    registry = {p.name for e in LIBRARY.values() for p in e.params}
    assert registry - set(parameters) == {"tau_s"}


def test_an_effect_value_out_of_its_range_names_it_from_python() -> None:
    from hpctl.model import unit

    u = Unit.seed()
    for t in _core.EFFECT_PARAMETERS:
        cls = getattr(unit, t["name"])
        # Every field, above its range and NaN (a field added later, such
        # as the leak's mass exponent, is checked like the first).
        for f in t["fields"]:
            lo, hi = f["range"]
            for bad in (hi * 10 if hi > 0 else 1.0, math.nan):
                values = {g["field"]: (bad if g is f else (g["default"] if g["default"] is not None else max(g["range"][0], min(1.0, g["range"][1]))))
                          for g in t["fields"]}
                with pytest.raises(_core.ParameterError, match=rf"{f['parameter']} = \S+ is outside the valid range \[\S+, \S+\]"):
                    u.with_effects(**{t["key"]: cls(**values)}).static_force_n(0.0, 293.15, True)


def test_controller_enums_carry_the_controllers_values() -> None:
    for enum, names in ((DriverMode, _core.CTRL_DRIVER_MODES), (DriveMode, _core.CTRL_DRIVE_MODES), (SpringMode, _core.CTRL_SPRING_MODES),
                        (DamperMode, _core.CTRL_DAMPER_MODES), (SequencerState, _core.CTRL_SEQUENCER_STATES)):
        assert [m.name.lower() for m in sorted(enum, key=int)] == names
    assert {m.name: int(m) for m in Diag} == _core.CTRL_DIAG_FLAGS
    assert {m.name: int(m) for m in InputGroup if m.name != "ALL"} == _core.CTRL_INPUT_GROUPS


def test_each_null_is_where_its_effect_does_nothing_and_its_start_is_inside() -> None:
    # Param.null: the value at which the effect leaves the model as it was
    # (a diagnosis restarts a candidate next to it); inside the fit bounds,
    # and the start next to it lies between it and the typical value.
    from hpctl.model.effects import LIBRARY

    nulls = [p for e in LIBRARY.values() for p in e.params if p.null is not None]
    assert {p.name for p in nulls} >= {"friction_coulomb_n", "oil_bulk_modulus_pa", "leak_time_constant_s", "valve_time_constant_s",
                                       "sensor_force_offset_n", "sensor_time_constant_s"}
    for p in nulls:
        assert p.lower <= p.null <= p.upper, p.name
        start = p.null_start()
        assert start is not None and p.lower <= start <= p.upper, p.name
        lo, hi = sorted((p.to_x(p.null), p.to_x(p.typical)))
        assert lo <= p.to_x(start) <= hi, p.name

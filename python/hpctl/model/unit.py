"""Describing a spring-damper unit: SI units, unit-suffixed names.

A :class:`Unit` is a frozen dataclass; :meth:`Unit.seed` is the built-in
unit standing for the seed's (defined once, in the Rust core's presets).
Units load from and save to TOML with the same field names.
"""

from __future__ import annotations

import dataclasses
import math
import tomllib
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, cast

import numpy as np
import tomli_w

from hpctl import _core, _effect_params
from hpctl._coretypes import DamperDict, UnitDict
from hpctl.errors import ParameterError, bad_argument, check_number

# The gas models by name, from the Rust core: the default (the reference
# equation of state of Span et al. 2000) first.
GAS_MODELS: tuple[str, ...] = tuple(_core.GAS_MODELS)


_FIELD_NAMES: dict[type, tuple[str, ...]] = {}
_SCALARS = (float, int, bool, str, type(None))


def plain(obj: Any) -> dict[str, Any]:
    """``dataclasses.asdict`` for the unit's dataclasses, whose fields are
    scalars or dataclasses: the same dict, without asdict's deep copy of
    every value (immutable scalars need none). The core reads a unit per
    run, and a flexible fit is thousands of runs: asdict was 3.9 s of the
    bundled campaign's 50 s fit (stop 39, BENCHMARKS.md)."""
    cls = type(obj)
    names = _FIELD_NAMES.get(cls)
    if names is None:
        names = _FIELD_NAMES[cls] = tuple(f.name for f in dataclasses.fields(obj))
    out = {}
    for name in names:
        v = getattr(obj, name)
        out[name] = v if type(v) in _SCALARS or not dataclasses.is_dataclass(v) or isinstance(v, type) else plain(v)
    return out
DEFAULT_GAS: str = _core.DEFAULT_GAS


@dataclass(frozen=True)
class DamperCurve:
    """One branch of the damper pack: pressure drop over flow magnitude ``q``,
    ``R q + K q^2`` below the blow-off pressure, ``p_b + S (q - q_b)`` above;
    ``blowoff_knee`` > 0 rounds the knee over that fraction of the blow-off
    flow without touching the low-speed curve (``hp_core::damper::DamperCurve``;
    0 = sharp). ``blowoff2_pa`` > 0 adds a second blow-off stage: above that
    pressure drop the slope is ``blowoff2_slope_pa_s_per_m3`` (a bypass or a
    second washer stack lifting later; 0 = none). ``bleed_parallel_m3_per_s_pa``
    > 0 puts a laminar bleed of that conductance beside the orifice (a real
    valve's bleed hole) rather than in series with it (0 = none)."""

    bleed_pa_s_per_m3: float
    orifice_pa_s2_per_m6: float
    blowoff_pa: float
    blowoff_slope_pa_s_per_m3: float
    blowoff_knee: float = 0.0
    blowoff2_pa: float = 0.0
    blowoff2_slope_pa_s_per_m3: float = 0.0
    bleed_parallel_m3_per_s_pa: float = 0.0


@dataclass(frozen=True)
class Damper:
    """The two-state damper: one curve per valve-5 state and direction."""

    on_compression: DamperCurve
    on_rebound: DamperCurve
    off_compression: DamperCurve
    off_rebound: DamperCurve

    def scaled(self, gain: float) -> Damper:
        """Every pressure drop multiplied by ``gain`` (same flows)."""

        def s(c: DamperCurve) -> DamperCurve:
            return DamperCurve(c.bleed_pa_s_per_m3 * gain, c.orifice_pa_s2_per_m6 * gain, c.blowoff_pa * gain, c.blowoff_slope_pa_s_per_m3 * gain,
                               c.blowoff_knee, c.blowoff2_pa * gain, c.blowoff2_slope_pa_s_per_m3 * gain, c.bleed_parallel_m3_per_s_pa / gain)

        return Damper(s(self.on_compression), s(self.on_rebound), s(self.off_compression), s(self.off_rebound))

    def to_dict(self) -> DamperDict:
        """The plain-dict form the Rust core reads."""
        return cast(DamperDict, plain(self))

    def force_n(self, vel_m_s: Sequence[float], piston_area_m2: float, damper_on: bool) -> np.ndarray:
        """The force at strut speeds ``vel_m_s`` (positive in compression)
        on a piston of ``piston_area_m2``, valve 5 closed (``damper_on``) or
        open: hp-core's pressure drop at the flow ``v A``, times ``A``."""
        area = check_number(piston_area_m2, "piston_area_m2")
        if not area > 0.0:
            raise bad_argument("piston_area_m2", piston_area_m2, "a positive area, m^2")
        v = np.asarray(vel_m_s, dtype=float)
        if not np.all(np.isfinite(v)):
            raise bad_argument("vel_m_s", vel_m_s, "finite strut speeds, m/s")
        return np.asarray(_core.damper_pressure_drop_pa(self.to_dict(), v * area, 0.0 if _flag(damper_on, "damper_on") else 1.0)) * area


# The effects' parameter classes, generated from the core's tables
# (scripts/gen_effect_params.py): each parameter is declared once, in hp-core.
Friction = _effect_params.Friction
OilCompliance = _effect_params.OilCompliance
OilNode = _effect_params.OilNode
Leakage = _effect_params.Leakage
ValveLag = _effect_params.ValveLag
Sensor = _effect_params.Sensor
WallConductance = _effect_params.WallConductance
Effects = _effect_params.Effects
_EFFECT_TYPES = _effect_params.EFFECT_TYPES


@dataclass(frozen=True)
class Unit:
    """A hydro-pneumatic spring-damper unit, in SI units.

    ``tau_s`` is the gas thermal time constant: ``0`` is isothermal,
    ``math.inf`` adiabatic. ``polytropic_exponent``, when set, replaces it
    with the classical polytropic law ``p v^n = const``. ``gas`` is one of
    :data:`GAS_MODELS`.
    """

    piston_area_m2: float
    small_acc_volume_m3: float
    large_acc_volume_m3: float
    static_pressure_pa: float
    static_temperature_k: float
    gas: str
    tau_s: float
    valve6_flow_area_m2: float
    valve6_transition_pa: float
    damper: Damper
    oil_density_kg_m3: float
    vapour_pressure_pa: float
    ambient_pressure_pa: float
    stroke_compression_m: float
    stroke_extension_m: float
    end_stop_stiffness_n_per_m: float
    end_stop_damping_n_s_per_m: float
    rated_speed_m_s: float
    effects: Effects = field(default_factory=Effects)
    polytropic_exponent: float | None = None

    @classmethod
    def seed(cls) -> Unit:
        """The built-in unit standing for the seed's experimental unit."""
        return cls.from_dict(_core.seed_unit())

    def replace(self, **changes: Any) -> Unit:
        """A copy with some fields changed (unknown fields raise
        :class:`~hpctl.errors.ParameterError`; values are checked when the
        unit is used, by the core)."""
        known = {f.name for f in dataclasses.fields(self)}
        unknown = sorted(set(changes) - known)
        if unknown:
            raise ParameterError(f"Unit has no field {', '.join(unknown)} (fields: {', '.join(sorted(known))})")
        return dataclasses.replace(self, **changes)

    def with_effects(self, **effects: Any) -> Unit:
        """A copy with some effects set (or removed with ``None``)."""
        return self.replace(effects=dataclasses.replace(self.effects, **effects))

    def to_dict(self) -> UnitDict:
        """The plain-dict form the Rust core reads (absent effects omitted)."""
        d = plain(self)
        d["effects"] = {k: v for k, v in d["effects"].items() if v is not None}
        return cast(UnitDict, d)

    @classmethod
    def from_dict(cls, d: Mapping[str, Any], source: str = "unit") -> Unit:
        """From the plain-dict form; unknown or missing keys raise
        :class:`~hpctl.errors.ParameterError` naming the key."""
        d = dict(d)
        try:
            damper_d = _expect_mapping(d.pop("damper"), f"{source}.damper")
            damper = Damper(
                **{
                    k: DamperCurve(**_expect_mapping(damper_d[k], f"{source}.damper.{k}"))
                    for k in ("on_compression", "on_rebound", "off_compression", "off_rebound")
                }
            )
            effects_d = _expect_mapping(d.pop("effects", {}) or {}, f"{source}.effects")
            effects = Effects(
                **{
                    k: _EFFECT_TYPES[k](**_expect_mapping(v, f"{source}.effects.{k}"))
                    for k, v in effects_d.items()
                    if v is not None
                }
            )
            unit = cls(damper=damper, effects=effects, **d)
        except KeyError as e:
            raise ParameterError(f"{source}: missing or unknown key {e}") from None
        except TypeError as e:
            raise ParameterError(f"{source}: {e}") from None
        unit.check()
        return unit

    def check(self) -> None:
        """Validates every value in the Rust core (raises ParameterError)."""
        _core.gas_masses_kg(self.to_dict())

    def gas_masses_kg(self) -> tuple[float, float]:
        """Nitrogen mass in accumulators S and L, kg."""
        return _core.gas_masses_kg(self.to_dict())

    # TOML: the same names, nested tables for the damper and effects.
    # TOML has no infinity literal shared by all writers, so an adiabatic
    # tau is written as the string "inf".
    def to_toml(self, path: str | Path) -> None:
        d: dict[str, Any] = {k: v for k, v in self.to_dict().items() if v is not None}
        if math.isinf(self.tau_s):
            d["tau_s"] = "inf"
        Path(path).write_text(tomli_w.dumps({"unit": d}))

    @classmethod
    def from_toml(cls, path: str | Path) -> Unit:
        path = Path(path)
        try:
            data = tomllib.loads(path.read_text())
        except (OSError, tomllib.TOMLDecodeError) as e:
            raise ParameterError(f"{path}: cannot read unit file: {e}") from None
        if set(data) != {"unit"}:
            raise ParameterError(f"{path}: expected exactly one table [unit], found {sorted(data)}")
        d = dict(data["unit"])
        if "preset" in d:
            # A partial file: its values over the preset's.
            name = d.pop("preset")
            if name not in PRESETS:
                raise ParameterError(f"{path}: [unit] preset = {name!r}: expected one of {', '.join(map(repr, PRESETS))}")
            d = _merge(PRESETS[name]().to_dict(), d, f"{path}: [unit]")
        if d.get("tau_s") == "inf":
            d["tau_s"] = math.inf
        try:
            return cls.from_dict(d, source=f"{path}: [unit]")
        except ParameterError as e:
            if "missing" in str(e):
                raise ParameterError(f"{e} (a file that gives only some values names the unit they change: preset = \"seed\")") from None
            raise

    def static_force_n(self, disp_m: float, t_k: float, spring_hard: bool) -> float:
        """Force at rest at compression ``disp_m`` with the gas at ``t_k``."""
        return _core.static_force_n(self.to_dict(), check_number(disp_m, "disp_m"), check_number(t_k, "t_k"), _flag(spring_hard, "spring_hard"))

    def load_pressure_pa(self, load_n: float) -> float:
        """The gas pressure that carries ``load_n`` at rest, Pa."""
        return _core.load_pressure_pa(self.to_dict(), check_number(load_n, "load_n"))

    def mass_pressure_pa(self, mass_kg: float) -> float:
        """The gas pressure that carries a sprung mass of ``mass_kg`` at rest
        (its weight under standard gravity), Pa."""
        return self.load_pressure_pa(check_number(mass_kg, "mass_kg") * STANDARD_GRAVITY_M_S2)

    def for_load(self, *, mass_kg: float | None = None, load_n: float | None = None) -> Unit:
        """This unit charged for a load: the static pressure (the gas
        pressure at the static position) that carries ``mass_kg`` (under
        standard gravity) or ``load_n`` at rest, so that the static
        position is where the load sits. Give exactly one of the two."""
        if (mass_kg is None) == (load_n is None):
            raise ParameterError(f"Unit.for_load: give exactly one of mass_kg (got {mass_kg!r}) and load_n (got {load_n!r})")
        p = self.mass_pressure_pa(mass_kg) if mass_kg is not None else self.load_pressure_pa(load_n)  # type: ignore[arg-type]
        unit = self.replace(static_pressure_pa=p)
        unit.check()
        return unit

    def static_disp_for_load_m(self, load_n: float, t_k: float, spring_hard: bool) -> float:
        """Compression at which the unit carries ``load_n`` at rest, gas at ``t_k``."""
        return _core.static_disp_for_load_m(self.to_dict(), check_number(load_n, "load_n"), check_number(t_k, "t_k"), _flag(spring_hard, "spring_hard"))


def _merge(base: Mapping[str, Any], changes: Mapping[str, Any], where: str) -> dict[str, Any]:
    """``base`` with ``changes`` merged in, table by table (``effects``
    may add an effect the base does not have); unknown keys are left for
    :meth:`Unit.from_dict` to name."""
    out = dict(base)
    for key, value in changes.items():
        if isinstance(value, Mapping) and isinstance(out.get(key), Mapping):
            out[key] = _merge(out[key], value, f"{where}.{key}")
        else:
            out[key] = value
    return out


def _flag(value: Any, name: str) -> bool:
    if not isinstance(value, (bool, np.bool_)):
        raise bad_argument(name, value, "a bool")
    return bool(value)


def _expect_mapping(value: Any, where: str) -> dict[str, Any]:
    if not isinstance(value, Mapping):
        raise ParameterError(f"{where} must be a table, got {value!r}")
    return dict(value)


SEED_SPRUNG_MASS_KG: float = _core.seed_sprung_mass_kg()
#: The units a partial unit file can start from (``[unit] preset = "seed"``).
PRESETS: dict[str, Callable[[], Unit]] = {"seed": Unit.seed}
STANDARD_GRAVITY_M_S2: float = _core.STANDARD_GRAVITY_M_S2

"""The effect library: switchable model terms, each with its parameters.

An effect is something a measurement may contain that the model may lack.
Each has a library name (used on the command line and in ``--json``), the
parameters a fit identifies (with bounds and whether they are fitted in
log scale), and what it does to a :class:`~hpctl.unit.Unit`. The terms
themselves are implemented in hp-core; this module only switches them.

The gas law is the one term that is always present in some form: without
``heat_transfer`` the gas follows the classical polytropic law with a
fitted exponent; with it, the seed's energy equation with a fitted thermal
time constant. Without ``real_gas`` the gas is ideal.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass

from hpctl.model.unit import (
    DEFAULT_GAS,
    Friction,
    Leakage,
    OilCompliance,
    OilNode,
    Sensor,
    Unit,
    ValveLag,
)


@dataclass(frozen=True)
class Param:
    """A fitted parameter: name (SI suffix), bounds, initial value; ``log``
    parameters are fitted as log10 (time constants, moduli)."""

    name: str
    lower: float
    upper: float
    initial: float
    log: bool = False

    def to_x(self, value: float) -> float:
        return math.log10(value) if self.log else value / self.scale

    def from_x(self, x: float) -> float:
        return float(10.0**x) if self.log else float(x * self.scale)

    @property
    def scale(self) -> float:
        return max(abs(self.lower), abs(self.upper), 1e-30)

    def x_bounds(self) -> tuple[float, float]:
        return (self.to_x(self.lower), self.to_x(self.upper))


Apply = Callable[[Unit, Mapping[str, float]], Unit]


@dataclass(frozen=True)
class Effect:
    """One switchable model term."""

    name: str
    description: str
    params: tuple[Param, ...]
    apply: Apply
    # Which records can reveal it (for choosing candidates and test programs).
    needs: str = ""


def _heat_transfer(u: Unit, p: Mapping[str, float]) -> Unit:
    return u.replace(tau_s=p["tau_s"], polytropic_exponent=None)


def _real_gas(u: Unit, p: Mapping[str, float]) -> Unit:
    return u.replace(gas=DEFAULT_GAS)


def _friction(u: Unit, p: Mapping[str, float]) -> Unit:
    return u.with_effects(friction=Friction(p["friction_coulomb_n"], p["friction_viscous_n_s_per_m"], 2e-3))


def _oil_compliance(u: Unit, p: Mapping[str, float]) -> Unit:
    return u.with_effects(oil_compliance=OilCompliance(p["oil_bulk_modulus_pa"], OIL_VOLUME_M3))


def _heat_buildup(u: Unit, p: Mapping[str, float]) -> Unit:
    return u.with_effects(oil_node=OilNode(p["oil_heat_capacity_j_per_k"], 3000.0, p["wall_to_oil_tau_s"], 20000.0))


def _leakage(u: Unit, p: Mapping[str, float]) -> Unit:
    return u.with_effects(leakage=Leakage(p["leak_time_constant_s"]))


def _valve_lag(u: Unit, p: Mapping[str, float]) -> Unit:
    return u.with_effects(valve_lag=ValveLag(p["valve_time_constant_s"]))


def _sensor(u: Unit, offset_n: float, pressure_offset_pa: float) -> Unit:
    return u.with_effects(sensor=Sensor(force_offset_n=offset_n, pressure_offset_pa=pressure_offset_pa, time_constant_s=0.0))


def _sensor_offset(u: Unit, p: Mapping[str, float]) -> Unit:
    return _sensor(u, offset_n=p["sensor_force_offset_n"], pressure_offset_pa=p["sensor_pressure_offset_pa"])


def _output_only(u: Unit, p: Mapping[str, float]) -> Unit:
    # Applied to the simulated outputs by the fit (see fit.apply_sensor_lag):
    # a first-order lag inside the ODE would force steps shorter than the
    # lag on records hours long.
    return u


# Oil on the strut side of the damper (strut bore, hoses), m^3: the
# compliance effect fits the effective bulk modulus of this volume.
OIL_VOLUME_M3 = 1.0e-3

LIBRARY: dict[str, Effect] = {
    e.name: e
    for e in (
        Effect("heat_transfer", "gas-wall heat transfer with a thermal time constant (the seed's Eq. 1) instead of a polytropic law",
               (Param("tau_s", 0.05, 500.0, 2.0, log=True),), _heat_transfer, "sine records over a range of frequencies"),
        Effect("real_gas", "real nitrogen (the reference equation of state, Span et al. 2000) instead of the ideal gas", (), _real_gas, "large compressions / high pressure"),
        Effect("friction", "seal friction: Coulomb plus viscous",
               (Param("friction_coulomb_n", 0.0, 5000.0, 200.0), Param("friction_viscous_n_s_per_m", 0.0, 20000.0, 100.0)), _friction,
               "any motion; independent of frequency"),
        Effect("oil_compliance", "oil compressibility and hose compliance between strut and damper",
               (Param("oil_bulk_modulus_pa", 2e7, 3e9, 1e9, log=True),), _oil_compliance, "fast motion through the damper"),
        Effect("heat_buildup", "damper heat warming the oil and, slowly, the gas (lumped oil node)",
               (Param("oil_heat_capacity_j_per_k", 1e3, 1e6, 2e4, log=True), Param("wall_to_oil_tau_s", 100.0, 1e5, 5000.0, log=True)),
               _heat_buildup, "long runs with the damper working"),
        Effect("leakage", "slow gas loss from the accumulators", (Param("leak_time_constant_s", 1e3, 1e8, 1e6, log=True),), _leakage,
               "long holds"),
        Effect("valve_lag", "first-order response of the solenoid valves", (Param("valve_time_constant_s", 2e-3, 1.0, 0.03, log=True),), _valve_lag,
               "valve switching during motion"),
        Effect("sensor_offset", "offsets of the force and pressure transducers",
               (Param("sensor_force_offset_n", -1e4, 1e4, 0.0), Param("sensor_pressure_offset_pa", -2e6, 2e6, 0.0)), _sensor_offset, "any record"),
        Effect("sensor_lag", "first-order lag of the transducers", (Param("sensor_time_constant_s", 1e-3, 0.5, 0.01, log=True),), _output_only,
               "fast motion"),
    )
}

# Parameters that every model has.
POLYTROPIC = Param("polytropic_exponent", 1.0, 1.8, 1.3)
CHARGE = Param("charge_scale", 0.7, 1.3, 1.0)
DAMPER_GAIN = Param("damper_gain", 0.05, 20.0, 1.0, log=True)

MODELS: dict[str, tuple[str, ...]] = {
    "classical": (),
    "seed": ("heat_transfer", "real_gas"),
    "full": tuple(LIBRARY),
}


def parse_model(spec: str) -> tuple[str, ...]:
    """A model by name (``classical``, ``seed``, ``full``), a comma-separated
    list of effect names, or both (``seed,friction``); ``none`` or
    ``classical`` alone is the bare classical polytropic ideal gas."""
    names: list[str] = []
    for token in (t.strip() for t in spec.split(",")):
        if token in MODELS:
            names += MODELS[token]
        elif token in LIBRARY:
            names.append(token)
        elif token not in ("", "none"):
            from hpctl.errors import ParameterError

            raise ParameterError(
                f"--model: unknown effect {token!r}; expected a model ({', '.join(MODELS)}) or effects from: {', '.join(LIBRARY)}"
            )
    return tuple(n for n in LIBRARY if n in names)


def model_params(effects: Sequence[str]) -> list[Param]:
    """The parameters a model with ``effects`` fits (before the base ones)."""
    out: list[Param] = []
    if "heat_transfer" not in effects:
        out.append(POLYTROPIC)
    for name in effects:
        out.extend(LIBRARY[name].params)
    return out


def build_unit(base: Unit, effects: Sequence[str], values: Mapping[str, float]) -> Unit:
    """``base`` (the classical ideal-gas polytropic unit) with ``effects``
    switched on at parameter ``values``."""
    unit = base.replace(gas="ideal", polytropic_exponent=values.get("polytropic_exponent", 1.3), tau_s=math.inf)
    unit = unit.replace(effects=type(unit.effects)())
    for name in effects:
        unit = LIBRARY[name].apply(unit, values)
    return unit

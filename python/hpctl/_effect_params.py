"""The effects' parameter classes, generated from the core's tables
(hp-core ``effect_params!``, exported as ``_core.EFFECT_PARAMETERS``) by
``python scripts/gen_effect_params.py``; do not edit by hand.

Public through :mod:`hpctl.model.unit` (``hpctl.Friction``, ...).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TypedDict


@dataclass(frozen=True)
class Friction:
    """Seal friction between strut piston and cylinder."""

    #: Coulomb (dry) friction force, N. Valid: [0, 1e+06]
    #: (``friction_coulomb_n``).
    coulomb_n: float
    #: Viscous friction coefficient, N s/m. Valid: [0, 1e+07]
    #: (``friction_viscous_n_s_per_m``).
    viscous_n_s_per_m: float = 0.0
    #: Velocity over which the Coulomb force builds up (tanh), m/s: the seal's
    #: pre-sliding compliance, and what keeps the model smooth. Valid: [1e-06,
    #: 1] (``friction_smoothing_velocity_m_s``).
    smoothing_velocity_m_s: float = 0.001
    #: Static over kinetic friction, `F_s / F_c` (1 = no Stribeck peak). Valid:
    #: [1, 10] (``friction_stribeck_ratio``).
    stribeck_ratio: float = 1.0
    #: Velocity over which the static excess decays, `exp(-(v/v_s)^2)`, m/s.
    #: Valid: [1e-05, 1] (``friction_stribeck_velocity_m_s``).
    stribeck_velocity_m_s: float = 0.01


@dataclass(frozen=True)
class OilCompliance:
    """Oil compressibility and hose compliance between strut and damper."""

    #: Effective bulk modulus of oil plus hoses, Pa. Valid: [1e+06, 1e+11]
    #: (``oil_bulk_modulus_pa``).
    bulk_modulus_pa: float
    #: Oil volume on the strut side of the damper, m^3. Valid: [1e-06, 1]
    #: (``oil_volume_m3``).
    oil_volume_m3: float


@dataclass(frozen=True)
class OilNode:
    """Lumped thermal nodes for damper heat build-up: the damper heats the oil,
    the oil warms the gas accumulators' wall slowly, both lose heat to
    ambient.
    """

    #: Heat capacity of the oil and the steel around it, J/K. Valid: [1, 1e+09]
    #: (``oil_heat_capacity_j_per_k``).
    heat_capacity_j_per_k: float
    #: Oil-to-ambient time constant, s (at a 100 K difference when
    #: `oil_to_ambient_exponent` is not 0). Valid: [0.001, 1e+09]
    #: (``oil_to_ambient_tau_s``).
    oil_to_ambient_tau_s: float
    #: Time constant of the gas wall following the oil, s. Valid: [0.001,
    #: 1e+09] (``wall_to_oil_tau_s``).
    wall_to_oil_tau_s: float
    #: Time constant of the gas wall following ambient, s. Valid: [0.001,
    #: 1e+09] (``wall_to_ambient_tau_s``).
    wall_to_ambient_tau_s: float
    #: Heat capacity of the gas accumulators' wall, J/K: the heat the gas gives
    #: its wall (a working gas spring's hysteresis, hundreds of W on a heat
    #: run) warms it, and the wall and the oil exchange heat both ways. The
    #: default, 1e12, is a wall the gas cannot warm and that follows the oil
    #: without cooling it (the seed's calibration, which lumps the gas's heat
    #: into that coupling). Valid: [1, 1e+12] (``wall_heat_capacity_j_per_k``).
    wall_heat_capacity_j_per_k: float = 1000000000000.0
    #: How the oil's time constant to ambient grows as the difference falls
    #: (natural convection: the seed measured 3000 s at 100 K and 6500 s below
    #: 20 K, an exponent of 0.48): at a difference dT it is
    #: `oil_to_ambient_tau_s (100 K / |dT|)^n`. 0, the default: constant.
    #: Valid: [0, 3] (``oil_to_ambient_exponent``).
    oil_to_ambient_exponent: float = 0.0


@dataclass(frozen=True)
class Leakage:
    """Slow loss of gas from both accumulators (past the floating piston
    seals): `dm/dt = -(m0 / tau) (m / m0)^k r^n`, `m0` the accumulator's gas
    mass at the static state and `r = (p - p_amb) / (p_static - p_amb)` its
    gauge pressure over the static one. The defaults, `k = 1` and `n = 0`,
    are a decay at the time constant whatever the pressure (`dm/dt = -m /
    tau`); `n = 1` a leak driven by the pressure difference, so the
    compressed accumulator leaks faster; `k = 0` a flow that does not follow
    the gas's mass beyond its pressure (seal permeation: `k = 0, n = 1` is
    `dm/dt = -(m0 / tau) r`).
    """

    #: Time constant of the gas mass decay at the static pressure, s. Valid:
    #: [1, 1e+12] (``leak_time_constant_s``).
    time_constant_s: float
    #: Exponent `n` of the gauge-pressure ratio the rate goes with. Valid: [0,
    #: 4] (``leak_pressure_exponent``).
    pressure_exponent: float = 0.0
    #: Exponent `k` of the gas mass over the static one the rate goes with (a
    #: fitted shape: below 0 the rate rises as the gas is lost, which a fit of
    #: a leak with `k = 0` may find within its errors; a leak's mass never
    #: falls below 0). Declared last so that the older positional form (time
    #: constant, pressure exponent) keeps its meaning. Valid: [-4, 4]
    #: (``leak_mass_exponent``).
    mass_exponent: float = 1.0


@dataclass(frozen=True)
class ValveLag:
    """The solenoid valves follow their command with a first-order lag."""

    #: Valve response time constant, s. Valid: [1e-05, 10]
    #: (``valve_time_constant_s``).
    time_constant_s: float


@dataclass(frozen=True)
class Sensor:
    """Imperfect transducers on the measured force and pressures."""

    #: Offset added to the measured strut force, N. Valid: [-1e+06, 1e+06]
    #: (``sensor_force_offset_n``).
    force_offset_n: float = 0.0
    #: Offset added to the measured gas pressure of S (its own transducer), Pa.
    #: Valid: [-1e+08, 1e+08] (``sensor_pressure_offset_pa``).
    pressure_offset_pa: float = 0.0
    #: First-order lag of all measured channels ([`crate::lag`]), s (0 = none).
    #: Valid: [0, 10] (``sensor_time_constant_s``).
    time_constant_s: float = 0.0
    #: Offset added to the measured gas pressure of L (a second transducer,
    #: with its own zero error), Pa. Declared last so that the older positional
    #: form (force, pressure, lag) keeps its meaning. Valid: [-1e+08, 1e+08]
    #: (``sensor_pressure2_offset_pa``).
    pressure2_offset_pa: float = 0.0


@dataclass(frozen=True)
class WallConductance:
    """Gas-wall heat transfer through a wall conductance `h A` that does not
    follow the gas's heat capacity: the thermal time constant `tau = m c_v /
    (h A)` moves with `m c_v` as `tau_s (m c_v / (m c_v)_static)^n` instead
    of staying at `tau_s` (`c_v` of real nitrogen rises 2-3 % from 15 to 30
    MPa; `m` falls with a leak). `n = 0` is the seed's constant time
    constant, `n = 1` a constant conductance. Acts only with a finite time
    constant.
    """

    #: The exponent `n` of `m c_v` in the time constant (1 = constant `h A`).
    #: Valid: [-10, 10] (``tau_cv_exponent``).
    cv_exponent: float = 1.0


@dataclass(frozen=True)
class Effects:
    """Optional model terms; ``None`` means the effect is absent."""

    friction: Friction | None = None
    oil_compliance: OilCompliance | None = None
    oil_node: OilNode | None = None
    leakage: Leakage | None = None
    valve_lag: ValveLag | None = None
    sensor: Sensor | None = None
    wall_conductance: WallConductance | None = None


#: Each effect's parameter class by its key in :class:`Effects`.
EFFECT_TYPES: dict[str, type] = {
    "friction": Friction,
    "oil_compliance": OilCompliance,
    "oil_node": OilNode,
    "leakage": Leakage,
    "valve_lag": ValveLag,
    "sensor": Sensor,
    "wall_conductance": WallConductance,
}


# --- the dict form the core reads (hpctl._coretypes.UnitDict.effects) ---


class FrictionDict(TypedDict):
    coulomb_n: float
    viscous_n_s_per_m: float
    smoothing_velocity_m_s: float
    stribeck_ratio: float
    stribeck_velocity_m_s: float


class OilComplianceDict(TypedDict):
    bulk_modulus_pa: float
    oil_volume_m3: float


class OilNodeDict(TypedDict):
    heat_capacity_j_per_k: float
    oil_to_ambient_tau_s: float
    wall_to_oil_tau_s: float
    wall_to_ambient_tau_s: float
    wall_heat_capacity_j_per_k: float
    oil_to_ambient_exponent: float


class LeakageDict(TypedDict):
    time_constant_s: float
    pressure_exponent: float
    mass_exponent: float


class ValveLagDict(TypedDict):
    time_constant_s: float


class SensorDict(TypedDict):
    force_offset_n: float
    pressure_offset_pa: float
    time_constant_s: float
    pressure2_offset_pa: float


class WallConductanceDict(TypedDict):
    cv_exponent: float


class EffectsDict(TypedDict, total=False):
    friction: FrictionDict
    oil_compliance: OilComplianceDict
    oil_node: OilNodeDict
    leakage: LeakageDict
    valve_lag: ValveLagDict
    sensor: SensorDict
    wall_conductance: WallConductanceDict

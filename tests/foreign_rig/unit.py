"""What the foreign rig's unit is: geometry, gas, damper, valves, thermal
network, and the optional effects, all in SI units.

Nothing here is taken from hp-core; the formulations are described where
they are used (model.py) and in docs/foreign-rig.md.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace

import numpy as np

from .damper import DamperPack, Orifice, default_pack

G_M_S2 = 9.80665
P_ATM_PA = 101325.0


@dataclass(frozen=True)
class Friction:
    """Seal friction: ``[F_c + (F_s - F_c) exp(-(v/v_s)^2)] tanh(v/v_e) + c v``,
    the Coulomb level ``F_c`` optionally rising with strut pressure
    (``pressure_coefficient`` per unit of p/p_static - 1: a pressure-energised seal)."""

    coulomb_n: float
    viscous_n_s_per_m: float
    static_ratio: float = 1.0  # breakaway over Coulomb (Stribeck peak)
    stribeck_velocity_m_s: float = 0.01
    smoothing_velocity_m_s: float = 1e-3
    pressure_coefficient: float = 0.0

    def force_n(self, v: np.ndarray, viscous: bool = True) -> np.ndarray:
        """The force at speeds ``v`` at the static pressure (the formula
        above; the model's right-hand side writes it out for scalars), with
        its viscous part or without."""
        stribeck = self.coulomb_n * (1.0 + (self.static_ratio - 1.0) * np.exp(-((v / self.stribeck_velocity_m_s) ** 2)))
        return np.asarray(stribeck * np.tanh(v / self.smoothing_velocity_m_s) + (self.viscous_n_s_per_m * v if viscous else 0.0))

    def peak_n(self) -> float:
        """The largest force without the viscous part, N: the breakaway
        force the records can show (``F_s`` only where the Stribeck peak
        lies well above the smoothing), on a grid of speeds 0.1 % apart
        (the peak's own error under 1e-6 of it)."""
        return float(np.max(self.force_n(np.geomspace(1e-6, 1.0, 14000), viscous=False)))


@dataclass(frozen=True)
class OilCompliance:
    """Oil and hose between the strut and the damper: effective bulk modulus
    of ``oil_volume_m3`` (hose expansion dominates, so it is constant)."""

    bulk_modulus_pa: float
    oil_volume_m3: float


@dataclass(frozen=True)
class HeatBuildup:
    """The gas cylinders' walls as one lumped node coupled to the damper oil
    (poor thermal separation): wall heat capacity, wall-oil and wall-ambient
    time constants (capacity over conductance)."""

    wall_heat_capacity_j_per_k: float
    wall_to_oil_tau_s: float
    wall_to_ambient_tau_s: float


@dataclass(frozen=True)
class Leakage:
    """Gas permeating through the seals: mass flow proportional to the
    pressure difference to atmosphere, ``dm/dt = -(m0 / tau) (p - p_atm) /
    (p0 - p_atm)``: ``time_constant_s`` is m/|dm/dt| at the static state."""

    time_constant_s: float


@dataclass(frozen=True)
class ValveLag:
    """Solenoid valves' opening fraction follows the command with a first-order
    lag; closing takes ``close_ratio`` times the opening time constant."""

    time_constant_s: float
    close_ratio: float = 1.0


@dataclass(frozen=True)
class SensorLag:
    """First-order lag of the force and pressure transducers (amplifier and
    snubber): one time constant for the three channels."""

    time_constant_s: float


@dataclass(frozen=True)
class SensorOffsets:
    """Zero offsets of the transducers, each its own (three instruments)."""

    force_n: float = 0.0
    p_gas_pa: float = 0.0
    p_gas2_pa: float = 0.0


@dataclass(frozen=True)
class BumpStop:
    """An elastomer bump stop met at ``start_m`` of compression (outside
    hpctl's effect library): ``F = k d^1.5 (1 + c_rel d')`` for penetration d."""

    start_m: float
    stiffness_n_per_m1_5: float
    damping_rel_s_per_m: float = 0.5


@dataclass(frozen=True)
class OilViscosity:
    """Damper oil viscosity falling with oil temperature,
    ``nu = nu_ref exp(-b (T_oil - T_ref))`` (outside hpctl's library: the
    damper characteristic softens as the oil warms)."""

    coefficient_per_k: float = 0.03


@dataclass(frozen=True)
class Effects:
    friction: Friction | None = None
    oil_compliance: OilCompliance | None = None
    heat_buildup: HeatBuildup | None = None
    leakage: Leakage | None = None
    valve_lag: ValveLag | None = None
    sensor_lag: SensorLag | None = None
    sensor_offset: SensorOffsets | None = None
    bump_stop: BumpStop | None = None
    oil_viscosity: OilViscosity | None = None


@dataclass(frozen=True)
class Unit:
    """The unit as it really is (the truth), SI units.

    ``static_pressure_pa`` is the gas pressure at the static position (both
    accumulators at rest, equal pressure, at ``static_temperature_k``);
    ``tau_s`` the gas thermal time constant at that state (0 isothermal,
    ``inf`` adiabatic); the wall conductance hA is held constant, so the
    time constant moves with c_v over a cycle.
    """

    piston_area_m2: float = 2.0e-3
    small_acc_volume_m3: float = 0.3e-3
    large_acc_volume_m3: float = 0.7e-3
    static_pressure_pa: float = P_ATM_PA + 3000.0 * G_M_S2 / 2.0e-3
    static_temperature_k: float = 293.15
    ambient_k: float = 293.15
    ambient_pressure_pa: float = P_ATM_PA
    tau_s: float = 2.0
    tau_large_ratio: float = 1.0  # tau of L over tau of S
    damper: DamperPack = field(default_factory=default_pack)
    valve6: Orifice = field(default_factory=lambda: Orifice(area_m2=3.0e-5, diameter_m=6.0e-3, cd_inf=0.65))
    vapour_pressure_pa: float = 1.0e3
    # The damper oil as a lumped node, always there (the t_oil_k channel):
    # heated by the damper, valve 6 and the seal, cooled to ambient with the
    # seed's measured time constants, 3000 s at 100 K and 6500 s at 20 K,
    # i.e. a convective conductance going as dT^0.48.
    oil_heat_capacity_j_per_k: float = 2.0e4
    oil_to_ambient_tau_100k_s: float = 3000.0
    oil_to_ambient_exponent: float = 0.48
    thermocouple_tau_s: float = 1.5
    effects: Effects = field(default_factory=Effects)

    def replace(self, **changes: object) -> Unit:
        return replace(self, **changes)  # type: ignore[arg-type]

    def with_effects(self, **effects: object) -> Unit:
        return self.replace(effects=replace(self.effects, **effects))  # type: ignore[arg-type]

    @property
    def static_force_n(self) -> float:
        return (self.static_pressure_pa - self.ambient_pressure_pa) * self.piston_area_m2

    def for_mass(self, sprung_mass_kg: float) -> Unit:
        """The same unit charged so that ``sprung_mass_kg`` rests at the static position."""
        return self.replace(static_pressure_pa=self.ambient_pressure_pa + sprung_mass_kg * G_M_S2 / self.piston_area_m2)

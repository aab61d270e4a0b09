"""Random cases: a unit with one effect (or none) at parameters drawn from
plausible ranges, and a data system with noise drawn too, from one seed.

The truth names each parameter in hpctl's vocabulary where hpctl's effect
library has it (``hpctl diagnose --list-effects``), and keeps everything
else under the foreign rig's own names.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, field, replace
from typing import Any

import numpy as np

from .damper import BlowOff, Damper, DamperPack, Passages
from .gas import Nitrogen
from .sensors import ChannelNoise, DataSystem
from .unit import (
    BumpStop,
    Friction,
    HeatBuildup,
    Leakage,
    OilCompliance,
    OilViscosity,
    SensorLag,
    SensorOffsets,
    Unit,
    ValveLag,
)

# Effects of hpctl's library this rig implements (its own way), and the
# effects outside the library (for "structure remains" checks).
LIBRARY_EFFECTS = ("friction", "oil_compliance", "heat_buildup", "leakage", "valve_lag", "sensor_offset", "sensor_lag")
OUTSIDE_EFFECTS = ("bump_stop", "oil_viscosity")
EFFECTS = LIBRARY_EFFECTS + OUTSIDE_EFFECTS

# hpctl's oil compliance is a bulk modulus of a fixed 1 L of oil: the
# identifiable quantity is the stiffness beta / V_oil, mapped to that volume.
HPCTL_OIL_VOLUME_M3 = 1.0e-3


@dataclass
class Case:
    effect: str | None
    seed: int
    unit: Unit
    sprung_mass_kg: float
    data_system: DataSystem
    declared_pressure_pa: float
    hpctl_params: dict[str, float] = field(default_factory=dict)
    foreign_params: dict[str, Any] = field(default_factory=dict)

    def damper_curve(self) -> dict[str, list[float]]:
        """The true damper force (N, strut minus gas pressure times area,
        rigid oil, no cavitation) against strut speed, per valve state and
        direction: what an identified damper characteristic should match."""
        d = Damper(self.unit.damper)
        a = self.unit.piston_area_m2
        v = [0.0, 0.005, 0.01, 0.02, 0.05, 0.1, 0.15, 0.2, 0.25, 0.3, 0.4, 0.5, 0.6, 0.8, 1.0]
        out: dict[str, list[float]] = {"speed_m_s": v}
        for state, bypass in (("on", 0.0), ("off", 1.0)):
            out[f"{state}_compression_n"] = [d.drop(a * x, bypass) * a for x in v]
            out[f"{state}_rebound_n"] = [-d.drop(-a * x, bypass) * a for x in v]
        return out

    def truth(self) -> dict[str, Any]:
        ds = self.data_system
        u = self.unit
        return {
            "effect": self.effect,
            "seed": self.seed,
            "in_hpctl_library": self.effect is None or self.effect in LIBRARY_EFFECTS,
            "hpctl_params": self.hpctl_params,
            "foreign_params": self.foreign_params,
            "unit": {
                "piston_area_m2": u.piston_area_m2,
                "small_acc_volume_m3": u.small_acc_volume_m3,
                "large_acc_volume_m3": u.large_acc_volume_m3,
                "static_pressure_pa": u.static_pressure_pa,
                "declared_static_pressure_pa": self.declared_pressure_pa,
                "static_temperature_k": u.static_temperature_k,
                "ambient_k": u.ambient_k,
                "sprung_mass_kg": self.sprung_mass_kg,
                "tau_s": u.tau_s,
                "gas": "CoolProp HEOS Nitrogen (Span et al. 2000)",
                "damper": asdict(u.damper),
                "damper_curve": self.damper_curve(),
                "valve6": asdict(u.valve6),
                "oil_heat_capacity_j_per_k": u.oil_heat_capacity_j_per_k,
                "thermocouple_tau_s": u.thermocouple_tau_s,
                "effects": {k: v for k, v in asdict(u.effects).items() if v is not None},
            },
            "noise": {
                "disp_m": ds.disp.as_dict(),
                "force_n": ds.force.as_dict(),
                "p_pa": ds.pressure.as_dict(),
                "t_k": ds.temperature.as_dict(),
                "jitter_s": ds.jitter_s,
            },
        }


def _log_uniform(rng: np.random.Generator, lo: float, hi: float) -> float:
    return float(math.exp(rng.uniform(math.log(lo), math.log(hi))))


def _scale(rng: np.random.Generator, spread: float = 1.25) -> float:
    return _log_uniform(rng, 1.0 / spread, spread)


def _draw_pack(rng: np.random.Generator, pack: DamperPack) -> DamperPack:
    """Every passage of the nominal pack varied (manufacturing and shim
    tolerances): conductances, areas, cracking pressures, spring rates."""

    def passages(p: Passages) -> Passages:
        o, b = p.orifice, p.blowoff
        return Passages(
            p.bleed_m3_per_s_pa * _scale(rng),
            replace(o, area_m2=o.area_m2 * _scale(rng)),
            BlowOff(b.crack_pa * _scale(rng, 1.2), b.area_per_pa * _scale(rng), b.max_area_m2, b.seat_diameter_m, b.smooth_pa),
        )

    return replace(pack, compression=passages(pack.compression), rebound=passages(pack.rebound), bypass=passages(pack.bypass))


def draw_data_system(rng: np.random.Generator) -> DataSystem:
    """Noise on every channel: white plus coloured (up to half the
    variance), quantised, with sample-time jitter."""

    def channel(lo: float, hi: float, lsb: float) -> ChannelNoise:
        total = _log_uniform(rng, lo, hi)
        frac = rng.uniform(0.0, 0.5)
        return ChannelNoise(white=total * math.sqrt(1 - frac), coloured=total * math.sqrt(frac), corr_time_s=_log_uniform(rng, 2e-3, 5e-2), lsb=lsb)

    return DataSystem(
        disp=channel(2e-6, 1e-5, 0.3 / 65536),
        force=channel(15.0, 60.0, 320e3 / 65536),
        pressure=channel(2e3, 1e4, 40e6 / 65536),
        temperature=channel(0.05, 0.2, 0.01),
        jitter_s=_log_uniform(rng, 2e-5, 2e-4),
    )


def draw_case(effect: str | None, seed: int, noise: bool = True, gauge_error: bool = True) -> Case:
    """The unit, sprung mass and data system of one randomised case.
    ``noise=False``: a perfect data system; ``gauge_error=False``: the
    records declare the true static pressure (for ablations)."""
    if effect is not None and effect not in EFFECTS:
        raise ValueError(f"effect {effect!r}: expected one of {', '.join(EFFECTS)} (or none)")
    rng = np.random.default_rng(seed)
    area = rng.uniform(1.9e-3, 2.15e-3)
    mass = rng.uniform(2700.0, 3300.0)
    t_amb = rng.uniform(288.0, 303.0)
    tau = _log_uniform(rng, 0.7, 6.0)
    base = Unit(piston_area_m2=area, static_temperature_k=t_amb, ambient_k=t_amb, tau_s=tau).for_mass(mass)
    base = base.replace(
        damper=_draw_pack(rng, base.damper),
        valve6=replace(base.valve6, area_m2=_log_uniform(rng, 2e-5, 5e-5)),
        oil_heat_capacity_j_per_k=_log_uniform(rng, 1.2e4, 3e4),
        thermocouple_tau_s=rng.uniform(0.8, 3.0),
    )
    # The bench's gauge: class 1 (the declared charge is off by up to 1 %).
    declared = base.static_pressure_pa * (1.0 + rng.uniform(-0.01, 0.01) * gauge_error)
    ds = draw_data_system(rng) if noise else DataSystem().quiet()
    # Effect parameters are drawn from their own stream, so that a case with
    # and without an effect share the same unit and noise.
    erng = np.random.default_rng([seed, 1])
    unit, hp, fp = _apply_effect(base, effect, erng)
    hp = {"tau_s": tau, **hp}
    rho = Nitrogen()
    fp["gas_mass_over_declared"] = rho.density(base.static_pressure_pa, t_amb) / rho.density(declared, t_amb)
    return Case(effect, seed, unit, mass, ds, declared, hp, fp)


def _apply_effect(u: Unit, effect: str | None, rng: np.random.Generator) -> tuple[Unit, dict[str, float], dict[str, Any]]:
    hp: dict[str, float] = {}
    fp: dict[str, Any] = {}
    if effect is None:
        return u, hp, fp
    if effect == "friction":
        f = Friction(
            coulomb_n=_log_uniform(rng, 150.0, 1500.0),
            viscous_n_s_per_m=rng.uniform(0.0, 2000.0),
            static_ratio=rng.uniform(1.0, 1.5),
            stribeck_velocity_m_s=_log_uniform(rng, 3e-3, 3e-2),
            smoothing_velocity_m_s=_log_uniform(rng, 3e-4, 3e-3),
        )
        hp = {"friction_coulomb_n": f.coulomb_n, "friction_viscous_n_s_per_m": f.viscous_n_s_per_m}
        fp = {"friction_static_ratio": f.static_ratio, "friction_stribeck_velocity_m_s": f.stribeck_velocity_m_s,
              "friction_smoothing_velocity_m_s": f.smoothing_velocity_m_s}
        return u.with_effects(friction=f), hp, fp
    if effect == "oil_compliance":
        c = OilCompliance(bulk_modulus_pa=_log_uniform(rng, 1.5e8, 8e8), oil_volume_m3=rng.uniform(0.6e-3, 1.4e-3))
        hp = {"oil_bulk_modulus_pa": c.bulk_modulus_pa * HPCTL_OIL_VOLUME_M3 / c.oil_volume_m3}
        fp = {"oil_bulk_modulus_pa": c.bulk_modulus_pa, "oil_volume_m3": c.oil_volume_m3}
        return u.with_effects(oil_compliance=c), hp, fp
    if effect == "heat_buildup":
        h = HeatBuildup(wall_heat_capacity_j_per_k=_log_uniform(rng, 3e3, 1e4), wall_to_oil_tau_s=_log_uniform(rng, 2500.0, 8000.0),
                        wall_to_ambient_tau_s=_log_uniform(rng, 1.2e4, 3e4))
        # The wall's time constant to ambient is c_w / G_a here and in hp-core
        # (hpctl's flexible model fits it).
        hp = {"oil_heat_capacity_j_per_k": u.oil_heat_capacity_j_per_k, "wall_to_oil_tau_s": h.wall_to_oil_tau_s,
              "wall_heat_capacity_j_per_k": h.wall_heat_capacity_j_per_k, "wall_to_ambient_tau_s": h.wall_to_ambient_tau_s}
        fp = {"wall_heat_capacity_j_per_k": h.wall_heat_capacity_j_per_k,
              "oil_to_ambient_tau_s": f"{u.oil_to_ambient_tau_100k_s} s at 100 K, as dT^-{u.oil_to_ambient_exponent}"}
        return u.with_effects(heat_buildup=h), hp, fp
    if effect == "leakage":
        lk = Leakage(_log_uniform(rng, 2e4, 1.5e5))
        hp = {"leak_time_constant_s": lk.time_constant_s}
        fp = {"leak_law": "dm/dt proportional to p - p_atm (seal permeation); time constant at the static state"}
        return u.with_effects(leakage=lk), hp, fp
    if effect == "valve_lag":
        v = ValveLag(_log_uniform(rng, 0.012, 0.08))
        hp = {"valve_time_constant_s": v.time_constant_s}
        fp = {"valve_close_ratio": v.close_ratio}
        return u.with_effects(valve_lag=v), hp, fp
    if effect == "sensor_offset":
        def signed(lo: float, hi: float) -> float:
            return float(rng.choice([-1.0, 1.0]) * rng.uniform(lo, hi))

        s = SensorOffsets(force_n=signed(120.0, 800.0), p_gas_pa=signed(2e4, 1e5), p_gas2_pa=signed(2e4, 1e5))
        hp = {"sensor_force_offset_n": s.force_n, "sensor_pressure_offset_pa": s.p_gas_pa, "sensor_pressure2_offset_pa": s.p_gas2_pa}
        fp = {"sensor_pressure_offset_pa": s.p_gas_pa, "sensor_pressure2_offset_pa": s.p_gas2_pa}
        return u.with_effects(sensor_offset=s), hp, fp
    if effect == "sensor_lag":
        sl = SensorLag(_log_uniform(rng, 0.004, 0.03))
        hp = {"sensor_time_constant_s": sl.time_constant_s}
        fp = {"sensor_lag_channels": "force_n, p_gas_pa, p_gas2_pa"}
        return u.with_effects(sensor_lag=sl), hp, fp
    if effect == "bump_stop":
        b = BumpStop(start_m=rng.uniform(0.035, 0.05), stiffness_n_per_m1_5=_log_uniform(rng, 2e6, 1e7))
        fp = {"bump_start_m": b.start_m, "bump_stiffness_n_per_m1_5": b.stiffness_n_per_m1_5, "bump_damping_rel_s_per_m": b.damping_rel_s_per_m}
        return u.with_effects(bump_stop=b), hp, fp
    if effect == "oil_viscosity":
        ov = OilViscosity(rng.uniform(0.02, 0.035))
        fp = {"viscosity_coefficient_per_k": ov.coefficient_per_k}
        return u.with_effects(oil_viscosity=ov), hp, fp
    raise AssertionError(effect)


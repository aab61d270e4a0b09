"""Long simulated drives for the ECU's gas-charge loss detector.

One corner's unit under its share of the body (SDOF rig) in closed loop
with the production corner controller and the ECU's gas-charge detector
(``hp_ctrl::gas_charge``, fed exactly as the vehicle step feeds it), run in
Rust (:func:`hpctl._core.gas_charge_drives`), many drives in parallel.

A drive is a plan of :class:`Segment` s (standstill, highway, country
road, rough road, track, off road: speed and ISO 8608 road class, and the
driver's ride-height request), on a day at one ambient temperature. The
unit carries the seed's oil node (damper heat into the oil, the oil and
the ambient into the accumulators' walls): hard driving heats the gas by
tens of kelvin over an hour, which is what the detector must not mistake
for a change of charge. A unit can start under-charged
(:func:`charged_unit`: a leak while parked) or leak while driving (the
unit's leakage effect).

``scripts/leak_study.py`` runs the study (healthy units for false alarms,
under-charged and leaking units for detection times) and
``docs/controller.md`` reports it.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import cast

import numpy as np
from numpy.typing import NDArray
from scipy.optimize import brentq

from hpctl import _core
from hpctl._coretypes import GasChargeCaseDict, GasChargeChangesDict, GasChargeDriveDict
from hpctl.control import road
from hpctl.model.unit import SEED_SPRUNG_MASS_KG, Leakage, OilNode, Sensor, Unit
from hpctl.sim.run import Sampled, _motion_dict

FloatArray = NDArray[np.float64]

#: The base is sampled at this step (the road's shortest wave, 2.83
#: cycles/m, at 22 m/s is 62 Hz: three samples a period and a cubic between).
BASE_DT_S = 0.005


@dataclass(frozen=True)
class Segment:
    """``duration_s`` at ``speed_m_s`` on an ISO 8608 ``road_class`` road
    (None: standing still), with the driver's ride-height request."""

    kind: str
    duration_s: float
    speed_m_s: float
    road_class: str | None
    ride_height_request_m: float = 0.0


#: The kinds of driving a plan is made of: speed, road class, the share of
#: a drive they take on average.
DRIVING: dict[str, tuple[float, str | None, float]] = {
    "standstill": (0.0, None, 0.10),
    "highway": (22.0, "A", 0.20),
    "country road": (15.0, "B", 0.25),
    "rough road": (10.0, "C", 0.20),
    "track": (6.0, "D", 0.15),
    "off road": (3.0, "E", 0.10),
}

#: Days: ambient temperature, K.
DAYS: dict[str, float] = {"cold": 243.15, "cool": 268.15, "mild": 288.15, "warm": 303.15, "hot": 318.15}


def plan(rng: np.random.Generator, duration_s: float, *, lowered_share: float = 0.2) -> list[Segment]:
    """A random drive of ``duration_s``: segments of 2-12 minutes of the
    :data:`DRIVING` kinds in their shares; a share ``lowered_share`` of
    the moving segments with a 30 mm lowering request (the sequencer then
    moves oil between the accumulators, which the estimate must not see)."""
    kinds = list(DRIVING)
    weights = np.array([DRIVING[k][2] for k in kinds])
    out: list[Segment] = []
    t = 0.0
    while t < duration_s:
        kind = kinds[int(rng.choice(len(kinds), p=weights / weights.sum()))]
        speed, road_class, _ = DRIVING[kind]
        length = min(float(rng.uniform(120.0, 720.0)), duration_s - t)
        request = -0.03 if speed > 0 and speed <= 15.0 and rng.uniform() < lowered_share else 0.0
        out.append(Segment(kind, length, speed, road_class, request))
        t += length
    return out


def base_motion(segments: Sequence[Segment], seed: int, *, dt_s: float = BASE_DT_S) -> Sampled:
    """The road under the wheel over the plan: each moving segment a fresh
    profile of its class (seeded), joined where the previous one ended
    (heights continuous), held while standing; faded in over the first 2 s."""
    rng = np.random.default_rng(seed)
    times, heights = [], []
    t0, z_end = 0.0, 0.0
    for seg in segments:
        n = max(int(round(seg.duration_s / dt_s)), 1)
        t = t0 + np.arange(n) * dt_s
        if seg.road_class is None or seg.speed_m_s <= 0:
            z = np.full(n, z_end)
        else:
            profile = road.profile(seg.road_class, seg.speed_m_s * seg.duration_s + 10.0, seed=int(rng.integers(2**31)), dx_m=0.05)
            z = profile.height_at(seg.speed_m_s * (t - t0))
            z = z - z[0] + z_end
        times.append(t)
        heights.append(z)
        t0 += n * dt_s
        z_end = float(z[-1])
    time_s = np.concatenate(times + [np.array([t0])])
    z_all = np.concatenate(heights + [np.array([z_end])])
    z_all = z_all * road.fade_in(time_s, 2.0)
    return Sampled(time_s, np.ascontiguousarray(z_all))


def charged_unit(unit: Unit, charge_ratio: float) -> Unit:
    """``unit`` charged with ``charge_ratio`` times its nominal gas mass
    (the same accumulator volumes, a lower static pressure at the static
    temperature, from the unit's own equation of state)."""
    if charge_ratio == 1.0:
        return unit
    if not 0.3 <= charge_ratio <= 1.1:
        raise ValueError(f"charge_ratio = {charge_ratio} must be within [0.3, 1.1]")
    t_k, p0 = unit.static_temperature_k, unit.static_pressure_pa
    rho = _core.gas_density_kg_m3(unit.gas, p0, t_k) * charge_ratio
    p = brentq(lambda p: _core.gas_density_kg_m3(unit.gas, p, t_k) - rho, 0.2 * p0, 1.5 * p0, xtol=1e-3, rtol=1e-12)
    return unit.replace(static_pressure_pa=float(p))


def seed_unit_with_heat() -> Unit:
    """The seed unit with the seed's oil node (damper heat build-up)."""
    return Unit.seed().with_effects(oil_node=OilNode(**_core.seed_oil_node()))


def drive_case(
    segments: Sequence[Segment],
    *,
    ambient_k: float,
    seed: int,
    unit: Unit | None = None,
    charge_ratio: float = 1.0,
    leak_time_constant_s: float | None = None,
    pressure_offset_pa: float = 0.0,
    t_offset_k: float = 0.0,
    gas_charge: Mapping[str, float] | None = None,
    record_dt_s: float = 1.0,
) -> GasChargeCaseDict:
    """The arguments of one drive for :func:`hpctl._core.gas_charge_drives`:
    the unit charged with ``charge_ratio`` of its nominal gas, leaking with
    ``leak_time_constant_s`` if given; its pressure transducers reading
    ``pressure_offset_pa`` high and its temperature sensor ``t_offset_k``
    high (their calibration errors)."""
    u = charged_unit(unit or seed_unit_with_heat(), charge_ratio)
    if leak_time_constant_s is not None:
        u = u.with_effects(leakage=Leakage(leak_time_constant_s))
    if pressure_offset_pa:
        u = u.with_effects(sensor=Sensor(pressure_offset_pa=pressure_offset_pa, pressure2_offset_pa=pressure_offset_pa))
    starts = np.cumsum([0.0] + [s.duration_s for s in segments[:-1]])
    case: GasChargeCaseDict = {
        "unit": u.to_dict(),
        "sprung_mass_kg": SEED_SPRUNG_MASS_KG,
        "ambient_k": float(ambient_k),
        "base": _motion_dict(base_motion(segments, seed)),
        "segments": {
            "start_s": np.asarray(starts, float),
            "speed_m_s": np.array([s.speed_m_s for s in segments], float),
            "ride_height_request_m": np.array([s.ride_height_request_m for s in segments], float),
        },
        "duration_s": float(sum(s.duration_s for s in segments)),
        "record_dt_s": record_dt_s,
        "t_gas_sensor_offset_k": float(t_offset_k),
    }
    if gas_charge:
        # Any subset of the detector's configuration; the core names an
        # unknown key or a value out of range.
        case["gas_charge"] = cast(GasChargeChangesDict, dict(gas_charge))
    return case


def run(cases: Sequence[GasChargeCaseDict], threads: int | None = None) -> list[GasChargeDriveDict]:
    """Runs the drives in parallel; a drive that failed raises its error."""
    out = []
    for r in _core.gas_charge_drives(list(cases), threads):
        if isinstance(r, Exception):
            raise r
        out.append(r)
    return out


def first_fault_s(record: GasChargeDriveDict) -> float | None:
    """Time of the first record with the fault raised, s (None: never)."""
    hits = np.flatnonzero(record["fault"])
    return float(record["time_s"][hits[0]]) if hits.size else None


def fault_episodes(record: GasChargeDriveDict) -> int:
    """How many times the fault was raised."""
    f = np.asarray(record["fault"], bool)
    return int(np.count_nonzero(f[1:] & ~f[:-1]) + int(f[0])) if f.size else 0


def settled_loss(record: GasChargeDriveDict) -> FloatArray:
    """The detector's loss estimate ``1 - charge_ratio`` once settled."""
    settled = np.asarray(record["settled"], bool)
    return np.asarray(1.0 - np.asarray(record["charge_ratio"], float)[settled], float)

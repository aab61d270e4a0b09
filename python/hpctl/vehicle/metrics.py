"""What a vehicle engineer measures on a run, per section of the route.

- **Ride** (ISO 2631-1 at the seat, :mod:`hpctl.vehicle.iso2631`): the
  frequency-weighted RMS acceleration per axis (Wd fore-aft and lateral, Wk
  vertical), the vibration total value ``a_v`` (comfort, k = 1) and the
  vibration dose values. The whole run is filtered once and each section
  cut from it, so no section starts with a filter transient.
- **Handling**: peak roll angle and roll rate, peak lateral acceleration.
- **Road holding**: the dynamic load coefficient, RMS of the wheel load's
  variation over its static value (the largest over the wheels); the
  smallest load as a fraction of static; time with a wheel off the ground.
- **Suspension travel**: the largest compression and extension as a
  fraction of the stroke, and end-stop hits (entries beyond the stroke).
- **Controller**: periods in the safe state after power-on recovery.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from hpctl.control.controller import Diag
from hpctl.vehicle import iso2631
from hpctl.vehicle.model import VehicleSpec
from hpctl.vehicle.route import Section

FloatArray = NDArray[np.float64]

#: Above this lateral acceleration the linear tyres of the handling model
#: overstate a heavy vehicle's grip: results there are flagged, m/s^2.
LINEAR_TYRE_LIMIT_M_S2 = 4.9


@dataclass(frozen=True)
class Ride:
    """ISO 2631-1 comfort at the seat, m/s^2 and m/s^1.75."""

    a_wx_m_s2: float
    a_wy_m_s2: float
    a_wz_m_s2: float
    a_v_m_s2: float
    vdv_z_m_s175: float
    vdv_total_m_s175: float


@dataclass(frozen=True)
class Wheels:
    """Road holding and suspension travel (worst wheel)."""

    dynamic_load_coefficient: float
    min_load_ratio: float
    lift_off_s: float
    compression_used: float
    extension_used: float
    end_stop_hits: int
    #: Which wheels hit an end stop or left the road (corner names).
    end_stop_wheels: tuple[str, ...]
    lifted_wheels: tuple[str, ...]


@dataclass(frozen=True)
class Handling:
    roll_peak_rad: float
    roll_rate_peak_rad_s: float
    lat_acc_peak_m_s2: float
    pitch_peak_rad: float


@dataclass(frozen=True)
class SectionMetrics:
    name: str
    kind: str
    duration_s: float
    ride: Ride
    wheels: Wheels
    handling: Handling
    #: Time in the controller's safe state (after the first recovery), s.
    safe_state_s: float


def _rising(x: NDArray[np.bool_]) -> int:
    if x.size == 0:
        return 0
    return int(np.count_nonzero(x[1:] & ~x[:-1]) + int(x[0]))


def section_metrics(
    vehicle: VehicleSpec,
    sections: tuple[Section, ...],
    signals: Mapping[str, FloatArray],
    corners: Mapping[str, FloatArray],
    controller: Mapping[str, FloatArray],
    static_tyre_load_n: FloatArray,
) -> list[SectionMetrics]:
    """Metrics of every section of one run (arrays as ``_core.vehicle_run``
    returns them, every control period)."""
    t = signals["time_s"]
    dt = float(np.median(np.diff(t))) if t.size > 1 else 1e-3
    aw = {
        "x": iso2631.weighted(signals["seat_acc_x_m_s2"], dt, iso2631.WD),
        "y": iso2631.weighted(signals["seat_acc_y_m_s2"], dt, iso2631.WD),
        "z": iso2631.weighted(signals["seat_acc_z_m_s2"], dt, iso2631.WK),
    }
    names = vehicle.corner_names()
    stroke_c = np.repeat([a.unit.stroke_compression_m for a in vehicle.axles], 2)
    stroke_e = np.repeat([a.unit.stroke_extension_m for a in vehicle.axles], 2)
    safe = np.zeros(t.size, dtype=bool)
    if "diag" in controller:
        in_safe = (controller["diag"].astype(np.int64) & int(Diag.SAFE_STATE)) != 0
        any_safe = in_safe.any(axis=1)
        recovered = np.flatnonzero(~in_safe.any(axis=1))
        if recovered.size:
            safe = any_safe & (np.arange(t.size) > recovered[0])
    out = []
    for s in sections:
        m = (signals["distance_m"] >= s.start_m) & (signals["distance_m"] < s.end_m)
        if not m.any():
            continue
        ax, ay, az = (rms(aw[k][m]) for k in ("x", "y", "z"))
        vx, vy, vz = (iso2631.vdv(aw[k][m], dt) for k in ("x", "y", "z"))
        ride = Ride(ax, ay, az, iso2631.vector_sum(ax, ay, az), vz, iso2631.vdv_total(vx, vy, vz))
        load = corners["tyre_force_n"][m]
        dyn = (load - static_tyre_load_n) / static_tyre_load_n
        disp = corners["disp_m"][m]
        beyond = (disp > stroke_c) | (disp < -stroke_e)
        hits = np.array([_rising(beyond[:, k]) for k in range(beyond.shape[1])])
        lifted = load <= 0.0
        wheels = Wheels(
            dynamic_load_coefficient=float(np.sqrt(np.mean(dyn * dyn, axis=0)).max()),
            min_load_ratio=float((load / static_tyre_load_n).min()),
            lift_off_s=float(lifted.any(axis=1).sum() * dt),
            compression_used=float((disp / stroke_c).max()),
            extension_used=float((-disp / stroke_e).max()),
            end_stop_hits=int(hits.sum()),
            end_stop_wheels=tuple(n for n, h in zip(names, hits) if h > 0),
            lifted_wheels=tuple(n for k, n in enumerate(names) if lifted[:, k].any()),
        )
        handling = Handling(
            roll_peak_rad=float(np.abs(signals["roll_rad"][m]).max()),
            roll_rate_peak_rad_s=float(np.abs(signals["roll_rate_rad_s"][m]).max()),
            lat_acc_peak_m_s2=float(np.abs(signals["lat_acc_m_s2"][m]).max()),
            pitch_peak_rad=float(np.abs(signals["pitch_rad"][m]).max()),
        )
        out.append(SectionMetrics(s.name, s.kind, float(m.sum() * dt), ride, wheels, handling, float(safe[m].sum() * dt)))
    return out


def rms(x: FloatArray) -> float:
    return iso2631.rms(x) if x.size else math.nan

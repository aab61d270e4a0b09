"""The vehicles (Rust, ``hp-vehicle``) as typed Python values.

A :class:`VehicleSpec` is the rigid body, two to four axles with a unit
(:class:`hpctl.model.unit.Unit`) and a tyre per wheel, and the seat where
comfort is measured; :func:`preset` gives the built-in armoured-vehicle
class 4x4 and 8x8 (3 t of sprung mass per wheel, the seed's unit at every
wheel; their numbers and reasoning are in ``crates/hp-vehicle/src/presets.rs``).
The physics, the checks and the presets live in Rust; this module only
names the fields.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from hpctl import _core
from hpctl._coretypes import ControllerConfigDict, VehicleDict
from hpctl.errors import ParameterError
from hpctl.model.unit import Unit

FloatArray = NDArray[np.float64]


@dataclass(frozen=True)
class Body:
    """The sprung mass: inertias about the centre of gravity, heights above ground."""

    mass_kg: float
    roll_inertia_kg_m2: float
    pitch_inertia_kg_m2: float
    yaw_inertia_kg_m2: float
    cg_height_m: float
    roll_centre_height_m: float


@dataclass(frozen=True)
class Axle:
    """One axle: position ahead of the centre of gravity, two wheels."""

    x_m: float
    track_m: float
    unsprung_mass_kg: float
    wheel_radius_m: float
    tyre_stiffness_n_per_m: float
    tyre_damping_n_s_per_m: float
    cornering_stiffness_n_per_rad: float
    steer_ratio: float
    unit: Unit


@dataclass(frozen=True)
class Seat:
    """Where ISO 2631-1 comfort is measured: ahead of and left of the
    centre of gravity, seat surface height above ground."""

    x_m: float
    y_m: float
    height_m: float


@dataclass(frozen=True)
class VehicleSpec:
    """A whole vehicle."""

    name: str
    body: Body
    axles: tuple[Axle, ...]
    steering_ratio: float
    seat: Seat

    @property
    def corner_count(self) -> int:
        return 2 * len(self.axles)

    @property
    def wheelbase_m(self) -> float:
        """Front to rear axle, m."""
        return self.axles[0].x_m - self.axles[-1].x_m

    @property
    def track_m(self) -> float:
        """The widest track, m."""
        return max(a.track_m for a in self.axles)

    def corner_names(self) -> list[str]:
        """``axle1_left``, ``axle1_right``, ... in the core's corner order."""
        return [f"axle{k + 1}_{side}" for k in range(len(self.axles)) for side in ("left", "right")]

    def to_core(self) -> VehicleDict:
        """The dict the Rust core reads."""
        b, s = self.body, self.seat
        return {
            "body": {
                "mass_kg": b.mass_kg,
                "roll_inertia_kg_m2": b.roll_inertia_kg_m2,
                "pitch_inertia_kg_m2": b.pitch_inertia_kg_m2,
                "yaw_inertia_kg_m2": b.yaw_inertia_kg_m2,
                "cg_height_m": b.cg_height_m,
                "roll_centre_height_m": b.roll_centre_height_m,
            },
            "axles": [
                {
                    "x_m": a.x_m,
                    "track_m": a.track_m,
                    "unsprung_mass_kg": a.unsprung_mass_kg,
                    "wheel_radius_m": a.wheel_radius_m,
                    "tyre_stiffness_n_per_m": a.tyre_stiffness_n_per_m,
                    "tyre_damping_n_s_per_m": a.tyre_damping_n_s_per_m,
                    "cornering_stiffness_n_per_rad": a.cornering_stiffness_n_per_rad,
                    "steer_ratio": a.steer_ratio,
                    "unit": a.unit.to_dict(),
                }
                for a in self.axles
            ],
            "steering_ratio": self.steering_ratio,
            "seat": {"x_m": s.x_m, "y_m": s.y_m, "height_m": s.height_m},
        }

    @classmethod
    def from_core(cls, name: str, d: VehicleDict) -> VehicleSpec:
        """From the core's dict form (``_core.vehicle_presets``); a malformed
        one raises :class:`ParameterError` naming the vehicle."""
        try:
            # The keys splat into the dataclasses: a missing or unknown one is
            # the TypeError below (the dict may come from outside the core).
            fields: list[dict[str, Any]] = [{**a, "unit": Unit.from_dict(a["unit"], f"{name}.axles[{k}].unit")} for k, a in enumerate(d["axles"])]
            axles = tuple(Axle(**f) for f in fields)
            return cls(name, Body(**d["body"]), axles, float(d["steering_ratio"]), Seat(**d["seat"]))
        except (KeyError, TypeError) as e:
            raise ParameterError(f"vehicle {name}: {e}") from None

    def with_unit(self, unit: Unit) -> VehicleSpec:
        """The same vehicle with ``unit`` at every wheel."""
        return dataclasses.replace(self, axles=tuple(dataclasses.replace(a, unit=unit) for a in self.axles))

    def controller_config(self) -> ControllerConfigDict:
        """The controller configuration for this vehicle (the seed
        calibration with its steering ratio and effective wheelbase)."""
        return _core.vehicle_controller_config(self.to_core())

    def statics(self, ambient_k: float | None = None, *, spring_hard: bool = True) -> Statics:
        """Static wheel loads and positions."""
        t = self.axles[0].unit.static_temperature_k if ambient_k is None else ambient_k
        d = _core.vehicle_statics(self.to_core(), t, spring_hard, True)
        return Statics(d["static_load_n"], d["static_disp_m"], d["tyre_static_deflection_m"], d["x_m"], d["y_m"], float(d["total_mass_kg"]))


@dataclass(frozen=True)
class Statics:
    """Per wheel (core order): static share of the sprung weight (N),
    strut compression and tyre deflection (m), position (m)."""

    static_load_n: FloatArray
    static_disp_m: FloatArray
    tyre_static_deflection_m: FloatArray
    x_m: FloatArray
    y_m: FloatArray
    total_mass_kg: float

    def tyre_static_load_n(self, vehicle: VehicleSpec) -> FloatArray:
        """Static wheel load on the road (sprung share plus the wheel), N."""
        unsprung = np.repeat([a.unsprung_mass_kg for a in vehicle.axles], 2)
        return np.asarray(self.static_load_n + unsprung * 9.80665, dtype=np.float64)


#: The built-in vehicles.
PRESETS = ("4x4", "8x8")


def preset(name: str) -> VehicleSpec:
    """A built-in vehicle: ``4x4`` or ``8x8``."""
    presets = _core.vehicle_presets()
    if name not in presets:
        raise ParameterError(f"vehicle {name!r} is not a built-in vehicle (one of: {', '.join(sorted(presets))})")
    return VehicleSpec.from_core(name, presets[name])

"""The vehicle the ECU controls in processor-in-the-loop runs: hp-vehicle's
full-vehicle plant (:class:`hpctl._core.VehiclePlant`) with the ECU's
sensors.

:class:`PilPlant` is a rigid body in heave, pitch and roll on two to four
axles, one hp-core unit and one tyre per wheel (``hp_vehicle::vehicle``),
on a road given as the heights of the left and right wheel tracks over
distance: the corners pull on one another through the body (load
transfer when a corner is lowered, warp of a four-point stance), and a
slope is the road's plane under the wheels.

**A slope, what is modelled.** The road's heights under the wheels tilt
the body (pitch and roll are angles from the horizontal, as an
inclinometer on the body reads them). Gravity stays vertical in the
plant's equations (small angles), so the weight's component along the
ground is added as it acts: along the slope it is held at the contact
patches (brakes or drive) while it pulls at the centre of gravity, which
is the pitch moment of a longitudinal acceleration ``g sin(grade)``, passed
to the plant as such (hp-vehicle's ``-m_s a_x h_cg``; the grade is the
plane fitted through the road heights under the wheels, so on an uneven
road it follows the wheels' mean ground plane). Across the slope the
sprung mass's weight shift above the roll axis is hp-vehicle's ``m_s g
roll (h_cg - h_rc)`` term, roll being the body's roll from the
horizontal. Not modelled: the share of the lateral weight component below
the roll axis (the geometric load transfer through the links, about 0.3 %
of a wheel's load on 5 mrad), and the tyres' lateral compliance.

**A leak** is the unit's leakage effect in one corner's unit (both
accumulators lose gas as ``exp(-t / tau)`` from the start): the corner's
unit replaced through ``VehiclePlant(corner_units=...)``.

**The sensors** (per corner, :class:`hpctl.hil.pil.CornerSensors`): gas
pressures of S and L as the unit's transducers report them, the strut
compression from the unit's nominal static position (the geometric
position the gas volumes are defined at; hp-vehicle's ``disp_m``), the
body's vertical acceleration above the corner (gravity removed), and the
gas temperature of L through a first-order lag (a real sensor cannot
follow the gas's adiabatic swings; ``hp_vehicle::closed_loop`` uses the
same model). The body's attitude for the vehicle message: pitch nose up
(hp-vehicle's is nose down) and roll left side up. A failing sensor is on
the frame side (the scenario changes the reading it sends), not here.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from typing import cast

import numpy as np

from hpctl import _core
from hpctl._coretypes import RoadDict, VehicleDict
from hpctl.hil.pil import CornerSensors, temperature_lag_weight
from hpctl.model.unit import Leakage, Unit

G_M_S2 = _core.STANDARD_GRAVITY_M_S2


class PilPlant:
    """``vehicle`` on ``road`` at rest in static equilibrium at ambient
    temperature ``ambient_k`` (the road must be level, height zero, under
    the wheels at the start), both valves of every unit closed (the ECU's
    power-on safe state). ``leak_time_constants_s`` gives corners a gas
    leak (``{corner: time constant}``, corner numbering as the ECU's: axle
    by axle from the front, left before right)."""

    def __init__(
        self,
        vehicle: VehicleDict,
        road: RoadDict,
        *,
        ambient_k: float,
        leak_time_constants_s: Mapping[int, float] | None = None,
        t_sensor_tau_s: float = 1.0,
        max_dt_s: float = 1e-3,
    ):
        units = {}
        axles = vehicle["axles"]
        for k, tau in (leak_time_constants_s or {}).items():
            if not 0 <= k < 2 * len(axles):
                raise ValueError(f"leak_time_constants_s has corner {k}; the vehicle has corners 0 to {2 * len(axles) - 1}")
            unit = Unit.from_dict(axles[k // 2]["unit"])
            units[k] = unit.with_effects(leakage=Leakage(tau)).to_dict()
        self.plant = _core.VehiclePlant(vehicle, road, ambient_k, spring_hard=True, damper_on=True, max_dt_s=max_dt_s, corner_units=units)
        self.t_sensor_tau_s = t_sensor_tau_s
        self.sample = self.plant.sample()
        self.t_read_k = list(self.corner("t_gas2_k"))
        statics = _core.vehicle_statics(vehicle, ambient_k)
        #: Corner positions (x forward from the centre of gravity, y left), m.
        self.geometry = np.column_stack([statics["x_m"], statics["y_m"]])
        #: Each corner's static load, N.
        self.static_load_n = np.asarray(statics["static_load_n"], dtype=float)
        x, y = self.geometry[:, 0], self.geometry[:, 1]
        self._fit = np.linalg.pinv(np.column_stack([np.ones(len(x)), x - x.mean(), y - y.mean()]))

    @property
    def corners(self) -> int:
        return int(self.plant.corner_count)

    @property
    def time_s(self) -> float:
        return float(self.plant.time_s)

    def corner(self, channel: str) -> list[float]:
        """A wheel channel (``_core.VEHICLE_CORNER_CHANNELS``) now, one value
        per corner."""
        return cast(list[float], self.sample[channel])

    def sensors(self) -> list[CornerSensors]:
        """What each corner's sensor cluster reads now."""
        p_s, p_l, disp, acc = (self.corner(c) for c in ("p_gas_pa", "p_gas2_pa", "disp_m", "body_acc_m_s2"))
        return [
            CornerSensors(p_gas_pa=p_s[k], p_gas2_pa=p_l[k], strut_disp_m=disp[k], body_acc_m_s2=acc[k], t_gas_k=self.t_read_k[k])
            for k in range(self.corners)
        ]

    def attitude_rad(self) -> tuple[float, float]:
        """Body pitch (nose up) and roll (left side up) from the horizontal."""
        return -float(cast(float, self.sample["pitch_rad"])), float(cast(float, self.sample["roll_rad"]))

    def ground_rad(self) -> tuple[float, float]:
        """The ground plane under the wheels (the least-squares plane through
        the road heights at the contact points): pitch nose up, roll left
        side up."""
        _, b, c = self._fit @ np.asarray(self.corner("road_m"))
        return math.atan(b), math.atan(c)

    def step(self, dt_s: float, valve5_open: Sequence[bool], valve6_open: Sequence[bool], speed_m_s: float) -> None:
        """Holds each corner's valve commands and the speed over ``dt_s`` and
        advances (the weight's component along the ground as the equivalent
        longitudinal acceleration, see the module's docstring)."""
        grade_rad, _ = self.ground_rad()
        self.sample = self.plant.step(dt_s, [bool(v) for v in valve5_open], [bool(v) for v in valve6_open], speed_m_s, G_M_S2 * math.sin(grade_rad))
        w = temperature_lag_weight(dt_s, self.t_sensor_tau_s)
        for k, t in enumerate(self.corner("t_gas2_k")):
            self.t_read_k[k] += w * (t - self.t_read_k[k])

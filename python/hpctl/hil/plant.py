"""The vehicle the ECU controls in processor-in-the-loop runs: a stand-in
for the full-vehicle plant, one sprung mass per corner.

:class:`CornerPlants` mounts one unit per corner on its own single-degree-of-
freedom rig (:class:`hpctl._core.Plant`: the unit under a static share of the
body's mass over a moving base), each with its own road input, and reads
the body's attitude from the corners' strut positions. What it leaves out
(say so with any result): the body is not rigid (the corners do not pull
on one another: no pitch and roll dynamics, no load transfer when a corner
is lowered or on a slope); a slope tilts the body by its angle and nothing
else. The full-vehicle plant (hp-vehicle's rigid body on 2-4 axles,
``hpctl._core.VehiclePlant``) is now in the bindings; moving the
processor-in-the-loop scenarios onto it is not done yet. The interface
(valve commands per corner in, sensor readings per corner out) is the one
such a plant has.

The sensors: gas pressures of S and L as the unit's transducers report
them, the strut compression from the unit's nominal static position (the
geometric position the gas volumes are defined at), the body's vertical
acceleration above the corner, and the gas temperature of L through a
first-order lag (a real sensor cannot follow the gas's adiabatic swings;
``hp_vehicle::closed_loop`` uses the same model).
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from hpctl import _core
from hpctl.hil.pil import CornerSensors, temperature_lag_weight
from hpctl.model.unit import Leakage, Unit
from hpctl.sim.run import Hold, Motion, sdof_rig


class CornerPlants:
    """``len(geometry)`` corners, corner ``k`` at ``geometry[k] = (x_m,
    y_m)`` (x forward, y to the left), each carrying ``sprung_mass_kg`` on
    its unit over ``bases[k]`` (default: a level road at rest), at ambient
    temperature ``ambient_k``. ``leak_time_constants_s`` gives corners a gas
    leak (``{corner: time constant}``, the unit's leakage effect: both
    accumulators lose gas as ``exp(-t / tau)`` from the start). At power-on
    both valves are closed (the ECU's safe state)."""

    def __init__(
        self,
        unit: Unit,
        geometry: Sequence[tuple[float, float]],
        *,
        sprung_mass_kg: float,
        ambient_k: float,
        bases: Sequence[Motion] | None = None,
        leak_time_constants_s: dict[int, float] | None = None,
        t_sensor_tau_s: float = 1.0,
        max_dt_s: float = 1e-3,
    ):
        n = len(geometry)
        bases = list(bases) if bases is not None else [Hold()] * n
        if len(bases) != n:
            raise ValueError(f"bases has {len(bases)} motions for {n} corners")
        leaks = leak_time_constants_s or {}
        self.geometry = np.asarray(geometry, dtype=float)
        self.t_sensor_tau_s = t_sensor_tau_s
        self.plants = []
        for k in range(n):
            u = unit.with_effects(leakage=Leakage(leaks[k])) if k in leaks else unit
            self.plants.append(_core.Plant(u.to_dict(), sdof_rig(bases[k], sprung_mass_kg).to_core(), ambient_k, True, True, max_dt_s))
        self.samples = [p.sample() for p in self.plants]
        self.t_read_k = [s["t_gas2_k"] for s in self.samples]
        # Least squares of a plane z = a + b x + c y over the corners.
        x, y = self.geometry[:, 0], self.geometry[:, 1]
        self._fit = np.linalg.pinv(np.column_stack([np.ones(n), x - x.mean(), y - y.mean()]))

    @property
    def corners(self) -> int:
        return len(self.plants)

    @property
    def time_s(self) -> float:
        return float(self.plants[0].time_s)

    def sensors(self) -> list[CornerSensors]:
        """What each corner's sensor cluster reads now."""
        return [
            CornerSensors(
                p_gas_pa=s["p_gas_pa"], p_gas2_pa=s["p_gas2_pa"], strut_disp_m=s["disp_m"], body_acc_m_s2=s["body_acc_m_s2"], t_gas_k=t
            )
            for s, t in zip(self.samples, self.t_read_k, strict=True)
        ]

    def attitude_rad(self, slope_pitch_rad: float = 0.0, slope_roll_rad: float = 0.0) -> tuple[float, float]:
        """Body pitch (nose up) and roll (left side up): the slope's plus the
        plane through the corners' heights (a corner compressed by ``d`` is
        ``d`` lower)."""
        z = -np.array([s["disp_m"] for s in self.samples])
        _, b, c = self._fit @ z
        return slope_pitch_rad + math.atan(b), slope_roll_rad + math.atan(c)

    def step(self, dt_s: float, valve5_open: Sequence[bool], valve6_open: Sequence[bool]) -> None:
        """Holds each corner's valve commands over ``dt_s`` and advances."""
        w = temperature_lag_weight(dt_s, self.t_sensor_tau_s)
        for k, plant in enumerate(self.plants):
            self.samples[k] = plant.step(dt_s, bool(valve5_open[k]), bool(valve6_open[k]))
            self.t_read_k[k] += w * (self.samples[k]["t_gas2_k"] - self.t_read_k[k])

"""Routes: where the vehicle drives, how fast, and what the driver does.

A :class:`Route` is a sequence of :class:`Segment` (a length of road with
its ISO 8608 class, obstacles, target speed and an optional lane change)
made into two road tracks on one distance grid (:func:`build`) and, for a
given vehicle, the driver's signals of every control period
(:func:`drive`). The default mixed route (:func:`mixed`): a smooth start
while the controllers power up, a highway, a double lane change, a rough
track and a stretch of obstacles (bump, pothole, washboard).

- **Speed**: each segment has a target speed; the driver accelerates and
  brakes at no more than ``accel_m_s2`` (1 m/s^2 by default, below the
  controller's longitudinal trigger: a gentle driver) and brakes early
  enough to enter a slower segment at its speed.
- **Double lane change** in the style of ISO 3888-2 (the obstacle-avoidance
  track for passenger cars up to 3.5 t): the standard's five sections of
  12, 13.5, 11, 12.5 and 12 m, lengthened by ``length_scale`` for a heavy
  vehicle, the lane widths 1.1 w + 0.25, w + 1 and 1.3 w + 0.25 for a
  vehicle of width w, the middle lane offset 1 m beside the entry lane.
  The path runs along the lanes' centre lines and changes lane over
  sections 2 and 4 with zero curvature at both ends
  (``y = D (u - sin(2 pi u) / (2 pi))``). The driver steers the path's
  curvature through the vehicle's own steady-state yaw-rate gain (the
  multi-axle single-track model's, solved here by hand): a feed-forward
  driver, so the vehicle lags the path a little, as a real one does.
- **Tyre enveloping**: the tyre's contact patch bridges short features, so
  the tracks are smoothed by a moving average over ``contact_length_m``
  (0.3 m) before driving; the ISO 8608 spectrum itself is generated and
  tested unsmoothed in :mod:`hpctl.control.road`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Literal

import numpy as np
from numpy.typing import NDArray

from hpctl._coretypes import RoadDict
from hpctl.control import road
from hpctl.control.controller import DriverMode
from hpctl.errors import ParameterError
from hpctl.vehicle.model import VehicleSpec

FloatArray = NDArray[np.float64]
G = 9.80665

#: The five sections of ISO 3888-2's obstacle-avoidance track, m.
ISO_3888_2_SECTIONS_M = (12.0, 13.5, 11.0, 12.5, 12.0)

Kind = Literal["start", "highway", "lane_change", "rough", "obstacles"]


@dataclass(frozen=True)
class Bump:
    """A cosine bump across both tracks (or one), at ``at_m`` from the segment start."""

    at_m: float
    height_m: float = 0.08
    length_m: float = 0.8
    side: Literal["both", "left", "right"] = "both"


@dataclass(frozen=True)
class Pothole:
    """A pothole: a cosine dip of ``depth_m`` over ``length_m``."""

    at_m: float
    depth_m: float = 0.06
    length_m: float = 0.6
    side: Literal["both", "left", "right"] = "left"


@dataclass(frozen=True)
class Washboard:
    """Corrugations: a sine of ``amplitude_m`` and ``wavelength_m`` over ``length_m``, both tracks."""

    at_m: float
    length_m: float = 20.0
    amplitude_m: float = 0.012
    wavelength_m: float = 0.7


Obstacle = Bump | Pothole | Washboard


def _smooth_step(u: NDArray[np.float64]) -> NDArray[np.float64]:
    """0 to 1 over [0, 1] with zero slope and curvature at both ends."""
    return np.asarray(u - np.sin(2.0 * np.pi * u) / (2.0 * np.pi), dtype=np.float64)


@dataclass(frozen=True)
class LaneChange:
    """An ISO 3888-2-style double lane change (see the module docs),
    starting ``at_m`` from the segment start."""

    at_m: float = 40.0
    length_scale: float = 2.5

    def sections_m(self) -> tuple[float, ...]:
        return tuple(self.length_scale * s for s in ISO_3888_2_SECTIONS_M)

    def offset_m(self, vehicle_width_m: float) -> float:
        """Lateral distance between the entry lane's and the middle lane's centre lines."""
        w = vehicle_width_m
        return 0.5 * (1.1 * w + 0.25) + 1.0 + 0.5 * (w + 1.0)

    def path_m(self, x_m: FloatArray, vehicle_width_m: float) -> FloatArray:
        """Lateral position of the path at distances ``x_m`` from the segment start."""
        l1, l2, l3, l4, _ = self.sections_m()
        d = self.offset_m(vehicle_width_m)
        x = np.asarray(x_m, dtype=float) - self.at_m
        up = np.clip((x - l1) / l2, 0.0, 1.0)
        down = np.clip((x - l1 - l2 - l3) / l4, 0.0, 1.0)
        return np.asarray(d * (_smooth_step(up) - _smooth_step(down)), dtype=np.float64)

    @property
    def length_m(self) -> float:
        return float(sum(self.sections_m()))


@dataclass(frozen=True)
class Segment:
    """A length of road driven at ``speed_m_s``."""

    name: str
    kind: Kind
    length_m: float
    speed_m_s: float
    road_class: str = "A"
    obstacles: tuple[Obstacle, ...] = ()
    lane_change: LaneChange | None = None


@dataclass(frozen=True)
class RouteSpec:
    """A route: its segments and how the roads are drawn."""

    name: str
    segments: tuple[Segment, ...]
    seed: int = 1
    accel_m_s2: float = 1.0
    contact_length_m: float = 0.3
    dx_m: float = 0.02


@dataclass(frozen=True)
class Section:
    """A segment on the built route: distance range of the vehicle's centre of gravity."""

    name: str
    kind: Kind
    start_m: float
    end_m: float
    speed_m_s: float


@dataclass(frozen=True)
class Route:
    """A route made into road tracks (heights every ``dx_m`` from ``start_m``)."""

    spec: RouteSpec
    start_m: float
    dx_m: float
    left_m: FloatArray
    right_m: FloatArray
    sections: tuple[Section, ...]
    lane_changes: tuple[tuple[float, LaneChange], ...] = field(default=())

    @property
    def length_m(self) -> float:
        return self.sections[-1].end_m

    def to_core(self) -> RoadDict:
        return {"start_m": self.start_m, "dx_m": self.dx_m, "left_m": self.left_m, "right_m": self.right_m}


def mixed(*, seed: int = 1, lane_change_speed_m_s: float = 12.5, rough_speed_m_s: float = 8.0, scale: float = 1.0) -> RouteSpec:
    """The mixed route: start (smooth, 100 m at 10 m/s), highway (class B,
    800 m at 22 m/s), a double lane change (class A at 12.5 m/s), rough track
    (class D, 300 m at 8 m/s), obstacles (class C at 5 m/s: bump, pothole
    under the left wheels, washboard). ``scale`` shortens every segment
    but the lane change (for quick tests)."""
    if not (0 < scale <= 1):
        raise ParameterError(f"route scale = {scale} must be within (0, 1]")
    lc = LaneChange()
    return RouteSpec(
        "mixed",
        (
            Segment("start", "start", 100.0 * max(scale, 0.5), 10.0, "A"),
            Segment("highway", "highway", 800.0 * scale, 22.0, "B"),
            Segment("lane change", "lane_change", lc.at_m + lc.length_m + 50.0, lane_change_speed_m_s, "A", lane_change=lc),
            Segment("rough track", "rough", 300.0 * scale, rough_speed_m_s, "D"),
            Segment(
                "obstacles",
                "obstacles",
                150.0 * scale + 40.0,
                5.0,
                "C",
                obstacles=(Bump(20.0 * scale + 10.0), Pothole(60.0 * scale + 15.0), Washboard(100.0 * scale + 20.0, length_m=20.0 * scale)),
            ),
        ),
        seed=seed,
    )


def _obstacle_heights(o: Obstacle, x: FloatArray) -> tuple[FloatArray, FloatArray]:
    """Left and right height of an obstacle at segment distances ``x``."""
    if isinstance(o, Washboard):
        # Whole wavelengths, so it starts and ends level.
        waves = max(1, int(o.length_m / o.wavelength_m))
        inside = (x >= o.at_m) & (x <= o.at_m + waves * o.wavelength_m)
        # Crests of twice the amplitude from level ground: starts level, C1.
        z = np.where(inside, o.amplitude_m * (1.0 - np.cos(2.0 * np.pi * (x - o.at_m) / o.wavelength_m)), 0.0)
        return z, z
    sign = 1.0 if isinstance(o, Bump) else -1.0
    size = o.height_m if isinstance(o, Bump) else o.depth_m
    u = (x - o.at_m) / o.length_m
    z = np.where((u >= 0) & (u <= 1), sign * 0.5 * size * (1.0 - np.cos(2.0 * np.pi * u)), 0.0)
    zero = np.zeros_like(z)
    return (z if o.side in ("both", "left") else zero), (z if o.side in ("both", "right") else zero)


def build(spec: RouteSpec, vehicle: VehicleSpec) -> Route:
    """The road tracks of a route for a vehicle (its track width sets the
    left-right coherence; its wheelbase the run-in behind the start)."""
    if not spec.segments:
        raise ParameterError("a route needs at least one segment")
    for s in spec.segments:
        if not (math.isfinite(s.length_m) and s.length_m > 0 and math.isfinite(s.speed_m_s) and 0 < s.speed_m_s <= 40):
            raise ParameterError(f"segment {s.name!r}: length_m = {s.length_m} must be positive and speed_m_s = {s.speed_m_s} within (0, 40]")
    dx = spec.dx_m
    # The rear wheels start one wheelbase behind the centre of gravity.
    run_in = vehicle.axles[0].x_m - vehicle.axles[-1].x_m + 5.0
    start = -run_in
    total = sum(s.length_m for s in spec.segments)
    n = int(math.ceil((total + run_in + 10.0) / dx)) + 1
    x = start + np.arange(n) * dx
    left = np.zeros(n)
    right = np.zeros(n)
    sections = []
    lane_changes = []
    pos = 0.0
    track = vehicle.track_m
    for k, s in enumerate(spec.segments):
        inside = (x >= pos) & (x < pos + s.length_m)
        tracks = road.two_tracks(s.road_class, s.length_m + 1.0, track_m=track, seed=spec.seed * 1000 + k, dx_m=dx)
        local = np.asarray(x[inside] - pos, dtype=np.float64)
        left[inside] += np.interp(local, tracks.distance_m, tracks.left_m)
        right[inside] += np.interp(local, tracks.distance_m, tracks.right_m)
        for o in s.obstacles:
            zl, zr = _obstacle_heights(o, local)
            left[inside] += zl
            right[inside] += zr
        sections.append(Section(s.name, s.kind, pos, pos + s.length_m, s.speed_m_s))
        if s.lane_change is not None:
            lane_changes.append((pos, s.lane_change))
        pos += s.length_m
    # Segments join without steps: each random track is shifted to continue
    # the previous one's end height, faded over the first 10 m.
    for sec in sections[1:]:
        i = int(round((sec.start_m - start) / dx))
        if 0 < i < n:
            for h in (left, right):
                jump = h[i] - h[i - 1]
                ramp = np.clip((x[i:] - sec.start_m) / 10.0, 0.0, 1.0)
                h[i:] -= jump * (1.0 - ramp)
    # The vehicle starts at rest on level road: zero before the start, faded in over 20 m.
    fade = 0.5 * (1.0 - np.cos(np.pi * np.clip(x / 20.0, 0.0, 1.0)))
    left *= fade
    right *= fade
    # Tyre enveloping: a moving average over the contact length.
    w = max(1, int(round(spec.contact_length_m / dx)))
    if w > 1:
        kernel = np.ones(w) / w
        left = np.convolve(left, kernel, mode="same")
        right = np.convolve(right, kernel, mode="same")
    return Route(spec, float(start), dx, np.ascontiguousarray(left), np.ascontiguousarray(right), tuple(sections), tuple(lane_changes))


@dataclass(frozen=True)
class Drive:
    """The driver's signals of every control period (the arrays the core's
    ``vehicle_run`` reads) and the planned distance and path."""

    dt_s: float
    time_s: FloatArray
    distance_m: FloatArray
    speed_m_s: FloatArray
    long_acc_m_s2: FloatArray
    steer_angle_rad: FloatArray
    steer_rate_rad_s: FloatArray
    path_m: FloatArray
    driver_mode: DriverMode = DriverMode.AUTO

    def to_core(self) -> dict[str, NDArray[np.generic]]:
        n = self.time_s.size
        return {
            "speed_m_s": self.speed_m_s,
            "long_acc_m_s2": self.long_acc_m_s2,
            "steer_angle_rad": self.steer_angle_rad,
            "steer_rate_rad_s": self.steer_rate_rad_s,
            "ride_height_request_m": np.zeros(n),
            "brake_pressed": np.zeros(n, dtype=bool),
            "driver_mode": np.full(n, int(self.driver_mode), dtype=np.int64),
        }


def yaw_rate_gain_per_rad(vehicle: VehicleSpec, speed_m_s: float, total_mass_kg: float) -> float:
    """Steady-state yaw rate per front road-wheel angle of the vehicle's
    single-track model at ``speed_m_s`` (1/s): the two steady equations
    ``sum C_i alpha_i = m u r``, ``sum x_i C_i alpha_i = 0`` solved for the
    lateral velocity and the yaw rate."""
    u = max(speed_m_s, 0.5)
    x = np.array([a.x_m for a in vehicle.axles])
    c = np.array([a.cornering_stiffness_n_per_rad for a in vehicle.axles])
    rho = np.array([a.steer_ratio for a in vehicle.axles])
    a = np.array([[np.sum(c) / u, np.sum(c * x) / u + total_mass_kg * u], [np.sum(c * x) / u, np.sum(c * x * x) / u]])
    b = np.array([np.sum(c * rho), np.sum(c * x * rho)])
    return float(np.linalg.solve(a, b)[1])


def drive(route: Route, vehicle: VehicleSpec, *, dt_s: float = 1e-3, total_mass_kg: float | None = None) -> Drive:
    """The driver's signals along ``route`` for ``vehicle``: the speed
    profile (see the module docs) and the lane changes' steering."""
    if not (math.isfinite(dt_s) and 1e-5 <= dt_s <= 0.01):
        raise ParameterError(f"dt_s = {dt_s} must be within [1e-5, 0.01] s")
    a_max = route.spec.accel_m_s2
    secs = route.sections
    starts = np.array([s.start_m for s in secs])
    speeds = np.array([s.speed_m_s for s in secs])
    end = route.length_m
    # Allowed speed over distance: each section's speed, and before a slower
    # section the braking parabola into it.
    xs = np.arange(0.0, end + 1.0, 0.5)
    idx = np.clip(np.searchsorted(starts, xs, side="right") - 1, 0, len(secs) - 1)
    allowed = speeds[idx]
    for k in range(1, len(secs)):
        ahead = xs < starts[k]
        allowed[ahead] = np.minimum(allowed[ahead], np.sqrt(speeds[k] ** 2 + 2.0 * a_max * (starts[k] - xs[ahead])))
    # March in time with the acceleration limited.
    t_list, x_list, v_list = [0.0], [0.0], [float(speeds[0])]
    x, v = 0.0, float(speeds[0])
    while x < end:
        # The allowed speed of the grid point at or behind x (never the next
        # section's before it begins).
        target = float(allowed[min(int(x / 0.5), allowed.size - 1)])
        dv = np.clip(target - v, -a_max * dt_s, a_max * dt_s)
        v = max(v + dv, 0.5)
        x += v * dt_s
        t_list.append(t_list[-1] + dt_s)
        x_list.append(x)
        v_list.append(v)
    time = np.array(t_list)
    dist = np.array(x_list)
    speed = np.array(v_list)
    long_acc = np.gradient(speed, dt_s) if speed.size > 1 else np.zeros_like(speed)
    # Steering: the path's curvature through the steady-state yaw-rate gain.
    width = vehicle.track_m + 0.45
    path = np.zeros_like(dist)
    for pos, lc in route.lane_changes:
        path += lc.path_m(dist - pos, width)
    dy = np.gradient(path, dist) if dist.size > 1 else np.zeros_like(dist)
    ddy = np.gradient(dy, dist) if dist.size > 1 else np.zeros_like(dist)
    curvature = ddy / (1.0 + dy * dy) ** 1.5
    m = vehicle.statics().total_mass_kg if total_mass_kg is None else total_mass_kg
    gains = {round(float(u), 1): yaw_rate_gain_per_rad(vehicle, float(u), m) for u in np.unique(np.round(speed, 1))}
    gain = np.array([gains[round(float(u), 1)] for u in speed])
    front_wheel = speed * curvature / gain
    steer = front_wheel * vehicle.steering_ratio
    steer_rate = np.gradient(steer, dt_s) if steer.size > 1 else np.zeros_like(steer)
    return Drive(dt_s, time, dist, speed, long_acc, steer, steer_rate, path)

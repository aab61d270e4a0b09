"""The controller in closed loop with the plant: a sprung mass on the unit
(SDOF rig) driven over an ISO 8608 random road, the controller stepping
every control period (1 kHz) in Rust (``hp_ctrl::closed_loop``).

A :class:`Scenario` says what the vehicle and the driver do: a cruising
speed, ride-height requests, and manoeuvres (:class:`LaneChange`,
:class:`Braking`) that make the vehicle signals the controller reads
(speed, lateral and longitudinal acceleration, steering angle and rate,
brake pedal). The controller sees the plant's measured gas pressures,
strut compression, body acceleration and L's gas temperature through a
lagged sensor (see ``docs/controller.md``).

:func:`run` runs one case, :func:`run_many` many in parallel;
:func:`height_change_summary` measures a ride-height change against its
request with a reference independent of the controller: the offset that
the oil held in L gives at rest, from the plant's own gas volume and the
true static load.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from dataclasses import asdict, dataclass, field
from typing import Any, Union

import numpy as np
from numpy.typing import NDArray
from scipy.signal import lfilter

from hpctl import _core
from hpctl._coretypes import ClosedLoopCaseDict, ClosedLoopDict
from hpctl.caveats import Caveat, Code
from hpctl.control import road
from hpctl.control.controller import ControllerConfig, Diag, DriveMode, DriverMode, SequencerState
from hpctl.errors import ParameterError, bad_argument, check_int, check_number
from hpctl.model.unit import SEED_SPRUNG_MASS_KG, Unit
from hpctl.sim import checks
from hpctl.sim.run import sdof_rig

FloatArray = NDArray[np.float64]


@dataclass(frozen=True)
class HeightRequest:
    """From ``start_s`` on, the driver requests ``height_m`` (negative = lower)."""

    start_s: float
    height_m: float


@dataclass(frozen=True)
class LaneChange:
    """A lateral shift of ``width_m`` in ``duration_s``: lateral position
    ``W (u - sin(2 pi u) / (2 pi))``, ``u = (t - start) / duration``, so the
    lateral acceleration is one sine period of amplitude ``2 pi W / T^2``."""

    start_s: float
    duration_s: float = 2.5
    width_m: float = 3.5


@dataclass(frozen=True)
class Braking:
    """A braking burst: deceleration ``decel_m_s2`` for ``duration_s`` with
    raised-cosine ramps of ``ramp_s`` at both ends, brake pedal pressed."""

    start_s: float
    duration_s: float = 2.0
    decel_m_s2: float = 4.0
    ramp_s: float = 0.3


Manoeuvre = Union[LaneChange, Braking]


def _raised_cosine(u: NDArray[np.floating[Any]]) -> FloatArray:
    return np.asarray(0.5 * (1.0 - np.cos(np.pi * np.clip(u, 0.0, 1.0))), dtype=np.float64)


@dataclass(frozen=True)
class Scenario:
    """What the vehicle and the driver do over ``duration_s``."""

    duration_s: float
    speed_m_s: float
    requests: tuple[HeightRequest, ...] = ()
    manoeuvres: tuple[Manoeuvre, ...] = ()
    driver_mode: DriverMode = DriverMode.AUTO
    #: The vehicle's steering ratio and wheelbase (steering from lateral acceleration).
    steering_ratio: float = 18.0
    wheelbase_m: float = 3.5
    #: Lag of the measured lateral acceleration behind the steering (tyre lag), s.
    tyre_lag_s: float = 0.1

    def signals(self, dt_s: float) -> dict[str, FloatArray]:
        """Per control period: ``time_s``, ``distance_m`` and the scenario
        fields of the closed loop (``_core.CTRL_SCENARIO_FIELDS``)."""
        for name in ("duration_s", "speed_m_s", "steering_ratio", "wheelbase_m", "tyre_lag_s"):
            check_number(getattr(self, name), f"scenario.{name}")
        if not (np.isfinite(self.duration_s) and self.duration_s > 0 and np.isfinite(self.speed_m_s) and self.speed_m_s >= 0):
            raise ParameterError(f"scenario duration_s = {self.duration_s} must be positive and speed_m_s = {self.speed_m_s} not negative")
        n = int(round(self.duration_s / dt_s))
        t: FloatArray = np.arange(n, dtype=np.float64) * dt_s
        long_acc = np.zeros(n)
        brake = np.zeros(n, dtype=bool)
        for m in self.manoeuvres:
            if isinstance(m, Braking):
                ramp = min(m.ramp_s, 0.5 * m.duration_s)
                up = _raised_cosine((t - m.start_s) / ramp) if ramp > 0 else (t >= m.start_s).astype(float)
                down = 1.0 - (_raised_cosine((t - m.start_s - m.duration_s + ramp) / ramp) if ramp > 0 else (t >= m.start_s + m.duration_s).astype(float))
                long_acc -= m.decel_m_s2 * up * down
                brake |= (t >= m.start_s) & (t < m.start_s + m.duration_s)
        speed = np.maximum(self.speed_m_s + np.concatenate([[0.0], np.cumsum(long_acc[:-1]) * dt_s]), 0.0)
        long_acc = np.where(speed > 0, long_acc, 0.0)
        distance = np.concatenate([[0.0], np.cumsum(speed[:-1]) * dt_s])
        lat_kinematic = np.zeros(n)
        for m in self.manoeuvres:
            if isinstance(m, LaneChange):
                u = (t - m.start_s) / m.duration_s
                inside = (u >= 0) & (u <= 1)
                lat_kinematic += np.where(inside, 2 * np.pi * m.width_m / m.duration_s**2 * np.sin(2 * np.pi * u), 0.0)
        # Steering-wheel angle of the kinematic bicycle model (no understeer).
        with np.errstate(divide="ignore", invalid="ignore"):
            steer = np.where(speed > 1.0, lat_kinematic * self.steering_ratio * self.wheelbase_m / np.maximum(speed, 1.0) ** 2, 0.0)
        steer_rate = np.gradient(steer, dt_s) if n > 1 else np.zeros(n)
        # The measured lateral acceleration follows with the tyre lag.
        k = dt_s / (self.tyre_lag_s + dt_s)
        lat = np.asarray(lfilter([k], [1.0, k - 1.0], lat_kinematic), dtype=float)
        request = np.zeros(n)
        for r in sorted(self.requests, key=lambda r: r.start_s):
            request[t >= r.start_s] = r.height_m
        return {
            "time_s": t,
            "distance_m": distance,
            "speed_m_s": speed,
            "lat_acc_m_s2": lat,
            "long_acc_m_s2": long_acc,
            "steer_angle_rad": steer,
            "steer_rate_rad_s": steer_rate,
            "ride_height_request_m": request,
            "brake_pressed": brake.astype(float),
        }


@dataclass(frozen=True)
class Case:
    """One closed-loop run. Without a ``config`` the controller is
    configured for the case's unit (:func:`config_for_unit`)."""

    scenario: Scenario
    road_class: str = "C"
    seed: int = 0
    unit: Unit = field(default_factory=Unit.seed)
    sprung_mass_kg: float = SEED_SPRUNG_MASS_KG
    config: ControllerConfig | None = None
    dt_s: float = 1e-3
    ambient_k: float | None = None
    record_every: int = 1
    t_gas_sensor_tau_s: float = 1.0

    def controller_config(self) -> ControllerConfig:
        """The controller configuration the run uses: ``config`` if given,
        else the one derived from the unit."""
        return self.config if self.config is not None else config_for_unit(self.unit)

    def core_args(self) -> ClosedLoopCaseDict:
        """The arguments of ``_core.closed_loop``."""
        if not isinstance(self.scenario, Scenario):
            raise bad_argument("scenario", self.scenario, "an hpctl.control.closed_loop.Scenario")
        if not isinstance(self.unit, Unit):
            raise bad_argument("unit", self.unit, "an hpctl.Unit")
        check_number(self.dt_s, "dt_s")
        check_number(self.sprung_mass_kg, "sprung_mass_kg")
        check_number(self.t_gas_sensor_tau_s, "t_gas_sensor_tau_s")
        if self.ambient_k is not None:
            check_number(self.ambient_k, "ambient_k")
        check_int(self.seed, "seed", 0, 2**63 - 1)
        check_int(self.record_every, "record_every", 1, 2**31)
        if self.config is not None and not isinstance(self.config, Mapping):
            raise bad_argument("config", self.config, "a controller configuration mapping (or None: derived from the unit)")
        if not (np.isfinite(self.dt_s) and 1e-5 <= self.dt_s <= 0.01):
            raise ParameterError(f"dt_s = {self.dt_s} must be within [1e-5, 0.01] s")
        sig = self.scenario.signals(self.dt_s)
        length = float(sig["distance_m"][-1]) + 1.0
        profile = road.profile(self.road_class, length, seed=self.seed, dx_m=0.01)
        base = road.base_motion(profile, sig["distance_m"], sig["time_s"])
        n = sig["time_s"].size
        scenario: dict[str, NDArray[Any]] = {name: np.ascontiguousarray(sig[name], dtype=np.float64) for name in
                    ("speed_m_s", "lat_acc_m_s2", "long_acc_m_s2", "steer_angle_rad", "steer_rate_rad_s", "ride_height_request_m")}
        scenario["brake_pressed"] = sig["brake_pressed"] > 0.5
        scenario["driver_mode"] = np.full(n, int(self.scenario.driver_mode), dtype=np.int64)
        return {
            "unit": self.unit.to_dict(),
            "rig": sdof_rig(base, self.sprung_mass_kg).to_core(),
            "scenario": scenario,
            "dt_s": float(self.dt_s),
            "ambient_k": self.unit.static_temperature_k if self.ambient_k is None else float(self.ambient_k),
            "config": self.controller_config(),
            "record_every": int(self.record_every),
            "t_gas_sensor_tau_s": float(self.t_gas_sensor_tau_s),
        }


@dataclass(frozen=True)
class ClosedLoop:
    """A closed-loop run: plant channels (see ``hpctl.sim.CHANNELS``), the
    controller's inputs and outputs, every recorded period."""

    case: Case
    plant: dict[str, FloatArray]
    inputs: dict[str, NDArray[Any]]
    outputs: dict[str, NDArray[Any]]

    @property
    def time_s(self) -> FloatArray:
        return self.plant["time_s"]

    @property
    def static_load_pressure_pa(self) -> float:
        """The gas pressure that carries the sprung mass at rest (absolute), Pa."""
        return self.case.unit.mass_pressure_pa(self.case.sprung_mass_kg)

    def held_offset_m(self) -> FloatArray:
        """The ride-height offset the oil in L gives at rest, from the
        plant alone: L's gas volume minus its volume at the static load
        pressure and L's gas temperature, as strut travel (negative =
        lowered). Meaningful while valve 6 is closed."""
        u = self.case.unit
        m_large_kg = _core.gas_masses_kg(u.to_dict())[1]
        p_load = self.static_load_pressure_pa
        rest_m3 = np.array([m_large_kg / _core.gas_density_kg_m3(u.gas, p_load, float(t)) for t in self.plant["t_gas2_k"]])
        return np.asarray((self.plant["v_gas2_m3"] - rest_m3) / u.piston_area_m2, dtype=np.float64)


def config_for_unit(unit: Unit) -> ControllerConfig:
    """The controller configuration for ``unit``: the unit block derived
    from the unit (in the controller crate, ``UnitConfig::from_unit``), the
    default calibration for the rest. The seed unit gives the seed config."""
    return _core.ctrl_config_for_unit(unit.to_dict())


def _result(case: Case, d: ClosedLoopDict) -> ClosedLoop:
    return ClosedLoop(case, dict(d["plant"]), dict(d["inputs"]), dict(d["outputs"]))


def run(case: Case, progress: Callable[[int, int], None] | None = None) -> ClosedLoop:
    """Runs one closed loop."""
    a = case.core_args()
    out = _core.closed_loop(
        a["unit"], a["rig"], a["scenario"], a["dt_s"], a["ambient_k"], a["config"],
        record_every=a["record_every"], t_gas_sensor_tau_s=a["t_gas_sensor_tau_s"], progress=progress,
    )
    return _result(case, out)


def run_many(cases: Sequence[Case], threads: int | None = None) -> list[ClosedLoop | Exception]:
    """Runs closed loops in parallel in Rust (all cores unless ``threads``);
    a case that fails yields its exception in place of a result."""
    results = _core.closed_loop_many([c.core_args() for c in cases], threads)
    return [r if isinstance(r, Exception) else _result(c, r) for c, r in zip(cases, results)]


def _rising_edges(x: NDArray[np.bool_]) -> NDArray[np.bool_]:
    return np.concatenate([[bool(x[0])], x[1:] & ~x[:-1]]) if x.size else x


@dataclass(frozen=True, kw_only=True)
class HeightChange:
    """How one ride-height request went (:func:`height_change_summary`),
    SI units; ``to_dict`` is its form in ``summary.json``."""

    start_s: float
    end_s: float
    request_m: float
    target_m: float
    held_offset_m: float
    error_m: float
    estimate_m: float
    time_to_reach_s: float | None
    released_to_soft_s: float | None
    valve6_openings: int
    blocked_s: float
    tolerance_m: float
    reached: bool
    road_mean_change_m: float
    p_gas_pa: float
    p_gas2_pa: float
    p_gas2_target_pa: float
    p_load_estimate_pa: float
    p_load_true_pa: float
    sequencer_end: str
    strut_disp_min_m: float
    strut_disp_max_m: float

    def to_dict(self) -> dict[str, Any]:
        """The fields in declaration order (the keys of ``summary.json``)."""
        return asdict(self)


@dataclass(frozen=True, kw_only=True)
class ModeSwitches:
    """Mode switches over a run (:func:`mode_summary`), times in s."""

    first_ride_s: float | None
    handling_entered_s: list[float]
    ride_returned_s: list[float]
    triggers: list[str]
    shortest_handling_s: float | None
    safe_state_after_first_ride: bool

    def to_dict(self) -> dict[str, Any]:
        """The fields in declaration order (the keys of ``summary.json``)."""
        return asdict(self)


@dataclass(frozen=True, kw_only=True)
class DemoSummary:
    """What :func:`demo` reports: the road, the two height changes and the
    mode switches."""

    road_class: str
    speed_m_s: float
    seed: int
    lowering: HeightChange
    raising: HeightChange
    modes: ModeSwitches

    def to_dict(self) -> dict[str, Any]:
        """The summary as ``hpctl closed-loop`` writes it to ``summary.json``
        (before the command adds its plots, configuration and warnings)."""
        return asdict(self)


def height_change_summary(r: ClosedLoop, start_s: float, end_s: float, *, window_s: float = 5.0) -> HeightChange:
    """How a ride-height request made at ``start_s`` went, up to ``end_s``.

    - ``held_offset_m``: the plant's held offset (see
      :meth:`ClosedLoop.held_offset_m`), the achieved height at rest, at
      ``end_s``, or, when the sequencer released valve 6 to the soft spring
      (a return to zero in Ride), just before it did; ``error_m`` its
      difference to the (clamped) request.
    - ``estimate_m``: the controller's ride-height estimate then.
    - ``time_to_reach_s``: from the request to the first ``Holding`` (or
      ``Idle``) after sequencing (None if it never got there);
      ``released_to_soft_s``: to the release, if any.
    - ``valve6_openings``: openings of valve 6 while sequencing.
    - ``road_mean_change_m``: change of the mean strut compression, as body
      height (negative = lower), over ``window_s`` before the request and
      before ``end_s``: the lowering as seen on the road (noisy, and it
      includes the spring-mode change of the damper's packing).
    - pressures at ``end_s``, strut travel extremes over the run.
    """
    t = r.time_s
    o = r.outputs
    before = (t >= start_s - window_s) & (t < start_s)
    during = (t >= start_s) & (t < end_s)
    last = (t >= end_s - window_s) & (t < end_s)
    if not (before.any() and during.any() and last.any()):
        raise ParameterError(f"the run ({t[-1]:.1f} s) does not cover {start_s - window_s:.1f}..{end_s:.1f} s")
    idx = np.flatnonzero(during)
    k_end = int(idx[-1])
    request = float(r.inputs["ride_height_request_m"][k_end])
    cfg = r.case.controller_config()["ride_height"]
    target = float(np.clip(request, -cfg["request_max_m"], cfg["request_max_m"])) if abs(request) > cfg["request_deadband_m"] else 0.0
    seq = o["sequencer"][during]
    moving = (seq == SequencerState.LOWERING) | (seq == SequencerState.RAISING)
    reached_s: float | None = None
    released_s: float | None = None
    k_eval = k_end
    if moving.any():
        first_move = int(np.flatnonzero(moving)[0])
        settled = np.flatnonzero((seq[first_move:] == SequencerState.HOLDING) | (seq[first_move:] == SequencerState.IDLE))
        if settled.size:
            reached_s = float(t[idx[first_move + int(settled[0])]] - start_s)
        idle = np.flatnonzero(seq[first_move:] == SequencerState.IDLE)
        if idle.size:
            # Released to the soft spring: the held offset is the one just
            # before valve 6 opened for good.
            k_idle = int(idx[first_move + int(idle[0])])
            released_s = float(t[k_idle] - start_s)
            k_eval = k_idle - 1
    v6 = o["valve6_open"][during].astype(bool)
    openings = int(np.count_nonzero(_rising_edges(v6) & moving))
    dt = float(np.median(np.diff(t))) if t.size > 1 else 0.0
    blocked_s = float(np.count_nonzero(seq == SequencerState.BLOCKED) * dt)
    held = float(r.held_offset_m()[k_eval])
    disp = r.plant["disp_m"]
    return HeightChange(
        start_s=start_s,
        end_s=end_s,
        request_m=request,
        target_m=target,
        held_offset_m=held,
        error_m=held - target,
        estimate_m=float(o["ride_height_m"][k_eval]),
        time_to_reach_s=reached_s,
        released_to_soft_s=released_s,
        valve6_openings=openings,
        blocked_s=blocked_s,
        tolerance_m=float(cfg["tolerance_m"]),
        reached=reached_s is not None and abs(held - target) <= float(cfg["tolerance_m"]),
        road_mean_change_m=-float(disp[last].mean() - disp[before].mean()),
        p_gas_pa=float(r.plant["p_gas_pa"][k_eval]),
        p_gas2_pa=float(r.plant["p_gas2_pa"][k_eval]),
        p_gas2_target_pa=float(o["p_gas2_target_pa"][k_eval]),
        p_load_estimate_pa=float(o["p_load_pa"][k_eval]),
        p_load_true_pa=r.static_load_pressure_pa,
        sequencer_end=SequencerState(int(o["sequencer"][k_end])).name.lower(),
        strut_disp_min_m=float(disp.min()),
        strut_disp_max_m=float(disp.max()),
    )


def mode_summary(r: ClosedLoop) -> ModeSwitches:
    """Mode switches over the run after the power-on Handling (the safe
    state and its hold): when Handling was entered and Ride returned, the
    triggers that fired, and the shortest stay in Handling."""
    t = r.time_s
    mode = r.outputs["drive_mode"].astype(int)
    diag = r.outputs["diag"].astype(np.int64)
    ride = np.flatnonzero(mode == DriveMode.RIDE)
    first_ride = int(ride[0]) if ride.size else mode.size
    change = np.flatnonzero(np.diff(mode) != 0) + 1
    change = change[change > first_ride]
    entries = [float(t[k]) for k in change if mode[k] == DriveMode.HANDLING]
    exits = [float(t[k]) for k in change if mode[k] == DriveMode.RIDE]
    after = diag[first_ride:]
    triggers = sorted(flag.name for flag in Diag if flag.name and flag.name.startswith("TRIGGER_") and np.any(after & flag))
    spans = []
    for e in entries:
        later = [x for x in exits if x > e]
        if later:
            spans.append(later[0] - e)
    return ModeSwitches(
        first_ride_s=float(t[first_ride]) if ride.size else None,
        handling_entered_s=entries,
        ride_returned_s=exits,
        triggers=triggers,
        shortest_handling_s=min(spans) if spans else None,
        safe_state_after_first_ride=bool(np.any(after & Diag.SAFE_STATE)),
    )


def height_change_caveats(s: HeightChange, what: str) -> list[Caveat]:
    """What a height change summary (:func:`height_change_summary`) cannot
    claim: a request not reached (never settled, or held further from the
    target than the controller's tolerance) and a blocked sequencer."""
    out = []
    duration = float(s.end_s) - float(s.start_s)
    # A short pause on a bump is the sequencer working; a pause that lost
    # the request or took most of the time is worth saying.
    if s.blocked_s > 0 and (not s.reached or s.blocked_s >= 0.5 * duration):
        share = s.blocked_s / duration
        out.append(Caveat(
            Code.SEQUENCER_BLOCKED,
            f"{what}: the ride-height sequencer was blocked (paused by driving dynamics, the load estimate settling or the "
            f"safe state) for {s.blocked_s:.1f} s of {duration:.1f} s ({100 * share:.0f} %)",
            {"change": what, "blocked_s": s.blocked_s, "duration_s": duration, "sequencer_end": s.sequencer_end},
        ))
    if not s.reached:
        why = "the sequencer never settled" if s.time_to_reach_s is None else f"held {1e3 * s.held_offset_m:.1f} mm"
        out.append(Caveat(
            Code.TARGET_MISSED,
            f"{what}: the request of {1e3 * s.target_m:.1f} mm was not reached ({why}; error {1e3 * s.error_m:+.1f} mm, "
            f"tolerance {1e3 * s.tolerance_m:.1f} mm)",
            {"change": what, "target_m": s.target_m, "held_offset_m": s.held_offset_m, "error_m": s.error_m,
             "tolerance_m": s.tolerance_m, "time_to_reach_s": s.time_to_reach_s},
        ))
    return out


def run_caveats(r: ClosedLoop, name: str) -> list[Caveat]:
    """What a closed-loop run cannot stand behind: the plant's checks (end
    stops, the gas model's range, the rated speed), the controller's safe
    state after its power-on recovery (with the flags that were set), and a
    controller configured for another unit than the plant's."""
    out = checks.channels(r.case.unit, r.plant, name)
    mode = r.outputs["drive_mode"].astype(int)
    diag = r.outputs["diag"].astype(np.int64)
    ride = np.flatnonzero(mode == DriveMode.RIDE)
    first_ride = int(ride[0]) if ride.size else 0
    safe = (diag[first_ride:] & int(Diag.SAFE_STATE)) != 0
    if safe.any() or not ride.size:
        idx = first_ride + np.flatnonzero(safe) if safe.any() else np.arange(diag.size)
        flags = int(np.bitwise_or.reduce(diag[idx])) if idx.size else 0
        names = sorted(f.name for f in Diag if f.name and flags & f and f != Diag.SAFE_STATE and not f.name.startswith("TRIGGER_"))
        t = r.time_s
        share = idx.size / max(diag.size - first_ride, 1)
        when = "never left it after power-on" if not ride.size else f"entered it at t = {float(t[idx[0]]):.2f} s"
        out.append(Caveat(
            Code.SAFE_STATE,
            f"{name}: the controller was in its safe state ({when}; {100 * share:.0f} % of the run after power-on) with "
            f"{', '.join(names) or 'no other flag'}",
            {"run": name, "first_time_s": float(t[idx[0]]) if idx.size else None, "share": share, "flags": names},
        ))
    if r.case.config is not None:
        derived = config_for_unit(r.case.unit)["unit"]
        given = r.case.config["unit"]
        differ = sorted(k for k, v in derived.items() if given.get(k) != v)
        if differ:
            out.append(Caveat(
                Code.CONFIG_NOT_DERIVED,
                f"{name}: the controller's unit configuration differs from the simulated unit in {', '.join(differ)}",
                {"run": name, "fields": differ},
            ))
    return out


#: The demonstration's schedule: lower at 8 s (after the power-on recovery
#: and the load estimate's settling), back to zero at 40 s, end at 64 s.
DEMO_LOWER_AT_S, DEMO_RAISE_AT_S, DEMO_END_S = 8.0, 40.0, 64.0
#: The manoeuvre run: a lane change at 8 s, a braking burst at 18 s.
DEMO_MANOEUVRE_END_S = 28.0


def demo_cases(*, road_class: str, speed_m_s: float, lower_m: float, seed: int, unit: Unit | None = None,
               config: ControllerConfig | None = None) -> tuple[Case, Case]:
    """The two demonstration runs: (a) lowering by ``lower_m`` and back on
    the random road, (b) a lane change and a braking burst. The controller
    runs ``config`` (None: derived from the unit)."""
    u = Unit.seed() if unit is None else unit
    height = Scenario(DEMO_END_S, speed_m_s, requests=(HeightRequest(DEMO_LOWER_AT_S, -lower_m), HeightRequest(DEMO_RAISE_AT_S, 0.0)))
    modes = Scenario(DEMO_MANOEUVRE_END_S, speed_m_s, manoeuvres=(LaneChange(8.0), Braking(18.0)))
    return Case(height, road_class, seed, u, config=config), Case(modes, road_class, seed + 1, u, config=config)


def demo(*, road_class: str, speed_m_s: float, lower_m: float, seed: int, unit: Unit | None = None, config: ControllerConfig | None = None,
         threads: int | None = None) -> tuple[ClosedLoop, ClosedLoop, DemoSummary]:
    """Runs the demonstration; returns the height-change run, the mode run
    and the summary (:mod:`hpctl.report.closed_loop` plots the runs)."""
    if not (np.isfinite(lower_m) and 0 < lower_m <= 0.1):
        raise ParameterError(f"lower_m = {lower_m} must be within (0, 0.1] m")
    if not (np.isfinite(speed_m_s) and 0 < speed_m_s <= 40):
        raise ParameterError(f"speed_m_s = {speed_m_s} must be within (0, 40] m/s")
    cases = demo_cases(road_class=road_class, speed_m_s=speed_m_s, lower_m=lower_m, seed=seed, unit=unit, config=config)
    results = run_many(cases, threads)
    for r in results:
        if isinstance(r, Exception):
            raise r
    height, modes = (r for r in results if isinstance(r, ClosedLoop))
    summary = DemoSummary(
        road_class=road_class.upper(),
        speed_m_s=speed_m_s,
        seed=seed,
        lowering=height_change_summary(height, DEMO_LOWER_AT_S, DEMO_RAISE_AT_S),
        raising=height_change_summary(height, DEMO_RAISE_AT_S, DEMO_END_S),
        modes=mode_summary(modes),
    )
    return height, modes, summary


def demo_caveats(height: ClosedLoop, modes: ClosedLoop, summary: DemoSummary) -> list[Caveat]:
    """The warnings of :func:`demo`: each run's (:func:`run_caveats`) and
    each height change's (:func:`height_change_caveats`)."""
    return (run_caveats(height, "ride-height run") + height_change_caveats(summary.lowering, "lowering")
            + height_change_caveats(summary.raising, "raising") + run_caveats(modes, "mode run"))

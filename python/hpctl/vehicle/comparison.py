"""The comparison: one vehicle, one route, several suspension settings.

The four passive settings (soft or hard spring x low or high damping: the
valves held) and the semi-active suspension (one ``hp-ctrl`` controller per
wheel, the firmware's code and calibration) drive the same route; each run
is reduced to its section metrics (:mod:`hpctl.vehicle.metrics`), the
warnings a result must carry (end stops, wheel lift-off, safe states,
lateral acceleration beyond the handling model's range, failed cases) and
a decimated trace for the figures. Runs go in parallel on threads (the
core releases the GIL), each reduced as soon as it ends so memory holds
only as many full-rate runs as there are threads.

The two numbers of the ride-versus-handling comparison:

- comfort: ``a_v`` at the seat on the rough track (ISO 2631-1 vibration
  total value, lower is more comfortable);
- handling: the peak roll angle in the lane change (lower is better), with
  the dynamic tyre-load coefficient there beside it.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping, Sequence
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray

from hpctl import _core
from hpctl._coretypes import SuspensionDict
from hpctl.caveats import Caveat, Code
from hpctl.control.config import merged
from hpctl.control.controller import DriveMode
from hpctl.data.records import RecordStatic, RecordTest, RecordUnit, RigRecord
from hpctl.errors import HpctlError, ParameterError
from hpctl.vehicle.metrics import LINEAR_TYRE_LIMIT_M_S2, SectionMetrics, section_metrics
from hpctl.vehicle.model import VehicleSpec
from hpctl.vehicle.route import Drive, Route, RouteSpec, build, drive

FloatArray = NDArray[np.float64]

#: The sections the headline numbers come from.
COMFORT_SECTION, HANDLING_SECTION = "rough", "lane_change"


@dataclass(frozen=True)
class Setting:
    """A suspension setting: passive (valves held) or semi-active."""

    name: str
    spring_hard: bool = False
    damper_on: bool = False
    semi_active: bool = False
    #: Controller configuration (semi-active): None for the vehicle's
    #: default, else the values given merged over it (a whole
    #: configuration, or a part: :func:`hpctl.control.config.merged`).
    config: Mapping[str, Any] | None = None

    def to_core(self, vehicle: VehicleSpec) -> SuspensionDict:
        if self.semi_active:
            default = vehicle.controller_config()
            return {"kind": "semi_active", "config": default if self.config is None else merged(default, self.config)}
        return {"kind": "passive", "spring_hard": self.spring_hard, "damper_on": self.damper_on}


PASSIVE: tuple[Setting, ...] = (
    Setting("soft, low damping", spring_hard=False, damper_on=False),
    Setting("soft, high damping", spring_hard=False, damper_on=True),
    Setting("hard, low damping", spring_hard=True, damper_on=False),
    Setting("hard, high damping", spring_hard=True, damper_on=True),
)
SEMI_ACTIVE = Setting("semi-active", semi_active=True)
SETTINGS: tuple[Setting, ...] = PASSIVE + (SEMI_ACTIVE,)


@dataclass(frozen=True)
class Case:
    vehicle: VehicleSpec
    route: RouteSpec
    setting: Setting
    dt_s: float = 1e-3
    ambient_k: float | None = None

    @property
    def label(self) -> str:
        return f"{self.vehicle.name} {self.setting.name}"


@dataclass(frozen=True)
class Trace:
    """A run every ``step``-th period, for figures and records."""

    time_s: FloatArray
    distance_m: FloatArray
    signals: dict[str, FloatArray]
    corners: dict[str, FloatArray]
    controller: dict[str, FloatArray]


@dataclass
class CaseResult:
    case: Case
    sections: list[SectionMetrics] = field(default_factory=list)
    warnings: list[Caveat] = field(default_factory=list)
    trace: Trace | None = None
    error: str | None = None
    route: Route | None = None

    def section(self, kind: str) -> SectionMetrics | None:
        return next((s for s in self.sections if s.kind == kind), None)

    @property
    def comfort_m_s2(self) -> float:
        s = self.section(COMFORT_SECTION)
        return s.ride.a_v_m_s2 if s else math.nan

    @property
    def roll_peak_rad(self) -> float:
        s = self.section(HANDLING_SECTION)
        return s.handling.roll_peak_rad if s else math.nan


def _warnings(case: Case, sections: Sequence[SectionMetrics]) -> list[Caveat]:
    out = []
    who = case.label
    where = {"vehicle": case.vehicle.name, "setting": case.setting.name}
    for s in sections:
        w = s.wheels
        if w.end_stop_hits:
            out.append(Caveat(Code.END_STOP, f"{who}: {w.end_stop_hits} end-stop hit(s) on the {s.name} ({', '.join(w.end_stop_wheels)})",
                              {**where, "section": s.name, "hits": w.end_stop_hits, "wheels": list(w.end_stop_wheels)}))
        if w.lifted_wheels:
            out.append(Caveat(Code.WHEEL_LIFT_OFF, f"{who}: wheel lift-off for {w.lift_off_s:.3f} s on the {s.name} ({', '.join(w.lifted_wheels)})",
                              {**where, "section": s.name, "lift_off_s": w.lift_off_s, "wheels": list(w.lifted_wheels)}))
        if s.safe_state_s > 0:
            out.append(Caveat(Code.SAFE_STATE, f"{who}: controller safe state for {s.safe_state_s:.3f} s on the {s.name}",
                              {**where, "section": s.name, "safe_state_s": s.safe_state_s}))
        if s.handling.lat_acc_peak_m_s2 > LINEAR_TYRE_LIMIT_M_S2:
            out.append(Caveat(
                Code.HANDLING_RANGE,
                f"{who}: lateral acceleration {s.handling.lat_acc_peak_m_s2:.2f} m/s^2 on the {s.name} is beyond the "
                f"linear tyre model's range ({LINEAR_TYRE_LIMIT_M_S2} m/s^2): handling results there overstate the grip",
                {**where, "section": s.name, "lat_acc_peak_m_s2": s.handling.lat_acc_peak_m_s2, "limit_m_s2": LINEAR_TYRE_LIMIT_M_S2},
            ))
    return out


def run_case(
    case: Case,
    *,
    route: Route | None = None,
    trace_step: int = 10,
    progress: Callable[[int, int], None] | None = None,
    reference_plant: bool = False,
    driver: Drive | None = None,
) -> CaseResult:
    """Runs one case and reduces it (a failure is kept in the result, not raised).

    `reference_plant` runs the vehicle with RK4 steps and the gas evaluated
    directly instead of the default ROS2 steps on the tabulated gas (what
    the default is checked against; about four times slower). `driver`
    is the route's drive for this vehicle when the caller has it already
    (a serial Python loop over the periods: the tuning computes it once
    per vehicle and route, not once per candidate).
    """
    result = CaseResult(case)
    try:
        r = build(case.route, case.vehicle) if route is None else route
        result.route = r
        statics = case.vehicle.statics(case.ambient_k, spring_hard=case.setting.spring_hard or case.setting.semi_active)
        d: Drive = drive(r, case.vehicle, dt_s=case.dt_s, total_mass_kg=statics.total_mass_kg) if driver is None else driver
        ambient = case.vehicle.axles[0].unit.static_temperature_k if case.ambient_k is None else case.ambient_k
        out = _core.vehicle_run(
            case.vehicle.to_core(),
            r.to_core(),
            d.to_core(),
            case.setting.to_core(case.vehicle),
            case.dt_s,
            ambient,
            progress=progress,
            reference_plant=reference_plant,
        )
        sig, cor, ctl = dict(out["vehicle"]), dict(out["corners"]), dict(out["controller"])
        result.sections = section_metrics(case.vehicle, r.sections, sig, cor, ctl, statics.tyre_static_load_n(case.vehicle))
        result.warnings = _warnings(case, result.sections)
        k = max(1, trace_step)
        result.trace = Trace(
            sig["time_s"][::k].copy(),
            sig["distance_m"][::k].copy(),
            {n: v[::k].copy() for n, v in sig.items()},
            {n: v[::k].copy() for n, v in cor.items()},
            {n: v[::k].copy() for n, v in ctl.items()},
        )
    except HpctlError as e:
        result.error = f"{type(e).__name__}: {e}"
        result.warnings.append(Caveat(Code.CASE_FAILED, f"{case.label}: case failed: {result.error}",
                                      {"vehicle": case.vehicle.name, "setting": case.setting.name, "error": result.error}))
    return result


@dataclass
class Evaluation:
    results: list[CaseResult]

    @property
    def warnings(self) -> list[Caveat]:
        return [w for r in self.results for w in r.warnings]

    @property
    def failed(self) -> list[CaseResult]:
        return [r for r in self.results if r.error is not None]

    def by_vehicle(self) -> dict[str, list[CaseResult]]:
        out: dict[str, list[CaseResult]] = {}
        for r in self.results:
            out.setdefault(r.case.vehicle.name, []).append(r)
        return out


def evaluate(
    vehicles: Sequence[VehicleSpec],
    route: RouteSpec,
    settings: Sequence[Setting] = SETTINGS,
    *,
    threads: int | None = None,
    dt_s: float = 1e-3,
    trace_step: int = 10,
    on_done: Callable[[CaseResult], None] | None = None,
) -> Evaluation:
    """Every setting on every vehicle along ``route`` (threads: all cores
    when None)."""
    if not vehicles or not settings:
        raise ParameterError("evaluate needs at least one vehicle and one setting")
    routes = {v.name: build(route, v) for v in vehicles}
    cases = [Case(v, route, s, dt_s) for v in vehicles for s in settings]
    workers = threads or _cores()

    def one(c: Case) -> CaseResult:
        r = run_case(c, route=routes[c.vehicle.name], trace_step=trace_step)
        if on_done is not None:
            on_done(r)
        return r

    with ThreadPoolExecutor(max_workers=workers) as pool:
        results = list(pool.map(one, cases))
    return Evaluation(results)


def _cores() -> int:
    import os

    return max(1, len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else (os.cpu_count() or 1))


def mode_share(result: CaseResult, kind: str) -> float:
    """Share of a section's time the semi-active controllers spent in
    Handling (all wheels), from the trace."""
    tr = result.trace
    if tr is None or "drive_mode" not in tr.controller or result.route is None:
        return math.nan
    s = next((x for x in result.route.sections if x.kind == kind), None)
    if s is None:
        return math.nan
    m = (tr.distance_m >= s.start_m) & (tr.distance_m < s.end_m)
    return float((tr.controller["drive_mode"][m] == int(DriveMode.HANDLING)).all(axis=1).mean()) if m.any() else math.nan


def wheel_records(result: CaseResult) -> list[tuple[str, RigRecord]]:
    """The run as rig records, one per wheel (``sdof`` kind: the strut
    between the body above the wheel and the wheel as its base), at the
    trace's rate, with the tyre force and the road as extra columns."""
    tr = result.trace
    if tr is None:
        return []
    v = result.case.vehicle
    statics = v.statics(result.case.ambient_k)
    sig = tr.signals
    out = []
    for k, name in enumerate(v.corner_names()):
        a = v.axles[k // 2]
        u = a.unit
        body = sig["heave_m"] - statics.x_m[k] * sig["pitch_rad"] + statics.y_m[k] * sig["roll_rad"]
        hard = 1.0 - tr.corners["valve6_open"][:, k]
        on = 1.0 - tr.corners["valve5_open"][:, k]
        data = {
            "time_s": tr.time_s,
            "disp_m": tr.corners["disp_m"][:, k],
            "body_disp_m": body,
            "base_disp_m": tr.corners["wheel_disp_m"][:, k],
            "p_gas_pa": tr.corners["p_gas_pa"][:, k],
            "p_gas2_pa": tr.corners["p_gas2_pa"][:, k],
            "t_gas_k": tr.corners["t_gas_k"][:, k],
            "spring_hard": hard,
            "damper_on": on,
            "tyre_force_n": tr.corners["tyre_force_n"][:, k],
            "road_m": tr.corners["road_m"][:, k],
        }
        rec = RigRecord(
            kind="sdof",
            unit=RecordUnit(u.piston_area_m2, u.small_acc_volume_m3, u.large_acc_volume_m3),
            static=RecordStatic(u.static_pressure_pa, u.static_temperature_k, u.static_temperature_k if result.case.ambient_k is None else result.case.ambient_k),
            test=RecordTest("hard" if hard.mean() >= 0.5 else "soft", "on" if on.mean() >= 0.5 else "off", "drive"),
            data={c: np.ascontiguousarray(x, dtype=np.float64) for c, x in data.items()},
            description=f"{v.name} {result.case.setting.name}, wheel {name}, route {result.case.route.name} (seed {result.case.route.seed})",
            sprung_mass_kg=float(statics.static_load_n[k] / 9.80665),
        )
        out.append((f"{v.name}_{_slug(result.case.setting.name)}_{name}", rec))
    return out


def _slug(text: str) -> str:
    return "".join(c if c.isalnum() else "_" for c in text).strip("_").lower().replace("__", "_")

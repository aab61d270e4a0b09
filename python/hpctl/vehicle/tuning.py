"""Tuning the controller's thresholds over a set of routes.

The objective of a configuration, per vehicle and route, is

    J = a_v(rough) / a_v(rough; soft spring, low damping)
      + roll(lane change) / roll(lane change; hard spring, high damping)
      + 0.1 per end-stop hit

averaged over the set: 2 means "as comfortable as the soft passive setting
and as flat as the hard one", the goal. The references are the passive
runs on the same routes, measured once. A case that fails counts as
``FAILED_J``.

The optimiser is SciPy's differential evolution (a well-kept,
derivative-free global method that evaluates a whole population at once,
seeded for repeatability) over :data:`PARAMETERS`, starting from the
vehicle's default configuration (which stays in the population, so the
result is never worse than the default on the route set). Each
generation's population is evaluated in parallel by an *executor*:

- local (default): threads on this machine (the core releases the GIL);
- a Dask cluster (``hpctl tune --cluster tcp://HOST:8786``): candidates
  go to the cluster's workers, which rebuild the routes from their specs
  (a few numbers), so only configurations and results cross the network.
  See ``docs/vehicle.md`` for why Dask and how to start a cluster.
"""

from __future__ import annotations

import copy
import math
import os
from collections.abc import Callable, Iterable, Mapping, Sequence
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass
from functools import lru_cache
from typing import Any, Protocol, cast

import numpy as np
from numpy.typing import NDArray
from scipy.optimize import differential_evolution

from hpctl.control.config import merged
from hpctl.control.controller import ControllerConfig
from hpctl.errors import ParameterError
from hpctl.vehicle.comparison import PASSIVE, Case, Setting, run_case
from hpctl.vehicle.model import preset
from hpctl.vehicle.route import Drive, Route, RouteSpec, build, drive

#: The value of a case that failed.
FAILED_J = 10.0
#: Extra cost of one end-stop hit.
END_STOP_J = 0.1


@dataclass(frozen=True)
class Parameter:
    """A configuration field to tune: ``block.key`` within ``[low, high]``
    (searched on a log scale when ``log``)."""

    block: str
    key: str
    low: float
    high: float
    log: bool = False

    @property
    def name(self) -> str:
        return f"{self.block}.{self.key}"


#: The thresholds tuned by default: when Handling is entered (lateral
#: acceleration, steering rate), how long it is held, and the skyhook
#: damper's estimator, deadband and switching interval. Exit thresholds keep
#: their default ratio to the entry thresholds.
PARAMETERS: tuple[Parameter, ...] = (
    Parameter("mode", "lat_acc_enter_m_s2", 1.0, 4.0),
    Parameter("mode", "steer_rate_enter_rad_s", 0.5, 4.0),
    Parameter("mode", "handling_hold_s", 0.5, 4.0),
    Parameter("estimator", "body_velocity_tau_s", 0.2, 3.0),
    Parameter("damper", "valve5_min_interval_s", 0.005, 0.08),
    Parameter("damper", "skyhook_deadband_m2_s2", 1e-5, 1e-2, log=True),
)
_EXIT_OF = {("mode", "lat_acc_enter_m_s2"): "lat_acc_exit_m_s2", ("mode", "steer_rate_enter_rad_s"): "steer_rate_exit_rad_s"}


def _value(config: ControllerConfig, p: Parameter) -> float:
    """The value of ``p`` in ``config`` (a parameter names its block and key
    at run time, so it reads the configuration as the nested mapping it is)."""
    return float(cast(Mapping[str, Mapping[str, float]], config)[p.block][p.key])


def apply(config: ControllerConfig, params: Sequence[Parameter], x: Sequence[float]) -> ControllerConfig:
    """``config`` with the parameters set to ``x`` (exit thresholds scaled along)."""
    # Keys named at run time (Parameter.block/key): written through a plain
    # nested dict; the copy has every key of ``config``, so the type holds.
    c: dict[str, dict[str, Any]] = copy.deepcopy(cast(dict[str, dict[str, Any]], config))
    for p, v in zip(params, x):
        value = float(10.0**v) if p.log else float(v)
        exit_key = _EXIT_OF.get((p.block, p.key))
        if exit_key is not None:
            ratio = c[p.block][exit_key] / c[p.block][p.key]
            c[p.block][exit_key] = value * ratio
        c[p.block][p.key] = value
    return cast(ControllerConfig, c)


def values(config: ControllerConfig, params: Sequence[Parameter]) -> list[float]:
    """The search coordinates of ``config`` (log10 where the parameter is log-scaled)."""
    return [math.log10(_value(config, p)) if p.log else _value(config, p) for p in params]


@dataclass(frozen=True)
class Problem:
    """What is tuned on what: preset vehicle names, route specs, the
    parameters, and the passive references per (vehicle, route)."""

    vehicles: tuple[str, ...]
    routes: tuple[RouteSpec, ...]
    params: tuple[Parameter, ...] = PARAMETERS
    #: (comfort of soft/low, roll of hard/high) per (vehicle, route index).
    references: tuple[tuple[str, int, float, float], ...] = ()
    #: The configuration to start from: None for each vehicle's default,
    #: else values merged over it (``hpctl tune --config``).
    config: Mapping[str, Any] | None = None

    def start(self, vehicle: str) -> ControllerConfig:
        """The starting configuration of ``vehicle``."""
        default = preset(vehicle).controller_config()
        return default if self.config is None else merged(default, self.config)

    def reference(self, vehicle: str, k: int) -> tuple[float, float]:
        for v, i, a, b in self.references:
            if v == vehicle and i == k:
                return a, b
        raise ParameterError(f"no passive reference for {vehicle} on route {k}")


@lru_cache(maxsize=16)
def _route(vehicle: str, spec: RouteSpec) -> Route:
    """Routes are rebuilt where they are driven (a worker keeps its own)."""
    return build(spec, preset(vehicle))


@lru_cache(maxsize=16)
def _drive(vehicle: str, spec: RouteSpec) -> Drive:
    """The driver's signals along a route: the same for every candidate,
    and a serial Python loop (holding the GIL) over the periods that cost
    more than the vehicle run itself, so computed once per worker."""
    v = preset(vehicle)
    return drive(_route(vehicle, spec), v, dt_s=Case(v, spec, PASSIVE[0]).dt_s, total_mass_kg=v.statics().total_mass_kg)


def references(vehicles: Sequence[str], routes: Sequence[RouteSpec], *, threads: int | None = None) -> tuple[tuple[str, int, float, float], ...]:
    """The passive references: a_v of soft/low on the rough track and the
    roll of hard/high in the lane change, per vehicle and route."""
    soft = next(s for s in PASSIVE if not s.spring_hard and not s.damper_on)
    hard = next(s for s in PASSIVE if s.spring_hard and s.damper_on)
    jobs = [(v, k, spec) for v in vehicles for k, spec in enumerate(routes)]

    def one(job: tuple[str, int, RouteSpec]) -> tuple[str, int, float, float]:
        v, k, spec = job
        vs = preset(v)
        a = run_case(Case(vs, spec, soft), route=_route(v, spec), trace_step=1000)
        b = run_case(Case(vs, spec, hard), route=_route(v, spec), trace_step=1000)
        if a.error or b.error:
            raise ParameterError(f"passive reference failed for {v} on route {k}: {a.error or b.error}")
        return v, k, a.comfort_m_s2, b.roll_peak_rad

    with ThreadPoolExecutor(max_workers=threads or os.cpu_count() or 1) as pool:
        return tuple(pool.map(one, jobs))


@dataclass(frozen=True)
class Score:
    """One configuration's objective and what went into it."""

    j: float
    comfort_ratio: float
    roll_ratio: float
    end_stop_hits: int
    failures: int
    pid: int


def score(problem: Problem, x: Sequence[float]) -> Score:
    """The objective of the configuration at ``x`` (runs every vehicle and route)."""
    js, comforts, rolls, hits, failures = [], [], [], 0, 0
    for v in problem.vehicles:
        vs = preset(v)
        config = apply(problem.start(v), problem.params, x)
        for k, spec in enumerate(problem.routes):
            r = run_case(Case(vs, spec, Setting("tuned", semi_active=True, config=config)), route=_route(v, spec), trace_step=1000, driver=_drive(v, spec))
            if r.error is not None or not (math.isfinite(r.comfort_m_s2) and math.isfinite(r.roll_peak_rad)):
                failures += 1
                js.append(FAILED_J)
                continue
            a_ref, roll_ref = problem.reference(v, k)
            c, rl = r.comfort_m_s2 / a_ref, r.roll_peak_rad / roll_ref
            h = sum(s.wheels.end_stop_hits for s in r.sections)
            hits += h
            comforts.append(c)
            rolls.append(rl)
            js.append(c + rl + END_STOP_J * h)
    nan = float("nan")
    return Score(float(np.mean(js)), float(np.mean(comforts)) if comforts else nan, float(np.mean(rolls)) if rolls else nan, hits, failures, os.getpid())


def objective(x: NDArray[np.float64], problem: Problem) -> float:
    """What the optimiser minimises (module level, so it pickles to workers)."""
    return score(problem, list(x)).j


class Executor(Protocol):
    """Maps a function over candidates, in parallel somewhere."""

    def map(self, fn: Callable[[Any], Any], items: Iterable[Any]) -> list[Any]: ...

    def close(self) -> None: ...


class LocalExecutor:
    """Threads on this machine."""

    def __init__(self, threads: int | None = None) -> None:
        self.threads = threads or os.cpu_count() or 1
        self._pool = ThreadPoolExecutor(max_workers=self.threads)

    def map(self, fn: Callable[[Any], Any], items: Iterable[Any]) -> list[Any]:
        return list(self._pool.map(fn, items))

    def close(self) -> None:
        self._pool.shutdown()


class DaskExecutor:
    """The workers of a Dask cluster at ``address`` (``tcp://HOST:PORT``)."""

    def __init__(self, address: str, timeout_s: float = 30.0) -> None:
        from dask.distributed import Client

        self.client = Client(address, timeout=timeout_s)  # type: ignore[no-untyped-call]

    def map(self, fn: Callable[[Any], Any], items: Iterable[Any]) -> list[Any]:
        futures = self.client.map(fn, list(items), pure=False)
        return list(self.client.gather(futures))  # type: ignore[no-untyped-call]

    @property
    def workers(self) -> int:
        return len(self.client.scheduler_info().get("workers", {}))

    def close(self) -> None:
        self.client.close()  # type: ignore[no-untyped-call]


@dataclass(frozen=True)
class TuneResult:
    problem: Problem
    default: Score
    best: Score
    best_x: tuple[float, ...]
    config: ControllerConfig
    generations: int
    evaluations: int
    #: Best objective after each generation.
    history: tuple[float, ...]

    def changes(self) -> list[tuple[str, float, float]]:
        """(parameter, default value, tuned value)."""
        default = self.problem.start(self.problem.vehicles[0])
        return [(p.name, _value(default, p), _value(self.config, p)) for p in self.problem.params]


def tune(
    problem: Problem,
    executor: Executor,
    *,
    popsize: int = 2,
    maxiter: int = 4,
    seed: int = 1,
    on_generation: Callable[[int, float], None] | None = None,
) -> TuneResult:
    """Differential evolution over the problem's parameters from the
    default configuration; every generation evaluated by ``executor``."""
    if not problem.references:
        raise ParameterError("the problem has no passive references (tune.references)")
    params = problem.params
    default_config = problem.start(problem.vehicles[0])
    x0 = values(default_config, params)
    bounds = [((math.log10(p.low), math.log10(p.high)) if p.log else (p.low, p.high)) for p in params]
    for (lo, hi), v, p in zip(bounds, x0, params):
        if not lo <= v <= hi:
            raise ParameterError(f"default {p.name} = {v} is outside its tuning range [{lo}, {hi}]")
    evaluations = 0
    history: list[float] = []

    def mapper(fn: Callable[[Any], float], population: Iterable[Any]) -> list[float]:
        nonlocal evaluations
        xs = [np.asarray(x, dtype=float) for x in population]
        evaluations += len(xs)
        return executor.map(_Objective(problem), xs)

    def callback(intermediate_result: Any) -> None:
        history.append(float(intermediate_result.fun))
        if on_generation is not None:
            on_generation(len(history), float(intermediate_result.fun))

    res = differential_evolution(
        objective,
        bounds,
        args=(problem,),
        x0=np.asarray(x0),
        popsize=popsize,
        maxiter=maxiter,
        rng=np.random.default_rng(seed),
        polish=False,
        updating="deferred",
        workers=mapper,
        callback=callback,
        tol=0.0,
        init="latinhypercube",
    )
    best_x = tuple(float(v) for v in res.x)
    best = score(problem, best_x)
    default = score(problem, x0)
    return TuneResult(problem, default, best, best_x, apply(default_config, params, best_x), len(history), evaluations, tuple(history))


class _Score:
    """:func:`score` bound to a problem, picklable for cluster workers."""

    def __init__(self, problem: Problem) -> None:
        self.problem = problem

    def __call__(self, x: Sequence[float]) -> Score:
        return score(self.problem, list(x))


class _Objective:
    """The objective bound to a problem, picklable for cluster workers."""

    def __init__(self, problem: Problem) -> None:
        self.problem = problem

    def __call__(self, x: NDArray[np.float64]) -> float:
        return objective(x, self.problem)

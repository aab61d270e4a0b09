"""Where a flexible fit's damper characteristic starts: each branch's shape
fitted to the measured force and gas pressure, without running the model.

On a characterisation rig the strut force less the gas pressure's force on
the piston is the damper's pressure drop on the piston plus the seal's
friction: ``F - A (p_S - p_amb) = A dp(A v) + F_friction`` (hp-core's
``Unit``: the pack sits between the strut and accumulator S, whose pressure
the record's ``p_gas_pa`` is). On an SDOF rig no transducer measures ``F``,
but the body shows it: the strut holds the body's weight and accelerates
it, ``F = m (g + a)``, with ``a`` the measured body displacement's second
derivative (:func:`_strut_force`). Every branch (valve 5's state, the
direction of flow) is fitted to that per sample by hp-core's own curve
(``_core.damper_pressure_drop_pa``) with the flexible model's parameters
and priors, beside what else the model makes of that force (a Coulomb
friction, an offset: :func:`static_damper_values`). That costs a second or
two, against seconds per evaluation of the dynamic fit, which then starts
near the records' damper instead of the nominal one.

Why: a damper far from the nominal curve left the dynamic fit crawling
along a valley for its whole budget. The foreign rig's rebound orifice is
all but closed beside its bleed (140-170 x hpctl's nominal coefficient);
at ``FOREIGN_RIG_SEED=1197046202`` the heat run's force stayed at 3.3 x
the noise after 60 evaluations from the nominal curve (1.3 x after 200),
while the family follows that damper within 3 N statically
(``scripts/foreign_damper_family.py``).

The SDOF steps matter most: they drive the damper at up to about 1.2 m/s,
where a campaign's slow characterisation records reach 0.016 m/s with the
damper off (the bundled campaign of ``scripts/bench_diagnose.py``); without
them the static curve is extrapolated there, and the dynamic fit started
from it at 2,403 x the noise in the steps' body displacement (a residual
sum of squares of 2.5e9 against 6.2e6 with them).

What it cannot see: the gas's and the oil's dynamics between the piston
and the transducer (the oil's compliance delays the flow at speed), the
sensors' lag, a viscous friction (the bleeds take it up: it is a force in
proportion to the speed, as theirs is). It is a start; the dynamic fit
goes on from it (:func:`hpctl.identify.fit.fit` says so in its message).
"""

from __future__ import annotations

import collections
import dataclasses
import functools
import threading
from collections.abc import Callable, Sequence
from concurrent.futures import Executor, Future

import numpy as np
from numpy.typing import NDArray
from scipy.signal import savgol_coeffs, savgol_filter

from hpctl.identify import STATIC_STARTS
from hpctl.identify.damper_static import Samples, StaticProblem, StaticResidual, solve_start
from hpctl.identify.dataset import Dataset
from hpctl.identify.signals import filter_bends, within_reach
from hpctl.model.effects import DAMPER_BRANCHES, FRICTION_SMOOTHING_VELOCITY_M_S, Param
from hpctl.model.unit import STANDARD_GRAVITY_M_S2

FloatArray = NDArray[np.float64]

#: The effects whose force the static fit takes beside the curves, shared
#: by the branches: a sensor offset's constant, the friction's Coulomb force.
STATIC_TERMS = {"sensor_offset": "offset", "friction": "coulomb"}
#: Effects a damper characteristic fitted without them takes up in its
#: shape: those shared terms (as a blow-off at no flow) and the oil's
#: compliance (whose lag a model without it cannot make: every branch bent
#: to a residual of 157 x the noise, foreign rig seed 7). A flexible fit
#: that adds one to such a damper restarts it from the static fit where
#: that starts lower (:func:`hpctl.identify.fit.fit`).
ABSORBED_BY_DAMPER = (*STATIC_TERMS, "oil_compliance")
#: Samples slower than this are left out, m/s: the velocity estimate's
#: noise and the gas's lag at a reversal. Down to it the samples show the
#: friction's smoothed step (hp-core's, at the model's smoothing velocity),
#: which pins the Coulomb force apart from a blow-off at no flow.
MIN_SPEED_M_S = 0.001
#: Samples this close to a change of valve 5 (either side) are left out:
#: the logged flag is up to one interval off the switch.
SWITCH_GUARD_SAMPLES = 2
#: Samples at most this fast start the shared constants (the friction and
#: the offset) where the model has them, m/s; at least this many of them.
SLOW_SPEED_M_S = 0.005
MIN_SLOW_SAMPLES = 10
#: A branch with fewer samples than this keeps its nominal start.
MIN_SAMPLES = 50
#: At most this many samples per branch, spread evenly over its speeds'
#: order (a heat run has 10^5: the curve needs the range, not the count).
MAX_SAMPLES = 2000


def _branch_samples(datasets: Sequence[Dataset], branch: str) -> Samples | None:
    on, compression = branch.startswith("on_"), branch.endswith("_compression")
    parts: list[tuple[FloatArray, ...]] = []
    for d in datasets:
        measured = _strut_force(d)
        if measured is None:
            continue
        y, sigma_force, transducer = measured
        v = d.strut_vel_m_s
        near_switch = np.zeros(len(v), bool)
        for i in np.flatnonzero(np.diff(d.damper_on.astype(np.int8))):
            near_switch[max(i + 1 - SWITCH_GUARD_SAMPLES, 0):i + 1 + SWITCH_GUARD_SAMPLES] = True
        area = d.base.piston_area_m2
        y = y - area * (d.targets["p_gas_pa"] - d.base.ambient_pressure_pa)
        keep = ((d.damper_on == on) & ((v > MIN_SPEED_M_S) if compression else (v < -MIN_SPEED_M_S)) & ~near_switch
                & np.isfinite(y) & np.isfinite(v))
        if keep.any():
            sigma = np.hypot(sigma_force, area * d.sigma["p_gas_pa"])
            n = int(keep.sum())
            parts.append((area * v[keep], y[keep], np.broadcast_to(sigma, v.shape)[keep], np.full(n, area), np.full(n, transducer)))
    if not parts or sum(len(p[0]) for p in parts) < MIN_SAMPLES:
        return None
    q, y, s, a, f = (np.concatenate(c) for c in zip(*parts))
    if len(q) > MAX_SAMPLES:
        # Evenly over the speeds' order: each speed range as the records hold it.
        pick = np.argsort(np.abs(q))[np.linspace(0, len(q) - 1, MAX_SAMPLES).astype(int)]
        q, y, s, a, f = q[pick], y[pick], s[pick], a[pick], f[pick]
    return Samples(q, y, s, a, f)


#: The body's acceleration on an SDOF record: a Savitzky-Golay second
#: derivative of its measured displacement, quartic over 15 samples (75 ms
#: at the SDOF rig's 5 ms: the noise's gain is small). Where that window
#: cannot follow the motion (the step's 50 ms rise, where the damper sees
#: its highest speeds) a quadratic over 7 samples, with the two's
#: difference as its error: left out, those samples took the damper's
#: speeds above 0.02-0.4 m/s away, and the fit started from the rest at
#: 1.0e8 (55 iterations to 2.63 x the noise, the bundled campaign) against
#: 6.0e6 (34 to 2.45 x).
#: Neither window follows the body where its acceleration turns within a
#: few milliseconds (the step's corners, the strut's reversal at the rise's
#: end): a sample whose window spans one is the acceleration averaged
#: over it (FOREIGN_RIG_SEED=541218712: 2.1 m/s^2, 6 kN, off 10 ms before
#: the reversal). Kept as they are (stop 64): left out, or given the
#: spread of the short estimates over the window as their error, the
#: bundled campaign's declared fit ended at 1.32-1.48 x the noise instead
#: of 1.24 and its diagnosis at 1.025 instead of 0.989, 63 s instead of
#: 41 s (the strut's speed, estimated by a window too, is averaged the same
#: way, so those samples still lie near the curve, test_damper_start).
SDOF_ACCEL_WINDOW = 15
SDOF_ACCEL_ORDER = 4
SDOF_ACCEL_SHORT_WINDOW = 7
SDOF_ACCEL_SHORT_ORDER = 2
#: An SDOF record's samples slower than this are left out, m/s (:func:`_strut_force`).
SDOF_MIN_SPEED_M_S = 0.01


def _strut_force(d: Dataset) -> tuple[FloatArray, FloatArray | float, float] | None:
    """The strut's force on a record (NaN where it is not known), its noise
    per sample and whether it is the force transducer's (1.0: a sensor
    offset applies) or the body's weight and inertia (0.0). A
    characterisation record measures it; on an SDOF record it is what holds
    the body up and accelerates it, ``m (g + a)``, with ``a`` the measured
    body displacement's second derivative. None where a record has neither
    (or no gas pressure, or too few samples)."""
    if "p_gas_pa" not in d.targets:
        return None
    if d.record.kind == "characterisation" and "force_n" in d.targets:
        return d.targets["force_n"], float(d.sigma["force_n"]), 1.0
    mass = d.record.sprung_mass_kg
    if d.record.kind != "sdof" or "body_disp_m" not in d.targets or mass is None or len(d.times_s) < 2 * SDOF_ACCEL_WINDOW:
        return None
    dt = d.interval_s
    x = d.targets["body_disp_m"]
    sigma_x = float(d.sigma["body_disp_m"])
    # Each displacement's error: its noise and the clock's jitter (all
    # channels are sampled at one jittered instant: a sample ``delta`` late
    # reads ``x + v delta``). At the steps' speeds the jitter's part is
    # the larger: 0.4 m/s x 70 us is 28 um against 2.5 um of noise
    # (FOREIGN_RIG_SEED=541218712), and a sample given the noise alone
    # was 10 x its error off the body's force.
    speed = savgol_filter(x, SDOF_ACCEL_SHORT_WINDOW, SDOF_ACCEL_SHORT_ORDER, deriv=1, delta=dt)
    var_x = sigma_x**2 + (speed * d.input_jitter_s) ** 2
    accel, error = _second_derivative(x, var_x, dt, SDOF_ACCEL_WINDOW, SDOF_ACCEL_ORDER)
    short, short_error = _second_derivative(x, var_x, dt, SDOF_ACCEL_SHORT_WINDOW, SDOF_ACCEL_SHORT_ORDER)
    # Where the long quartic does not follow the displacement within its
    # noise (the step's rise), its second derivative is biased: the short
    # window's there, its noise and the two's difference (the bias it may
    # still have) its error.
    bent = filter_bends(x, savgol_filter(x, SDOF_ACCEL_WINDOW, SDOF_ACCEL_ORDER), sigma_x, SDOF_ACCEL_WINDOW)
    force = mass * (STANDARD_GRAVITY_M_S2 + np.where(bent, short, accel))
    # The filter takes the samples as evenly spaced: around an interval more
    # than 1 % off the record's (a dropped sample) its derivative is not
    # the acceleration, so those samples, with the window's reach, are out.
    uneven = np.zeros(len(x), bool)
    gaps = np.flatnonzero(np.abs(np.diff(d.times_s) - dt) > 0.01 * dt)
    uneven[gaps] = uneven[gaps + 1] = True
    force[within_reach(uneven, SDOF_ACCEL_WINDOW)] = np.nan
    # Slow samples out: near a reversal the strut's speed, estimated from
    # two smoothed displacements, is a few mm/s off, where the friction
    # turns over (foreign friction case, seed 4: the samples below 2 mm/s
    # 650-960 N off the true force, half its Coulomb force).
    force[np.abs(d.strut_vel_m_s) < SDOF_MIN_SPEED_M_S] = np.nan
    sigma = mass * np.where(bent, np.hypot(short_error, short - accel), error)
    return force, sigma, 0.0


def _second_derivative(x: FloatArray, var_x: FloatArray, dt: float, window: int, order: int) -> tuple[FloatArray, FloatArray]:
    """Savitzky-Golay second derivative of ``x`` and its error per sample,
    from the samples' independent errors of variance ``var_x``: the centred
    window's weights, also within half a window of the ends (where the
    filter fits the end window instead: an approximation there)."""
    c2 = savgol_coeffs(window, order, deriv=2, delta=dt) ** 2
    var = np.convolve(np.pad(var_x, window // 2, mode="edge"), c2[::-1], "valid")
    return np.asarray(savgol_filter(x, window, order, deriv=2, delta=dt)), np.sqrt(var)


#: Static fits kept for the fits that ask again (:func:`static_damper_values`).
CACHE_SIZE = 16
_cache: collections.OrderedDict[tuple[object, ...], tuple[tuple[Dataset, ...], Future[dict[str, float]]]] = collections.OrderedDict()
_cache_lock = threading.Lock()
#: Per kept prefetch that its caller may help (:func:`prefetch_static`'s
#: ``take_back``): what takes back the starts no worker has taken up yet
#: and solves them in the thread that waits.
_take_backs: dict[tuple[object, ...], Callable[[], None]] = {}


def _key(datasets: Sequence[Dataset], params: Sequence[Param], effects: Sequence[str]) -> tuple[object, ...]:
    # Each record by what the static fit reads of it, by identity: a fit
    # that places the valve switches or weighs the samples anew replaces
    # its Dataset by a copy sharing these (dataclasses.replace), which asks
    # for the same static fit (a diagnosis's candidates fit the records as
    # the declared model's fit placed their switches).
    reads = tuple((id(d.record), id(d.base), id(d.targets), id(d.sigma), id(d.damper_on), id(d.strut_vel_m_s), id(d.times_s), d.input_jitter_s)
                  for d in datasets)
    return (reads, tuple(p.name for p in params if p.name.startswith("damper_") or p.name in (*_STARTED, *_FRICTION_SHAPE)),
            tuple(e for e in STATIC_TERMS if e in effects))


def static_damper_values(datasets: Sequence[Dataset], params: Sequence[Param], effects: Sequence[str] = ()) -> dict[str, float]:
    """:func:`fit_static_damper`, kept: a diagnosis asks for the same static
    fit many times (the declared model's fit and every screening fit of an
    effect without shared terms, such as oil compliance, ask for the one
    without them; friction's screening, its confirmation and the accepted
    model's fit for the one with the Coulomb force), and it depends only on
    the records, the shape parameters and the shared terms. The records are
    known by the identity of what the fit reads of them (a ``Dataset`` is
    not changed once prepared, only copied with other switch places or
    weights; the entry holds them, so that no other record takes those
    ids). A fit
    asked for while another thread computes it, or started in worker
    processes by :func:`prefetch_static`, is waited for, not computed
    twice (a prefetch's starts that no worker has taken up yet are taken
    back and solved here where it asked for that); one whose workers failed
    is computed here."""
    key = _key(datasets, params, effects)
    with _cache_lock:
        hit = _cache.get(key)
        if hit is not None:
            _cache.move_to_end(key)
            pending, mine = hit[1], False
        else:
            pending, mine = Future(), True
            _keep(key, datasets, pending)
        take_back = None if mine else _take_backs.pop(key, None)
    if take_back is not None:
        take_back()
    if mine:
        try:
            pending.set_result(fit_static_damper(datasets, params, effects))
        except BaseException as e:
            pending.set_exception(e)
            _forget(key, pending)
            raise
    try:
        return dict(pending.result())
    except Exception:
        if mine:
            raise
        # A prefetch whose worker processes failed (their pool broken or
        # shut down): the same fit here.
        _forget(key, pending)
        return static_damper_values(datasets, params, effects)


def _keep(key: tuple[object, ...], datasets: Sequence[Dataset], pending: Future[dict[str, float]]) -> None:
    # Under _cache_lock.
    _cache[key] = (tuple(datasets), pending)
    while len(_cache) > CACHE_SIZE:
        _take_backs.pop(_cache.popitem(last=False)[0], None)


def _forget(key: tuple[object, ...], pending: Future[dict[str, float]]) -> None:
    with _cache_lock:
        if key in _cache and _cache[key][1] is pending:
            del _cache[key]
            _take_backs.pop(key, None)


def prefetch_static(datasets: Sequence[Dataset], params: Sequence[Param], effects: Sequence[str], pool: Executor, take_back: bool = False) -> None:
    """Starts :func:`static_damper_values`'s fit in ``pool`` (a process
    pool: :func:`hpctl.identify.workers.static_pool`), one start a task, unless it is kept or
    under way; the first fit that asks for it waits for it there. With
    ``take_back``, that fit first takes back the starts no worker has
    taken up yet (the last first) and solves them itself: for a caller that
    has nothing else to do meanwhile (``hpctl fit --flexible``: three starts
    on two cores' workers, the third waited for one of the first two while
    this process waited for it, 0.5 s of 3.2 on the bundled campaign; stop
    63). Never where other threads' fits run (a diagnosis): a start in a
    thread holds the GIL for its whole solve.

    Why processes: the static fit is SciPy's trust region on a few thousand
    samples, Python holding the GIL for most of its time. Beside a
    diagnosis's candidates in threads it took 38 s instead of 9 (the bundled
    campaign's friction, scripts/bench_diagnose.py), and with its results
    given (cached before) that diagnosis took 65.7 s instead of 81.0
    (BENCHMARKS.md, stop 53). In a worker process it takes a core's time
    without the GIL, and its three starts run side by side. The worker
    computes what this process would (the same code and inputs, BLAS on one
    thread in both: :mod:`hpctl.identify.workers`)."""
    key = _key(datasets, params, effects)
    with _cache_lock:
        if key in _cache:
            return
        pending: Future[dict[str, float]] = Future()
        _keep(key, datasets, pending)
    try:
        problem = static_problem(datasets, params, effects)
        if problem is None:
            pending.set_result({})
            return
        parts = [pool.submit(solve_start, problem, k) for k in range(len(problem.starts))]
    except BaseException as e:  # a broken or shut-down pool: the caller's fit computes it
        pending.set_exception(e)
        return
    # Each start's end, from its worker or from the thread that took it back.
    ends: list[Future[tuple[FloatArray, float] | None]] = [Future() for _ in parts]
    left = [len(parts)]
    lock = threading.Lock()

    def done(_end: Future[tuple[FloatArray, float] | None]) -> None:
        with lock:
            left[0] -= 1
            if left[0]:
                return
        try:
            pending.set_result(static_values(problem, params, [end.result() for end in ends]))
        except BaseException as e:
            pending.set_exception(e)

    def relay(k: int, part: Future[tuple[FloatArray, float] | None]) -> None:
        if part.cancelled():
            return  # taken back: its end comes from there
        try:
            ends[k].set_result(part.result())
        except BaseException as e:
            ends[k].set_exception(e)

    def take() -> None:
        for k in reversed(range(len(parts))):
            if parts[k].cancel():
                try:
                    end = solve_start(problem, k)
                except BaseException as e:
                    ends[k].set_exception(e)
                    if not isinstance(e, Exception):
                        raise  # Ctrl-C: the fit stops (and finds it failed if asked again)
                else:
                    ends[k].set_result(end)

    for end in ends:
        end.add_done_callback(done)
    for k, p in enumerate(parts):
        p.add_done_callback(functools.partial(relay, k))
    if take_back:
        with _cache_lock:
            _take_backs[key] = take


#: The model's parameters the static fit also starts (its shared terms),
#: and the friction's shape where the model has it (the Stribeck peak's
#: ratio and velocity, the smoothing velocity).
_STARTED = ("friction_coulomb_n", "sensor_force_offset_n")
_FRICTION_SHAPE = ("friction_stribeck_ratio", "friction_stribeck_velocity_m_s", "friction_smoothing_velocity_m_s")


def static_problem(datasets: Sequence[Dataset], params: Sequence[Param], effects: Sequence[str] = ()) -> StaticProblem | None:
    """:func:`fit_static_damper`'s problem and its starts; None where the
    records exercise no branch of ``params`` at speed."""
    if not datasets:
        return None
    found = [(b, mine, s) for b in DAMPER_BRANCHES
             if (mine := [p for p in params if p.name.startswith(f"damper_{b}_")]) and (s := _branch_samples(datasets, b)) is not None]
    if not found:
        return None
    shape = [p for _, mine, _ in found for p in mine]
    # The shared terms, a column each per branch: 1 for the offset, the
    # model's friction per newton of Coulomb force.
    constants = [c for e, c in STATIC_TERMS.items() if e in effects]
    n_shape, n_fixed = len(shape), len(shape) + len(constants)
    # The friction's shape where the model has one to start: the Stribeck
    # peak's ratio and velocity and the smoothing shape the Coulomb column
    # (hp-core's `Friction`). Without them the Coulomb force alone split
    # the peak's excess at the slow samples from the kinetic level at
    # speed, and the curves made up the rest (foreign friction case, seed
    # 345813898: a peak of 1.35 x 1,063 N decaying over 8 mm/s; the bypass
    # branches 5.1 x the noise off the truth, 0.13-0.17 x with the shape;
    # with the peak but the smoothing fixed, 1.6 x, and the peak took up
    # the smoothings' difference: ratios of 1.5-3 at 2 mm/s).
    friction_shape = [p for name in _FRICTION_SHAPE for p in params if p.name == name] if "coulomb" in constants else []
    if len(friction_shape) != len(_FRICTION_SHAPE):
        friction_shape = []
    fitted = [*shape, *friction_shape]
    lo = np.array([p.x_bounds()[0] for p in shape] + [-np.inf if c == "offset" else 0.0 for c in constants]
                  + [p.x_bounds()[0] for p in friction_shape])
    hi = np.array([p.x_bounds()[1] for p in shape] + [np.inf] * len(constants) + [p.x_bounds()[1] for p in friction_shape])
    index = [*range(n_shape), *range(n_fixed, n_fixed + len(friction_shape))]
    prior = tuple((i, p.to_x(p.typical), p.prior_sigma) for i, p in zip(index, fitted) if p.prior_sigma is not None)
    smoothing_m_s = next((p.initial for p in params if p.name == "friction_smoothing_velocity_m_s"), FRICTION_SMOOTHING_VELOCITY_M_S)

    # Which residual rows each parameter moves: a branch's shape its own
    # samples (and its prior row), the constants every sample. Finite
    # differences then perturb the branches' columns together.
    sizes = [len(s.q_m3_s) for _, _, s in found]
    edges = np.concatenate([[0], np.cumsum(sizes)])
    sparsity = np.zeros((int(edges[-1]) + len(prior), len(lo)), bool)
    first = 0
    for k, (_, mine, _) in enumerate(found):
        sparsity[edges[k]:edges[k + 1], first:first + len(mine)] = True
        first += len(mine)
    sparsity[:edges[-1], n_shape:] = True
    for row, (i, _, _) in enumerate(prior):
        sparsity[edges[-1] + row, i] = True
    problem = StaticProblem(datasets[0].base.damper, tuple(b for b, _, _ in found), tuple(s for _, _, s in found), tuple(shape), tuple(constants),
                            tuple(friction_shape), lo, hi, prior, smoothing_m_s, sparsity)

    # The constants start from the slowest samples, where the damper's
    # force is small beside the friction's: started at zero, the curves
    # took the friction up as a blow-off at no flow and kept it (foreign
    # friction case, seed 7: 0 N Coulomb against the truth's 883 N).
    # The friction's shape starts where the model starts it.
    friction_x0 = [p.to_x(p.initial) for p in friction_shape]
    c0 = np.zeros(len(constants))
    if constants:
        slow = [(abs(s.q_m3_s / s.area_m2) <= SLOW_SPEED_M_S) for _, _, s in found]
        a = np.concatenate([cols[m] for cols, m in zip(StaticResidual(problem).columns(np.array([0.0] * n_fixed + friction_x0)), slow)])
        if len(a) >= MIN_SLOW_SAMPLES:
            y = np.concatenate([s.force_n[m] for (_, _, s), m in zip(found, slow)])
            c0 = np.linalg.lstsq(a, y, rcond=None)[0]
            c0 = np.maximum(c0, lo[n_shape:n_fixed])
    starts = []
    for orifice, blowoff in STATIC_STARTS:
        start = {p.name: orifice if p.name.endswith("_orifice_scale") else blowoff if p.name.endswith("_blowoff_scale") else p.initial
                 for p in shape}
        starts.append(np.array([p.to_x(min(max(start[p.name], p.lower), p.upper)) for p in shape] + list(c0) + friction_x0))
    return dataclasses.replace(problem, starts=tuple(starts))


def static_values(problem: StaticProblem, params: Sequence[Param], ends: Sequence[tuple[FloatArray, float] | None]) -> dict[str, float]:
    """The model's starts from the best of ``ends`` (:func:`solve_start`'s,
    one per start; the first of equal costs), empty where none ended."""
    best: tuple[FloatArray, float] | None = None
    for end in ends:
        if end is not None and (best is None or end[1] < best[1]):
            best = end
    if best is None:
        return {}
    x = best[0]
    n_shape = len(problem.shape)
    out = {p.name: p.from_x(float(xi)) for p, xi in zip(problem.shape, x[:n_shape])}
    # The shared terms as the model's parameters' starts: the Coulomb force;
    # the offset as the force transducer's (the pressure transducer's part,
    # A p_off, is the fit's to separate: the pressure channels show it).
    for name, c in zip(_STARTED, ("coulomb", "offset")):
        p = next((p for p in params if p.name == name), None)
        if p is not None and c in problem.constants:
            out[name] = min(max(float(x[n_shape + problem.constants.index(c)]), p.lower), p.upper)
    out.update({p.name: p.from_x(float(xi)) for p, xi in zip(problem.friction_shape, x[n_shape + len(problem.constants):])})
    return out


def fit_static_damper(datasets: Sequence[Dataset], params: Sequence[Param], effects: Sequence[str] = ()) -> dict[str, float]:
    """The flexible model's damper-shape ``params`` fitted to the records'
    force less the gas's (the module's docstring), every branch at once;
    branches the records (characterisation and SDOF) do not exercise at
    speed are left out (they start where the model starts them). Beside the
    curves, what the model with ``effects`` adds to that force at speed: a
    Coulomb friction (``friction``: the same magnitude in every branch,
    against the motion, smoothed as the model smooths it) and an offset
    (``sensor_offset``: the force transducer's less the pressure
    transducer's on the piston), each shared by every branch; the offset
    only on samples of the force transducer (an SDOF record's force comes
    from the body's motion: the pressure transducer's part there is left
    to the dynamic fit).
    Where the model has the friction's Stribeck peak and smoothing
    (the flexible model's ``FRICTION_SHAPE``), they shape that Coulomb force
    as hp-core's `Friction` does and are fitted too, inside their bounds
    and priors, and returned as starts.
    Nothing else: a constant of its own per branch traded with a blow-off
    reached at no flow (the curve ``p_b + S q`` over the records' speeds)
    and started the model with a force it cannot make (foreign heat run,
    seed 1197046202: the rebound curve 268 N off). Those two are returned
    too, inside their bounds: ``friction_coulomb_n`` and
    ``sensor_force_offset_n`` (the whole offset taken as the force
    transducer's). The first dataset's template curve is the nominal one the
    multipliers scale (every dataset of a fit shares it)."""
    problem = static_problem(datasets, params, effects)
    if problem is None:
        return {}
    return static_values(problem, params, [solve_start(problem, k) for k in range(len(problem.starts))])

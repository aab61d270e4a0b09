"""Profile-likelihood intervals: how far one fitted parameter can move
before the data object, every other parameter fitted again at each value.

The standard errors of :func:`hpctl.identify.fit.fit` come from the
Jacobian at the optimum: the cost taken as a parabola there. Where
parameters trade along a bending valley that can mislead, and it does not
say what holds an estimate where it is. Holding the parameter at a value
and fitting the others does: on the foreign rig (docs/foreign-rig.md,
stop 33) seal friction's Coulomb force, seed 1, 263 +- 26 N against a true
322 N; held at 322 N the residuals' sum of squares rose by 1.7 and the
damper priors' by 3.0 (its orifice multipliers pulled from 6 to 21-27 x
nominal). A point costs a fit, so the interval is asked for
(``hpctl fit --profile``), not part of every fit.

A quantity derived from fitted parameters (:data:`hpctl.model.effects.DERIVED`,
the breakaway friction force ``F_c r``) is profiled the same way: held at
a value by one factor following the others (:class:`hpctl.identify.fit.Tie`),
everything else fitted again. Its error through the covariance (the delta
method) takes the valley as straight; where it bends the profile says
how far the records let the product go (slow sines alone, stop 68:
docs/foreign-rig.md).

The cost is the fit's own (residuals in noise units plus its priors), the
noise taken as known: the interval is where the cost has risen by
``sigmas**2`` over the optimum (the likelihood-ratio test; for a model
linear in its parameters, estimate +- ``sigmas`` standard errors with
independent residuals). The fit's errors also carry the input's noise and
coloured noise, which this does not: where the two disagree the interval
says the cost's shape, not the noise's.
"""

from __future__ import annotations

import math
import threading
from collections.abc import Mapping, Sequence
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass
from typing import Literal, TypedDict

from hpctl.errors import HpctlError, bad_argument
from hpctl.identify.blas import one_blas_thread
from hpctl.identify.derived import derived
from hpctl.identify.fit import FitResult, Model, Tie, fit, objective, prior_cost, product_range
from hpctl.model.effects import DERIVED, Param

#: Points fitted per side at most.
MAX_FITS_PER_SIDE = 6
#: Each point's evaluation budget: more than a fit's default (60). Held
#: at a value, the others have further to go than from a fit's warm
#: start, and a point stopped short overstates the rise (the foreign
#: friction case, seed 5, Coulomb force held at the truth: 9.4 after 60
#: evaluations, 4.9 converged after 300).
POINT_MAX_NFEV = 300
#: A side is done when the cost's rise there is within this share of its
#: target (``sigmas**2``).
RISE_TOLERANCE = 0.1

#: Why a side of an interval has no limit: the cost had not risen to the
#: target at the fit range's end, or at the last of the side's
#: :data:`MAX_FITS_PER_SIDE` points, or the model could not be run there.
Open = Literal["range_end", "not_reached", "failed"]


class ProfilePointJson(TypedDict):
    value: float
    rise: float
    converged: bool


class ProfileIntervalJson(TypedDict):
    """``fit.json``'s ``profile_intervals`` entries."""

    name: str
    estimate: float
    stderr: float
    sigmas: float
    lower: float | None
    upper: float | None
    lower_open: Open | None
    upper_open: Open | None
    better_found: bool
    points: list[ProfilePointJson]
    failed: list[str]


@dataclass(frozen=True)
class ProfilePoint:
    """The model fitted with the parameter held at ``value``."""

    value: float
    #: Its cost over the optimum's (noise units, priors included).
    rise: float
    #: The others' values there.
    values: Mapping[str, float]
    #: Whether that fit converged; one stopped at its evaluation limit can
    #: overstate the rise, and so narrow the interval.
    converged: bool = True


@dataclass(frozen=True)
class ProfileInterval:
    """Where the cost rises by ``sigmas**2`` on either side of the
    estimate. A limit is None where the records do not bound it within what
    was searched, and :attr:`lower_open` / :attr:`upper_open` say why: the
    parameter's fit range ends first, the side's points never rose to the
    target, or the model could not be run (:attr:`failed` says where)."""

    name: str
    estimate: float
    stderr: float
    sigmas: float
    lower: float | None
    upper: float | None
    points: tuple[ProfilePoint, ...]
    #: Points the model could not be run at (each ended its side, whose
    #: limit is then None: not known, not unbounded).
    failed: tuple[str, ...] = ()
    #: Why :attr:`lower` (:attr:`upper`) is None; None where it is a limit.
    lower_open: Open | None = None
    upper_open: Open | None = None

    def covers(self, value: float) -> bool:
        return (self.lower is None or self.lower <= value) and (self.upper is None or value <= self.upper)

    @property
    def better_found(self) -> ProfilePoint | None:
        """A point whose cost is below the estimate's by more than the
        target's tolerance: the estimate is not the cost's minimum (the fit
        stopped short of it, or its input-noise bias correction moved it
        further than that), and the interval is about a point that is not
        one."""
        low = min(self.points, key=lambda p: p.rise, default=None)
        return low if low is not None and low.rise < -RISE_TOLERANCE * self.sigmas**2 else None

    @property
    def unconverged(self) -> tuple[ProfilePoint, ...]:
        """The points whose fit stopped short (see :attr:`ProfilePoint.converged`)."""
        return tuple(q for q in self.points if not q.converged)

    def to_json(self) -> ProfileIntervalJson:
        return {"name": self.name, "estimate": self.estimate, "stderr": self.stderr, "sigmas": self.sigmas,
                "lower": self.lower, "upper": self.upper, "lower_open": self.lower_open, "upper_open": self.upper_open, "better_found": self.better_found is not None,
                "points": [ProfilePointJson(value=q.value, rise=q.rise, converged=q.converged) for q in self.points], "failed": list(self.failed)}

    def farthest(self, direction: float) -> ProfilePoint | None:
        """The point farthest from the estimate below (``direction`` < 0)
        or above it: where an open side's search ended."""
        return max((q for q in self.points if (q.value - self.estimate) * direction > 0), key=lambda q: abs(q.value - self.estimate),
                   default=None)

    def limit_text(self, direction: float, digits: int = 6) -> str:
        """The lower (``direction`` < 0) or upper limit, or why there is none
        and how far its search went."""
        limit, why = (self.lower, self.lower_open) if direction < 0 else (self.upper, self.upper_open)
        if limit is not None:
            return f"{limit:.{digits}g}"
        if why == "failed":
            return "(not known: the model failed)"
        last = self.farthest(direction)
        if last is None:
            return "(open)"
        where = "the fit range's end" if why == "range_end" else f"the last of {MAX_FITS_PER_SIDE} fits"
        return f"(open: rise {last.rise:.3g} at {last.value:.{digits}g}, {where})"

    def describe(self) -> str:
        lo, hi = self.limit_text(-1.0), self.limit_text(1.0)
        text = (f"{self.name}: {self.estimate:.6g}, {self.sigmas:g}-sigma profile interval [{lo}, {hi}] "
                f"(linear: +- {self.sigmas * self.stderr:.3g}; {len(self.points)} fits)")
        if (b := self.better_found) is not None:
            text += f"; WARNING: a lower cost at {b.value:.6g} ({b.rise:+.3g}): the estimate is not the cost's minimum"
        if bad := self.unconverged:
            text += f"; WARNING: {len(bad)} of {len(self.points)} fits stopped at their evaluation limit (the interval may be too narrow)"
        for f in self.failed:
            text += f"; WARNING: {f}"
        return text


def cost(result: FitResult, values: Mapping[str, float]) -> float:
    """The fit's cost at ``result``'s residuals: the residual sum of squares
    in noise units plus the priors' squares at ``values``."""
    return result.rss + prior_cost(result.model, values)


def profiled_names(model: Model) -> list[str]:
    """What :func:`profile_interval` can hold of a fit of ``model``: its
    fitted parameters and the derived products of them (:data:`DERIVED`)."""
    fitted = [p.name for p in model.params]
    return fitted + [d.name for d in DERIVED if all(f in fitted for f in d.factors)]


def _held(result: FitResult, name: str) -> tuple[Param, float, float]:
    """The quantity ``name`` a profile holds, as a :class:`Param` (its
    range and coordinate), its estimate and its standard error: a fitted
    parameter, or a derived product of them, whose range is the product of
    its factors' and whose coordinate is linear."""
    params = {p.name: p for p in result.model.params}
    if name in params:
        return params[name], result.values[name], result.stderr.get(name, math.nan)
    d = next((x for x in derived(result) if x.name == name), None)
    if d is None:
        raise bad_argument("name", name, f"a parameter the model fitted or a quantity derived from them ({', '.join(profiled_names(result.model))})")
    lo, hi = product_range([params[f] for f in d.factors])
    return Param(name, lo, hi, d.value, d.value, (lo, hi)), d.value, d.stderr


def _tie(result: FitResult, name: str, value: float) -> Tie:
    """A derived product ``name`` held at ``value``: its first factor
    without a prior follows the others (the breakaway force: the Coulomb
    force, the Stribeck ratio fitted with its prior)."""
    factors = next(d.factors for d in DERIVED if d.name == name)
    params = {p.name: p for p in result.model.params}
    follows = next((f for f in factors if params[f].prior_sigma is None), None)
    if follows is None:  # the optimiser's prior rows are the fitted parameters': one must be free of one
        raise bad_argument("name", name, f"a derived quantity with a factor without a prior ({', '.join(factors)} all have one)")
    return Tie(follows, value, tuple(f for f in factors if f != follows))


def _refit(result: FitResult, values: Mapping[str, float], start: Mapping[str, float], tie: Tie | None = None) -> FitResult:
    """``result``'s model fitted again with ``values`` (and ``tie``) held, from ``start``."""
    m = result.model
    return fit(result.datasets, m.effects, initial=start, fit_damper=m.fit_damper, flexible=m.flexible, held=m.held or None,
               fixed={**m.fixed, **values}, tie=tie, input_noise=False, errors=False, place_switches=False, max_nfev=POINT_MAX_NFEV)


def _point(result: FitResult, name: str, value: float, start: Mapping[str, float], base: float) -> ProfilePoint:
    fitted = any(p.name == name for p in result.model.params)
    fixed, tie = ({name: value}, None) if fitted else ({}, _tie(result, name, value))
    r = _settled(result, fixed, start, tie)
    if tie is not None and (other := _other_start(result, tie, start)) is not None:
        # A product reached two ways: by the factor that follows (from
        # ``start`` as it is) and by the first of the others, the follower
        # kept where it was. The factors trade along a bending valley, and
        # a fit from one side can stop in a side valley the other does not
        # (the foreign slow sines, FOREIGN_RIG_SEED=1599396050: the
        # breakaway force held at the truth's rose 3.21 from the first start
        # where both factors held at the truth's rose 1.66); the lower end kept.
        second = _settled(result, fixed, other, tie)
        r = second if cost(second, second.values) < cost(r, r.values) else r
    return ProfilePoint(value, cost(r, r.values) - base, r.values, r.success)


def _settled(result: FitResult, fixed: Mapping[str, float], start: Mapping[str, float], tie: Tie | None) -> FitResult:
    """:func:`_refit`, and where it stopped on its budget once more from
    where it stopped: a point stopped short overstates the rise (the
    foreign slow sines, seed 3's second redraw, the breakaway force held at
    the truth: 8.92 after 300 evaluations, 5.80 converged; 12 of 144 points
    stopped so, stop 68)."""
    r = _refit(result, fixed, start, tie)
    if not r.success:
        again = _refit(result, fixed, r.values, tie)
        r = again if cost(again, again.values) <= cost(r, r.values) else r
    return r


def _other_start(result: FitResult, tie: Tie, start: Mapping[str, float]) -> dict[str, float] | None:
    """``start`` with the tie's product reached by its first other factor,
    the follower at its value in ``start``; None where that factor would
    leave its fit range (or the follower is zero)."""
    follower, first, rest = start[tie.name], tie.others[0], tie.others[1:]
    p = next(q for q in result.model.params if q.name == first)
    denominator = follower * math.prod(start[o] for o in rest)
    if not denominator > 0.0:
        return None
    moved = tie.product / denominator
    return {**start, first: moved} if p.lower <= moved <= p.upper else None


def profile_point(result: FitResult, name: str, value: float) -> ProfilePoint:
    """One point of the profile of ``name`` (a fitted parameter or a
    derived product, :func:`profiled_names`): the model fitted again with
    it held at ``value`` (the others warm from ``result``), and the rise
    of the fit's cost over ``result``'s. ``value`` lies inside the
    ``sigmas`` profile-likelihood interval when the rise is below
    ``sigmas**2`` (one fit instead of the interval's several: to ask
    whether a value, a specification or a rig's truth, is consistent with
    the records)."""
    p, _, _ = _held(result, name)
    if not (math.isfinite(value) and p.lower <= value <= p.upper):
        raise bad_argument("value", value, f"a value of {name} inside its fit range [{p.lower:g}, {p.upper:g}]")
    return _point(result, name, value, result.values, cost(result, result.values))


def held_rise(result: FitResult, values: Mapping[str, float]) -> float:
    """The rise of the fit's cost over ``result``'s with several parameters
    held at ``values`` together (the others fitted again, warm from
    ``result``, as :func:`profile_point` fits): whether values of
    parameters that trade, such as a rig's truth of the Coulomb force and
    the Stribeck ratio whose product the records show, are consistent with
    the records (inside their joint region of probability ``P`` when the
    rise is below the chi-square quantile ``P`` of as many degrees of
    freedom as values held)."""
    if not values:
        raise bad_argument("values", dict(values), "at least one fitted parameter and its value")
    params = {p.name: p for p in result.model.params}
    for name, value in values.items():
        if name not in params:
            raise bad_argument("values", name, f"parameters the model fitted ({', '.join(params)})")
        p = params[name]
        if not (math.isfinite(value) and p.lower <= value <= p.upper):
            raise bad_argument(f"values[{name!r}]", value, f"a value of {name} inside its fit range [{p.lower:g}, {p.upper:g}]")
    r = _refit(result, values, {**result.values, **values})
    return cost(r, r.values) - cost(result, result.values)


def profile_interval(result: FitResult, name: str, *, sigmas: float = 2.0) -> ProfileInterval:
    """The ``sigmas`` profile-likelihood interval of ``name``, a parameter
    of the fitted ``result`` or a quantity derived from them
    (:func:`profiled_names`; a fit with its errors: they set the first
    step). Each point fits the model again with ``name`` held, warm from
    the point before on its side, on ``result``'s datasets (its valve
    switches where it placed them), without the input noise.

    On each side the first point is ``sigmas`` standard errors out (in the
    fit's coordinate: decades for a log parameter); then a secant on the
    square root of the rise (straight in the coordinate for a linear
    model) until the rise is within :data:`RISE_TOLERANCE` of
    ``sigmas**2``, at most :data:`MAX_FITS_PER_SIDE` fits."""
    if not (math.isfinite(sigmas) and 0.0 < sigmas <= 10.0):
        raise bad_argument("sigmas", sigmas, "a number of standard errors in (0, 10]")
    p, est, se = _held(result, name)
    if not (math.isfinite(se) and se > 0.0):
        raise bad_argument("result", f"{name} +- {se}", "a fit with a finite, positive standard error for the parameter")
    x_est = p.to_x(est)
    se_x = se / (est * math.log(10.0)) if p.log else se / p.scale
    lo_x, hi_x = p.x_bounds()
    base = cost(result, result.values)
    target = sigmas**2

    def side(direction: float, points: list[ProfilePoint], failed: list[str], halt: threading.Event) -> tuple[float | None, Open | None]:
        # One side's points and failures go to its own lists: the two sides
        # run at once (below).
        end = hi_x if direction > 0 else lo_x
        x_prev, t_prev = x_est, 0.0
        x = x_est + direction * sigmas * se_x
        start: Mapping[str, float] = result.values
        for _ in range(MAX_FITS_PER_SIDE):
            if halt.is_set():  # the other side failed: the interval is not had
                return None, None
            clipped = min(max(x, lo_x), hi_x)
            try:
                pt = _point(result, name, p.from_x(clipped), start, base)
            except HpctlError as e:
                failed.append(f"the model could not be run with {name} = {p.from_x(clipped):.6g}, so the interval's "
                              f"{'upper' if direction > 0 else 'lower'} limit is not known: {e}")
                return None, "failed"
            points.append(pt)
            start = pt.values
            t = math.sqrt(max(pt.rise, 0.0))
            if abs(pt.rise - target) <= RISE_TOLERANCE * target:
                return pt.value, None
            if clipped == end and pt.rise < target:
                return None, "range_end"
            # The secant on sqrt(rise) through the last two points (the
            # estimate's is 0); where it does not rise, twice as far.
            if t > t_prev:
                x_next = clipped + (sigmas - t) * (clipped - x_prev) / (t - t_prev)
            else:
                x_next = x_est + 2.0 * (clipped - x_est)
            x_prev, t_prev, x = clipped, t, x_next
        # Not within the tolerance: the point nearest the target on this
        # side, between the last below and the first above it.
        above = [q for q in points if q.rise >= target]
        below = [q for q in points if q.rise < target]
        if not above:
            return None, "not_reached"
        far = min(above, key=lambda q: abs(p.to_x(q.value) - x_est))
        near = max(below, key=lambda q: abs(p.to_x(q.value) - x_est), default=None)
        if near is None:
            return far.value, None
        a, b = p.to_x(near.value), p.to_x(far.value)
        ta, tb = math.sqrt(max(near.rise, 0.0)), math.sqrt(far.rise)
        return p.from_x(a + (sigmas - ta) * (b - a) / (tb - ta)), None

    # The two sides at once, the lower in a thread of its own: each is a
    # chain of fits warm from the one before, independent of the other
    # side, so the interval is the same either way; a fit's serial
    # stretches (the optimiser's linear algebra, a long record run alone)
    # leave a core idle that the other side's fit takes (BENCHMARKS.md,
    # stop 69). BLAS on one thread for both, set here (hpctl.identify.blas).
    lows: tuple[list[ProfilePoint], list[str]] = ([], [])
    highs: tuple[list[ProfilePoint], list[str]] = ([], [])
    halt = threading.Event()

    def halting(direction: float, kept: tuple[list[ProfilePoint], list[str]]) -> tuple[float | None, Open | None]:
        # Ctrl-C or a bug in one side: the other stops after its fit under way.
        try:
            return side(direction, *kept, halt)
        except BaseException:
            halt.set()
            raise

    with one_blas_thread(), ThreadPoolExecutor(max_workers=1, thread_name_prefix="hpctl-profile") as pool:
        below_side = pool.submit(halting, -1.0, lows)
        upper, upper_open = halting(1.0, highs)
        lower, lower_open = below_side.result()
    return ProfileInterval(name, est, se, sigmas, lower, upper, tuple(sorted(lows[0] + highs[0], key=lambda q: q.value)),
                           tuple(lows[1] + highs[1]), lower_open, upper_open)


@dataclass(frozen=True)
class Restart:
    """A fit started again where a profile found the cost lower than at
    the estimate (:func:`refit_from_better`)."""

    #: The fit from there.
    result: FitResult
    #: The profile that found it and the point it started from.
    name: str
    start: ProfilePoint
    #: The objective (:func:`hpctl.identify.fit.objective`) before and after.
    before: float
    after: float


def refit_from_better(result: FitResult, profiles: Sequence[ProfileInterval], max_nfev: int) -> Restart | None:
    """``result``'s model fitted again as ``result`` was (its errors and the
    input's noise), from the lowest profile point below the estimate
    (:attr:`ProfileInterval.better_found`), where that fit ends lower than
    ``result`` by more than the profile's tolerance: the fit had stopped in
    a side valley of the cost, not at its minimum (the foreign rig's slow
    sines, seed 1: the breakaway force 357 N where the cost is 7.5 lower at
    403 N, the truth 403.8; docs/foreign-rig.md, stop 68). None where no
    profile found such a point or the fit from there ends no lower (a
    point below an estimate that the input noise's bias correction moved
    off the minimum, which the fit from there moves alike)."""
    found = [(iv, b) for iv in profiles if (b := iv.better_found) is not None]
    if not found:
        return None
    iv, low = min(found, key=lambda f: f[1].rise)
    m = result.model
    again = fit(result.datasets, m.effects, initial=low.values, fit_damper=m.fit_damper, flexible=m.flexible, held=m.held or None,
                fixed=dict(m.fixed) or None, max_nfev=max_nfev)
    before, after = objective(result), objective(again)
    if not after < before - RISE_TOLERANCE * iv.sigmas**2:
        return None
    return Restart(again, iv.name, low, before, after)

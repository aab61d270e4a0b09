"""Signal processing for measured records: noise levels, smoothing that
never distorts the excitation, fourth-order derivatives on irregular
samples. (The first-order sensor lag of a
sampled signal is the core's: :func:`hpctl._core.sensor_lag`.)"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import TypedDict

import numpy as np
from numpy.typing import NDArray
from scipy.optimize import nnls
from scipy.signal import savgol_coeffs, savgol_filter
from scipy.stats import chi2, norm

FloatArray = NDArray[np.float64]


# Fourth differences beyond this many standard deviations are steps or
# spikes, not noise.
_CLIP = 4.0
# The variance a normal distribution keeps when cut at +-_CLIP sigma.
_CLIP_KEPT = 1.0 - 2.0 * _CLIP * float(norm.pdf(_CLIP)) / (2.0 * float(norm.cdf(_CLIP)) - 1.0)


def noise_sigma(y: FloatArray, order: int = 4) -> float:
    """Noise level of a sampled signal from its fourth differences: white
    noise of variance s^2 gives differences of variance 70 s^2, while a
    signal smooth on the sampling scale contributes almost nothing (its
    fourth difference scales with the fourth power of the sampling step).
    ``order``: the order of the differences (even; 6 and 8 for signals
    rough on the sampling scale, :func:`noise_level`).

    The median absolute deviation keeps steps and spikes out but wastes
    data: on 401 white samples it scatters by 7.7 % (one record's pressure
    read 24 % low, and a clean residual looked like 1.3 x the noise). The
    root mean square of the differences within 4 sigma of their centre,
    starting from the MAD and corrected for the cut, scatters by 5.5 % and
    still ignores steps and spikes."""
    d4 = np.diff(np.asarray(y, float), order)
    if d4.size == 0:
        return 0.0
    centre = float(np.median(d4))
    s = float(np.median(np.abs(d4 - centre))) / 0.6745
    for _ in range(3):
        kept = d4[np.abs(d4 - centre) < _CLIP * s]
        if kept.size < 2:
            break
        centre = float(np.mean(kept))
        s = float(np.sqrt(np.mean((kept - centre) ** 2) / _CLIP_KEPT))
    return s / math.sqrt(math.comb(2 * order, order))


# Coloured noise. A transducer's noise is often partly correlated from
# sample to sample (an anti-alias or bridge filter, a drifting amplifier):
# white plus an exponentially correlated part, autocorrelation rho^k at lag
# k with rho = exp(-dt / corr_time). The fourth difference sees the
# correlated part only in the share below, which falls to 0 as the sampling
# interval shrinks under the correlation time: a record sampled fast reads
# its noise low, and a residual that is all noise then looks like
# structure (foreign rig, seed 7: the 1 Hz sine's pressure read 3.1 kPa
# where the noise is 4.2 kPa, and "1.43 x the noise" was all noise).
# One record cannot tell a slow noise from the signal, but records of the
# same channel sampled at different rates can: the slowly sampled ones see
# all of it. So the fit identifies the white and the correlated variances
# and the correlation time from the levels of every record of a channel,
# and gives each record back what its fourth difference missed.

#: n * var(s^2) / s^4 of the level's variance estimate on n samples, by
#: the order of the differences that were checked to hold noise (white or
#: correlated noise alike; 5.0 and 6.3 measured on 2,000-3,000 draws of
#: 400-2,000 samples).
LEVEL_REL_VAR = {4: 5.0, 6: 6.3}
#: The sum of squares a correlated part must remove (weighted by the
#: levels' scatter) before it is believed: a likelihood-ratio statistic with
#: two parameters more (one searched): 2 false alarms in 4,000 campaigns of
#: white noise sampled as the foreign rig's sweep; half the variance
#: correlated over 15 / 50 ms is found in 77 / 94 % (tests/test_noise_colour.py).
COLOUR_EVIDENCE = 12.0
#: Evidence that suggests a correlated part without establishing it: the
#: 95 % point of chi-square on the two parameters it adds. Not taken into
#: the weights; said where a channel is judged above the noise, with what
#: the channel would read with it (:attr:`hpctl.identify.diagnose.Place.colour_hint`).
#: On three records sampled as the foreign rig's short sweep (401 samples at
#: 167, 17 and 5 ms; stop 74): white noise reaches it in 1.5 % of 2,000
#: campaigns (COLOUR_EVIDENCE in 0.1 %); of 1,000 drawn as the foreign
#: rig draws its noise, the 112 with a third or more of the variance
#: correlated over 20-50 ms have it established in 31 % and only suggested
#: in 40 % more; on the five-sine sweep 2.0 % and 58 % + 26 % (of 113). (The foreign
#: control, FOREIGN_RIG_SEED=9: the force's levels 58.0, 43.4 and 47.5 N,
#: evidence 8.9; the truth 44.0 N white and 39.1 N over 38 ms, so the 0.3 Hz
#: sine's residual, all noise, read 1.31 x its level.)
COLOUR_HINT_EVIDENCE = 6.0


def _colour_consistent(levels: int) -> float:
    """The most the levels may scatter about the colour's fit (weighted sum
    of squares): the 99.9 % point of chi-square with the levels less the
    three parameters."""
    return float(chi2.ppf(0.999, max(levels - 3, 1)))


#: Correlation times tried, per sampling interval of the fastest record up
#: to a third of that of the slowest, where the slowest record's fourth
#: difference still reads 92 % of the correlated variance. A longer one
#: would be extrapolated, not seen: up to the slowest interval itself (the
#: earlier bound, where that record reads 51 %) three records of the
#: foreign rig's heat case read one force's noise 35 % high
#: (FOREIGN_RIG_SEED=1229674921: levels 41.5, 28.9 and 32.1 N at 167, 17
#: and 5 ms, the truth 37.0 N correlated over 34 ms, taken as 50 N over
#: 167 ms). On 1,000 draws of the foreign rig's noise (correlated over
#: 2-50 ms) sampled as those three records, the total read over 1.25 x in
#: 0.5 % of them with the earlier bound and in none with this one, the
#: detection rate and the median unchanged (stop 46).
_COLOUR_TAU_STEPS = 60
_COLOUR_TAU_MAX_SHARE = 1.0 / 3.0


def difference_share(rho: float | FloatArray, order: int = 4) -> FloatArray:
    """The share of a correlated noise's variance (autocorrelation
    ``rho^k``) that the differences of ``order`` read: 1 for white noise
    (``rho = 0``), 0 for a constant (``rho = 1``); for the fourth,
    ``(70 - 112 rho + 56 rho^2 - 16 rho^3 + 2 rho^4) / 70``."""
    r = np.asarray(rho, float)
    c = np.array([(-1.0) ** i * math.comb(order, i) for i in range(order + 1)])
    # sum_ij c_i c_j rho^|i-j| = sum_k a_k rho^k, a_k the weights' autocorrelation at lag k.
    a = np.correlate(c, c, "full")[order:]
    return np.asarray(sum(a[k] * (1.0 if k == 0 else 2.0) * r**k for k in range(order + 1)) / a[0])


@dataclass(frozen=True)
class NoiseColour:
    """One channel's noise as white plus exponentially correlated,
    identified from its levels in records sampled at different rates
    (:func:`noise_colour`)."""

    channel: str
    white_var: float
    coloured_var: float
    corr_time_s: float
    #: How much the levels' weighted sum of squares fell with the
    #: correlated part (against :data:`COLOUR_EVIDENCE`).
    evidence: float

    def missed_var(self, dt_s: float, order: int = 4) -> float:
        """The correlated variance a record sampled every ``dt_s`` does not
        see in its differences of ``order``."""
        return float(self.coloured_var * (1.0 - difference_share(math.exp(-dt_s / self.corr_time_s), order)))

    @property
    def coloured_share(self) -> float:
        return self.coloured_var / (self.white_var + self.coloured_var)

    def to_json(self) -> NoiseColourJson:
        return {"channel": self.channel, "white_sigma": math.sqrt(self.white_var), "coloured_sigma": math.sqrt(self.coloured_var),
                "coloured_share": self.coloured_share, "corr_time_s": self.corr_time_s, "evidence": self.evidence}

    def describe(self) -> str:
        return (f"{self.channel}: {self.coloured_share:.0%} of the noise's variance correlated over {self.corr_time_s * 1e3:.3g} ms "
                f"(white {math.sqrt(self.white_var):.4g}, correlated {math.sqrt(self.coloured_var):.4g}; evidence {self.evidence:.1f})")


class NoiseColourJson(TypedDict):
    """A channel's correlated noise (JSON); sigmas in the channel's unit."""

    channel: str
    white_sigma: float
    coloured_sigma: float
    coloured_share: float
    corr_time_s: float
    evidence: float


#: The largest ratio of the normalised mean squares of the differences of
#: one order and of the next even one that noise gives, white or
#: exponentially correlated (1 for white, up to 1.048 for the fourth over
#: the sixth, 1.023 for the sixth over the eighth, as the correlation time
#: grows), and the ratio's scatter times sqrt(n) (0.40-0.45 and 0.32-0.34
#: measured on 3,000 draws of 401 and 2,000 samples).
_NEXT_ORDER_NOISE_MAX = {4: 1.048, 6: 1.023}
_NEXT_ORDER_SCATTER = {4: 0.45, 6: 0.34}


def differences_are_noise(y: FloatArray, order: int = 4) -> bool:
    """Whether the differences of ``order`` of ``y`` hold its noise only,
    not the signal too: the differences two orders higher suppress a
    signal smooth on the sampling scale by two further orders, noise (white
    or correlated) hardly at all. The foreign rig's 75-minute heat run, a
    0.5 Hz sine sampled at 20 Hz with the damper working, read its
    pressure's level at 11.6 kPa from the fourth difference, 4.5 from the
    sixth, where the noise is 4.2."""
    y = np.asarray(y, float)
    if len(y) < 64 or not np.all(np.isfinite(y)) or order not in _NEXT_ORDER_NOISE_MAX:
        return False
    m = [float(np.mean(np.diff(y, k) ** 2)) / math.comb(2 * k, k) for k in (order, order + 2)]
    return m[1] > 0.0 and m[0] / m[1] <= _NEXT_ORDER_NOISE_MAX[order] + 5.0 * _NEXT_ORDER_SCATTER[order] / math.sqrt(len(y))


@dataclass(frozen=True)
class NoiseLevel:
    """A record channel's noise level and the order of the differences it
    was read from."""

    sigma: float
    order: int
    #: Whether a test said those differences hold noise only (False: the
    #: eighth, unchecked, the signal may still show in them).
    checked: bool


def noise_level(y: FloatArray) -> NoiseLevel:
    """The noise level from the lowest order of differences (4, 6, 8) that
    holds noise only: a signal rough on the sampling scale (a sine sampled
    40 times a cycle with the damper's knees) raises the fourth
    difference's level, and a level too high hides structure as noise (the
    foreign heat run's force read 99 N, where the noise is 16)."""
    for order in (4, 6):
        if differences_are_noise(y, order):
            return NoiseLevel(noise_sigma(y, order), order, True)
    # None checked: noise alone reads alike at every order, what the signal
    # adds differs, so the least is the closest (the heat run's force: 99,
    # 41 and 33 N from the fourth, sixth and eighth, against 16).
    return min((NoiseLevel(noise_sigma(y, k), k, False) for k in (4, 6, 8)), key=lambda lv: lv.sigma)


def noise_colour(channel: str, levels: Sequence[tuple[float, int, NoiseLevel]], min_evidence: float = COLOUR_EVIDENCE) -> NoiseColour | None:
    """The correlated part of a channel's noise from ``levels``, one
    ``(sampling interval s, samples, level)`` per record of the channel;
    only levels whose differences were checked to hold noise count (a
    level raised by the signal would pass for the noise's correlated part).
    ``None`` when the levels do not show one (all sampled alike, fewer than
    three records, or evidence under ``min_evidence``:
    :data:`COLOUR_EVIDENCE` to be believed, :data:`COLOUR_HINT_EVIDENCE`
    to be suggested)."""
    levels = [lv for lv in levels if lv[2].checked]
    if len(levels) < 3:
        return None
    dt = np.array([lv[0] for lv in levels], float)
    n = np.array([lv[1] for lv in levels], float)
    y = np.array([lv[2].sigma for lv in levels], float) ** 2
    orders = np.array([lv[2].order for lv in levels])
    if not (np.all(np.isfinite(dt)) and np.all(dt > 0) and np.all(np.isfinite(y)) and np.all(y > 0)):
        return None
    keep = np.ones(len(levels), bool)
    while keep.sum() >= 3 and dt[keep].max() >= 2.0 * dt[keep].min():
        fitted = _colour_fit(dt[keep], n[keep], y[keep], orders[keep])
        if fitted is None:
            return None
        sse, sse0, white, coloured, tau, above = fitted
        if coloured <= 0.0 or sse0 - sse < min_evidence:
            return None
        # The colour must explain every level within its scatter: a level the
        # signal still raises (hpctl's virtual heat run, its force read 35 N
        # from the sixth difference where the noise is 28 and the 0.1 Hz sine,
        # sampled alike, read 27.7) looks like the slow part of a noise, but
        # not one the other records agree with (weighted sum of squares 62 on
        # 3 degrees of freedom; a real colour on the foreign rig: 0.2-2.5).
        if sse <= _colour_consistent(int(keep.sum())):
            return NoiseColour(channel, white, coloured, tau, sse0 - sse)
        # Such a level is set aside and the colour sought in the others: the
        # signal only ever raises a level. (The foreign control campaign's
        # strut gas pressure, seed 11: the 1 Hz sine and the fast damper-on
        # record read 2.77 and 2.73 kPa at 5 and 2 ms, the SDOF steps
        # 2.23-2.30 at 5 ms; the truth 2.26 white and 1.85 correlated over
        # 33 ms. No colour was found, and the steps' weights missed it: 1.34
        # x there.)
        worst = int(np.argmax(above))
        if above[worst] <= 0.0:
            return None
        keep[np.flatnonzero(keep)[worst]] = False
    return None


def _colour_fit(dt: FloatArray, n: FloatArray, y: FloatArray, orders: NDArray[np.int_]
                ) -> tuple[float, float, float, float, float, FloatArray] | None:
    """The colour that best explains the variances ``y`` read from
    differences of ``orders`` at intervals ``dt`` (``n`` samples each):
    its weighted sum of squares, that of a white noise alone, the white and
    coloured variances, the correlation time, and each level's weighted
    excess over the colour's (positive: above it)."""
    sw = np.sqrt(n / np.array([LEVEL_REL_VAR[int(k)] for k in orders])) / y  # 1 / the level's standard deviation
    a0 = float(np.sum(sw**2 * y) / np.sum(sw**2))
    sse0 = float(np.sum((sw * (y - a0)) ** 2))
    best: tuple[float, float, float, float, FloatArray] | None = None
    for tau in np.geomspace(dt.min() / 10.0, dt.max() * _COLOUR_TAU_MAX_SHARE, _COLOUR_TAU_STEPS):
        g = np.array([float(difference_share(math.exp(-d / tau), int(k))) for d, k in zip(dt, orders)])
        coef, res = nnls(np.column_stack((sw, sw * g)), sw * y)
        if best is None or res**2 < best[0]:
            best = (float(res**2), float(coef[0]), float(coef[1]), float(tau), sw * (y - coef[0] - coef[1] * g))
    if best is None:
        return None
    return best[0], sse0, best[1], best[2], best[3], best[4]


# Quintic over 15 samples: a cubic over 11 (the earlier choice) passed
# white noise with a gain of 0.455 but shrank a sine sampled 200 times a
# cycle by 2.9e-6 of its amplitude, enough to bias the gas charge and time
# constant by 0.1-0.2 standard errors on the virtual rig's sweep (issue 12);
# the quintic shrinks it by 4e-9 (2e-5 at 50 samples a cycle) for a noise
# gain of 0.489. The noise that matters for the fit is the input's low-
# frequency part, which no smoothing removes.
SMOOTH_WINDOW, SMOOTH_ORDER = 15, 5
# How much of the input's white noise survives the smoothing (standard deviation).
SMOOTH_NOISE_GAIN = float(np.sqrt(np.sum(savgol_coeffs(SMOOTH_WINDOW, SMOOTH_ORDER) ** 2)))


def smooth(t: FloatArray, x: FloatArray) -> FloatArray:
    """The measured displacement with its noise filtered (Savitzky-Golay,
    quintic, 15 samples): the model is driven by it, and a noisy input would
    become a noisy velocity for the damper and friction. Where the signal
    has features sharper than the window (a step, or a sine sampled a few
    times per cycle), the filter would move it by more than its noise: there
    the raw samples are kept, so smoothing never distorts the excitation."""
    return smooth_bends(t, x)[0]


def smooth_bends(t: FloatArray, x: FloatArray) -> tuple[FloatArray, NDArray[np.bool_]]:
    """:func:`smooth`'s signal, and where it kept the raw samples."""
    x = np.asarray(x, float)
    if len(x) < 2 * SMOOTH_WINDOW:
        return x, np.ones(len(x), bool)
    smooth = np.asarray(savgol_filter(x, SMOOTH_WINDOW, SMOOTH_ORDER))
    bends = filter_bends(x, smooth, noise_sigma(x), SMOOTH_WINDOW)
    return np.where(bends, x, smooth), bends


def filter_bends(x: FloatArray, filtered: FloatArray, sigma: float, window: int) -> NDArray[np.bool_]:
    """Where a filter of ``window`` samples moved the signal ``x`` by more
    than four times its noise ``sigma`` (a feature sharper than the window),
    and the filter's reach around those samples (:func:`within_reach`)."""
    return within_reach(np.abs(np.asarray(filtered) - x) > 4.0 * max(sigma, 1e-12), window)


def within_reach(mask: NDArray[np.bool_], window: int) -> NDArray[np.bool_]:
    """The samples a centred window of ``window`` samples around any sample
    of ``mask`` covers."""
    return np.asarray(np.convolve(mask.astype(float), np.ones(window), "same") > 0)


FIVE_POINT = np.array([1.0, -8.0, 0.0, 8.0, -1.0]) / 12.0


def derivative(t: FloatArray, x: FloatArray, corners: FloatArray | None = None) -> FloatArray:
    """dx/dt at the samples, fourth-order accurate: the derivative of the
    quartic through each sample and its two neighbours on either side
    (irregular spacing allowed); second order at the two ends. A sample
    whose five samples straddle one of the instants ``corners``
    (:func:`hpctl.identify.corners.corners`: its acceleration jumps there)
    takes the quartic through the five nearest on its own side instead,
    where there are five between the corners (else the centred one)."""
    t = np.asarray(t, float)
    x = np.asarray(x, float)
    n = len(x)
    out = np.gradient(x, t, edge_order=2) if n >= 3 else np.gradient(x, t) if n == 2 else np.zeros(n)
    if n < 5:
        return np.asarray(out)
    i = np.arange(2, n - 2)
    out[2:n - 2] = _quartic_slope(t, x, i, 2)
    if corners is None or len(corners) == 0:
        return np.asarray(out)
    taus = np.sort(np.asarray(corners, float))
    # First sample after each corner (a sample on a corner is on both sides).
    after = np.searchsorted(t, taus, side="right")
    straddled = np.zeros(n, bool)
    for a in after:
        straddled[max(a - 2, 0):min(a + 2, n)] = True
    js = np.flatnonzero(straddled)
    # The stencil nearest the centred one that no corner splits (strictly
    # inside its span), each sample's taken together with the others'
    # (one at a time, these were 0.2 s of the bundled campaign's fit).
    chosen = np.full(len(js), -1)
    for e in (2, 1, 3, 0, 4):
        lo = js - e
        inside = (lo >= 0) & (lo + 4 < n)
        a, b = t[np.clip(lo, 0, n - 1)], t[np.clip(lo + 4, 0, n - 1)]
        split = np.searchsorted(taus, b, side="left") > np.searchsorted(taus, a, side="right")
        chosen[(chosen < 0) & inside & ~split] = e
    for e in (2, 1, 3, 0, 4):
        at = js[chosen == e]
        if at.size:
            out[at] = _quartic_slope(t, x, at, e)
    return np.asarray(out)


def _quartic_slope(t: FloatArray, x: FloatArray, i: NDArray[np.intp], e: int) -> FloatArray:
    """The slope at samples ``i`` of the quartics through the five samples
    from ``i - e`` on (``e`` = 2: centred), the derivative of their
    Lagrange basis at a node: at the node itself the sum of the reciprocal
    distances to the others, elsewhere the other nodes' product over the
    basis' denominator."""
    lo = i - e
    nodes = np.stack([t[lo + k] for k in range(5)])  # 5 x m
    tc = t[i]
    weights = np.zeros_like(nodes)
    for j in range(5):
        if j == e:
            weights[j] = sum(1.0 / (tc - nodes[m]) for m in range(5) if m != e)
            continue
        num = np.ones_like(tc)
        den = np.ones_like(tc)
        for m in range(5):
            if m != j:
                den *= nodes[j] - nodes[m]
            if m not in (j, e):
                num *= tc - nodes[m]
        weights[j] = num / den
    return np.asarray(np.sum(weights * np.stack([x[lo + k] for k in range(5)]), axis=0))


def velocity_noise_gain(dt_s: float) -> float:
    """Standard deviation of the velocity the model sees (the five-point
    derivative of the smoothed input, the interpolation's tangents) per
    unit of white input noise."""
    coeffs = savgol_coeffs(SMOOTH_WINDOW, SMOOTH_ORDER)
    return float(np.sqrt(np.sum((np.convolve(coeffs, FIVE_POINT) / dt_s) ** 2)))


#: A residual's growth with its channel's rate of change is reported when
#: its estimate stands this many standard errors above zero ...
RATE_NOISE_MIN_T = 3.0
#: ... and, in the weights, it would take at least this share of the
#: residual's variance above the noise's ...
RATE_NOISE_MIN_SHARE = 1.0 / 3.0
#: ... and, among the tenth of the samples where the rate is largest,
#: consecutive residuals correlate less than this: a jitter's instants are
#: drawn one by one, a model's error there is smooth (the foreign
#: campaign's damper-off step: 0.21).
RATE_NOISE_MAX_AUTOCORR = 0.5


@dataclass(frozen=True)
class RateNoise:
    """A residual whose size grows with its channel's rate of change
    without following its sign (:func:`rate_noise`): what a sample-time
    jitter of ``jitter_s`` (standard deviation) would make, ``t`` standard
    errors from none, and the residual's RMS over the noise with that
    jitter's variance in the weights."""

    jitter_s: float
    t: float
    rms_ratio: float


def rate_noise(residual: FloatArray, sigma: FloatArray | float, rate: FloatArray) -> RateNoise | None:
    """Whether a residual holds noise in proportion to its channel's rate of
    change, as sampling at instants off the logged ones does: a sample
    taken ``delta`` late reads ``y + rate * delta``, so independent
    instants of standard deviation ``s_t`` add ``(rate s_t)^2`` to each
    sample's variance. A sensor's lag also grows with the rate, but follows
    its sign (the residual's correlation with the rate, reported apart).

    ``s_t^2`` by least squares on the squares, ``r^2 - sigma^2 = rate^2
    s_t^2`` (each weighted alike; its standard error from the squares'
    variance, ``2 (sigma^2 + rate^2 s_t^2)^2`` for a normal residual),
    after the residual's part in proportion to the rate is taken out (a
    lag's: the squares of ``-tau rate`` grow with the rate too).
    None unless it stands :data:`RATE_NOISE_MIN_T` errors above zero, takes
    :data:`RATE_NOISE_MIN_SHARE` of the excess variance and is white where
    the rate is largest (:data:`RATE_NOISE_MAX_AUTOCORR`), or where the
    inputs are not finite. Measured on the foreign rig's bundled campaign
    (friction found): the damper-off SDOF step's body displacement read
    23.2 us at 3.3 errors, 1.32 -> 1.15 x the noise, where the foreign
    rig's clock jitter was 20.4 us (docs/foreign-rig.md, stop 47)."""
    r = np.asarray(residual, float)
    s2 = np.broadcast_to(np.asarray(sigma, float) ** 2, r.shape)
    v = np.asarray(rate, float)
    a = v * v
    if not (len(r) and np.all(np.isfinite(r)) and np.all(np.isfinite(s2)) and np.all(np.isfinite(a))) or np.any(s2 <= 0.0):
        return None
    aa = float(a @ a)
    if aa <= 0.0:
        return None
    r0, r = r, r - v * (float(v @ r) / float(v @ v))
    excess = r * r - s2
    st2 = float(a @ excess) / aa
    if st2 <= 0.0:
        return None
    t = float(a @ excess) / math.sqrt(float(np.sum(a * a * 2.0 * (s2 + a * st2) ** 2)))
    before = float(np.mean(r * r / s2))
    after = float(np.mean(r * r / (s2 + a * st2)))
    if t < RATE_NOISE_MIN_T or before <= 1.0 or before - after < RATE_NOISE_MIN_SHARE * (before - 1.0):
        return None
    fast = np.flatnonzero(a >= np.quantile(a, 0.9))
    pairs = fast[np.isin(fast + 1, fast)]
    if len(pairs) < 3 or float(np.corrcoef(r[pairs], r[pairs + 1])[0, 1]) >= RATE_NOISE_MAX_AUTOCORR:
        return None
    # The residual's own RMS (its part along the rate kept) with the jitter in the weights.
    return RateNoise(math.sqrt(st2), t, math.sqrt(float(np.mean(r0 * r0 / (s2 + a * st2)))))

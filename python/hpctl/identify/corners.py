"""Corners of a measured input: instants where its acceleration jumps (a
raised-cosine step's start and end), located between the samples, so that
the input's velocity at a sample is never taken across one.

Why: the drive's velocity at the samples is the derivative of the quartic
through each sample and its two neighbours on either side
(:func:`hpctl.identify.signals.derivative`). Across a corner that quartic
straddles two different curves: on a 43 mm raised-cosine step over 50 ms
sampled at 200 Hz it missed the velocity by up to 72 mm/s, which the
damper turned into 21 um RMS of body motion against 5 um of noise
(docs/foreign-rig.md). Choosing the stencil by its smoothness alone (no
corner located) does not tell the sides apart at ten samples a rise and
made the error larger where the corner fell between samples (stop 48).

How: around each sampling interval where the smoothing kept the raw
samples (a feature sharper than its window), the samples within
:data:`CORNER_HALF_WINDOW` either side are fitted twice by least squares,
by one polynomial of degree six, and by a cubic joined at a trial instant
``tau`` inside the interval to itself plus ``(t - tau)_+^2 (c0 + c1 (t -
tau) + c2 (t - tau)^2)`` after ``tau`` (or the same before it, whichever
fits better: the flat side is the cubic's, a step's start's after and its
end's before): continuous in displacement and velocity, free in its
acceleration and above (both fits seven parameters). A corner is taken
where the join's sum of squares is below the polynomial's by at least
:data:`CORNER_MIN_GAIN` noise variances, at the trial instant with the
least; corners closer than the half window to a better one are not."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

FloatArray = NDArray[np.float64]

#: Samples either side of a trial interval in a corner's fit: five reach
#: half a rise of ten samples into the step, where the quartic join still
#: follows a raised cosine within the noise (a cubic join left 44 um on
#: the 43 mm step, five samples in).
CORNER_HALF_WINDOW = 5
#: Trial instants per sampling interval.
CORNER_TRIALS = 16
#: A join is a corner when it lowers the window's sum of squares below the
#: smooth polynomial's by this many noise variances (both fits have seven
#: parameters; 25 is five standard deviations of one).
CORNER_MIN_GAIN = 25.0
# Parameters of either fit.
_PARAMS = 7


def _residual_ss(basis: FloatArray, x: FloatArray) -> FloatArray:
    """Least-squares residual sums of squares of ``x`` (..., n) on stacked
    bases (..., n, p), by QR (the normal equations would lose the residual,
    microns on tens of millimetres, to rounding)."""
    q, _ = np.linalg.qr(basis)
    fitted = q @ np.einsum("...np,...n->...p", q, x)[..., None]
    return np.asarray(np.sum((x - fitted[..., 0]) ** 2, axis=-1))


def _even(n: int) -> FloatArray:
    """A window of ``n`` evenly spaced instants, in sampling intervals from
    its centre."""
    return np.arange(n, dtype=float) - (n - 1) / 2.0


def _regular(u: FloatArray) -> NDArray[np.bool_]:
    """Which windows (rows of ``u``) are evenly sampled (all, on a rig's clock)."""
    return np.asarray(np.all(np.abs(u - _even(u.shape[1])) < 1e-6, axis=1))


def _complement_ss(xw: FloatArray, basis: FloatArray) -> FloatArray:
    """The residual sums of squares of the windows ``xw`` (m x n) about each
    of the bases ``basis`` (..., n, p) they share, (m, ...): the projections
    on the bases' orthogonal complements, one matrix product."""
    q, _ = np.linalg.qr(basis, mode="complete")
    comp = q[..., _PARAMS:]  # (..., n, n - p)
    n, k = comp.shape[-2:]
    lead = comp.shape[:-2]
    flat = np.moveaxis(comp.reshape(-1, n, k), 1, 0).reshape(n, -1)  # n x (bases k)
    return np.asarray(np.sum((xw @ flat).reshape(len(xw), -1, k) ** 2, axis=-1).reshape(len(xw), *lead))


def _smooth_ss(u: FloatArray, xw: FloatArray, regular: NDArray[np.bool_]) -> FloatArray:
    """The residual sums of squares of the windows ``xw`` (m x 2w) about one
    polynomial of degree six in ``u`` (their instants in sampling intervals
    from the trial interval's centre). The ``regular`` windows (evenly
    sampled: :func:`_regular`) share one basis, so their residual is a
    projection on its orthogonal complement, a matrix product; only the
    others take a QR each (a whole 75-minute heat run at 200 Hz can be one
    bend: 900,000 windows)."""
    out = np.empty(len(u))
    out[regular] = _complement_ss(xw[regular], _even(u.shape[1])[:, None] ** np.arange(_PARAMS))
    if not np.all(regular):
        irregular = ~regular
        out[irregular] = _residual_ss(u[irregular][..., None] ** np.arange(_PARAMS), xw[irregular])
    return out


def _join_ss(u: FloatArray, xw: FloatArray, regular: NDArray[np.bool_], frac: FloatArray, after: bool) -> FloatArray:
    """The residual sums of squares of the windows ``xw`` (c x 2w, at
    instants ``u``) about the join (:func:`_join_basis`) at each trial
    instant ``frac`` (c x trials). As in :func:`_smooth_ss`, the
    ``regular`` windows share a basis per trial instant: their residuals
    are projections, the others' a QR per window and trial (the QRs were
    0.15 s of the 0.29 s that the 80 drives of the bundled campaign's
    carried input noise took to locate their corners; stop 63)."""
    out = np.empty((len(u), len(frac)))
    if np.any(regular):
        out[regular] = _complement_ss(xw[regular], _join_basis(_even(u.shape[1])[None, :] - frac[:, None], after))
    if not np.all(regular):
        irregular = ~regular
        uc = u[irregular][:, None, :] - frac[None, :, None]  # c x trials x 2w
        out[irregular] = _residual_ss(_join_basis(uc, after), np.broadcast_to(xw[irregular][:, None, :], uc.shape))
    return out


def _join_basis(u: FloatArray, after: bool) -> FloatArray:
    """The join's basis at instants ``u`` from ``tau`` (in sampling
    intervals): a cubic, plus the quartic's higher terms after ``tau`` (or
    before it)."""
    s = np.maximum(u, 0.0) if after else np.minimum(u, 0.0)
    return np.stack([u**0, u, u**2, u**3, s**2, s**3, s**4], axis=-1)


def _join_basis_slope(u: FloatArray, after: bool) -> FloatArray:
    """The derivative of :func:`_join_basis` in ``u`` (the join's instant
    moves the other way)."""
    s = np.maximum(u, 0.0) if after else np.minimum(u, 0.0)
    return np.stack([0.0 * u, u**0, 2 * u, 3 * u**2, 2 * s, 3 * s**2, 4 * s**3], axis=-1)


def corners(t: FloatArray, x: FloatArray, sigma: float, bends: NDArray[np.bool_]) -> FloatArray:
    """The instants, s (sorted), where the sampled input ``x`` of white
    noise ``sigma`` has a corner, sought in the intervals whose two samples
    are both in ``bends`` (where the smoothing kept the raw samples).

    >>> import numpy as np
    >>> t = np.arange(0.0, 0.3, 0.005)
    >>> s = np.clip((t - 0.1013) / 0.05, 0.0, 1.0)
    >>> x = 0.043 * 0.5 * (1.0 - np.cos(np.pi * s))
    >>> np.round(corners(t, x, 1e-6, np.ones(len(t), bool)) * 1e3, 1)  # on a grid of 0.31 ms
    array([101.4, 151.4])
    """
    t = np.asarray(t, float)
    x = np.asarray(x, float)
    n, w = len(t), CORNER_HALF_WINDOW
    if n < 2 * w or not np.all(np.isfinite(x)) or not np.all(np.isfinite(t)):
        return np.zeros(0)
    ks = np.flatnonzero(bends[:-1] & bends[1:])
    ks = ks[(ks >= w - 1) & (ks + w + 1 <= n)]
    if ks.size == 0:
        return np.zeros(0)
    win = ks[:, None] + np.arange(-w + 1, w + 1)[None, :]  # m x 2w
    h = t[ks + 1] - t[ks]
    if np.any(h <= 0):
        return np.zeros(0)
    u = (t[win] - 0.5 * (t[ks] + t[ks + 1])[:, None]) / h[:, None]
    xw = x[win] - x[win].mean(axis=1, keepdims=True)
    regular = _regular(u)
    smooth_ss = _smooth_ss(u, xw, regular)
    floor = CORNER_MIN_GAIN * max(sigma, 1e-12) ** 2
    # The join's sum of squares is at least zero: an interval whose smooth
    # fit is already within the gain holds no corner (a sine sampled a few
    # times a cycle, where the whole record is a bend).
    cand = np.flatnonzero(smooth_ss > floor)
    if cand.size == 0:
        return np.zeros(0)
    frac = (np.arange(CORNER_TRIALS) + 0.5) / CORNER_TRIALS - 0.5  # trial tau, in intervals from the centre
    # The cubic on either side: the other side's curve is the quartic.
    join_ss = np.minimum(*(_join_ss(u[cand], xw[cand], regular[cand], frac, after) for after in (True, False)))
    best = np.argmin(join_ss, axis=1)
    gain = smooth_ss[cand] - join_ss[np.arange(cand.size), best]
    taus = t[ks[cand]] + (frac[best] + 0.5) * h[cand]
    found: list[tuple[int, float]] = []
    for j in np.argsort(-gain):
        if gain[j] < floor:
            break
        k = int(ks[cand[j]])
        if all(abs(k - kk) >= w for kk, _ in found):
            found.append((k, float(taus[j])))
    return np.sort(np.array([tau for _, tau in found], float))


#: A clock's jitter is read from the joins' residuals when their excess over
#: the white noise stands this many standard errors (of the noise's own sum
#: of squares) above none: at three, 14 of 200 jitter-free draws of four
#: steps read 12-29 us (the sum of squares is skewed, and the noise's level
#: is itself read); at four, 3 of 100.
JITTER_MIN_T = 4.0
#: A join whose residual a jump in the velocity at ``tau`` (one parameter
#: more) lowers by more than this F ratio (its 99 % point on 1 and 3 - 1
#: degrees of freedom) is a corner the join does not follow (a ramp's), and
#: its residual is the shape's, not the clock's: a linear ramp of 20-60 mm
#: over 50 ms read a jitter of 120 us where there was none.
JITTER_VELOCITY_JUMP_F = 98.5
#: Trial instants over two of corners()'s trial spacings around each
#: corner, where its join's residual is read.
JOIN_REFINE_TRIALS = 129


@dataclass(frozen=True)
class JoinResidual:
    """What the joins at an input's corners leave beyond its white noise:
    the sum of squares above the noise's expectation, m^2; the rate's square
    in the same projection, ``sum M_ii rate_i^2`` (m^2/s^2), with ``M`` the
    joins' residual projections; and the noise's own sum of squares'
    variance, m^4. A sample taken ``delta`` late reads ``x + rate * delta``:
    with a jitter of ``s`` the excess is ``s^2`` times the rate's square
    (:func:`clock_jitter`)."""

    excess_ss: float = 0.0
    rate_ss: float = 0.0
    null_var: float = 0.0


def join_residual(t: FloatArray, x: FloatArray, sigma: float, instants: FloatArray, rate: FloatArray) -> JoinResidual:
    """:class:`JoinResidual` of the input ``x`` (white noise ``sigma``, rate
    of change ``rate``) at its corners ``instants`` (:func:`corners`)."""
    t = np.asarray(t, float)
    x = np.asarray(x, float)
    rate = np.asarray(rate, float)
    n, w = len(t), CORNER_HALF_WINDOW
    excess = rate_ss = null_var = 0.0
    for tau in np.asarray(instants, float):
        k = int(np.searchsorted(t, tau)) - 1
        if k - w + 1 < 0 or k + w + 1 > n or not np.all(np.isfinite(x[k - w + 1:k + w + 1])):
            continue
        win = np.arange(k - w + 1, k + w + 1)
        u = (t[win] - tau) / (t[k + 1] - t[k])
        xw = x[win] - x[win].mean()
        after = min((True, False), key=lambda a: float(_residual_ss(_join_basis(u, a), xw)))
        # The instant on a finer grid than corners()'s: its grid's error
        # (up to a 32nd of an interval) leaves a residual of second order
        # in it, which read as a jitter of 0.0019 sampling intervals on
        # noise-free raised cosines of 8-12 samples a rise (0.0005 on a
        # grid four times finer, where the quartic's own miss is left): on
        # the bundled campaign's slow steps at 5 Hz, 381 us where there was
        # none.
        shift = np.linspace(-1.0, 1.0, JOIN_REFINE_TRIALS) / CORNER_TRIALS
        uu = u[None, :] - shift[:, None]
        trial_ss = _residual_ss(_join_basis(uu, after), np.broadcast_to(xw, uu.shape))
        best = int(np.argmin(trial_ss))
        u, ss = uu[best], float(trial_ss[best])
        basis = _join_basis(u, after)
        kink = np.maximum(u, 0.0) if after else np.minimum(u, 0.0)
        ss_jump = float(_residual_ss(np.column_stack([basis, kink]), xw))
        dof_jump = len(win) - _PARAMS - 1
        if ss_jump > 0.0 and (ss - ss_jump) / (ss_jump / dof_jump) > JITTER_VELOCITY_JUMP_F:
            continue
        # The corner's instant was fitted too (it takes about one degree of
        # freedom of the three: without it the jitter read 0.78 x the truth
        # at the median): the projection is the one with the join's slope in
        # tau, to first order.
        coef = np.linalg.lstsq(basis, xw, rcond=None)[0]
        q = np.linalg.qr(np.column_stack([basis, _join_basis_slope(u, after) @ coef]))[0]
        m = np.eye(len(win)) - q @ q.T
        diag = np.diag(m)
        excess += ss - sigma**2 * float(np.sum(diag))
        rate_ss += float(np.sum(diag * rate[win] ** 2))
        null_var += 2.0 * sigma**4 * float(np.sum(m**2))
    return JoinResidual(excess, rate_ss, null_var)


def clock_jitter(parts: Sequence[JoinResidual]) -> float:
    """The sample-time jitter, s (standard deviation), the joins of inputs
    sampled by one clock show together (:func:`join_residual`), zero where
    their excess is not :data:`JITTER_MIN_T` standard errors above none.

    Why: a rig's clock samples the input as it samples the outputs, and on
    the SDOF rig the damper turns the base's late and early samples into
    force. hpctl's virtual SDOF step, damper on, its base sampled with a
    120 us jitter, left the body at 1.39 x its weights over the record and
    2.75 x in the half second after the step, at the truth (1.11 and 1.00 x
    without). One record's two corners read the jitter within a factor of
    about two (the foreign control campaign, seed 12, 120 us: 81-203 us
    from its four SDOF steps), so the records of one rig are read together.

    Unbiased for a residual of noise and jitter: the expected sum of squares
    is ``sum M_ii (sigma^2 + rate_i^2 s^2)``."""
    excess = sum(p.excess_ss for p in parts)
    rate_ss = sum(p.rate_ss for p in parts)
    null_var = sum(p.null_var for p in parts)
    if rate_ss <= 0.0 or null_var <= 0.0 or not np.isfinite(excess) or excess < JITTER_MIN_T * np.sqrt(null_var):
        return 0.0
    return float(np.sqrt(excess / rate_ss))

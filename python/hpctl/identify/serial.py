"""Serially correlated output noise in the fit's covariance.

A transducer's noise is rarely white: an amplifier's drift, mains pick-up
and an anti-alias filter make neighbouring samples share part of it (the
foreign rig's channels carry up to half their variance as first-order
coloured noise with 2-50 ms correlation times). A covariance that takes
the residuals as independent then counts every sample as new information
and its standard errors come out too small wherever the sampling is
faster than the correlation: on the foreign rig's 1 Hz sine (5 ms
samples) against a 38 ms pressure noise, the gas time constant's
exponent came out 1.119 +- 0.028 against a truth of 1 (4.3 standard
errors; FOREIGN_RIG_SEED=1696361428, docs/foreign-rig.md).

This module estimates, per record and channel, the autocorrelation of
the output noise from the residuals themselves (what the carried input
noise explains taken out) and builds the part of the sandwich's middle
matrix that the output noise contributes with it: a heteroskedasticity-
and-autocorrelation-consistent estimate (Newey and West 1987) with a
truncated kernel whose length each block chooses from its own
autocorrelation. Without correlation it is the independent case exactly.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np
from numpy.typing import NDArray

FloatArray = NDArray[np.float64]

#: Longest lag taken in, as a share of a block's samples: past it the
#: sample autocorrelation is mostly its own estimation error.
MAX_LAG_SHARE = 0.25

#: And in samples: a transducer's noise is correlated over tens of
#: milliseconds (the foreign rig's up to 50 ms: 10 samples at 5 ms), while
#: a residual the model leaves (a 75-minute heat run's slow drift) can stay
#: above the band for thousands of samples, each lag a k x k product over
#: the whole block. 64 lags are 320 ms at
#: the fastest sampling the records use.
MAX_LAGS = 64

#: The autocorrelation is summed up to the first lag where it falls below
#: this many standard errors of a sample autocorrelation of uncorrelated
#: noise (1/sqrt(n)): inside the band it cannot be told from none.
BAND_Z = 2.0


def output_autocorrelation(residual: FloatArray, input_draws: FloatArray | None) -> FloatArray:
    """rho(1), rho(2), ... of the output noise in one block of residuals
    (one channel of one record), up to the first lag inside the band of
    no correlation (empty if lag 1 already is). ``input_draws`` (samples
    x draws): what fresh draws of the measured input's noise change in the
    residuals; its own autocovariance is taken out, since the covariance
    counts the input noise's part from those draws already."""
    n = len(residual)
    max_lag = min(int(MAX_LAG_SHARE * n), MAX_LAGS)
    if max_lag < 1:
        return np.zeros(0)
    e = residual - residual.mean()
    gamma = _autocovariance(e[:, None], max_lag)
    if input_draws is not None and input_draws.shape[1] > 1:
        d = input_draws - input_draws.mean(axis=1, keepdims=True)
        gamma -= _autocovariance(d, max_lag) / (d.shape[1] - 1)
    if not gamma[0] > 0.0:  # also NaN: nothing left for the output noise
        return np.zeros(0)
    rho = gamma[1:] / gamma[0]
    below = np.flatnonzero(~(rho >= BAND_Z / math.sqrt(n)))
    return np.asarray(np.clip(rho[: below[0] if below.size else len(rho)], 0.0, 1.0), float)


def _autocovariance(x: FloatArray, max_lag: int) -> FloatArray:
    """sum over columns of sum_t x_t x_{t+l} / n, l = 0..max_lag (through
    the FFT: the input noise's 32 draws over a 45,000-sample block lag by
    lag took 0.35 s)."""
    n = x.shape[0]
    f = np.fft.rfft(x, n=2 * n, axis=0)
    acov = np.fft.irfft(np.sum(np.abs(f) ** 2, axis=1), n=2 * n)
    return np.asarray(acov[: max_lag + 1] / n, float)


def output_meat(
    j_data: FloatArray, share: FloatArray, residual: FloatArray, blocks: Sequence[int], input_draws: FloatArray | None
) -> FloatArray:
    """sum over blocks of A' R A, A the data Jacobian's rows scaled by the
    square root of each residual's output-noise share and R the block's
    output-noise correlation (Toeplitz in :func:`output_autocorrelation`);
    times the output noise's variance per unit share it is that noise's
    part of the sandwich's middle matrix. ``blocks``: the lengths of the
    consecutive blocks of rows (channels of records, in the residual
    vector's order)."""
    a = j_data * np.sqrt(share)[:, None]
    meat = a.T @ a
    start = 0
    for n in blocks:
        sl = slice(start, start + n)
        start += n
        rho = output_autocorrelation(residual[sl], None if input_draws is None else input_draws[sl])
        if rho.size == 0:
            continue
        # sum over lags of rho(l) sum_t a_t a_{t+l}' = A' B with B the rows
        # of A ahead by l, weighted by rho(l) and summed: one product over
        # the block instead of one per lag.
        ab = a[sl]
        ahead = np.zeros_like(ab)
        for lag, r in enumerate(rho, start=1):
            ahead[: n - lag] += r * ab[lag:]
        c = ab.T @ ahead
        meat += c + c.T
    return np.asarray(meat)

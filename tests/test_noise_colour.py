"""Coloured measurement noise: what the fourth difference reads of it, and
its correlated part identified from records of one channel sampled at
different rates (hpctl.identify.signals.noise_colour).

The noise here is drawn with SciPy's lfilter (an exact AR(1) in the
samples, the Ornstein-Uhlenbeck process sampled at a constant interval),
independent of hpctl and of the foreign rig's generator."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.linalg import toeplitz
from scipy.signal import lfilter
from scipy.stats import binom

from hpctl.identify.dataset import _channel_var
from hpctl.identify.signals import NoiseLevel, difference_share, differences_are_noise, noise_colour, noise_level, noise_sigma

# The foreign rig's five-sine sweep: two cycles of 0.01-1 Hz, 200 samples a cycle.
SWEEP_DT_S = (0.5, 1 / 6, 0.05, 1 / 60, 0.005)
SAMPLES = 400


def ou(rng: np.random.Generator, n: int, dt_s: float, corr_time_s: float, sigma: float) -> np.ndarray:
    a = math.exp(-dt_s / corr_time_s)
    e = rng.normal(0.0, sigma * math.sqrt(1.0 - a * a), n + 2000)
    return np.asarray(lfilter([1.0], [1.0, -a], e))[2000:]  # stationary after the burn-in


def levels(rng: np.random.Generator, white: float, coloured: float, corr_time_s: float, dts: tuple[float, ...] = SWEEP_DT_S,
           samples: int = SAMPLES) -> list[tuple[float, int, NoiseLevel]]:
    out = []
    for dt in dts:
        y = rng.normal(0.0, white, samples) + (ou(rng, samples, dt, corr_time_s, coloured) if coloured > 0 else 0.0)
        out.append((dt, samples, noise_level(y)))
    return out


@pytest.mark.parametrize("order", [4, 6, 8])
@pytest.mark.parametrize("rho", [0.0, 0.3, 0.717, 0.95])
def test_the_differences_read_the_share_the_autocovariance_gives(rho: float, order: int) -> None:
    # Var(c . x) = c^T R c for the difference weights c (binomial, signs
    # alternating) and the process's correlation matrix R (rho^|i-j|), over
    # Var(c . white) = c . c (70 for the fourth).
    c = np.array([(-1.0) ** i * math.comb(order, i) for i in range(order + 1)])
    r = toeplitz(rho ** np.arange(order + 1))
    assert float(difference_share(rho, order)) == pytest.approx(float(c @ r @ c) / float(c @ c), rel=1e-12)
    if order == 4:
        assert float(difference_share(rho)) == pytest.approx((70 - 112 * rho + 56 * rho**2 - 16 * rho**3 + 2 * rho**4) / 70, rel=1e-12)


def test_the_share_is_what_noise_sigma_reads_of_correlated_noise() -> None:
    rng = np.random.default_rng(5)
    for corr_time_s in (0.005, 0.02):
        reads = np.array([noise_sigma(ou(rng, SAMPLES, 0.005, corr_time_s, 1.0)) ** 2 for _ in range(400)])
        # 400 draws of a level scattering by sqrt(5 / 400) = 11 %: the mean within 3 of its errors.
        expected = float(difference_share(math.exp(-0.005 / corr_time_s)))
        assert abs(reads.mean() - expected) < 3 * expected * math.sqrt(5.0 / SAMPLES / 400), (corr_time_s, reads.mean(), expected)


def test_white_noise_is_rarely_taken_for_coloured() -> None:
    rng = np.random.default_rng(11)
    draws = 2000
    alarms = sum(noise_colour("p_gas2_pa", levels(rng, 1.0, 0.0, 0.01)) is not None for _ in range(draws))
    # Measured 2 in 4,000; a count above the bound has probability below
    # 1e-3 if the true rate were 0.5 %.
    assert alarms <= binom.ppf(0.999, draws, 0.005), alarms


@pytest.mark.parametrize("corr_time_s", [0.015, 0.05])
def test_half_the_variance_correlated_is_found_and_the_fast_record_given_it_back(corr_time_s: float) -> None:
    # Half of the noise's variance correlated over 15 or 50 ms: the 1 Hz
    # sine's fourth difference reads 0.77 or 0.73 of the noise.
    rng = np.random.default_rng(int(corr_time_s * 1e3))
    found, fastest = 0, []
    for _ in range(300):
        lv = levels(rng, math.sqrt(0.5), math.sqrt(0.5), corr_time_s)
        k = noise_colour("p_gas2_pa", lv)
        found += k is not None
        dt, _, level = lv[-1]
        fastest.append(math.sqrt(level.sigma**2 + (k.missed_var(dt, level.order) if k else 0.0)))
    # Found in most campaigns (measured 0.77 and 0.94).
    assert found / 300 > 0.5, found
    # The fastest record's level, corrected, is the noise's (1): the median
    # within 5 %, and no more over-read than the level of white noise is by
    # its own scatter (90 % below 1.07 measured; 1.10 allowed).
    f = np.array(fastest)
    assert 0.95 < float(np.median(f)) < 1.05 and float(np.quantile(f, 0.9)) < 1.10, (np.median(f), np.quantile(f, 0.9))


# The foreign rig's heat case: its three short sines (0.03, 0.3 and 1 Hz)
# sampled 6, 60 and 200 times a second, 401 samples each.
HEAT_DT_S = (1 / 6, 1 / 60, 0.005)


def foreign_noise_total(rng: np.random.Generator, dts: tuple[float, ...]) -> float:
    """The noise total the records' levels give over the truth's, for the
    foreign rig's draw (tests/foreign_rig/draw.py: up to half the variance
    correlated, over 2-50 ms; the total 1)."""
    frac, corr_time_s = rng.uniform(0.0, 0.5), math.exp(rng.uniform(math.log(2e-3), math.log(5e-2)))
    lv = levels(rng, math.sqrt(1 - frac), math.sqrt(frac), corr_time_s, dts, SAMPLES + 1)
    return math.sqrt(channel_noise_var(lv))


def channel_noise_var(lv: list[tuple[float, int, NoiseLevel]]) -> float:
    """The channel's noise variance as `prepare` takes it from its records'
    levels (the colour's total where one is found)."""
    var = _channel_var(lv, noise_colour("force_n", lv))
    assert var is not None
    return var


def test_three_records_do_not_extrapolate_a_correlation_they_barely_see() -> None:
    # FOREIGN_RIG_SEED=1229674921's force (the truth 37.0 N, 26.8 white and
    # 25.5 correlated over 34 ms): the three sines read these levels, and
    # with correlation times up to the slowest record's interval the colour
    # was 29.1 N white and 40.5 N correlated over 167 ms, 50 N in all
    # (1.35 x), the heat run's weights with it.
    lv = [(1 / 6, 401, NoiseLevel(41.49, 4, True)), (1 / 60, 401, NoiseLevel(28.88, 4, True)), (0.005, 401, NoiseLevel(32.11, 4, True))]
    total = math.sqrt(channel_noise_var(lv))
    assert total <= 1.25 * 37.0, (total, noise_colour("force_n", lv))
    # Over the foreign rig's draws sampled as those records: read over 1.25 x
    # the truth in 30 of 4,000 with that bound, 1 with a third of it (stop
    # 46); the count below is at most 5 with probability 0.999 at a rate of
    # 1 in 2,000, at most 4 with probability 0.0008 at the old rate.
    rng = np.random.default_rng(46)
    totals = np.array([foreign_noise_total(rng, HEAT_DT_S) for _ in range(2000)])
    over = int(np.sum(totals > 1.25))
    assert over <= binom.ppf(0.999, 2000, 0.0005), (over, np.quantile(totals, [0.5, 0.99, 0.999]))
    # and not read low for it: the median within 5 % (0.97 measured: the
    # fast records' differences miss some of the correlated part where it
    # is not found).
    assert 0.95 < float(np.median(totals)) < 1.05, np.median(totals)


def test_no_colour_from_records_sampled_alike_or_too_few() -> None:
    rng = np.random.default_rng(3)
    same = [(0.005, SAMPLES, noise_level(rng.normal(0.0, s, SAMPLES))) for s in (1.0, 0.6, 0.4, 1.0)]
    assert noise_colour("force_n", same) is None
    assert noise_colour("force_n", [(0.5, SAMPLES, NoiseLevel(1.0, 4, True)), (0.005, SAMPLES, NoiseLevel(0.5, 4, True))]) is None
    nan = [(0.5, SAMPLES, NoiseLevel(1.0, 4, True)), (0.05, SAMPLES, NoiseLevel(math.nan, 4, True)), (0.005, SAMPLES, NoiseLevel(0.5, 4, True))]
    assert noise_colour("force_n", nan) is None


def test_noise_white_or_correlated_passes_for_noise() -> None:
    rng = np.random.default_rng(8)
    for corr_time_s in (0.0, 0.005, 0.05):
        flagged = 0
        for _ in range(500):
            y = rng.normal(0.0, 0.7, SAMPLES) + (ou(rng, SAMPLES, 0.005, corr_time_s, 0.7) if corr_time_s else 0.0)
            flagged += not differences_are_noise(y)
        assert flagged <= 2, (corr_time_s, flagged)


@pytest.mark.parametrize("ripple_pa", [5e5, 1e6])
def test_a_signal_rough_on_the_sampling_scale_is_read_from_higher_differences_and_not_taken_for_colour(ripple_pa: float) -> None:
    # A strut pressure whose compression half carries a 2 Hz component of
    # 0.5 or 1 MPa (the damper's knee at work), 0.5 Hz sampled at 20 Hz as
    # the foreign rig's heat run, 4 kPa of white noise: its fourth
    # difference reads 6.8 or 11.7 kPa, the signal too (the heat run's read
    # 11.6); the sixth and eighth still a little of it.
    rng = np.random.default_rng(4)
    t = np.arange(0.0, 600.0, 0.05)
    signal = 15e6 + 4e6 * np.sin(np.pi * t) + ripple_pa * np.maximum(np.sin(np.pi * t), 0.0) ** 2 * np.sin(4.0 * np.pi * t)
    y = signal + rng.normal(0.0, 4e3, len(t))
    assert noise_sigma(y) > 1.5 * 4e3 and not differences_are_noise(y)
    # A higher order reads the noise within 5 %.
    level = noise_level(y)
    assert level.order > 4 and level.sigma == pytest.approx(4e3, rel=0.05), level
    # Beside the sweep's five clean records the level read implies no
    # colour; nor does the fourth difference's, were it taken for noise:
    # the 0.1 Hz sine, sampled alike, reads 4 kPa, and no colour explains
    # both (the consistency bound).
    clean = [(dt, SAMPLES, noise_level(rng.normal(0.0, 4e3, SAMPLES))) for dt in SWEEP_DT_S]
    assert noise_colour("p_gas_pa", [*clean, (0.05, len(t), NoiseLevel(noise_sigma(y), 4, True))]) is None
    assert noise_colour("p_gas_pa", [*clean, (0.05, len(t), level)]) is None
    assert noise_colour("p_gas_pa", [*clean, (0.05, len(t), NoiseLevel(noise_sigma(y), 4, False))]) is None


def test_a_level_the_signal_raises_is_set_aside_and_the_colour_found_in_the_others() -> None:
    # The foreign control campaign's strut gas pressure (seed 11: 2.26 kPa
    # white, 1.85 correlated over 33 ms): the sweep's five sines, the fast
    # record at 2 ms and five records at 5 ms, the 1 Hz sine's and the fast
    # record's levels raised a fifth by the signal (they read 2.77 and 2.73
    # kPa where the steps at 5 ms read 2.23-2.30). Without setting them
    # aside no colour was found in 14 of 100 such draws, and the steps'
    # weights missed the correlated part (their residual 1.34 x); with it,
    # in 85, the total's median 2.94 kPa (the truth 2.92).
    rng = np.random.default_rng(49)
    truth = math.hypot(2260.0, 1850.0)
    totals = []
    for _ in range(40):
        lv = (levels(rng, 2260.0, 1850.0, 0.033, SWEEP_DT_S, 401) + levels(rng, 2260.0, 1850.0, 0.033, (0.002,), 1501)
              + levels(rng, 2260.0, 1850.0, 0.033, (0.005,) * 5, 1001))
        for i in (4, 5):
            dt, n, level = lv[i]
            lv[i] = (dt, n, NoiseLevel(1.2 * level.sigma, level.order, True))
        colour = noise_colour("p_gas_pa", lv)
        if colour is not None:
            totals.append(math.sqrt(colour.white_var + colour.coloured_var))
    assert len(totals) >= 28, len(totals)
    assert float(np.median(totals)) == pytest.approx(truth, rel=0.1), (np.median(totals), truth)


def test_a_colour_the_levels_suggest_but_do_not_establish_is_a_hint_of_the_right_size() -> None:
    # Three records sampled as the foreign rig's short sweep, 401 samples
    # each. White noise: a hint (COLOUR_HINT_EVIDENCE, the 95 % point of
    # chi-square on two) in 1.5 % of 2,000 campaigns measured (1,000 here); 40 % of the
    # variance correlated over 35 ms: established in 26 % of 300, only
    # suggested in 48 % more, and a suggested colour's total is the noise's
    # (median 1.01, 10-90 % 0.96-1.06 measured).
    from hpctl.identify.signals import COLOUR_HINT_EVIDENCE

    rng = np.random.default_rng(74)
    draws = 1000
    hints = 0
    for _ in range(draws):
        lv = levels(rng, 1.0, 0.0, 0.01, HEAT_DT_S, SAMPLES + 1)
        hint = noise_colour("force_n", lv, COLOUR_HINT_EVIDENCE)
        hints += hint is not None
        # Established implies suggested: one rule, two thresholds.
        assert noise_colour("force_n", lv) is None or hint is not None
    assert hints <= binom.ppf(0.999, draws, 0.03), hints
    suggested, totals = 0, []
    for _ in range(300):
        lv = levels(rng, math.sqrt(0.6), math.sqrt(0.4), 0.035, HEAT_DT_S, SAMPLES + 1)
        hint = noise_colour("force_n", lv, COLOUR_HINT_EVIDENCE)
        if noise_colour("force_n", lv) is None and hint is not None:
            suggested += 1
            totals.append(math.sqrt(hint.white_var + hint.coloured_var))
    assert suggested / 300 > 0.3, suggested
    assert 0.95 < float(np.median(totals)) < 1.05 and 0.9 < float(np.quantile(totals, 0.1)) and float(np.quantile(totals, 0.9)) < 1.1, totals

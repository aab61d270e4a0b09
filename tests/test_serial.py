"""The output noise's autocorrelation in the fit's covariance
(hpctl.identify.serial), against what it did not compute: the spread of
least-squares estimates over many draws of known coloured noise, and the
closed form for a mean under first-order autoregressive noise."""

from __future__ import annotations

import numpy as np

from hpctl.identify.serial import output_autocorrelation, output_meat


def _ar1(rng: np.random.Generator, n: int, phi: float, draws: int) -> np.ndarray:
    """``draws`` columns of unit-variance AR(1) noise, coefficient ``phi``."""
    e = rng.normal(size=(n, draws))
    x = np.empty_like(e)
    x[0] = e[0]
    for t in range(1, n):
        x[t] = phi * x[t - 1] + np.sqrt(1.0 - phi**2) * e[t]
    return x


def _sandwich_sd(j: np.ndarray, r: np.ndarray, blocks: list[int]) -> np.ndarray:
    s2 = float(r @ r) / (len(r) - j.shape[1])
    bread = np.linalg.inv(j.T @ j)
    return np.sqrt(np.diag(bread @ (s2 * output_meat(j, np.ones(len(r)), r, blocks, None)) @ bread))


def test_white_noise_leaves_the_independent_covariance() -> None:
    # Uncorrelated residuals: no lag is taken in on most draws, and the
    # middle matrix is J'J exactly (the old covariance).
    rng = np.random.default_rng(3)
    n = 400
    j = np.column_stack([np.ones(n), np.sin(np.linspace(0, 6, n))])
    exact = 0
    for _ in range(50):
        r = rng.normal(size=n)
        rho = output_autocorrelation(r, None)
        assert np.all((rho >= 2.0 / np.sqrt(n)) & (rho <= 1.0))
        if rho.size == 0:
            exact += 1
            np.testing.assert_array_equal(output_meat(j, np.ones(n), r, [n], None), j.T @ j)
    # Lag 1 is inside the band on about 97.7 % of draws (one-sided 2 sigma).
    assert exact >= 44, exact


def test_errors_cover_the_spread_under_coloured_noise() -> None:
    # Two blocks (two channels of a record) of a slow regressor pair, noise
    # 40 % white and 60 % AR(1) with coefficient 0.85 (a correlation time
    # of 6 samples: the foreign rig's 38 ms pressure noise at 5 ms). The
    # spread of the least-squares estimates over 400 draws is what the
    # errors must match; independent errors are about half of it.
    rng = np.random.default_rng(11)
    n, draws, phi, coloured = 400, 400, 0.85, 0.6
    t = np.linspace(0.0, 1.0, n)
    block = np.column_stack([np.ones(n), np.sin(2 * np.pi * 2 * t)])
    j = np.vstack([block, 0.5 * block])
    noise = (np.sqrt(1 - coloured) * rng.normal(size=(2 * n, draws))
             + np.sqrt(coloured) * np.vstack([_ar1(rng, n, phi, draws), _ar1(rng, n, phi, draws)]))
    estimates, hac, independent = [], [], []
    for k in range(draws):
        y = noise[:, k]
        beta, *_ = np.linalg.lstsq(j, y, rcond=None)
        r = y - j @ beta
        estimates.append(beta)
        hac.append(_sandwich_sd(j, r, [n, n]))
        independent.append(np.sqrt(np.diag(np.linalg.inv(j.T @ j)) * float(r @ r) / (2 * n - 2)))
    spread = np.std(np.array(estimates), axis=0, ddof=1)  # sampling error about 3.5 %
    ratio = np.mean(np.array(hac), axis=0) / spread
    naive = np.mean(np.array(independent), axis=0) / spread
    # The truncated kernel stops where the autocorrelation meets the band
    # (about lag 10 of a decay to 0.85^10 = 0.2 of the coloured part): it
    # misses the tail, a few per cent to 15 % of the error.
    print(f"errors over spread: serial {ratio}, independent {naive}")
    assert np.all((ratio > 0.8) & (ratio < 1.1)), (ratio, naive)
    assert np.all(naive < 0.6), naive
    # The closed form for the mean of AR(1) noise: variance factor
    # 1 + 2 sum rho(l) = (1 + phi) / (1 - phi) for the coloured part.
    factor = (1 - coloured) + coloured * (1 + phi) / (1 - phi)
    np.testing.assert_allclose(spread[0] / np.sqrt(np.linalg.inv(j.T @ j)[0, 0]), np.sqrt(factor), rtol=0.1)


def test_the_carried_input_noise_is_not_counted_twice() -> None:
    # Residuals that are all carried input noise (the draws show the same
    # correlated process): nothing is left for the output noise's
    # correlation, which comes out empty rather than the input's.
    rng = np.random.default_rng(5)
    n = 400
    carried = _ar1(rng, n, 0.9, 33)
    rho_all = output_autocorrelation(carried[:, 0], None)
    assert rho_all.size > 3  # correlated on its own
    rho_out = output_autocorrelation(carried[:, 0], carried[:, 1:])
    assert rho_out.size <= 1, rho_out


def test_the_autocovariance_through_the_fft_is_the_direct_sum() -> None:
    from hpctl.identify.serial import _autocovariance

    rng = np.random.default_rng(2)
    x = rng.normal(size=(997, 3))
    direct = [float(np.sum(x[: 997 - lag] * x[lag:])) / 997 for lag in range(41)]
    np.testing.assert_allclose(_autocovariance(x, 40), direct, rtol=1e-12, atol=1e-12)

"""The data system: what turns the true signals into a record.

Per channel: the transducer's offset (an effect), white noise, coloured
noise (an Ornstein-Uhlenbeck process with its own correlation time, exact
at any sample spacing) and quantisation to the converter's step. The
transducer lags (force, pressure: an effect; thermocouples: always) are
states of the plant, since a lag needs the continuous signal. Sample-time
jitter: every channel is sampled at ``t_nominal + delta`` (one sample-and-
hold for all), but the logger writes the nominal time.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass

import numpy as np
from numpy.typing import NDArray

FloatArray = NDArray[np.float64]


@dataclass(frozen=True)
class ChannelNoise:
    white: float = 0.0
    coloured: float = 0.0
    corr_time_s: float = 0.0
    lsb: float = 0.0

    @property
    def sigma(self) -> float:
        """Standard deviation of the total measurement noise (quantisation
        counted as uniform, lsb^2/12)."""
        return math.sqrt(self.white**2 + self.coloured**2 + self.lsb**2 / 12.0)

    def as_dict(self) -> dict[str, float]:
        return {**asdict(self), "sigma": self.sigma}


@dataclass(frozen=True)
class DataSystem:
    disp: ChannelNoise = ChannelNoise(white=5e-6, lsb=0.3 / 65536)
    force: ChannelNoise = ChannelNoise(white=30.0, lsb=320e3 / 65536)
    pressure: ChannelNoise = ChannelNoise(white=5e3, lsb=40e6 / 65536)
    temperature: ChannelNoise = ChannelNoise(white=0.1, lsb=0.01)
    jitter_s: float = 0.0

    def for_channel(self, column: str) -> ChannelNoise:
        if column in ("disp_m", "body_disp_m", "base_disp_m"):
            return self.disp
        if column == "force_n":
            return self.force
        if column in ("p_gas_pa", "p_gas2_pa"):
            return self.pressure
        if column in ("t_gas_k", "t_oil_k", "t_amb_k"):
            return self.temperature
        raise KeyError(column)

    def quiet(self) -> DataSystem:
        """No noise, no quantisation, no jitter (for physics checks)."""
        z = ChannelNoise()
        return DataSystem(z, z, z, z, 0.0)


def ou_noise(times_s: FloatArray, sigma: float, corr_time_s: float, rng: np.random.Generator) -> FloatArray:
    """Stationary Ornstein-Uhlenbeck noise of standard deviation ``sigma``
    sampled exactly at ``times_s`` (any spacing)."""
    n = len(times_s)
    if sigma <= 0 or n == 0:
        return np.zeros(n)
    if corr_time_s <= 0:
        return rng.normal(0.0, sigma, n)
    a = np.exp(-np.diff(times_s) / corr_time_s)
    e = rng.normal(0.0, 1.0, n)
    out = np.empty(n)
    out[0] = sigma * e[0]
    s = sigma * np.sqrt(1.0 - a * a)
    for k in range(1, n):
        out[k] = a[k - 1] * out[k - 1] + s[k - 1] * e[k]
    return out


def measure(true: FloatArray, times_s: FloatArray, noise: ChannelNoise, rng: np.random.Generator, offset: float = 0.0) -> FloatArray:
    """The recorded values of one channel."""
    y = np.asarray(true, dtype=float) + offset
    if noise.white > 0:
        y = y + rng.normal(0.0, noise.white, len(y))
    if noise.coloured > 0:
        y = y + ou_noise(times_s, noise.coloured, noise.corr_time_s, rng)
    if noise.lsb > 0:
        y = np.round(y / noise.lsb) * noise.lsb
    return y


def jittered(nominal_s: FloatArray, jitter_s: float, rng: np.random.Generator, duration_s: float) -> FloatArray:
    """The instants the channels were really sampled: nominal plus Gaussian
    jitter, clipped to a third of the neighbouring spacing so that they stay
    in order and inside the test."""
    if jitter_s <= 0:
        return np.asarray(nominal_s, dtype=float).copy()
    t = np.asarray(nominal_s, dtype=float)
    gap = np.diff(t)
    room = np.minimum(np.concatenate(([gap[0]], gap)), np.concatenate((gap, [gap[-1]]))) / 3.0
    delta = np.clip(rng.normal(0.0, jitter_s, len(t)), -room, room)
    return np.clip(t + delta, 0.0, duration_s)

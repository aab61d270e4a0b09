"""Random road profiles after ISO 8608.

The standard describes a road by the power spectral density of its height
over spatial frequency ``n`` (cycles/m):

    G_d(n) = G_d(n0) (n / n0)^-2,   n0 = 0.1 cycles/m,

with the class's geometric mean ``G_d(n0)`` of 16, 64, 256, 1024, ... x 1e-6
m^3 for classes A, B, C, D, ... (each class four times the one before). A
profile is a sum of cosines at ``n_k = k dn`` with amplitudes
``sqrt(2 G_d(n_k) dn)`` and independent uniform phases (an inverse FFT),
band-limited to the standard's range 0.011-2.83 cycles/m, so its
one-sided PSD is ``G_d`` in that band. Driven at a speed ``v`` it becomes a
base displacement ``z(t) = z(x(t))`` for the SDOF rig.

A vehicle needs two tracks, left and right, ``B`` apart (the track width):
:func:`two_tracks` draws them with the same PSD and the coherence of a
homogeneous, isotropic road surface (Dodds and Robson 1973), which for
the standard's exponent of 2 is exactly ``gamma(n) = x K_1(x)``,
``x = 2 pi n B`` (the cross-spectrum of a surface whose 2-D spectrum falls
as ``|k|^-3``): long waves are common to both tracks, short ones
independent. ISO 8608 itself describes one track only.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.special import k1

from hpctl.errors import ParameterError
from hpctl.sim.run import Sampled

FloatArray = NDArray[np.float64]

#: Reference spatial frequency of ISO 8608, cycles/m.
N0_CYCLES_M = 0.1
#: Geometric mean of G_d(n0) per class, m^3.
CLASS_GD_N0_M3: dict[str, float] = {c: 16e-6 * 4.0**k for k, c in enumerate("ABCDEFGH")}
#: The class limits of G_d(n0), m^3 (lower, upper; each class spans a
#: factor of 4 around its geometric mean; A has no lower and H no upper limit).
CLASS_GD_N0_LIMITS_M3: dict[str, tuple[float, float]] = {
    c: (0.0 if c == "A" else g / 2.0, float("inf") if c == "H" else 2.0 * g) for c, g in CLASS_GD_N0_M3.items()
}
#: The spatial frequency band of ISO 8608, cycles/m.
BAND_CYCLES_M = (0.011, 2.83)


def displacement_psd_m3(n_cycles_m: ArrayLike, road_class: str) -> FloatArray:
    """ISO 8608 displacement PSD G_d(n) of ``road_class`` (class geometric mean), m^3."""
    gd0 = _class_gd(road_class)
    n = np.asarray(n_cycles_m, dtype=float)
    return gd0 * (n / N0_CYCLES_M) ** -2


def _class_gd(road_class: str) -> float:
    try:
        return CLASS_GD_N0_M3[road_class.upper()]
    except (KeyError, AttributeError):
        raise ParameterError(f"road class {road_class!r} is not an ISO 8608 class (one of {', '.join(CLASS_GD_N0_M3)})") from None


@dataclass(frozen=True)
class RoadProfile:
    """Road height over distance."""

    distance_m: FloatArray
    height_m: FloatArray
    road_class: str

    def height_at(self, x_m: ArrayLike) -> FloatArray:
        """Height at distances ``x_m`` (linear interpolation between the
        profile's points, which are much closer than the shortest wavelength)."""
        return np.asarray(np.interp(np.asarray(x_m, dtype=float), self.distance_m, self.height_m), dtype=np.float64)


def _grid(length_m: float, dx_m: float, band_cycles_m: tuple[float, float]) -> tuple[int, float, FloatArray]:
    """The FFT grid of a profile: point count, frequency step and the
    frequencies (cycles/m)."""
    if not (np.isfinite(length_m) and length_m > 0):
        raise ParameterError(f"road length_m = {length_m} must be positive")
    if not (np.isfinite(dx_m) and 0 < dx_m <= 0.5 / band_cycles_m[1]):
        raise ParameterError(f"road dx_m = {dx_m} must be positive and resolve the band's top ({band_cycles_m[1]} cycles/m)")
    # The FFT length covers the profile and the longest wavelength.
    count = int(np.ceil(max(length_m, 2.0 / band_cycles_m[0]) / dx_m)) + 1
    count += count % 2
    dn = 1.0 / (count * dx_m)
    return count, dn, np.asarray(np.arange(count // 2 + 1) * dn, dtype=np.float64)


def _amplitudes(road_class: str, n: FloatArray, dn: float, band_cycles_m: tuple[float, float]) -> FloatArray:
    """Cosine amplitudes ``sqrt(2 G_d(n) dn)`` inside the band, zero outside."""
    in_band = (n >= band_cycles_m[0]) & (n <= band_cycles_m[1])
    amplitude = np.zeros_like(n)
    amplitude[in_band] = np.sqrt(2.0 * displacement_psd_m3(n[in_band], road_class) * dn)
    return amplitude


def _synthesise(amplitude: FloatArray, phase: NDArray[np.complex128], count: int) -> FloatArray:
    return np.asarray(np.fft.irfft(0.5 * count * amplitude * phase, n=count), dtype=np.float64)


def profile(road_class: str, length_m: float, *, seed: int, dx_m: float = 0.05, band_cycles_m: tuple[float, float] = BAND_CYCLES_M) -> RoadProfile:
    """A random ISO 8608 profile of ``length_m`` with points every ``dx_m``,
    from a seeded generator (same seed, same road)."""
    _class_gd(road_class)
    count, dn, n = _grid(length_m, dx_m, band_cycles_m)
    rng = np.random.default_rng(seed)
    phase = np.exp(1j * rng.uniform(0.0, 2.0 * np.pi, size=n.size))
    height = _synthesise(_amplitudes(road_class, n, dn, band_cycles_m), phase, count)
    distance = np.arange(count) * dx_m
    keep = distance <= length_m + dx_m
    return RoadProfile(np.asarray(distance[keep], dtype=np.float64), np.asarray(height[keep], dtype=np.float64), road_class.upper())


def isotropic_coherence(n_cycles_m: ArrayLike, track_m: float) -> FloatArray:
    """Coherence of two parallel tracks ``track_m`` apart on an isotropic
    surface with the ISO 8608 exponent 2: ``x K_1(x)``, ``x = 2 pi n B``
    (1 at n = 0; the cross-spectrum over the PSD, real and positive)."""
    x = 2.0 * np.pi * np.asarray(n_cycles_m, dtype=float) * track_m
    with np.errstate(invalid="ignore", divide="ignore"):
        out = np.where(x > 0, x * k1(np.maximum(x, 1e-300)), 1.0)
    return np.asarray(np.clip(out, 0.0, 1.0), dtype=np.float64)


@dataclass(frozen=True)
class RoadTracks:
    """Two wheel tracks on one distance grid."""

    distance_m: FloatArray
    left_m: FloatArray
    right_m: FloatArray
    road_class: str
    track_m: float


def two_tracks(
    road_class: str, length_m: float, *, track_m: float, seed: int, dx_m: float = 0.05, band_cycles_m: tuple[float, float] = BAND_CYCLES_M
) -> RoadTracks:
    """Left and right ISO 8608 tracks ``track_m`` apart: each with the
    class's PSD, with the isotropic coherence between them
    (:func:`isotropic_coherence`). The right track's phase at each frequency
    is the left one's with weight ``gamma`` plus an independent one with
    weight ``sqrt(1 - gamma^2)``, so its PSD is the same and the
    cross-spectrum is ``gamma G_d``."""
    _class_gd(road_class)
    if not (np.isfinite(track_m) and 0 < track_m <= 10):
        raise ParameterError(f"track_m = {track_m} must be within (0, 10] m")
    count, dn, n = _grid(length_m, dx_m, band_cycles_m)
    rng = np.random.default_rng(seed)
    left_phase = np.exp(1j * rng.uniform(0.0, 2.0 * np.pi, size=n.size))
    own_phase = np.exp(1j * rng.uniform(0.0, 2.0 * np.pi, size=n.size))
    gamma = isotropic_coherence(n, track_m)
    right_phase = gamma * left_phase + np.sqrt(1.0 - gamma**2) * own_phase
    amplitude = _amplitudes(road_class, n, dn, band_cycles_m)
    distance = np.arange(count) * dx_m
    keep = distance <= length_m + dx_m
    return RoadTracks(
        np.asarray(distance[keep], dtype=np.float64),
        _synthesise(amplitude, left_phase, count)[keep],
        _synthesise(amplitude, right_phase, count)[keep],
        road_class.upper(),
        float(track_m),
    )


def fade_in(t_s: FloatArray, duration_s: float) -> FloatArray:
    """A raised-cosine ramp from 0 to 1 over ``duration_s`` (C1, so the base
    starts at rest)."""
    u = np.clip(t_s / duration_s, 0.0, 1.0) if duration_s > 0 else np.ones_like(t_s)
    return 0.5 * (1.0 - np.cos(np.pi * u))


def base_motion(road: RoadProfile, distance_m: FloatArray, time_s: FloatArray, *, fade_s: float = 2.0) -> Sampled:
    """The base displacement of a vehicle at ``distance_m(time_s)`` along
    ``road``, faded in over ``fade_s`` from the level of the start (so the
    rig starts at rest), as a sampled motion."""
    z = road.height_at(distance_m)
    z = (z - z[0]) * fade_in(np.asarray(time_s, float) - float(time_s[0]), fade_s)
    return Sampled(np.ascontiguousarray(time_s, dtype=float), np.ascontiguousarray(z, dtype=float))

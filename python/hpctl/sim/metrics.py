"""What a suspension engineer reads off responses: natural frequency,
damping ratio, overshoot, settling time, loop area."""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

FloatArray = NDArray[np.float64]


def crossings_s(t: FloatArray, y: FloatArray, level: float, after_s: float = -math.inf) -> FloatArray:
    """Times at which ``y`` crosses ``level`` (linear interpolation), after ``after_s``."""
    d = np.asarray(y, float) - level
    i = np.flatnonzero((d[:-1] * d[1:] < 0) & (t[:-1] >= after_s))
    return t[i] + (t[i + 1] - t[i]) * d[i] / (d[i] - d[i + 1])


def natural_frequency_hz(t: FloatArray, y: FloatArray, level: float, after_s: float = -math.inf) -> float | None:
    """Frequency of the oscillation about ``level`` from the first full
    period between crossings; ``None`` when it does not oscillate."""
    c = crossings_s(t, y, level, after_s)
    if len(c) < 3:
        return None
    return float(1.0 / (c[2] - c[0]))


def extremes(t: FloatArray, y: FloatArray, level: float, after_s: float = -math.inf) -> list[tuple[float, float]]:
    """The largest excursion from ``level`` between successive crossings:
    (time, excursion) pairs, alternating in sign."""
    c = crossings_s(t, y, level, after_s)
    bounds = np.concatenate(([after_s if math.isfinite(after_s) else t[0]], c, [t[-1]]))
    out = []
    for a, b in zip(bounds[:-1], bounds[1:]):
        m = (t >= a) & (t <= b)
        if not m.any():
            continue
        d = y[m] - level
        k = int(np.argmax(np.abs(d)))
        out.append((float(t[m][k]), float(d[k])))
    return out


def damping_ratio(t: FloatArray, y: FloatArray, level: float, after_s: float = -math.inf) -> float | None:
    """Damping ratio from the logarithmic decrement of successive
    same-sign excursions about ``level``; ``None`` without two of them."""
    ex = [e for _, e in extremes(t, y, level, after_s)]
    pairs = [(ex[i], ex[i + 2]) for i in range(len(ex) - 2) if ex[i] * ex[i + 2] > 0 and abs(ex[i + 2]) > 0]
    if not pairs:
        return None
    a, b = pairs[0]
    delta = math.log(abs(a) / abs(b))
    return float(delta / math.sqrt(4 * math.pi**2 + delta**2))


def overshoot_m(y: FloatArray, level: float, step_m: float) -> float:
    """How far the response went beyond ``level`` in the step's direction."""
    beyond = (np.asarray(y) - level) * math.copysign(1.0, step_m)
    return float(max(0.0, beyond.max()))


def settling_time_s(t: FloatArray, y: FloatArray, level: float, band_m: float, start_s: float) -> float | None:
    """Time from ``start_s`` after which ``y`` stays within ``band_m`` of
    ``level``; ``None`` if it never does."""
    outside = np.flatnonzero(np.abs(np.asarray(y) - level) > band_m)
    if outside.size == 0:
        return 0.0
    last = int(outside[-1])
    if last >= len(t) - 1:
        return None
    return float(max(0.0, t[last + 1] - start_s))


def loop_area_j(x: FloatArray, f: FloatArray) -> float:
    """Area of the force-displacement loop ``closed-integral f dx`` (J) over
    the samples given (one whole cycle); positive when energy is absorbed.

    The polygon is closed from the last sample back to the first: samples
    rarely fall on the period exactly, and an open path adds the force
    times the gap (a few joules at 20 mm, 30 kN) to a loop whose true area
    may be zero (an isothermal gas)."""
    x = np.asarray(x, float)
    f = np.asarray(f, float)
    if x.size < 2:
        return 0.0
    xc = np.append(x, x[0])
    fc = np.append(f, f[0])
    return float(np.sum(0.5 * (fc[1:] + fc[:-1]) * np.diff(xc)))


def gas_work_j(p_pa: FloatArray, v_m3: FloatArray) -> float:
    """Work done on a gas over one cycle, ``-closed-integral p dV`` (J). A
    gas exchanging heat with walls at one temperature cannot give out net
    work over a cycle (Kelvin-Planck): this is >= 0 up to rounding."""
    return -loop_area_j(v_m3, p_pa)


def last_cycle(t: FloatArray, frequency_hz: float) -> NDArray[np.bool_]:
    """Mask of the samples of the last whole period of a sine run."""
    period = 1.0 / frequency_hz
    n = math.floor((t[-1] - t[0]) / period + 1e-9)
    start = t[0] + (n - 1) * period
    return np.asarray(t >= start - 1e-9 * period)


def cycle_stats(t: FloatArray, y: FloatArray, frequency_hz: float, every: int = 1) -> dict[str, FloatArray]:
    """Per whole period of a sine run (or per ``every`` periods): the
    middle time, the mean, the smallest and the largest value of ``y``; a
    long run drawn as these instead of every sample shows its trend (a
    line per cycle at 2,250 cycles is a solid block)."""
    period = every / frequency_hz
    k = np.floor((t - t[0]) / period + 1e-9).astype(np.int64)
    whole = k < math.floor((t[-1] - t[0]) / period + 1e-9)
    k, yy = k[whole], y[whole]
    if k.size == 0:
        empty = np.empty(0)
        return {"time_s": empty, "mean": empty, "min": empty, "max": empty}
    n = int(k[-1]) + 1
    count = np.bincount(k, minlength=n).astype(float)
    mean = np.bincount(k, weights=yy, minlength=n) / np.maximum(count, 1.0)
    lo = np.full(n, np.inf)
    hi = np.full(n, -np.inf)
    np.minimum.at(lo, k, yy)
    np.maximum.at(hi, k, yy)
    keep = count > 0
    return {"time_s": (t[0] + (np.arange(n) + 0.5) * period)[keep], "mean": mean[keep], "min": lo[keep], "max": hi[keep]}


def step_response(t: FloatArray, body_disp_m: FloatArray, strut_disp_m: FloatArray, p_gas_pa: FloatArray,
                  height_m: float, start_s: float, rise_s: float) -> dict[str, float | None]:
    """What the seed's SDOF step test reports: natural frequency, damping
    ratio, overshoot, settling time (5 % band), peak gas pressure, and the
    static strut compression before the step."""
    after = start_s + rise_s
    return {
        "natural_frequency_hz": natural_frequency_hz(t, body_disp_m, height_m, after),
        "damping_ratio": damping_ratio(t, body_disp_m, height_m, after),
        "overshoot_m": overshoot_m(body_disp_m, height_m, height_m),
        "settling_time_s": settling_time_s(t, body_disp_m, height_m, 0.05 * abs(height_m), start_s),
        "peak_p_gas_pa": float(np.max(p_gas_pa)),
        "static_disp_m": float(strut_disp_m[0]),
    }

"""Whole-body vibration after ISO 2631-1:1997: the frequency weightings Wk
(vertical, seated) and Wd (horizontal), the weighted RMS acceleration,
the vibration total value and the vibration dose value (VDV).

Each weighting is the standard's product of four analogue filters
(ISO 2631-1 Annex A, Table A.2; the same parameters as ISO 8041):

    band limiting   H_h(s) = s^2 / (s^2 + w1 s / Q1 + w1^2)          (high pass, f1 = 0.4 Hz)
                    H_l(s) = w2^2 / (s^2 + w2 s / Q1 + w2^2)         (low pass, f2 = 100 Hz), Q1 = 1/sqrt(2)
    a-v transition  H_t(s) = (1 + s / w3) / (1 + s / (Q4 w4) + s^2 / w4^2)
    upward step     H_s(s) = (1 + s / (Q5 w5) + s^2 / w5^2) / (1 + s / (Q6 w6) + s^2 / w6^2) (w5 / w6)^2

with Wk: f3 = f4 = 12.5 Hz, Q4 = 0.63, f5 = 2.37 Hz, Q5 = 0.91, f6 = 3.35 Hz,
Q6 = 0.91; Wd: f3 = f4 = 2.0 Hz, Q4 = 0.63, no upward step. A record is
filtered with the bilinear transform of each section (SciPy): at 1 kHz its
magnitude is within 0.1 % of the analogue weighting up to 16 Hz, 0.4 % at
31.5 Hz and 7 % at 100 Hz (frequency warping near the 100 Hz band limit),
where a vehicle's body vibration has no energy left to speak of.

The standard's comfort measures on the seat surface (section 8.2):
``a_w`` the weighted RMS per axis, ``a_v = sqrt(k_x^2 a_wx^2 + k_y^2
a_wy^2 + k_z^2 a_wz^2)`` with ``k = 1`` for comfort, ``VDV = (int
a_w^4 dt)^(1/4)`` per axis and ``(sum (k VDV_i)^4)^(1/4)`` in total.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import lru_cache

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy import signal

from hpctl.errors import ParameterError

FloatArray = NDArray[np.float64]


@dataclass(frozen=True)
class Weighting:
    """The parameters of one ISO 2631-1 weighting (Hz; ``inf`` = section absent)."""

    name: str
    f1_hz: float
    f2_hz: float
    f3_hz: float
    f4_hz: float
    q4: float
    f5_hz: float
    q5: float
    f6_hz: float
    q6: float

    def analogue(self) -> list[tuple[FloatArray, FloatArray]]:
        """The four sections as (numerator, denominator) polynomials in s."""
        w = [2.0 * math.pi * f for f in (self.f1_hz, self.f2_hz, self.f3_hz, self.f4_hz, self.f5_hz, self.f6_hz)]
        w1, w2, w3, w4, w5, w6 = w
        q1 = 1.0 / math.sqrt(2.0)
        sections = [
            (np.array([1.0, 0.0, 0.0]), np.array([1.0, w1 / q1, w1**2])),
            (np.array([w2**2]), np.array([1.0, w2 / q1, w2**2])),
            (np.array([1.0 / w3, 1.0]), np.array([1.0 / w4**2, 1.0 / (self.q4 * w4), 1.0])),
        ]
        if math.isfinite(w5) and math.isfinite(w6):
            # (1 + s/(Q5 w5) + s^2/w5^2) (w5/w6)^2 / (1 + s/(Q6 w6) + s^2/w6^2), in monic form.
            sections.append((np.array([1.0, w5 / self.q5, w5**2]), np.array([1.0, w6 / self.q6, w6**2])))
        return sections

    def magnitude(self, f_hz: ArrayLike) -> FloatArray:
        """|W(j 2 pi f)| of the analogue weighting."""
        s = 2j * math.pi * np.asarray(f_hz, dtype=float)
        h = np.ones_like(s)
        for b, a in self.analogue():
            h = h * np.polyval(b, s) / np.polyval(a, s)
        return np.asarray(np.abs(h), dtype=np.float64)

    def sos(self, fs_hz: float) -> FloatArray:
        """Second-order sections of the digital filter at ``fs_hz`` (bilinear
        transform; designed once per weighting and rate, a copy returned)."""
        if not (math.isfinite(fs_hz) and fs_hz > 4.0 * min(self.f2_hz, 0.5 * fs_hz)):
            raise ParameterError(f"sampling rate fs_hz = {fs_hz} is too low for the weighting")
        return _sos(self, fs_hz).copy()


@lru_cache(maxsize=32)
def _sos(weighting: Weighting, fs_hz: float) -> FloatArray:
    """:meth:`Weighting.sos`, cached: the design (SciPy's bilinear transform
    and tf2sos through numpy's polynomials) took 11 % of a tuning
    candidate's time, in Python under the GIL, for the same few filters
    every time."""
    out = []
    for b, a in weighting.analogue():
        bz, az = signal.bilinear(b, a, fs=fs_hz)
        out.append(signal.tf2sos(bz, az))
    sos = np.asarray(np.vstack(out), dtype=np.float64)
    sos.flags.writeable = False
    return sos


#: Vertical acceleration, seated (ISO 2631-1 Table A.2).
WK = Weighting("Wk", 0.4, 100.0, 12.5, 12.5, 0.63, 2.37, 0.91, 3.35, 0.91)
#: Horizontal acceleration, seated (ISO 2631-1 Table A.2).
WD = Weighting("Wd", 0.4, 100.0, 2.0, 2.0, 0.63, math.inf, 1.0, math.inf, 1.0)


def weighted(acc_m_s2: ArrayLike, dt_s: float, weighting: Weighting) -> FloatArray:
    """The frequency-weighted acceleration of a record sampled every ``dt_s``."""
    a = np.asarray(acc_m_s2, dtype=float)
    if not (math.isfinite(dt_s) and dt_s > 0):
        raise ParameterError(f"dt_s = {dt_s} must be positive")
    return np.asarray(signal.sosfilt(weighting.sos(1.0 / dt_s), a), dtype=np.float64)


def rms(x: ArrayLike) -> float:
    a = np.asarray(x, dtype=float)
    return float(np.sqrt(np.mean(a * a))) if a.size else math.nan


def vdv(x: ArrayLike, dt_s: float) -> float:
    """Vibration dose value of a weighted acceleration, m/s^1.75."""
    a = np.asarray(x, dtype=float)
    # (a^2)^2, not a**4: numpy's power takes the general path for 4, about
    # 50 times slower on a record (the same value within an ulp per sample).
    return float((np.sum(np.square(np.square(a))) * dt_s) ** 0.25)


def vector_sum(a_x: float, a_y: float, a_z: float, k: tuple[float, float, float] = (1.0, 1.0, 1.0)) -> float:
    """The vibration total value ``sqrt(sum (k_i a_i)^2)`` (comfort: k = 1)."""
    return math.sqrt((k[0] * a_x) ** 2 + (k[1] * a_y) ** 2 + (k[2] * a_z) ** 2)


def vdv_total(v_x: float, v_y: float, v_z: float, k: tuple[float, float, float] = (1.0, 1.0, 1.0)) -> float:
    """The total VDV ``(sum (k_i VDV_i)^4)^(1/4)``."""
    return float(((k[0] * v_x) ** 4 + (k[1] * v_y) ** 4 + (k[2] * v_z) ** 4) ** 0.25)

"""Prescribed motions of the actuator: displacement and velocity at any
time, and the instants where they are not smooth (the integrator restarts
there)."""

from __future__ import annotations

import math
from dataclasses import dataclass


@dataclass(frozen=True)
class Sine:
    """``x = offset + amplitude sin(2 pi f t)``."""

    amplitude_m: float
    frequency_hz: float
    offset_m: float = 0.0

    def x(self, t: float) -> float:
        return self.offset_m + self.amplitude_m * math.sin(2 * math.pi * self.frequency_hz * t)

    def v(self, t: float) -> float:
        w = 2 * math.pi * self.frequency_hz
        return self.amplitude_m * w * math.cos(w * t)

    def breaks(self, duration_s: float) -> list[float]:
        return []


def _raised_cosine(s: float) -> tuple[float, float]:
    """Shape and slope of a raised-cosine ramp at fraction ``s`` of it."""
    if s <= 0.0:
        return 0.0, 0.0
    if s >= 1.0:
        return 1.0, 0.0
    return 0.5 * (1.0 - math.cos(math.pi * s)), 0.5 * math.pi * math.sin(math.pi * s)


@dataclass(frozen=True)
class Step:
    """A raised-cosine step of ``height_m`` from ``start_s`` over ``rise_s``."""

    height_m: float
    start_s: float = 0.5
    rise_s: float = 0.05

    def x(self, t: float) -> float:
        return self.height_m * _raised_cosine((t - self.start_s) / self.rise_s)[0]

    def v(self, t: float) -> float:
        return self.height_m * _raised_cosine((t - self.start_s) / self.rise_s)[1] / self.rise_s

    def breaks(self, duration_s: float) -> list[float]:
        return [b for b in (self.start_s, self.start_s + self.rise_s) if 0 < b < duration_s]


@dataclass(frozen=True)
class Steps:
    """``count`` increments of ``increment_m`` up, then back down; each a
    raised-cosine ramp over ``ramp_s`` followed by a dwell of ``dwell_s``."""

    increment_m: float
    count: int
    ramp_s: float = 2.0
    dwell_s: float = 60.0

    @property
    def duration_s(self) -> float:
        return 2 * self.count * (self.ramp_s + self.dwell_s)

    def _where(self, t: float) -> tuple[float, float, float]:
        period = self.ramp_s + self.dwell_s
        k = min(int(t // period), 2 * self.count - 1) if t > 0 else 0
        level = k if k < self.count else 2 * self.count - k
        direction = 1.0 if k < self.count else -1.0
        shape, slope = _raised_cosine((t - k * period) / self.ramp_s)
        return level * self.increment_m, direction * self.increment_m, shape if t >= 0 else 0.0

    def x(self, t: float) -> float:
        base, step, shape = self._where(t)
        return base + step * shape

    def v(self, t: float) -> float:
        period = self.ramp_s + self.dwell_s
        k = min(int(t // period), 2 * self.count - 1) if t > 0 else 0
        direction = 1.0 if k < self.count else -1.0
        return direction * self.increment_m * _raised_cosine((t - k * period) / self.ramp_s)[1] / self.ramp_s

    def breaks(self, duration_s: float) -> list[float]:
        period = self.ramp_s + self.dwell_s
        out = []
        for k in range(2 * self.count):
            out += [k * period, k * period + self.ramp_s]
        return [b for b in out if 0 < b < duration_s]


@dataclass(frozen=True)
class Hold:
    position_m: float = 0.0

    def x(self, t: float) -> float:
        return self.position_m

    def v(self, t: float) -> float:
        return 0.0

    def breaks(self, duration_s: float) -> list[float]:
        return []


Motion = Sine | Step | Steps | Hold

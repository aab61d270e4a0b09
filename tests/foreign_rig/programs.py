"""Test programs: the same tests, names and sampling as hpctl's virtual rig
(``hpctl.identify.virtual_rig``), restated here so that nothing is
imported from it, plus the tests the issue's independent set used (slow
steps, the seed's four SDOF steps, the 75-minute heat run)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from .model import Segment
from .motion import Motion, Sine, Step, Steps

FloatArray = NDArray[np.float64]


@dataclass(frozen=True)
class Test:
    __test__ = False  # not a pytest class

    name: str
    motion: Motion
    duration_s: float
    samples: int
    spring_hard: bool = True
    damper_on: bool = False
    switch_period_s: float | None = None  # toggles valve 6 at this period, starting hard
    sdof: bool = False
    excitation: str = "sine"
    dense_until_s: float = 0.0  # 100 Hz until then, then even spacing

    def times_s(self) -> FloatArray:
        dt = self.duration_s / self.samples
        even = np.arange(int(round(self.duration_s / dt)) + 1, dtype=float) * dt
        if self.dense_until_s <= 0:
            return even
        dense = np.arange(0.0, self.dense_until_s, 0.01)
        return np.concatenate((dense, even[even >= self.dense_until_s]))

    def segments(self) -> list[Segment]:
        """Valve commands: valve 6 open = soft, valve 5 open = damper off."""
        if self.switch_period_s is None:
            return [Segment(0.0, not self.spring_hard, not self.damper_on)]
        out, k, t = [], 0, 0.0
        while t < self.duration_s:
            hard = k % 2 == 0
            out.append(Segment(t, not hard, not self.damper_on))
            k += 1
            t = k * self.switch_period_s
        return out

    def spring_hard_at(self, times_s: FloatArray) -> FloatArray:
        if self.switch_period_s is None:
            return np.full(len(times_s), float(self.spring_hard))
        return np.asarray((np.floor(times_s / self.switch_period_s) % 2) == 0, dtype=float)

    @property
    def amplitude_m(self) -> float | None:
        m = self.motion
        if isinstance(m, Sine):
            return m.amplitude_m
        if isinstance(m, Step):
            return abs(m.height_m)
        if isinstance(m, Steps):
            return abs(m.increment_m) * m.count
        return None

    @property
    def frequency_hz(self) -> float | None:
        return self.motion.frequency_hz if isinstance(self.motion, Sine) else None


SWEEP_FREQUENCIES_HZ = (0.01, 0.03, 0.1, 0.3, 1.0)


def sweep_tests(amplitude_m: float = 0.06, cycles: float = 2.0, per_cycle: int = 200) -> list[Test]:
    return [Test(f"sine_{f:g}hz", Sine(amplitude_m, f), cycles / f, int(cycles * per_cycle)) for f in SWEEP_FREQUENCIES_HZ]


def extra_tests() -> dict[str, list[Test]]:
    """Tests beyond the sweep, by key (several records for some)."""
    return {
        "fast": [Test("fast_damper_on", Sine(0.03, 2.0), 3.0, 1500, damper_on=True)],
        "switching": [Test("valve_switching", Sine(0.03, 0.8), 10.0, 2000, switch_period_s=1.3)],
        "hold": [Test("hold", Step(0.05, 1.0, 1.0), 900.0, 900, excitation="step", dense_until_s=20.0)],
        "heat": [Test("heat_run", Sine(0.06, 0.5), 600.0, 12000, damper_on=True)],
        "sdof": [Test("sdof_step", Step(0.043, 0.5, 0.05), 5.0, 1000, sdof=True, damper_on=True, excitation="step")],
        # Beyond hpctl's virtual rig:
        "steps": [Test("slow_steps", Steps(0.02, 4, 2.0, 60.0), 496.0, 2480, excitation="steps")],
        "sdof_all": [
            Test(f"sdof_step_{'hard' if h else 'soft'}_{'on' if d else 'off'}", Step(0.043, 0.5, 0.05), 5.0, 1000,
                 spring_hard=h, damper_on=d, sdof=True, excitation="step")
            for h in (True, False) for d in (True, False)
        ],
        "heat75": [Test("heat_run_75min", Sine(0.06, 0.5), 4500.0, 45000, damper_on=True)],
    }


PROGRAMS: dict[str, tuple[str, ...]] = {
    "sweep": (),
    "full": ("fast", "switching", "hold", "heat", "sdof"),
    "campaign": ("fast", "switching", "steps", "sdof_all"),
}

# The records each effect needs besides the sweep (as hpctl's virtual rig).
EFFECT_TESTS: dict[str, tuple[str, ...]] = {
    "oil_compliance": ("fast",),
    "heat_buildup": ("heat",),
    "leakage": ("hold",),
    "valve_lag": ("switching",),
    "oil_viscosity": ("heat",),
}


def tests_for(effect: str | None, program: str = "effect", extra: tuple[str, ...] = ()) -> list[Test]:
    """The sweep plus: the program's tests (``full``, ``campaign``), or with
    ``program="effect"`` the tests ``effect`` needs; plus ``extra`` keys."""
    if program not in PROGRAMS and program != "effect":
        raise ValueError(f"program {program!r}: expected effect or one of {', '.join(PROGRAMS)}")
    keys = list(PROGRAMS.get(program, ()))
    if program == "effect" and effect is not None:
        keys += [k for k in EFFECT_TESTS.get(effect, ()) if k not in keys]
    keys += [k for k in extra if k not in keys]
    more = extra_tests()
    unknown = [k for k in keys if k not in more]
    if unknown:
        raise ValueError(f"unknown test {unknown[0]!r}: expected one of {', '.join(more)}")
    return sweep_tests() + [t for k in keys for t in more[k]]


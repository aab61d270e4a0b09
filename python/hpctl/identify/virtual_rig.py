"""A virtual test rig: rig records from a higher-fidelity unit (any effects
switched on) with noise on every channel, to test the diagnosis on data
with undeclared effects in it. The records, like real ones, do not say
which effects are in them; the truth is returned (and written) separately.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from hpctl.data.records import LOGGED_SWITCH_LEAD, RecordTest, RigRecord
from hpctl.model.effects import LIBRARY, build_unit, ordered
from hpctl.model.unit import SEED_SPRUNG_MASS_KG, Unit
from hpctl.sim.experiments import _record
from hpctl.sim.run import (
    Motion,
    Sine,
    Step,
    characterisation_rig,
    run,
    sdof_rig,
    uniform_times,
)


@dataclass(frozen=True)
class Noise:
    """Standard deviations of the white noise added to each channel."""

    disp_m: float = 5e-6  # an LVDT on the actuator: a few micrometres
    force_n: float = 30.0
    p_pa: float = 5e3
    t_k: float = 0.1

    def scaled(self, factor: float) -> Noise:
        return Noise(self.disp_m * factor, self.force_n * factor, self.p_pa * factor, self.t_k * factor)


@dataclass(frozen=True)
class Test:
    """One test of a program: what the rig does."""

    name: str
    motion: Motion
    duration_s: float
    samples: int
    spring_hard: bool = True
    damper_on: bool = False
    switch_period_s: float | None = None  # toggles valve 6 (soft/hard) at this period
    sdof: bool = False
    excitation: str = "sine"
    dense_until_s: float = 0.0  # sample at 100 Hz until then (a step needs it), then evenly

    def times_s(self) -> NDArray[np.float64]:
        even = uniform_times(self.duration_s, self.duration_s / self.samples)
        if self.dense_until_s <= 0:
            return even
        dense = np.arange(0.0, self.dense_until_s, 0.01)
        return np.concatenate((dense, even[even >= self.dense_until_s]))


SWEEP_FREQUENCIES_HZ = (0.01, 0.03, 0.1, 0.3, 1.0)


def sweep_tests(amplitude_m: float = 0.06, cycles: float = 2.0, per_cycle: int = 200) -> list[Test]:
    """Sine tests over 0.01-1 Hz, hard spring, damper bypassed: what tells
    thermal loops (which vanish at both ends) from friction (which does not)."""
    return [
        Test(f"sine_{f:g}hz", Sine(amplitude_m, f), cycles / f, int(cycles * per_cycle))
        for f in SWEEP_FREQUENCIES_HZ
    ]


def effect_tests() -> dict[str, Test]:
    """Tests that reveal effects the sine sweep cannot."""
    return {
        "fast": Test("fast_damper_on", Sine(0.03, 2.0), 3.0, 1500, damper_on=True),
        "switching": Test("valve_switching", Sine(0.03, 0.8), 10.0, 2000, switch_period_s=1.3),
        "hold": Test("hold", Step(0.05, 1.0, 1.0), 900.0, 900, excitation="step", dense_until_s=20.0),
        "heat": Test("heat_run", Sine(0.06, 0.5), 600.0, 12000, damper_on=True),
        "sdof": Test("sdof_step", Step(0.043, 0.5, 0.05), 5.0, 1000, sdof=True, damper_on=True, excitation="step"),
    }


PROGRAMS: dict[str, tuple[str, ...]] = {
    "sweep": (),
    "full": ("fast", "switching", "hold", "heat", "sdof"),
}


def program_tests(program: str) -> list[Test]:
    if program not in PROGRAMS:
        from hpctl.errors import ParameterError

        raise ParameterError(f"--program {program!r}: expected one of {', '.join(PROGRAMS)}")
    extra = effect_tests()
    return sweep_tests() + [extra[k] for k in PROGRAMS[program]]


def record_test(unit: Unit, test: Test, noise: Noise, rng: np.random.Generator, ambient_k: float | None = None) -> RigRecord:
    """Runs one test on ``unit`` and returns its noisy record."""
    ambient = unit.static_temperature_k if ambient_k is None else ambient_k
    times = test.times_s()
    if test.switch_period_s is not None:
        spring_hard: Any = (np.floor(times / test.switch_period_s) % 2) == 0
    else:
        spring_hard = test.spring_hard
    rig = sdof_rig(test.motion, SEED_SPRUNG_MASS_KG) if test.sdof else characterisation_rig(test.motion)
    # The valves switch midway between samples, where the fit places a
    # switch its record's flag column shows (LOGGED_SWITCH_LEAD).
    result = run(unit, rig, times, spring_hard=spring_hard, damper_on=test.damper_on, ambient_k=ambient, switch_lead=LOGGED_SWITCH_LEAD)
    rt = RecordTest(
        spring="hard" if test.spring_hard else "soft",
        damper="on" if test.damper_on else "off",
        excitation=test.excitation,
        amplitude_m=getattr(test.motion, "amplitude_m", None) or getattr(test.motion, "height_m", None),
        frequency_hz=getattr(test.motion, "frequency_hz", None),
    )
    rec = _record(unit, result, kind="sdof" if test.sdof else "characterisation", test=rt, name=test.name,
                  description="hpctl virtual rig", ambient_k=ambient, sprung_mass_kg=SEED_SPRUNG_MASS_KG if test.sdof else None)
    for c, sd in (("disp_m", noise.disp_m), ("force_n", noise.force_n), ("body_disp_m", noise.disp_m), ("base_disp_m", noise.disp_m),
                  ("p_gas_pa", noise.p_pa), ("p_gas2_pa", noise.p_pa), ("t_gas_k", noise.t_k), ("t_oil_k", noise.t_k)):
        if c in rec.data and sd > 0:
            rec.data[c] = rec.data[c] + rng.normal(0.0, sd, len(rec.data[c]))
    # The rig's data system records the modes only where they change.
    if test.switch_period_s is None:
        del rec.data["spring_hard"], rec.data["damper_on"]
    return rec


def make_records(unit: Unit, program: str = "sweep", noise: Noise | None = None, seed: int = 0, tests: Sequence[Test] | None = None) -> list[RigRecord]:
    """The records of a test program on ``unit``."""
    rng = np.random.default_rng(seed)
    return [record_test(unit, t, noise or Noise(), rng) for t in (tests if tests is not None else program_tests(program))]


def effect_values(effects: Sequence[str], rng: np.random.Generator | None = None, overrides: dict[str, float] | None = None) -> dict[str, float]:
    """Parameter values for ``effects``: typical ones, random ones if ``rng``
    is given (the registry's ranges), and ``overrides`` on top."""
    out = {p.name: (p.typical if rng is None else p.draw(rng)) for e in effects for p in LIBRARY[e].params}
    out.update(overrides or {})
    return out


def truth_unit(effects: Sequence[str], values: dict[str, float], template: Unit | None = None) -> Unit:
    """The rig's unit: real gas and heat transfer (as real units are) plus
    ``effects`` at ``values``."""
    base = template or Unit.seed()
    names = ordered(("heat_transfer", "real_gas", *effects))
    v = {"tau_s": base.tau_s if math.isfinite(base.tau_s) else LIBRARY["heat_transfer"].params[0].typical, **values}
    return build_unit(base, names, v).replace(static_pressure_pa=base.static_pressure_pa)


def tests_for(effects: Sequence[str], program: str = "sweep") -> list[Test]:
    """The program's tests plus those the effects need."""
    keys = list(PROGRAMS[program] if program in PROGRAMS else ())
    for e in effects:
        keys += [k for k in LIBRARY[e].tests if k not in keys]
    extra = effect_tests()
    return sweep_tests() + [extra[k] for k in keys]

"""Running the characterisation and SDOF rigs on a unit.

Results are numpy arrays in SI units. The work happens in the Rust core with
the GIL released; :func:`run_many` runs cases in parallel on all cores.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any, Literal, Union, cast

import numpy as np
from numpy.typing import ArrayLike, NDArray

from hpctl import _core
from hpctl._coretypes import CaseDict, CharacterisationRigDict, MotionDict, SampledDict, SdofRigDict
from hpctl.errors import bad_argument, check_flags, check_float_array, check_number
from hpctl.model.unit import SEED_SPRUNG_MASS_KG, Unit

FloatArray = NDArray[np.float64]
CHANNELS: tuple[str, ...] = tuple(_core.CHANNELS)


@dataclass(frozen=True)
class Hold:
    disp_m: float = 0.0
    kind: Literal["hold"] = "hold"


@dataclass(frozen=True)
class Sine:
    """``x = offset + amplitude sin(2 pi f t)``."""

    amplitude_m: float
    frequency_hz: float
    offset_m: float = 0.0
    kind: Literal["sine"] = "sine"

    @classmethod
    def with_speed(cls, amplitude_m: float, speed_m_s: float) -> Sine:
        """The sine whose speed through the static position is ``speed_m_s``
        (the seed's "excitation speed")."""
        return cls(amplitude_m, speed_m_s / (2 * np.pi * amplitude_m))


@dataclass(frozen=True)
class Step:
    """A smooth (raised-cosine) step of ``height_m`` from ``start_s`` over ``rise_s``."""

    height_m: float
    start_s: float = 0.5
    rise_s: float = 0.05
    kind: Literal["step"] = "step"


@dataclass(frozen=True)
class Steps:
    """``count`` slow increments up, then back down, each ramp + dwell."""

    increment_m: float
    count: int
    ramp_s: float = 2.0
    dwell_s: float = 60.0
    kind: Literal["steps"] = "steps"

    @property
    def duration_s(self) -> float:
        return 2 * self.count * (self.ramp_s + self.dwell_s)


@dataclass(frozen=True)
class Sampled:
    """Samples interpolated by a C1 cubic (e.g. a measured displacement):
    through the given velocities if there are, else with three-point ones."""

    time_s: FloatArray
    disp_m: FloatArray
    vel_m_s: FloatArray | None = None
    kind: Literal["sampled"] = "sampled"


Motion = Union[Hold, Sine, Step, Steps, Sampled]


def _motion_dict(m: Motion) -> MotionDict:
    if isinstance(m, Sampled):
        d: SampledDict = {"kind": "sampled", "time_s": check_float_array(m.time_s, "Sampled.time_s"),
                          "disp_m": check_float_array(m.disp_m, "Sampled.disp_m")}
        if m.vel_m_s is not None:
            d["vel_m_s"] = check_float_array(m.vel_m_s, "Sampled.vel_m_s")
        return d
    if not isinstance(m, (Hold, Sine, Step, Steps)):
        raise bad_argument("motion", m, "one of hpctl.Hold, Sine, Step, Steps, Sampled")
    return cast(MotionDict, dict(vars(m)))


@dataclass(frozen=True)
class Result:
    """The channels of one run (see :data:`CHANNELS`), as numpy arrays."""

    channels: dict[str, FloatArray]

    def __getitem__(self, name: str) -> FloatArray:
        return self.channels[name]

    @property
    def time_s(self) -> FloatArray:
        return self.channels["time_s"]


Progress = Callable[[int, int], None]


def _case(
    unit: Unit,
    rig: Rig,
    times_s: ArrayLike,
    *,
    spring_hard: bool | ArrayLike,
    damper_on: bool | ArrayLike,
    dt_s: float,
    ambient_k: float | None,
    channels: Sequence[str] | None,
) -> CaseDict:
    if not isinstance(unit, Unit):
        raise bad_argument("unit", unit, "an hpctl.Unit")
    if channels is not None and (isinstance(channels, str) or not all(isinstance(c, str) for c in channels)):
        raise bad_argument("channels", channels, f"a sequence of channel names ({', '.join(CHANNELS)})")
    if not isinstance(rig, (CharacterisationRig, SdofRig)):
        raise bad_argument("rig", rig, "a rig (hpctl.sim.run.characterisation_rig or sdof_rig)")
    return {
        "unit": unit.to_dict(),
        "rig": rig.to_core(),
        "times_s": check_float_array(times_s, "times_s"),
        "dt_s": check_number(dt_s, "dt_s"),
        "ambient_k": unit.static_temperature_k if ambient_k is None else check_number(ambient_k, "ambient_k"),
        "spring_hard": check_flags(spring_hard, "spring_hard"),
        "damper_on": check_flags(damper_on, "damper_on"),
        "channels": None if channels is None else list(channels),
    }


@dataclass(frozen=True)
class CharacterisationRig:
    """The characterisation rig: the actuator prescribes the strut's
    compression."""

    strut: Motion

    def to_core(self) -> CharacterisationRigDict:
        """The plain-dict form the Rust core reads."""
        return {"kind": "characterisation", "strut": _motion_dict(self.strut)}


@dataclass(frozen=True)
class SdofRig:
    """The single-degree-of-freedom rig: a sprung mass on the unit over a
    moving base."""

    base: Motion
    sprung_mass_kg: float = SEED_SPRUNG_MASS_KG

    def to_core(self) -> SdofRigDict:
        """The plain-dict form the Rust core reads."""
        return {"kind": "sdof", "sprung_mass_kg": float(self.sprung_mass_kg), "base": _motion_dict(self.base)}


Rig = Union[CharacterisationRig, SdofRig]


def characterisation_rig(strut: Motion) -> CharacterisationRig:
    """The rig for a prescribed strut compression."""
    return CharacterisationRig(strut)


def sdof_rig(base: Motion, sprung_mass_kg: float = SEED_SPRUNG_MASS_KG) -> SdofRig:
    """The rig for a sprung mass on the unit over a moving base."""
    return SdofRig(base, sprung_mass_kg)


#: Most output samples of one run (8e8 bytes per channel).
MAX_SAMPLES = 100_000_000


def uniform_times(duration_s: float, sample_dt_s: float) -> FloatArray:
    """Output times 0, dt, 2 dt, ... up to ``duration_s``."""
    duration_s = check_number(duration_s, "duration_s")
    sample_dt_s = check_number(sample_dt_s, "sample_dt_s")
    if duration_s < 0:
        raise bad_argument("duration_s", duration_s, "a duration >= 0 s")
    if sample_dt_s <= 0:
        raise bad_argument("sample_dt_s", sample_dt_s, "an output interval > 0 s")
    n = int(round(duration_s / sample_dt_s))
    if n > MAX_SAMPLES:
        raise bad_argument("duration_s", duration_s, f"at most {MAX_SAMPLES:.0e} output samples ({n:.3g} at sample_dt_s = {sample_dt_s:g})")
    return np.arange(n + 1, dtype=float) * sample_dt_s


def run(
    unit: Unit,
    rig: Rig,
    times_s: ArrayLike,
    *,
    spring_hard: bool | ArrayLike = True,
    damper_on: bool | ArrayLike = True,
    dt_s: float = 1e-3,
    ambient_k: float | None = None,
    channels: Sequence[str] | None = None,
    progress: Progress | None = None,
) -> Result:
    """Runs ``rig`` (see :func:`characterisation_rig`, :func:`sdof_rig`)
    with outputs at ``times_s``; ``spring_hard`` / ``damper_on`` are one
    value or one per output time (holding until the next)."""
    c = _case(unit, rig, times_s, spring_hard=spring_hard, damper_on=damper_on, dt_s=dt_s, ambient_k=ambient_k, channels=channels)
    out = _core.simulate(c["unit"], c["rig"], c["times_s"], c["dt_s"], c["ambient_k"], c["spring_hard"], c["damper_on"], c["channels"], progress)
    return Result(dict(out))


def run_characterisation(
    unit: Unit,
    strut: Motion,
    duration_s: float,
    *,
    sample_dt_s: float = 1e-2,
    **kwargs: Any,
) -> Result:
    """The characterisation rig: prescribed strut compression."""
    return run(unit, characterisation_rig(strut), uniform_times(duration_s, sample_dt_s), **kwargs)


def run_sdof(
    unit: Unit,
    base: Motion,
    duration_s: float,
    *,
    sprung_mass_kg: float = SEED_SPRUNG_MASS_KG,
    sample_dt_s: float = 1e-3,
    **kwargs: Any,
) -> Result:
    """The single-degree-of-freedom rig: a sprung mass over a moving base."""
    return run(unit, sdof_rig(base, sprung_mass_kg), uniform_times(duration_s, sample_dt_s), **kwargs)


@dataclass(frozen=True)
class Case:
    """One run for :func:`run_many`."""

    unit: Unit
    rig: Rig
    times_s: FloatArray
    spring_hard: bool | ArrayLike = True
    damper_on: bool | ArrayLike = True
    dt_s: float = 1e-3
    ambient_k: float | None = None
    channels: Sequence[str] | None = None


def run_many(cases: Sequence[Case], threads: int | None = None) -> list[Result | Exception]:
    """Runs cases in parallel in Rust: ``threads`` None or 0 = all cores,
    at most 4 x the cores (else :class:`~hpctl.errors.ParameterError`). A
    case that fails yields its exception in place of a result. Ctrl-C stops
    the batch between cases."""
    dicts = []
    for c in cases:
        if not isinstance(c, Case):
            raise bad_argument("cases", c, "a sequence of hpctl.sim.run.Case")
        dicts.append(_case(c.unit, c.rig, c.times_s, spring_hard=c.spring_hard, damper_on=c.damper_on, dt_s=c.dt_s, ambient_k=c.ambient_k, channels=c.channels))
    return [r if isinstance(r, Exception) else Result(dict(r)) for r in _core.simulate_many(dicts, threads)]

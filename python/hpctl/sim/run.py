"""Running the characterisation and SDOF rigs on a unit.

Results are numpy arrays in SI units. The work happens in the Rust core with
the GIL released; :func:`run_many` runs cases in parallel on all cores.
"""

from __future__ import annotations

import math
import threading
from collections import OrderedDict
from collections.abc import Callable, Iterator, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Literal, Union, cast

import numpy as np
from numpy.typing import ArrayLike, NDArray

from hpctl import _core
from hpctl._coretypes import CaseDict, CharacterisationRigDict, MotionDict, SampledDict, SdofRigDict, UnitDict
from hpctl.data.records import RecordStatic, RecordTest, RecordUnit, RigRecord
from hpctl.errors import bad_argument, check_flags, check_float_array, check_number
from hpctl.model.effects import max_step_s
from hpctl.model.unit import SEED_SPRUNG_MASS_KG, Unit

FloatArray = NDArray[np.float64]
CHANNELS: tuple[str, ...] = tuple(_core.CHANNELS)
# The plant's relative tolerance, the core's one rule for step sizes: the
# steps follow the dynamics (stiff terms such as valve 6, oil compliance and
# valve or transducer lags included), so callers do not pick a step.
DEFAULT_RTOL: float = _core.DEFAULT_RTOL
#: The fixed step (``rtol=None``) unless a caller or an effect asks for a
#: shorter one: about valve 6's orifice time constant, s.
FIXED_STEP_S = 1e-3


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
    through the given velocities if there are, else with three-point ones.
    Error-controlled steps stop at every sample, where the cubic changes
    and the velocity's slope jumps (steps across these kinks made errors
    that added up over long records instead of cancelling)."""

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
class Result(Mapping[str, "FloatArray"]):
    """The channels of one run, as numpy arrays in SI units, by name:
    ``r["force_n"]``, ``r.force_n``; :attr:`names` lists them (in the order
    of :data:`CHANNELS`, or as asked for with ``channels=``). The run's
    unit, rig and ambient temperature come along, so that
    :meth:`to_record` can make a rig record of it."""

    channels: dict[str, FloatArray]
    unit: Unit | None = field(default=None, compare=False, repr=False)
    rig: Rig | None = field(default=None, compare=False, repr=False)
    ambient_k: float | None = field(default=None, compare=False, repr=False)
    #: With ``record_steps``: the adaptive steps' end times, s.
    step_end_s: FloatArray | None = field(default=None, compare=False, repr=False)

    @classmethod
    def from_core(cls, out: Mapping[str, FloatArray], unit: Unit | None = None, rig: Rig | None = None, ambient_k: float | None = None) -> Result:
        d = dict(out)
        steps = d.pop("step_end_s", None)
        return cls(d, unit, rig, ambient_k, steps)

    def __getitem__(self, name: str) -> FloatArray:
        try:
            return self.channels[name]
        except KeyError:
            raise KeyError(f"{name!r}: not a channel of this result (it has: {', '.join(self.channels)})") from None

    def __iter__(self) -> Iterator[str]:
        return iter(self.channels)

    def __len__(self) -> int:
        return len(self.channels)

    def __getattr__(self, name: str) -> FloatArray:
        # Only called when normal lookup fails: channels as attributes.
        channels = self.__dict__.get("channels")
        if channels is None or name.startswith("_") or name not in channels:
            have = f" (channels: {', '.join(channels)})" if channels else ""
            raise AttributeError(f"Result has no attribute or channel {name!r}{have}")
        return channels[name]  # type: ignore[no-any-return]

    def __dir__(self) -> list[str]:
        return sorted(set(super().__dir__()) | set(self.channels))

    @property
    def names(self) -> tuple[str, ...]:
        """The channel names of this result."""
        return tuple(self.channels)

    @property
    def time_s(self) -> FloatArray:
        return self.channels["time_s"]

    def to_record(self, name: str = "record", *, description: str = "", test: RecordTest | None = None) -> RigRecord:
        """This run as a rig record (``docs/rig-data-format.md``): the
        columns a rig measures, the unit as built, the static state, and
        the test (from the rig's motion unless given). Needs a result of
        :func:`run` (which knows its unit and rig) with the channels a
        record needs."""
        if self.unit is None or self.rig is None:
            raise bad_argument("result", self, "a result of hpctl.run (it knows its unit and rig)")
        kind: Literal["characterisation", "sdof"] = "sdof" if isinstance(self.rig, SdofRig) else "characterisation"
        if test is None:
            motion = self.rig.base if isinstance(self.rig, SdofRig) else self.rig.strut
            test = motion_test(motion, spring_hard=bool(self.channels.get("spring_hard", [1.0])[0] > 0.5),
                               damper_on=bool(self.channels.get("damper_on", [1.0])[0] > 0.5))
        ambient = self.unit.static_temperature_k if self.ambient_k is None else self.ambient_k
        return record_of(self.unit, self.channels, kind=kind, test=test, name=name, description=description or f"hpctl simulation: {kind}",
                         ambient_k=ambient, sprung_mass_kg=self.rig.sprung_mass_kg if isinstance(self.rig, SdofRig) else None)


def motion_test(motion: Motion, *, spring_hard: bool, damper_on: bool) -> RecordTest:
    """The ``[test]`` table of a record of ``motion``."""
    excitation = {"sine": "sine", "step": "step", "steps": "steps"}.get(motion.kind, "drive")
    return RecordTest(spring="hard" if spring_hard else "soft", damper="on" if damper_on else "off", excitation=excitation,
                      amplitude_m=getattr(motion, "amplitude_m", None) or getattr(motion, "height_m", None), frequency_hz=getattr(motion, "frequency_hz", None))


def record_of(unit: Unit, channels: Mapping[str, FloatArray], *, kind: Literal["characterisation", "sdof"], test: RecordTest, name: str,
              description: str, ambient_k: float, sprung_mass_kg: float | None = None) -> RigRecord:
    """A rig record of simulated channels: what a rig measures (the
    record's columns, :data:`hpctl.data.records.COLUMNS`), the unit as
    built and its static state."""
    columns = ["time_s", "disp_m", "force_n"]
    if kind == "sdof":
        columns += ["body_disp_m", "base_disp_m"]
    columns += ["p_gas_pa", "p_gas2_pa", "t_gas_k"]
    if unit.effects.oil_node is not None:
        columns += ["t_oil_k"]
    missing = [c for c in (*columns, "spring_hard", "damper_on") if c not in channels]
    if missing:
        raise bad_argument("channels", sorted(channels), f"the channels of a record (missing: {', '.join(missing)})")
    data = {c: np.asarray(channels[c], float) for c in columns}
    data["t_amb_k"] = np.full(len(channels["time_s"]), ambient_k)
    data["spring_hard"] = np.asarray(channels["spring_hard"], float)
    data["damper_on"] = np.asarray(channels["damper_on"], float)
    return RigRecord(
        kind=kind,
        description=description,
        unit=RecordUnit(unit.piston_area_m2, unit.small_acc_volume_m3, unit.large_acc_volume_m3, "N2"),
        static=RecordStatic(unit.static_pressure_pa, unit.static_temperature_k, ambient_k),
        test=test,
        data=data,
        sprung_mass_kg=sprung_mass_kg,
        name=name,
    )


Progress = Callable[[int, int], None]

#: Units whose core dict :func:`_unit_dict` keeps.
UNIT_DICTS_KEPT = 256
_unit_dicts: OrderedDict[int, tuple[Unit, UnitDict]] = OrderedDict()
_unit_dicts_lock = threading.Lock()


def _unit_dict(unit: Unit) -> UnitDict:
    """``unit.to_dict()``, kept for the same unit object (held, so that its
    id stays its own): a fit runs one unit on each record its parameters
    reach (:meth:`hpctl.identify.fit.Model.unit_for` keeps the units), and
    the dict took 0.2 s of the bundled campaign's flexible fit, 2,812 of
    them for about 1,700 units (stop 63). A unit is frozen and the dict
    goes to the core alone, which reads it."""
    key = id(unit)
    with _unit_dicts_lock:
        hit = _unit_dicts.get(key)
        if hit is not None and hit[0] is unit:
            _unit_dicts.move_to_end(key)
            return hit[1]
    made = unit.to_dict()
    with _unit_dicts_lock:
        _unit_dicts[key] = (unit, made)
        _unit_dicts.move_to_end(key)
        while len(_unit_dicts) > UNIT_DICTS_KEPT:
            _unit_dicts.popitem(last=False)
    return made


def _case(
    unit: Unit,
    rig: Rig,
    times_s: ArrayLike,
    *,
    spring_hard: bool | ArrayLike,
    damper_on: bool | ArrayLike,
    dt_s: float | None,
    rtol: float | None,
    ambient_k: float | None,
    channels: Sequence[str] | None,
    steps_s: ArrayLike | None = None,
    record_steps: bool = False,
    gas_table: bool = False,
    switch_lead: float = 0.0,
) -> CaseDict:
    if not isinstance(unit, Unit):
        raise bad_argument("unit", unit, "an hpctl.Unit")
    if channels is not None and (isinstance(channels, str) or not all(isinstance(c, str) for c in channels)):
        raise bad_argument("channels", channels, f"a sequence of channel names ({', '.join(CHANNELS)})")
    if not isinstance(rig, (CharacterisationRig, SdofRig)):
        raise bad_argument("rig", rig, "a rig (hpctl.sim.run.characterisation_rig or sdof_rig)")
    # Error-controlled steps capped at dt_s, or fixed RK4 steps of dt_s
    # (default: 1 ms or the fastest dynamics the unit's effects add); the
    # core checks the ranges.
    if dt_s is not None:
        step = check_number(dt_s, "dt_s")
    else:
        step = math.inf if rtol is not None else min(FIXED_STEP_S, max_step_s(unit))
    return {
        "unit": _unit_dict(unit),
        "rig": rig.to_core(),
        "times_s": check_float_array(times_s, "times_s"),
        "dt_s": step,
        "rtol": None if rtol is None else check_number(rtol, "rtol", finite=False),
        "steps_s": None if steps_s is None else check_float_array(steps_s, "steps_s"),
        "record_steps": bool(record_steps),
        "gas_table": bool(gas_table),
        "switch_lead": check_number(switch_lead, "switch_lead"),
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
    dt_s: float | None = None,
    rtol: float | None = DEFAULT_RTOL,
    ambient_k: float | None = None,
    channels: Sequence[str] | None = None,
    progress: Progress | None = None,
    steps_s: ArrayLike | None = None,
    record_steps: bool = False,
    switch_lead: float = 0.0,
) -> Result:
    """Runs ``rig`` (see :func:`characterisation_rig`, :func:`sdof_rig`)
    with outputs at ``times_s``; ``spring_hard`` / ``damper_on`` are one
    value or one per output time (holding until the next).

    The steps are error-controlled to the relative tolerance ``rtol`` (and
    at most ``dt_s`` long, if given), the outputs taken from the dense
    output; ``rtol=None`` integrates with fixed RK4 steps of at most
    ``dt_s`` (default 1 ms) that land on every output time.

    ``record_steps`` keeps the adaptive steps' end times
    (:attr:`Result.step_end_s`); ``steps_s`` replays such a list without
    error control, so that a finite-difference derivative with respect to
    a unit parameter does not see the step-size selection change.

    Where the valves change from one output to the next they switch
    ``switch_lead`` of the interval before the output that has the new
    ones: 0 (the default) at it, as a controller commands them;
    :data:`hpctl.data.records.LOGGED_SWITCH_LEAD` (midway) for a record's
    logged valve states."""
    c = _case(unit, rig, times_s, spring_hard=spring_hard, damper_on=damper_on, dt_s=dt_s, rtol=rtol, ambient_k=ambient_k, channels=channels,
              steps_s=steps_s, record_steps=record_steps, switch_lead=switch_lead)
    out = _core.simulate(
        c["unit"], c["rig"], c["times_s"], c["dt_s"], c["ambient_k"], c["spring_hard"], c["damper_on"], c["channels"], progress, c["rtol"],
        c["steps_s"], c["record_steps"], c["gas_table"], c["switch_lead"],
    )
    return Result.from_core(out, unit, rig, c["ambient_k"])


def run_characterisation(
    unit: Unit,
    strut: Motion,
    duration_s: float,
    *,
    sample_dt_s: float = 1e-2,
    spring_hard: bool | ArrayLike = True,
    damper_on: bool | ArrayLike = True,
    dt_s: float | None = None,
    rtol: float | None = DEFAULT_RTOL,
    ambient_k: float | None = None,
    channels: Sequence[str] | None = None,
    progress: Progress | None = None,
    steps_s: ArrayLike | None = None,
    record_steps: bool = False,
) -> Result:
    """The characterisation rig: prescribed strut compression, outputs
    every ``sample_dt_s`` over ``duration_s``; the other arguments as for
    :func:`run`."""
    return run(unit, characterisation_rig(strut), uniform_times(duration_s, sample_dt_s), spring_hard=spring_hard, damper_on=damper_on, dt_s=dt_s, rtol=rtol, ambient_k=ambient_k, channels=channels,
               progress=progress, steps_s=steps_s, record_steps=record_steps)


def run_sdof(
    unit: Unit,
    base: Motion,
    duration_s: float,
    *,
    sprung_mass_kg: float = SEED_SPRUNG_MASS_KG,
    sample_dt_s: float = 1e-3,
    spring_hard: bool | ArrayLike = True,
    damper_on: bool | ArrayLike = True,
    dt_s: float | None = None,
    rtol: float | None = DEFAULT_RTOL,
    ambient_k: float | None = None,
    channels: Sequence[str] | None = None,
    progress: Progress | None = None,
    steps_s: ArrayLike | None = None,
    record_steps: bool = False,
) -> Result:
    """The single-degree-of-freedom rig: a sprung mass over a moving base,
    outputs every ``sample_dt_s`` over ``duration_s``; the other arguments
    as for :func:`run`."""
    return run(unit, sdof_rig(base, sprung_mass_kg), uniform_times(duration_s, sample_dt_s), spring_hard=spring_hard, damper_on=damper_on, dt_s=dt_s, rtol=rtol, ambient_k=ambient_k, channels=channels,
               progress=progress, steps_s=steps_s, record_steps=record_steps)


@dataclass(frozen=True)
class Case:
    """One run for :func:`run_many`."""

    unit: Unit
    rig: Rig
    times_s: FloatArray
    spring_hard: bool | ArrayLike = True
    damper_on: bool | ArrayLike = True
    dt_s: float | None = None
    rtol: float | None = DEFAULT_RTOL
    ambient_k: float | None = None
    channels: Sequence[str] | None = None
    steps_s: FloatArray | None = None
    record_steps: bool = False
    #: The reference gas through the process's table instead of the
    #: equation (pressure within 1.3e-8 of it, several times cheaper; other
    #: gases are evaluated directly): for the many runs of a fit.
    gas_table: bool = False
    #: Where a valve switch falls between two outputs (see :func:`run`).
    switch_lead: float = 0.0


def run_many(cases: Sequence[Case], threads: int | None = None) -> list[Result | Exception]:
    """Runs cases in parallel in Rust: ``threads`` None or 0 = all cores,
    at most 4 x the cores (else :class:`~hpctl.errors.ParameterError`). A
    case that fails yields its exception in place of a result. Ctrl-C stops
    the batch between cases."""
    dicts = []
    for c in cases:
        if not isinstance(c, Case):
            raise bad_argument("cases", c, "a sequence of hpctl.sim.run.Case")
        dicts.append(_case(c.unit, c.rig, c.times_s, spring_hard=c.spring_hard, damper_on=c.damper_on, dt_s=c.dt_s, rtol=c.rtol, ambient_k=c.ambient_k,
                           channels=c.channels, steps_s=c.steps_s, record_steps=c.record_steps, gas_table=c.gas_table,
                           switch_lead=c.switch_lead))
    results = _core.simulate_many(dicts, threads)
    return [r if isinstance(r, Exception) else Result.from_core(r, c.unit, c.rig, d["ambient_k"]) for c, d, r in zip(cases, dicts, results)]

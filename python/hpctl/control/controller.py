"""The valve-switching controller (Rust, ``hp-ctrl``) from Python.

:class:`Controller` holds the compiled parameters and the state of one
controller and steps it one control period at a time (:meth:`Controller.step`,
typed :class:`Inputs` in, :class:`Outputs` out) or many at once
(:meth:`Controller.step_many`, arrays in and out, for long sequences and
property tests). The configuration is a nested dict in SI units, like
:func:`seed_config` returns (typed: :class:`ControllerConfig`, one
TypedDict per block of ``hp_ctrl::Config``); every key is required and
unknown keys are rejected.

NaN, infinite, out-of-range and stale inputs are legal: the controller
answers them with its documented safe state (``docs/controller.md``). Only
structurally wrong calls (unknown or missing keys, wrong types, undefined
enum values) raise :class:`hpctl.ParameterError`.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import asdict, dataclass, fields
from enum import IntEnum, IntFlag
from typing import Any, cast

import numpy as np
from numpy.typing import ArrayLike, NDArray

from hpctl import _core
from hpctl._coretypes import ControllerConfigDict, ControllerInputsDict, ControllerOutputsDict
from hpctl.errors import bad_argument, check_float_array, check_number

#: The controller's whole configuration, typed block by block (the
#: TypedDicts of hpctl._coretypes: hp_ctrl::Config's fields).
ControllerConfig = ControllerConfigDict

# The values come from the controller itself (the bindings export its
# tables); the names are checked against those tables by the tests.


class _Named(IntEnum):
    """An enum that prints as its name (``RIDE``, not ``0``: Python 3.11's
    IntEnum prints its number); its value is still the controller's."""

    def __str__(self) -> str:
        return self.name

    def __format__(self, spec: str) -> str:
        # A numeric format (f"{mode:d}") formats the number.
        return self.name if not spec else int.__format__(int(self), spec)


class _NamedFlags(IntFlag):
    """Flags that print as their names joined by ``|`` (``0`` when none)."""

    def __str__(self) -> str:
        return self.name or "0"

    def __format__(self, spec: str) -> str:
        return str(self) if not spec else int.__format__(int(self), spec)


class DriverMode(_Named):
    """The driver's mode switch."""

    AUTO = _core.CTRL_DRIVER_MODES.index("auto")
    COMFORT = _core.CTRL_DRIVER_MODES.index("comfort")
    SPORT = _core.CTRL_DRIVER_MODES.index("sport")


class DriveMode(_Named):
    RIDE = _core.CTRL_DRIVE_MODES.index("ride")
    HANDLING = _core.CTRL_DRIVE_MODES.index("handling")


class SpringMode(_Named):
    """Valve 6 closed (hard, S alone) or open (soft, S + L)."""

    HARD = _core.CTRL_SPRING_MODES.index("hard")
    SOFT = _core.CTRL_SPRING_MODES.index("soft")


class DamperMode(_Named):
    """Valve 5 closed (high damping) or open (bypass, low)."""

    HIGH = _core.CTRL_DAMPER_MODES.index("high")
    LOW = _core.CTRL_DAMPER_MODES.index("low")


class SequencerState(_Named):
    IDLE = _core.CTRL_SEQUENCER_STATES.index("idle")
    LOWERING = _core.CTRL_SEQUENCER_STATES.index("lowering")
    RAISING = _core.CTRL_SEQUENCER_STATES.index("raising")
    HOLDING = _core.CTRL_SEQUENCER_STATES.index("holding")
    BLOCKED = _core.CTRL_SEQUENCER_STATES.index("blocked")


class InputGroup(_NamedFlags):
    """Input groups, one bit each (``Inputs.fresh``)."""

    PRESSURES = _core.CTRL_INPUT_GROUPS["PRESSURES"]
    STRUT = _core.CTRL_INPUT_GROUPS["STRUT"]
    BODY = _core.CTRL_INPUT_GROUPS["BODY"]
    VEHICLE = _core.CTRL_INPUT_GROUPS["VEHICLE"]
    STEERING = _core.CTRL_INPUT_GROUPS["STEERING"]
    TEMPERATURE = _core.CTRL_INPUT_GROUPS["TEMPERATURE"]
    DRIVER = _core.CTRL_INPUT_GROUPS["DRIVER"]
    ALL = sum(_core.CTRL_INPUT_GROUPS.values())


class Diag(_NamedFlags):
    """Diagnostic flags of ``Outputs.diag`` (``docs/controller.md``)."""

    SAFE_STATE = _core.CTRL_DIAG_FLAGS["SAFE_STATE"]
    RECOVERING = _core.CTRL_DIAG_FLAGS["RECOVERING"]
    BAD_DT = _core.CTRL_DIAG_FLAGS["BAD_DT"]
    LINK_FAULT = _core.CTRL_DIAG_FLAGS["LINK_FAULT"]
    NOT_FINITE = _core.CTRL_DIAG_FLAGS["NOT_FINITE"]
    OUT_OF_RANGE = _core.CTRL_DIAG_FLAGS["OUT_OF_RANGE"]
    RATE_LIMIT = _core.CTRL_DIAG_FLAGS["RATE_LIMIT"]
    STALE = _core.CTRL_DIAG_FLAGS["STALE"]
    GROUP_PRESSURES = _core.CTRL_DIAG_FLAGS["GROUP_PRESSURES"]
    GROUP_STRUT = _core.CTRL_DIAG_FLAGS["GROUP_STRUT"]
    GROUP_BODY = _core.CTRL_DIAG_FLAGS["GROUP_BODY"]
    GROUP_VEHICLE = _core.CTRL_DIAG_FLAGS["GROUP_VEHICLE"]
    GROUP_STEERING = _core.CTRL_DIAG_FLAGS["GROUP_STEERING"]
    GROUP_TEMPERATURE = _core.CTRL_DIAG_FLAGS["GROUP_TEMPERATURE"]
    GROUP_DRIVER = _core.CTRL_DIAG_FLAGS["GROUP_DRIVER"]
    REQUEST_CLAMPED = _core.CTRL_DIAG_FLAGS["REQUEST_CLAMPED"]
    SEQUENCER_PAUSED = _core.CTRL_DIAG_FLAGS["SEQUENCER_PAUSED"]
    HEIGHT_HOLDS_SPRING = _core.CTRL_DIAG_FLAGS["HEIGHT_HOLDS_SPRING"]
    HEIGHT_ESTIMATE_HELD = _core.CTRL_DIAG_FLAGS["HEIGHT_ESTIMATE_HELD"]
    TRIGGER_LATERAL = _core.CTRL_DIAG_FLAGS["TRIGGER_LATERAL"]
    TRIGGER_STEER_RATE = _core.CTRL_DIAG_FLAGS["TRIGGER_STEER_RATE"]
    TRIGGER_LONGITUDINAL = _core.CTRL_DIAG_FLAGS["TRIGGER_LONGITUDINAL"]
    TRIGGER_BRAKE = _core.CTRL_DIAG_FLAGS["TRIGGER_BRAKE"]
    TRIGGER_SPEED = _core.CTRL_DIAG_FLAGS["TRIGGER_SPEED"]
    TRIGGER_SPORT = _core.CTRL_DIAG_FLAGS["TRIGGER_SPORT"]
    HANDLING_HOLD = _core.CTRL_DIAG_FLAGS["HANDLING_HOLD"]


#: All handling-trigger flags.
TRIGGERS = (
    Diag.TRIGGER_LATERAL | Diag.TRIGGER_STEER_RATE | Diag.TRIGGER_LONGITUDINAL | Diag.TRIGGER_BRAKE | Diag.TRIGGER_SPEED | Diag.TRIGGER_SPORT
)


@dataclass(frozen=True)
class Inputs:
    """What the ECU measures in one period, SI units."""

    p_gas_pa: float
    p_gas2_pa: float
    t_gas_k: float
    strut_disp_m: float = 0.0
    body_acc_m_s2: float = 0.0
    speed_m_s: float = 0.0
    lat_acc_m_s2: float = 0.0
    long_acc_m_s2: float = 0.0
    steer_angle_rad: float = 0.0
    steer_rate_rad_s: float = 0.0
    brake_pressed: bool = False
    driver_mode: DriverMode = DriverMode.AUTO
    ride_height_request_m: float = 0.0
    fresh: InputGroup = InputGroup.ALL
    link_fault: bool = False

    def to_dict(self) -> ControllerInputsDict:
        """The extension's form: enums and the group mask as numbers."""
        d = asdict(self)
        d["driver_mode"] = int(self.driver_mode)
        d["fresh"] = int(self.fresh)
        return cast(ControllerInputsDict, d)


@dataclass(frozen=True)
class Outputs:
    """What the controller commands and reports in one period."""

    valve5_open: bool
    valve6_open: bool
    drive_mode: DriveMode
    spring_mode: SpringMode
    damper_mode: DamperMode
    sequencer: SequencerState
    diag: Diag
    ride_height_m: float
    p_gas2_target_pa: float
    p_load_pa: float
    strut_vel_m_s: float
    body_vel_m_s: float

    @classmethod
    def from_dict(cls, d: ControllerOutputsDict) -> Outputs:
        return cls(
            valve5_open=bool(d["valve5_open"]),
            valve6_open=bool(d["valve6_open"]),
            drive_mode=DriveMode(d["drive_mode"]),
            spring_mode=SpringMode(d["spring_mode"]),
            damper_mode=DamperMode(d["damper_mode"]),
            sequencer=SequencerState(d["sequencer"]),
            diag=Diag(d["diag"]),
            ride_height_m=float(d["ride_height_m"]),
            p_gas2_target_pa=float(d["p_gas2_target_pa"]),
            p_load_pa=float(d["p_load_pa"]),
            strut_vel_m_s=float(d["strut_vel_m_s"]),
            body_vel_m_s=float(d["body_vel_m_s"]),
        )

    @property
    def safe(self) -> bool:
        """The outputs are the safe state."""
        return bool(self.diag & Diag.SAFE_STATE)


#: Input fields and their array dtypes for :meth:`Controller.step_many`.
INPUT_DTYPES: dict[str, type] = {
    f.name: (bool if f.name in ("brake_pressed", "link_fault") else np.int64 if f.name in ("driver_mode", "fresh") else np.float64)
    for f in fields(Inputs)
}


def input_arrays(inputs: Mapping[str, ArrayLike]) -> dict[str, NDArray[Any]]:
    """``inputs`` (a value or an array per field; missing fields as the
    :class:`Inputs` defaults; fields without a default are required) as
    equally long contiguous arrays of the dtypes :meth:`Controller.step_many`
    takes."""
    if not isinstance(inputs, Mapping):
        raise bad_argument("inputs", inputs, "a mapping of input field names to values or arrays")
    unknown = set(inputs) - set(INPUT_DTYPES)
    if unknown:
        raise _core.ParameterError(f"unknown input field(s) {sorted(unknown)} (known: {', '.join(INPUT_DTYPES)})")
    for name, v in inputs.items():
        if isinstance(v, (str, bytes)) or np.ndim(v) > 1:
            raise bad_argument(f"inputs.{name}", v, "a number or a one-dimensional array")
    lengths = {np.size(v) for v in inputs.values() if np.ndim(v) > 0}
    if len(lengths) > 1:
        raise _core.ParameterError(f"input arrays of unequal lengths {sorted(lengths)}")
    n = lengths.pop() if lengths else 1
    out: dict[str, NDArray[Any]] = {}
    for f in fields(Inputs):
        if f.name in inputs:
            value = inputs[f.name]
        elif isinstance(f.default, (int, float, bool)):
            value = f.default
        else:
            raise _core.ParameterError(f"missing input field {f.name}")
        try:
            converted: NDArray[Any] = np.asarray(value, dtype=INPUT_DTYPES[f.name])
        except (TypeError, ValueError):
            raise bad_argument(f"inputs.{f.name}", value, f"a value or a one-dimensional array convertible to {np.dtype(INPUT_DTYPES[f.name])}") from None
        out[f.name] = np.ascontiguousarray(np.broadcast_to(converted, (n,)))
    return out


def seed_config() -> ControllerConfig:
    """The seed unit's controller configuration (nested dict, SI units)."""
    return _core.ctrl_seed_config()


class Controller:
    """One controller: compiled parameters and state, starting at power-on
    (the safe state)."""

    def __init__(self, config: ControllerConfig | None = None) -> None:
        if config is not None and not isinstance(config, Mapping):
            raise bad_argument("config", config, "a configuration mapping like seed_config() (or None)")
        # A copy as a plain dict: the extension reads dicts (any Mapping is accepted here).
        self._core = _core.Controller(None if config is None else cast(ControllerConfig, dict(config)))

    @property
    def config(self) -> ControllerConfig:
        return self._core.config

    def reset(self) -> None:
        """Back to power-on."""
        self._core.reset()

    def step(self, inputs: Inputs, dt_s: float) -> Outputs:
        """One control period."""
        if not isinstance(inputs, Inputs):
            raise bad_argument("inputs", inputs, "an hpctl.control.controller.Inputs")
        return Outputs.from_dict(self._core.step(inputs.to_dict(), check_number(dt_s, "dt_s", finite=False)))

    def step_many(self, inputs: Mapping[str, ArrayLike], dt_s: float | ArrayLike) -> dict[str, NDArray[Any]]:
        """Consecutive periods: ``inputs`` as for :func:`input_arrays`,
        ``dt_s`` one step size or one per period. Returns the outputs as
        arrays (enums as their numeric values, ``diag`` as uint32)."""
        arrays = input_arrays(inputs)
        dt: float | NDArray[np.float64] = check_number(dt_s, "dt_s", finite=False) if np.ndim(dt_s) == 0 else check_float_array(dt_s, "dt_s")
        return self._core.step_many(arrays, dt)

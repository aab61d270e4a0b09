"""The exception hierarchy: every input error is an :class:`HpctlError`,
which is a :class:`ValueError`.

The classes come from the Rust extension, where the one core error enum is
mapped onto them; :class:`RecordError` adds malformed rig records,
:class:`OutputError` output folders that cannot be used as asked.

A bad argument raises :class:`ParameterError` whose message names the
parameter, its value and what was expected, and which carries them as the
attributes ``parameter``, ``value`` and ``expected`` (where the check knows
them: the Rust core's range errors and the checks below). The checks here
are for the Python API's entry points: a wrong type or shape there must not
surface as a bare ``TypeError`` from deep inside numpy or the bindings.
"""

from __future__ import annotations

import math
import numbers
from typing import Any, cast

import numpy as np
from numpy.typing import NDArray

from hpctl._core import (
    CanRejectError,
    ConvergenceError,
    HpctlError,
    InternalError,
    ParameterError,
    SimulationError,
)

__all__ = [
    "CanRejectError",
    "ConvergenceError",
    "HpctlError",
    "InternalError",
    "MappingError",
    "MissingDependencyError",
    "OutputError",
    "ParameterError",
    "RecordError",
    "SimulationError",
    "bad_argument",
    "check_flags",
    "check_float_array",
    "check_int",
    "check_number",
]


class RecordError(HpctlError):
    """A rig record (CSV + TOML) does not follow the format.

    The message says which file, which line or key, and what was expected.
    """


class MappingError(HpctlError):
    """A channel-mapping file (foreign channel names and units to the
    record's) is malformed, names a channel the file does not have, or a
    unit that is unknown or of the wrong kind. The message says which."""


class MissingDependencyError(HpctlError):
    """An optional dependency is not installed; the message names the
    extra that installs it (``pip install 'hpctl[interop]'``)."""


class OutputError(HpctlError):
    """An output folder cannot be used as asked: another hpctl run is
    writing into it, or it holds files hpctl did not write (see
    :mod:`hpctl.data.output`)."""


def bad_argument(name: str, value: Any, expected: str) -> ParameterError:
    """``ParameterError("name = value: expected ...")`` with the attributes
    ``parameter``, ``value`` and ``expected``."""
    shown = " ".join(repr(value).split())  # one line, whatever the repr
    if len(shown) > 80:
        shown = shown[:77] + "..."
    e = ParameterError(f"{name} = {shown}: expected {expected}")
    e.parameter = name  # type: ignore[attr-defined]
    e.value = value  # type: ignore[attr-defined]
    e.expected = expected  # type: ignore[attr-defined]
    return e


def check_number(value: Any, name: str, *, finite: bool = True) -> float:
    """A real number (not a bool, not a string) as a float; NaN and
    infinities refused unless ``finite`` is false."""
    expected = "a finite real number" if finite else "a real number"
    if isinstance(value, np.ndarray) and value.ndim == 0:
        value = value.item()
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, numbers.Real):
        raise bad_argument(name, value, expected)
    v = float(value)
    if finite and not math.isfinite(v):
        raise bad_argument(name, value, expected)
    return v


def check_int(value: Any, name: str, lo: int, hi: int) -> int:
    """An integer within ``[lo, hi]`` (not a bool, not a float)."""
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, numbers.Integral) or not lo <= int(value) <= hi:
        raise bad_argument(name, value, f"an integer within [{lo}, {hi}]")
    return int(value)


def check_float_array(value: Any, name: str) -> NDArray[np.float64]:
    """A one-dimensional array of real numbers as a contiguous float64
    array (lists, tuples, integer arrays accepted)."""
    expected = "a one-dimensional array or sequence of real numbers"
    if isinstance(value, (str, bytes)):
        raise bad_argument(name, value, expected)
    try:
        a = np.asarray(value)
    except (TypeError, ValueError):
        raise bad_argument(name, value, expected) from None
    if a.ndim != 1 or not (np.issubdtype(a.dtype, np.number) or a.dtype == np.bool_) or np.issubdtype(a.dtype, np.complexfloating):
        raise bad_argument(name, value, f"{expected} (got {a.ndim}-D {a.dtype})")
    return np.ascontiguousarray(a, dtype=np.float64)


def check_flags(value: Any, name: str) -> bool | list[bool]:
    """A bool, or a one-dimensional sequence of bools (0/1 accepted)."""
    expected = "a bool or a one-dimensional sequence of bools (or 0/1)"
    if isinstance(value, (bool, np.bool_)):
        return bool(value)
    if isinstance(value, (str, bytes)) or np.ndim(value) != 1:
        raise bad_argument(name, value, expected)
    a = np.asarray(value)
    # tolist, not a loop of bool(): a run's flags are a record's samples,
    # and a flexible fit is thousands of runs (2.5 s of the bundled
    # campaign's 50 s fit, stop 39).
    if a.dtype == np.bool_:
        return cast(list[bool], a.tolist())
    if np.issubdtype(a.dtype, np.number) and np.all((a == 0) | (a == 1)):
        return cast(list[bool], (a != 0).tolist())
    raise bad_argument(name, value, expected)

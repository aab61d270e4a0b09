"""The exception hierarchy: every input error is an :class:`HpctlError`,
which is a :class:`ValueError`.

The classes come from the Rust extension, where the one core error enum is
mapped onto them; :class:`RecordError` adds malformed rig records.
"""

from __future__ import annotations

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
    "ParameterError",
    "RecordError",
    "SimulationError",
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

"""Controller configuration files: TOML, one table per block of the
controller's configuration (``[unit]``, ``[monitor]`` with
``[monitor.timeouts]``, ``[estimator]``, ``[mode]``, ``[damper]``,
``[ride_height]``), SI units, the same names as the dict form
(:func:`hpctl.control.controller.seed_config`).

A file may give only the values it changes: they are merged over a base,
by default the configuration derived from the unit
(:func:`hpctl.control.closed_loop.config_for_unit`, from ``hp-ctrl``'s
``UnitConfig::from_unit``). ``tuned.json`` from ``hpctl tune`` (JSON,
``{"config": ...}``) reads the same way. The values are checked by the
controller itself (the one place its ranges live): an unknown block or
key, a wrong type or a value outside its range raises
:class:`~hpctl.errors.ParameterError` naming the file, the key, the value
and the valid range.

    [mode]
    lat_acc_enter_m_s2 = 2.5
    lat_acc_exit_m_s2 = 1.5

    [ride_height]
    tolerance_m = 0.004
"""

from __future__ import annotations

import copy
import json
import tomllib
from collections.abc import Mapping
from pathlib import Path
from typing import Any, cast

import tomli_w

from hpctl.control.controller import Controller, ControllerConfig
from hpctl.errors import HpctlError, ParameterError


def merge(base: Mapping[str, Any], changes: Mapping[str, Any], where: str = "config") -> dict[str, Any]:
    """``base`` with ``changes`` merged in, table by table; a key that
    ``base`` does not have raises :class:`ParameterError` naming it and the
    known keys (a misspelt key must not be ignored). Generic over nested
    tables (the result is what the file said, not yet checked: :func:`check`
    turns it into a :class:`ControllerConfig`)."""
    out = copy.deepcopy(dict(base))
    for key, value in changes.items():
        path = f"{where}.{key}"
        if key not in out:
            raise ParameterError(f"{path}: unknown key (known in {where}: {', '.join(sorted(out))})")
        if isinstance(out[key], Mapping):
            if not isinstance(value, Mapping):
                raise ParameterError(f"{path} = {value!r}: expected a table of {', '.join(sorted(out[key]))}")
            out[key] = merge(out[key], value, path)
        elif isinstance(value, Mapping):
            raise ParameterError(f"{path}: expected a value, got a table")
        else:
            out[key] = value
    return out


def merged(base: ControllerConfig, changes: Mapping[str, Any], where: str = "config") -> ControllerConfig:
    """:func:`merge` of a configuration's changes (any subset of its
    tables and keys) over a whole configuration: the same keys as ``base``
    by construction (merge adds none and drops none), the values as given
    (the controller checks them where it is built)."""
    return cast(ControllerConfig, merge(base, changes, where))


def check(config: Mapping[str, Any], source: str = "config") -> ControllerConfig:
    """``config`` checked by the controller (every key present, no unknown
    one, types, ranges, the order of hysteresis thresholds); returns it as a
    plain dict, typed (the check is what makes the type true)."""
    checked = cast(ControllerConfig, dict(config))
    try:
        Controller(checked)
    except HpctlError as e:
        raise type(e)(f"{source}: {e}") from None
    return checked


def read_changes(path: str | Path) -> dict[str, Any]:
    """The values a configuration file gives (TOML, or JSON as ``hpctl tune``
    writes it), not yet merged or checked: any subset of the tables, so
    untyped until :func:`read_config` merges and checks it."""
    path = Path(path)
    try:
        text = path.read_text()
    except (OSError, UnicodeDecodeError) as e:
        raise ParameterError(f"{path}: cannot read the controller configuration: {e}") from None
    try:
        data: Any = json.loads(text) if path.suffix.lower() == ".json" else tomllib.loads(text)
    except (json.JSONDecodeError, tomllib.TOMLDecodeError) as e:
        raise ParameterError(f"{path}: not valid {'JSON' if path.suffix.lower() == '.json' else 'TOML'}: {e}") from None
    if isinstance(data, dict) and set(data) == {"config"}:
        data = data["config"]  # tuned.json
    if not isinstance(data, dict):
        raise ParameterError(f"{path}: expected tables of the controller configuration ([unit], [mode], ...)")
    return data


def read_config(path: str | Path, base: ControllerConfig) -> ControllerConfig:
    """The configuration a file describes: its values merged over ``base``
    (usually :func:`~hpctl.control.closed_loop.config_for_unit` of the unit
    the controller runs), checked."""
    changes = read_changes(path)
    try:
        merged = merge(base, changes, "config")
    except ParameterError as e:
        raise ParameterError(f"{path}: {e}") from None
    return check(merged, str(path))


def to_toml(config: ControllerConfig) -> str:
    """A configuration as the TOML text :func:`read_config` reads."""
    return tomli_w.dumps(dict(config))


def write_config(config: ControllerConfig, path: str | Path) -> Path:
    """Writes ``config`` as TOML (checked first: a file hpctl writes reads back)."""
    path = Path(path)
    path.write_text(to_toml(check(config)))
    return path

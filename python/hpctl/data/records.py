"""Rig records: the data contract of test benches (docs: rig-data-format.md).

A record is ``NAME.csv`` (time series) plus ``NAME.toml`` (what was tested).
:func:`read_record` checks everything and raises :class:`RecordError` naming
the file, the line or key, and what was expected; :func:`write_record`
writes exactly the format, so a record written and read back is identical.

The pair is written so that a reader never takes half of one write and
half of another for a record: both files go to temporary names first, then
the CSV is renamed into place, then the TOML (:mod:`hpctl.data.output`).
The TOML written by hpctl carries the CSV's SHA-256 (``[record]
csv_sha256``, optional for records from elsewhere); a CSV that does not
match it (an interrupted rewrite, a concurrent writer, an edit) is refused.
"""

from __future__ import annotations

import csv
import hashlib
import io
import math
import os
import tomllib
from dataclasses import dataclass, field
from pathlib import Path
from collections.abc import Mapping
from typing import Any, Literal

import numpy as np
import tomli_w
from numpy.typing import NDArray

from hpctl import _core
from hpctl.data.output import replace_in_order, temp_name
from hpctl.errors import RecordError, bad_argument

Kind = Literal["characterisation", "sdof"]
KINDS = ("characterisation", "sdof")
EXCITATIONS = ("sine", "step", "steps", "random", "drive")

# Known columns: unit, and for which kinds they are required.
COLUMNS: dict[str, tuple[str, tuple[str, ...]]] = {
    "time_s": ("s", KINDS),
    "disp_m": ("m", KINDS),
    "force_n": ("N", ("characterisation",)),
    "body_disp_m": ("m", ("sdof",)),
    "base_disp_m": ("m", ("sdof",)),
    "p_gas_pa": ("Pa", ()),
    "p_gas2_pa": ("Pa", ()),
    "t_gas_k": ("K", ()),
    "t_oil_k": ("K", ()),
    "t_amb_k": ("K", ()),
    "spring_hard": ("0/1", ()),
    "damper_on": ("0/1", ()),
}
FLAG_COLUMNS = ("spring_hard", "damper_on")
#: Where a valve switched, read from a flag column that changes between two
#: samples: the fraction of the interval before the first sample with the
#: new state. The column is the state at each sample, so the switch lies
#: anywhere in that interval; midway halves the largest timing error and
#: quarters its mean square against the sample that shows it (dt^2/12
#: instead of dt^2/3). At 200 Hz that is 2.5 ms, against valves that open
#: in 10-80 ms (hpctl.sim.run.run's ``switch_lead``).
LOGGED_SWITCH_LEAD = 0.5


@dataclass(frozen=True)
class RecordUnit:
    """The ``[unit]`` table: the unit as built."""

    piston_area_m2: float
    small_acc_volume_m3: float
    large_acc_volume_m3: float
    gas: str = "N2"


@dataclass(frozen=True)
class RecordStatic:
    """The ``[static]`` table: the state at the static position."""

    pressure_pa: float
    temperature_k: float
    ambient_k: float


@dataclass(frozen=True)
class RecordTest:
    """The ``[test]`` table."""

    spring: Literal["soft", "hard"]
    damper: Literal["off", "on"]
    excitation: str
    amplitude_m: float | None = None
    frequency_hz: float | None = None


@dataclass(eq=False)
class RigRecord:
    """One rig record. ``data`` keeps the CSV's columns in file order,
    unknown columns included. Two records are equal when everything a
    record file holds is (the name, which is the file's, aside): the
    tables and the columns, in order, sample for sample."""

    kind: Kind
    unit: RecordUnit
    static: RecordStatic
    test: RecordTest
    data: dict[str, NDArray[np.float64]]
    description: str = ""
    sprung_mass_kg: float | None = None
    name: str = field(default="record", compare=False)

    def __getitem__(self, column: str) -> NDArray[np.float64]:
        return self.data[column]

    def __eq__(self, other: object) -> bool:
        if not isinstance(other, RigRecord):
            return NotImplemented
        return (
            (self.kind, self.unit, self.static, self.test, self.description, self.sprung_mass_kg)
            == (other.kind, other.unit, other.static, other.test, other.description, other.sprung_mass_kg)
            and list(self.data) == list(other.data)
            and all(np.array_equal(self.data[c], other.data[c]) for c in self.data)
        )

    # Mutable (its arrays): not hashable, like the dataclass it was.
    __hash__ = None  # type: ignore[assignment]

    def __contains__(self, column: str) -> bool:
        return column in self.data

    def spring_hard(self) -> NDArray[np.bool_]:
        """Per-sample spring state (from the column, else from the TOML)."""
        if "spring_hard" in self.data:
            return self.data["spring_hard"] > 0.5
        return np.full(len(self.data["time_s"]), self.test.spring == "hard")

    def damper_on(self) -> NDArray[np.bool_]:
        """Per-sample damper state (from the column, else from the TOML)."""
        if "damper_on" in self.data:
            return self.data["damper_on"] > 0.5
        return np.full(len(self.data["time_s"]), self.test.damper == "on")


# TOML schema: table -> key -> (type, required, valid range or choices).
# Ranges of what the core models are the core's own (hp_core::ranges), so
# that a record the reader accepts is one the model can simulate.
_Range = tuple[float, float]
_CORE = _core.PARAMETER_RANGES
_SCHEMA: dict[str, dict[str, tuple[type, bool, Any]]] = {
    "record": {"kind": (str, True, KINDS), "description": (str, False, None), "csv_sha256": (str, False, None)},
    "unit": {
        "piston_area_m2": (float, True, _CORE["piston_area_m2"]),
        "small_acc_volume_m3": (float, True, _CORE["small_acc_volume_m3"]),
        "large_acc_volume_m3": (float, True, _CORE["large_acc_volume_m3"]),
        "gas": (str, False, ("N2",)),
    },
    "static": {
        "pressure_pa": (float, True, _CORE["static_pressure_pa"]),
        "temperature_k": (float, True, _CORE["static_temperature_k"]),
        "ambient_k": (float, True, _CORE["static_temperature_k"]),
    },
    "test": {
        "spring": (str, True, ("soft", "hard")),
        "damper": (str, True, ("off", "on")),
        "excitation": (str, True, EXCITATIONS),
        "amplitude_m": (float, False, (0.0, 1.0)),
        "frequency_hz": (float, False, (0.0, 1e3)),
    },
    "sdof": {"sprung_mass_kg": (float, True, _CORE["sprung_mass_kg"])},
}

# Suffixes of non-SI names people use, to say what was meant.
_NON_SI_HINTS = {
    "_mpa": "Pa", "_bar": "Pa", "_kpa": "Pa", "_psi": "Pa", "_c": "K", "_degc": "K",
    "_mm": "m", "_cm": "m", "_l": "m3", "_kn": "N", "_t": "kg", "_ms": "s",
}


def _toml_error(path: Path, where: str, expected: str) -> RecordError:
    return RecordError(f"{path}: {where}: {expected}")


def _check_value(path: Path, table: str, key: str, value: Any, spec: tuple[type, bool, Any]) -> Any:
    typ, _required, valid = spec
    where = f"[{table}] {key}"
    if typ is float:
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            raise _toml_error(path, where, f"expected a number in SI units ({key.rsplit('_', 1)[-1]}), got {value!r}")
        value = float(value)
        lo, hi = valid
        if not (math.isfinite(value) and lo <= value <= hi):
            raise _toml_error(path, where, f"= {value!r} is outside [{lo:g}, {hi:g}] (SI units: is it in the right unit?)")
        return value
    if not isinstance(value, str):
        raise _toml_error(path, where, f"expected a string, got {value!r}")
    if valid is not None and value not in valid:
        raise _toml_error(path, where, f"= {value!r}, expected one of {', '.join(map(repr, valid))}")
    return value


def _read_toml(path: Path) -> dict[str, dict[str, Any]]:
    try:
        raw = tomllib.loads(path.read_text())
    except FileNotFoundError:
        raise RecordError(f"{path}: file not found (a record is NAME.csv plus NAME.toml)") from None
    except (OSError, UnicodeDecodeError) as e:
        raise RecordError(f"{path}: cannot read: {e}") from None
    except tomllib.TOMLDecodeError as e:
        raise RecordError(f"{path}: not valid TOML: {e}") from None
    return _check_meta(raw, path)


def _check_meta(raw: Mapping[str, Any], path: Path | str) -> dict[str, dict[str, Any]]:
    """The metadata tables checked against the schema (errors name ``path``)."""
    path = Path(path)
    out: dict[str, dict[str, Any]] = {}
    for table, content in raw.items():
        if table not in _SCHEMA:
            raise _toml_error(path, f"[{table}]", f"unknown table; expected {', '.join(f'[{t}]' for t in _SCHEMA)}")
        if not isinstance(content, dict):
            raise _toml_error(path, table, "expected a table")
        schema = _SCHEMA[table]
        checked = {}
        for key, value in content.items():
            if key not in schema:
                hint = next((f" (hpctl reads SI units only: use a name ending in _{si.lower()})" for suf, si in _NON_SI_HINTS.items() if key.lower().endswith(suf)), "")
                raise _toml_error(path, f"[{table}] {key}", f"unknown key{hint}; expected one of {', '.join(schema)}")
            checked[key] = _check_value(path, table, key, value, schema[key])
        out[table] = checked
    for table in ("record", "unit", "static", "test"):
        if table not in out:
            raise _toml_error(path, f"[{table}]", "missing table")
    kind = out["record"].get("kind")
    if kind == "sdof" and "sdof" not in out:
        raise _toml_error(path, "[sdof]", "missing table (required for kind = \"sdof\")")
    if kind == "characterisation" and "sdof" in out:
        raise _toml_error(path, "[sdof]", "only allowed for kind = \"sdof\"")
    for table, content in out.items():
        for key, (_t, required, _v) in _SCHEMA[table].items():
            if required and key not in content:
                raise _toml_error(path, f"[{table}] {key}", "missing key")
    return out


def _read_csv(path: Path, kind: str, sha256: str | None = None) -> dict[str, NDArray[np.float64]]:
    try:
        raw = path.read_bytes()
        text = raw.decode("utf-8")
    except FileNotFoundError:
        raise RecordError(f"{path}: file not found (a record is NAME.csv plus NAME.toml)") from None
    except (OSError, UnicodeDecodeError) as e:
        raise RecordError(f"{path}: cannot read: {e}") from None
    if sha256 is not None and hashlib.sha256(raw).hexdigest() != sha256:
        raise RecordError(f"{path}: does not match the csv_sha256 in {path.with_suffix('.toml').name}: the two files were not written "
                          "together (an interrupted or concurrent write), or the CSV was edited since; if the edit is meant, "
                          "remove csv_sha256 from the TOML")
    rows = list(csv.reader(text.splitlines()))
    if not rows or not any(c.strip() for c in rows[0]):
        raise RecordError(f"{path}: line 1: expected a header row with at least time_s, disp_m")
    header = [c.strip() for c in rows[0]]
    for i, name in enumerate(header):
        if not name:
            raise RecordError(f"{path}: line 1: column {i + 1} has an empty name")
    duplicates = sorted({h for h in header if header.count(h) > 1})
    if duplicates:
        raise RecordError(f"{path}: line 1: duplicate column {duplicates[0]!r}")
    required = [c for c, (_u, kinds) in COLUMNS.items() if kind in kinds]
    missing = [c for c in required if c not in header]
    if missing:
        raise RecordError(f"{path}: line 1: missing required column {missing[0]!r} for a {kind} record (required: {', '.join(required)})")
    values = np.empty((len(rows) - 1, len(header)))
    for n, row in enumerate(rows[1:]):
        line = n + 2
        if len(row) != len(header):
            raise RecordError(f"{path}: line {line}: {len(row)} fields, expected {len(header)} (one per header column)")
        for j, cell in enumerate(row):
            try:
                v = float(cell)
            except ValueError:
                raise RecordError(f"{path}: line {line}, column {header[j]!r}: {cell!r} is not a number") from None
            if not math.isfinite(v):
                raise RecordError(f"{path}: line {line}, column {header[j]!r}: {cell!r} is not a finite number")
            values[n, j] = v
    if values.shape[0] < 2:
        raise RecordError(f"{path}: expected at least two data rows, found {values.shape[0]}")
    data = {name: values[:, j].copy() for j, name in enumerate(header)}
    t = data["time_s"]
    bad = np.flatnonzero(np.diff(t) <= 0)
    if bad.size:
        i = int(bad[0]) + 1
        raise RecordError(f"{path}: line {i + 2}, column 'time_s': {float(t[i])!r} does not increase strictly (previous {float(t[i - 1])!r})")
    for flag in FLAG_COLUMNS:
        if flag in data:
            off = np.flatnonzero((data[flag] != 0) & (data[flag] != 1))
            if off.size:
                i = int(off[0])
                raise RecordError(f"{path}: line {i + 2}, column {flag!r}: {float(data[flag][i])!r}, expected 0 or 1")
    return data


def record_paths(path: str | Path) -> tuple[Path, Path]:
    """``NAME.csv`` and ``NAME.toml`` for ``NAME``, ``NAME.csv`` or ``NAME.toml``."""
    if not isinstance(path, (str, os.PathLike)):
        raise bad_argument("path", path, "a path (str or os.PathLike) to NAME, NAME.csv or NAME.toml")
    p = Path(path)
    stem = p.with_suffix("") if p.suffix in (".csv", ".toml") else p
    return stem.with_name(stem.name + ".csv"), stem.with_name(stem.name + ".toml")


def read_record(path: str | Path) -> RigRecord:
    """Reads and checks a record (``NAME``, ``NAME.csv`` or ``NAME.toml``)."""
    csv_path, toml_path = record_paths(path)
    meta = _read_toml(toml_path)
    kind = meta["record"]["kind"]
    data = _read_csv(csv_path, kind, meta["record"].get("csv_sha256"))
    return RigRecord(
        kind=kind,
        description=meta["record"].get("description", ""),
        unit=RecordUnit(**meta["unit"]),
        static=RecordStatic(**meta["static"]),
        test=RecordTest(**meta["test"]),
        sprung_mass_kg=meta.get("sdof", {}).get("sprung_mass_kg"),
        data=data,
        name=csv_path.stem,
    )


def record_meta(record: RigRecord) -> dict[str, dict[str, Any]]:
    """The record's metadata as the TOML file holds it (tables of plain
    strings and floats): what other formats carry beside the columns."""
    meta: dict[str, dict[str, Any]] = {
        "record": {"kind": record.kind, "description": record.description},
        "unit": _drop_none(vars(record.unit)),
        "static": _drop_none(vars(record.static)),
        "test": _drop_none(vars(record.test)),
    }
    if record.kind == "sdof":
        meta["sdof"] = {"sprung_mass_kg": record.sprung_mass_kg}
    return meta


def record_from_parts(meta: Mapping[str, Any], data: Mapping[str, Any], source: str | Path, name: str = "record") -> RigRecord:
    """A record from metadata tables (as :func:`record_meta` gives them) and
    columns (name -> samples, in SI units), checked as :func:`read_record`
    checks a file: the schema, the required columns, finite samples, time
    strictly increasing, flags 0 or 1. Errors name ``source``, the table,
    key, column and sample."""
    checked = _check_meta(meta, source)
    kind = checked["record"]["kind"]
    columns: dict[str, NDArray[np.float64]] = {}
    n = None
    for column, values in data.items():
        try:
            a = np.array(values, dtype=np.float64).reshape(-1)
        except (TypeError, ValueError):
            raise RecordError(f"{source}: column {column!r}: not numbers") from None
        if n is not None and a.size != n:
            raise RecordError(f"{source}: column {column!r} has {a.size} samples, expected {n} (as the columns before it)")
        n = a.size
        bad = np.flatnonzero(~np.isfinite(a))
        if bad.size:
            raise RecordError(f"{source}: column {column!r}, sample {int(bad[0])}: {float(a[bad[0]])!r} is not a finite number")
        columns[str(column)] = a
    required = [c for c, (_u, kinds) in COLUMNS.items() if kind in kinds]
    missing = [c for c in required if c not in columns]
    if missing:
        raise RecordError(f"{source}: missing required column {missing[0]!r} for a {kind} record (required: {', '.join(required)})")
    if (n or 0) < 2:
        raise RecordError(f"{source}: expected at least two samples, found {n or 0}")
    t = columns["time_s"]
    bad = np.flatnonzero(np.diff(t) <= 0)
    if bad.size:
        i = int(bad[0]) + 1
        raise RecordError(f"{source}: column 'time_s', sample {i}: {float(t[i])!r} does not increase strictly (previous {float(t[i - 1])!r})")
    for flag in FLAG_COLUMNS:
        if flag in columns:
            off = np.flatnonzero((columns[flag] != 0) & (columns[flag] != 1))
            if off.size:
                i = int(off[0])
                raise RecordError(f"{source}: column {flag!r}, sample {i}: {float(columns[flag][i])!r}, expected 0 or 1")
    return RigRecord(
        kind=kind,
        description=checked["record"].get("description", ""),
        unit=RecordUnit(**checked["unit"]),
        static=RecordStatic(**checked["static"]),
        test=RecordTest(**checked["test"]),
        sprung_mass_kg=checked.get("sdof", {}).get("sprung_mass_kg"),
        data=columns,
        name=name,
    )


def write_record(record: RigRecord, path: str | Path) -> tuple[Path, Path]:
    """Writes ``NAME.csv`` and ``NAME.toml``; floats are written with the
    shortest representation that reads back to the same value. Both go to
    temporary names first, then the CSV is renamed into place, then the
    TOML (with the CSV's SHA-256): see the module docs."""
    if not isinstance(record, RigRecord):
        raise bad_argument("record", record, "an hpctl.data.records.RigRecord")
    csv_path, toml_path = record_paths(path)
    csv_path.parent.mkdir(parents=True, exist_ok=True)
    columns = list(record.data)
    arrays = [np.asarray(record.data[c], dtype=float) for c in columns]
    n = len(arrays[0])
    buf = io.StringIO()
    w = csv.writer(buf, lineterminator="\n")
    w.writerow(columns)
    for i in range(n):
        w.writerow([_fmt(c, a[i]) for c, a in zip(columns, arrays)])
    csv_bytes = buf.getvalue().encode("utf-8")
    meta = record_meta(record)
    meta["record"]["csv_sha256"] = hashlib.sha256(csv_bytes).hexdigest()
    csv_tmp, toml_tmp = temp_name(csv_path), temp_name(toml_path)
    try:
        for tmp, data in ((csv_tmp, csv_bytes), (toml_tmp, tomli_w.dumps(meta).encode("utf-8"))):
            with tmp.open("wb") as f:
                f.write(data)
                f.flush()
                os.fsync(f.fileno())
        replace_in_order([(csv_tmp, csv_path), (toml_tmp, toml_path)])
    finally:
        csv_tmp.unlink(missing_ok=True)
        toml_tmp.unlink(missing_ok=True)
    return csv_path, toml_path


def _fmt(column: str, v: float) -> str:
    if column in FLAG_COLUMNS:
        return str(int(v))
    return repr(float(v))


def _drop_none(d: dict[str, Any]) -> dict[str, Any]:
    return {k: v for k, v in d.items() if v is not None}

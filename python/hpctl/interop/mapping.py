"""Channel-mapping files: which foreign channel is which record column, in
which unit, and the record's metadata a foreign file does not carry.

A mapping file is TOML (docs/interop.md)::

    [channels]
    disp_m   = { name = "Weg", unit = "mm" }
    force_n  = { name = "Kraft", unit = "kN" }
    p_gas_pa = { name = "p_S", unit = "bar", gauge = true }   # + 101325 Pa
    t_gas_k  = { name = "T_S", unit = "degC" }

    [options]
    raster_s = 0.001        # resample channels on different time bases

    [record]                # the rig-record tables (rig-data-format.md)
    kind = "characterisation"
    [unit] ...  [static] ...  [test] ...

:func:`to_record` turns the channels a format module read (a
:class:`RawTable`) into a checked :class:`~hpctl.data.records.RigRecord`.
"""

from __future__ import annotations

import math
import tomllib
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from hpctl.data.records import FLAG_COLUMNS, RigRecord, record_from_parts
from hpctl.errors import MappingError, RecordError
from hpctl.interop.units import STANDARD_ATMOSPHERE_PA, si_unit, to_si

FloatArray = NDArray[np.float64]
#: The record-metadata tables a mapping file may carry.
META_TABLES = ("record", "unit", "static", "test", "sdof")


@dataclass(frozen=True)
class ChannelSpec:
    """One record column from one foreign channel."""

    column: str
    name: str
    unit: str | None = None
    #: The foreign pressure is gauge (relative to the standard atmosphere).
    gauge: bool = False


@dataclass(frozen=True)
class ChannelMap:
    channels: tuple[ChannelSpec, ...]
    raster_s: float | None = None
    meta: dict[str, dict[str, Any]] = field(default_factory=dict)
    path: str = "<mapping>"


def load_mapping(path: str | Path) -> ChannelMap:
    """Reads and checks a mapping file; errors name the file and the key."""
    p = Path(path)
    try:
        raw = tomllib.loads(p.read_text())
    except FileNotFoundError:
        raise MappingError(f"{p}: file not found") from None
    except (OSError, UnicodeDecodeError) as e:
        raise MappingError(f"{p}: cannot read: {e}") from None
    except tomllib.TOMLDecodeError as e:
        raise MappingError(f"{p}: not valid TOML: {e}") from None
    return parse_mapping(raw, str(p))


def parse_mapping(raw: Mapping[str, Any], source: str = "<mapping>") -> ChannelMap:
    unknown = sorted(set(raw) - {"channels", "options", *META_TABLES})
    if unknown:
        raise MappingError(f"{source}: unknown table [{unknown[0]}]; expected [channels], [options] and the record tables {', '.join(f'[{t}]' for t in META_TABLES)}")
    channels = raw.get("channels", {})
    if not isinstance(channels, dict):
        raise MappingError(f"{source}: [channels] must be a table")
    specs = []
    for column, spec in channels.items():
        where = f"{source}: [channels] {column}"
        if si_unit(column) is None:
            raise MappingError(f"{where}: not a record column or a name with an SI unit suffix (_pa, _k, _m, _n, _s, ...)")
        if isinstance(spec, str):
            spec = {"name": spec}
        if not isinstance(spec, dict) or not isinstance(spec.get("name"), str):
            raise MappingError(f"{where}: expected {{ name = \"FOREIGN NAME\", unit = \"UNIT\" }}")
        extra = sorted(set(spec) - {"name", "unit", "gauge"})
        if extra:
            raise MappingError(f"{where}: unknown key {extra[0]!r} (keys: name, unit, gauge)")
        unit = spec.get("unit")
        if unit is not None and not isinstance(unit, str):
            raise MappingError(f"{where}: unit must be a string")
        gauge = spec.get("gauge", False)
        if not isinstance(gauge, bool) or (gauge and si_unit(column) != "Pa"):
            raise MappingError(f"{where}: gauge = true/false, only for pressures (_pa)")
        specs.append(ChannelSpec(column, spec["name"], unit, gauge))
    options = raw.get("options", {})
    if not isinstance(options, dict) or set(options) - {"raster_s"}:
        raise MappingError(f"{source}: [options] takes raster_s only")
    raster = options.get("raster_s")
    if raster is not None and (isinstance(raster, bool) or not isinstance(raster, (int, float)) or not (math.isfinite(raster) and raster > 0)):
        raise MappingError(f"{source}: [options] raster_s = {raster!r} must be a positive number of seconds")
    meta = {t: dict(raw[t]) for t in META_TABLES if t in raw}
    return ChannelMap(tuple(specs), None if raster is None else float(raster), meta, source)


@dataclass
class Channel:
    """A channel as a file holds it: samples, unit (None: not stated) and
    its own time base (None: the table's)."""

    values: NDArray[Any]
    unit: str | None = None
    time_s: FloatArray | None = None


@dataclass
class RawTable:
    """What a format module read: channels by their names in the file, the
    common time base if the format has one, hpctl's metadata if the file
    carries it."""

    source: str
    channels: dict[str, Channel]
    time_s: FloatArray | None = None
    meta: dict[str, dict[str, Any]] | None = None


def _hold(t_new: FloatArray, t: FloatArray, x: FloatArray) -> FloatArray:
    """Zero-order hold of ``x(t)`` at ``t_new`` (for 0/1 flags)."""
    i = np.clip(np.searchsorted(t, t_new, side="right") - 1, 0, t.size - 1)
    return x[i]


def to_record(raw: RawTable, mapping: ChannelMap | None = None, name: str = "record") -> RigRecord:
    """The record in ``raw``: columns picked and converted to SI by
    ``mapping`` (without one, every channel must already be a record column
    and its unit SI or convertible), on one time base (``raster_s`` resamples
    channels that have different ones), metadata from the file overlaid by
    the mapping's tables."""
    where = raw.source
    if mapping is None:
        unknown = [n for n in raw.channels if si_unit(n) is None]
        if unknown:
            raise MappingError(f"{where}: channel {unknown[0]!r} is not a record column in SI units: give a channel-mapping file (docs/interop.md)")
        specs = [ChannelSpec(n, n, c.unit) for n, c in raw.channels.items()]
    else:
        specs = list(mapping.channels)
        missing = [s for s in specs if s.name not in raw.channels]
        if missing:
            raise MappingError(
                f"{mapping.path}: channel {missing[0].name!r} (for {missing[0].column}) is not in {where}; it has: {', '.join(sorted(raw.channels))}"
            )
    columns: dict[str, FloatArray] = {}
    times: dict[str, FloatArray | None] = {}
    for s in specs:
        ch = raw.channels[s.name]
        label = f"{mapping.path if mapping else where}: {s.column} (from {s.name!r})"
        x = to_si(ch.values, ch.unit if s.unit is None else s.unit, s.column, label)
        if s.gauge:
            x = x + STANDARD_ATMOSPHERE_PA
        columns[s.column] = x
        times[s.column] = None if ch.time_s is None else to_si(ch.time_s, None, "time_s", label)
    # The time base: a time_s column, else the table's, else the channels'.
    time = columns.pop("time_s", None)
    times.pop("time_s", None)
    if time is None:
        time = raw.time_s
    bases = {c: (t if t is not None else time) for c, t in times.items()}
    if any(b is None for b in bases.values()):
        raise RecordError(f"{where}: no time base: map a time channel to time_s")
    raster = mapping.raster_s if mapping else None
    if raster is not None:
        starts = [float(b[0]) for b in bases.values() if b is not None]
        ends = [float(b[-1]) for b in bases.values() if b is not None]
        t0, t1 = max(starts), min(ends)
        if not t1 > t0:
            raise RecordError(f"{where}: the channels do not overlap in time ({t0} s .. {t1} s)")
        grid = np.asarray(t0 + raster * np.arange(int(math.floor((t1 - t0) / raster + 1e-9)) + 1), dtype=np.float64)
        for c, b in bases.items():
            assert b is not None
            columns[c] = _hold(grid, b, columns[c]) if c in FLAG_COLUMNS else np.asarray(np.interp(grid, b, columns[c]), dtype=np.float64)
        time = grid
    else:
        assert time is not None or bases
        reference = time if time is not None else next(iter(bases.values()))
        for c, b in bases.items():
            if b is not None and reference is not None and (b.size != reference.size or not np.array_equal(b, reference)):
                raise RecordError(f"{where}: {c} has its own time base ({b.size} samples): set [options] raster_s in a mapping file to resample")
        time = reference
    meta: dict[str, dict[str, Any]] = {t: dict(v) for t, v in (raw.meta or {}).items()}
    for table, values in (mapping.meta if mapping else {}).items():
        meta.setdefault(table, {}).update(values)
    if not meta:
        raise RecordError(f"{where}: carries no hpctl record metadata: give a mapping file with the tables [record], [unit], [static], [test] (docs/interop.md)")
    data = {"time_s": np.asarray(time, dtype=np.float64), **columns}
    return record_from_parts(meta, data, where, name=name)

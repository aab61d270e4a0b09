"""Rig records to and from engineers' formats.

| format | suffix | library | metadata where |
|---|---|---|---|
| rig record | ``.csv`` + ``.toml`` | hpctl.data.records | the TOML |
| pandas | (in memory) | pandas | ``DataFrame.attrs`` |
| Parquet | ``.parquet`` | pyarrow | schema metadata ``hpctl`` (JSON), a field's ``unit`` |
| MDF4 | ``.mf4`` | asammdf | header comment (JSON), channel units |
| TDMS | ``.tdms`` | npTDMS | root properties ``hpctl.TABLE.KEY``, ``unit_string`` |
| MATLAB | ``.mat`` | scipy.io | ``record.meta``, ``record.units`` |

Every writer writes the record's columns in SI with their units and its
metadata, under a temporary name renamed into place; every reader gives a
:class:`~hpctl.interop.mapping.RawTable` that
:func:`~hpctl.interop.mapping.to_record` checks and converts (with a
channel-mapping file for foreign names and units).
"""

from __future__ import annotations

import json
import xml.etree.ElementTree as ET
from collections.abc import Callable
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from hpctl.data.records import COLUMNS, RigRecord, read_record, record_meta, record_paths, write_record
from hpctl.errors import MappingError, RecordError
from hpctl.interop._support import atomic_path, require
from hpctl.interop.mapping import Channel, ChannelMap, RawTable, to_record
from hpctl.interop.units import SUFFIX_UNITS

if TYPE_CHECKING:
    import pandas as pd

#: Format name -> file suffixes.
FORMATS: dict[str, tuple[str, ...]] = {
    "record": (".csv", ".toml"),
    "parquet": (".parquet", ".pq"),
    "mdf": (".mf4", ".mdf"),
    "tdms": (".tdms",),
    "mat": (".mat",),
}


def format_of(path: str | Path, fmt: str | None = None) -> str:
    """The format named, or the one the suffix says."""
    if fmt is not None:
        if fmt not in FORMATS:
            raise MappingError(f"format {fmt!r} is not one of {', '.join(FORMATS)}")
        return fmt
    suffix = Path(path).suffix.lower()
    for name, suffixes in FORMATS.items():
        if suffix in suffixes:
            return name
    # Any other name is a rig record's NAME (NAME.csv + NAME.toml), as
    # hpctl.data.records reads it ("sine_0.01hz" has the suffix ".01hz").
    return "record"


def unit_label(column: str) -> str:
    """A column's SI unit as files label it (the record format's spelling)."""
    if column in COLUMNS:
        return "" if COLUMNS[column][0] == "0/1" else COLUMNS[column][0]
    for suffix, unit in SUFFIX_UNITS:
        if column.endswith(suffix):
            return unit.replace("**", "^")
    return ""


def _units(record: RigRecord) -> dict[str, str]:
    return {c: unit_label(c) for c in record.data}


# ------------------------------------------------------------------ pandas


def to_dataframe(record: RigRecord) -> pd.DataFrame:
    """The record as a DataFrame: its columns (SI), ``attrs["hpctl"]`` the
    metadata tables, ``attrs["units"]`` each column's unit,
    ``attrs["name"]`` the record's name."""
    pd = require("pandas", "DataFrame conversion")
    df = pd.DataFrame({c: np.asarray(v, dtype=np.float64) for c, v in record.data.items()})
    df.attrs = {"hpctl": record_meta(record), "units": _units(record), "name": record.name}
    return df


def _raw_from_dataframe(df: pd.DataFrame, source: str) -> RawTable:
    units = df.attrs.get("units", {}) if isinstance(df.attrs.get("units"), dict) else {}
    channels = {str(c): Channel(df[c].to_numpy(dtype=np.float64), units.get(str(c))) for c in df.columns}
    meta = df.attrs.get("hpctl")
    return RawTable(source, channels, meta=dict(meta) if isinstance(meta, dict) else None)


def from_dataframe(df: pd.DataFrame, mapping: ChannelMap | None = None, name: str | None = None) -> RigRecord:
    """A record from a DataFrame (as :func:`to_dataframe` makes, or a
    foreign one with a channel mapping)."""
    record_name = name or str(df.attrs.get("name", "record"))
    return to_record(_raw_from_dataframe(df, "DataFrame"), mapping, record_name)


# ----------------------------------------------------------------- Parquet


def _write_parquet(record: RigRecord, path: Path) -> None:
    pa = require("pyarrow", "Parquet")
    pq = require("pyarrow.parquet", "Parquet")
    units = _units(record)
    fields = [pa.field(c, pa.float64(), metadata={b"unit": units[c].encode()}) for c in record.data]
    table = pa.table([pa.array(np.asarray(v, dtype=np.float64)) for v in record.data.values()],
                     schema=pa.schema(fields, metadata={b"hpctl": json.dumps(record_meta(record)).encode()}))
    with atomic_path(path) as tmp:
        pq.write_table(table, tmp)


def _read_parquet(path: Path) -> RawTable:
    pq = require("pyarrow.parquet", "Parquet")
    try:
        table = pq.read_table(path)
    except (OSError, ValueError) as e:
        raise RecordError(f"{path}: not a readable Parquet file: {e}") from None
    channels = {}
    for f in table.schema:
        unit = (f.metadata or {}).get(b"unit")
        channels[f.name] = Channel(table.column(f.name).to_numpy(), None if unit is None else unit.decode())
    meta = (table.schema.metadata or {}).get(b"hpctl")
    return RawTable(str(path), channels, meta=None if meta is None else json.loads(meta))


# -------------------------------------------------------------------- MDF4


def _write_mdf(record: RigRecord, path: Path) -> None:
    asammdf = require("asammdf", "MDF4")
    t = np.asarray(record.data["time_s"], dtype=np.float64)
    units = _units(record)
    signals = [
        asammdf.Signal(samples=np.asarray(v, dtype=np.float64), timestamps=t, name=c, unit=units[c])
        for c, v in record.data.items() if c != "time_s"
    ]
    mdf = asammdf.MDF(version="4.10")
    mdf.append(signals, comment=record.name)
    mdf.header.comment = json.dumps({"hpctl": record_meta(record), "name": record.name})
    with atomic_path(path) as tmp:
        mdf.save(tmp, overwrite=True)
    mdf.close()


def _mdf_meta(comment: str) -> dict[str, Any] | None:
    text = comment
    if comment.lstrip().startswith("<"):
        try:
            tx = ET.fromstring(comment).find("TX")
        except ET.ParseError:
            return None
        text = "" if tx is None or tx.text is None else tx.text
    try:
        doc = json.loads(text)
    except ValueError:
        return None
    return doc.get("hpctl") if isinstance(doc, dict) else None


def _read_mdf(path: Path) -> RawTable:
    asammdf = require("asammdf", "MDF4")
    try:
        mdf = asammdf.MDF(path)
    except Exception as e:  # asammdf raises several types for a bad file
        raise RecordError(f"{path}: not a readable MDF file: {e}") from None
    with mdf:
        channels = {}
        for s in mdf.iter_channels():
            if s.name in channels:
                raise RecordError(f"{path}: channel {s.name!r} appears in more than one group; hpctl reads each name once")
            channels[s.name] = Channel(np.asarray(s.samples, dtype=np.float64), s.unit or None, np.asarray(s.timestamps, dtype=np.float64))
        meta = _mdf_meta(mdf.header.comment or "")
    return RawTable(str(path), channels, meta=meta)


# -------------------------------------------------------------------- TDMS


def _flatten(meta: dict[str, dict[str, Any]]) -> dict[str, Any]:
    return {f"hpctl.{t}.{k}": v for t, table in meta.items() for k, v in table.items()}


def _unflatten(props: dict[str, Any]) -> dict[str, dict[str, Any]] | None:
    out: dict[str, dict[str, Any]] = {}
    for key, value in props.items():
        parts = key.split(".")
        if len(parts) == 3 and parts[0] == "hpctl":
            v = value.item() if isinstance(value, np.generic) else value
            out.setdefault(parts[1], {})[parts[2]] = v
    return out or None


def _write_tdms(record: RigRecord, path: Path) -> None:
    nptdms = require("nptdms", "TDMS")
    units = _units(record)
    root = nptdms.RootObject(properties={"name": record.name, **_flatten(record_meta(record))})
    group = nptdms.GroupObject("record")
    channels = [nptdms.ChannelObject("record", c, np.asarray(v, dtype=np.float64), properties={"unit_string": units[c]}) for c, v in record.data.items()]
    with atomic_path(path) as tmp:
        with nptdms.TdmsWriter(tmp) as w:
            w.write_segment([root, group, *channels])


def _read_tdms(path: Path) -> RawTable:
    nptdms = require("nptdms", "TDMS")
    try:
        f = nptdms.TdmsFile.read(path)
    except Exception as e:  # npTDMS raises several types for a bad file
        raise RecordError(f"{path}: not a readable TDMS file: {e}") from None
    channels = {}
    for group in f.groups():
        for ch in group.channels():
            if ch.name in channels:
                raise RecordError(f"{path}: channel {ch.name!r} appears in more than one group; hpctl reads each name once")
            time = None
            if "wf_increment" in ch.properties:
                time = np.asarray(ch.time_track(), dtype=np.float64)
            unit = ch.properties.get("unit_string")
            channels[ch.name] = Channel(np.asarray(ch[:], dtype=np.float64), str(unit) if unit else None, time)
    return RawTable(str(path), channels, meta=_unflatten(dict(f.properties)))


# ------------------------------------------------------------------ MATLAB


def _write_mat(record: RigRecord, path: Path) -> None:
    sio = require("scipy.io", "MATLAB .mat files")
    doc = {
        "record": {
            "name": record.name,
            "data": {c: np.asarray(v, dtype=np.float64).reshape(-1, 1) for c, v in record.data.items()},
            "units": _units(record),
            "meta": record_meta(record),
        }
    }
    with atomic_path(path) as tmp:
        sio.savemat(tmp, doc, long_field_names=True, do_compression=True, oned_as="column")


def _plain(x: Any) -> Any:
    """A loadmat value (mat_struct, 0-d arrays, char arrays) as Python."""
    if hasattr(x, "_fieldnames"):
        return {f: _plain(getattr(x, f)) for f in x._fieldnames}
    if isinstance(x, np.ndarray):
        if x.dtype.kind in "US":
            return "".join(str(s) for s in x.reshape(-1))
        if x.ndim == 0:
            return x.item()
        return x
    if isinstance(x, np.generic):
        return x.item()
    return x


def _read_mat(path: Path) -> RawTable:
    sio = require("scipy.io", "MATLAB .mat files")
    try:
        doc = sio.loadmat(path, squeeze_me=True, struct_as_record=False, chars_as_strings=True)
    except (OSError, ValueError, NotImplementedError) as e:
        raise RecordError(f"{path}: not a readable MATLAB file (v4-v7.2; v7.3 is HDF5): {e}") from None
    if "record" in doc:
        rec = _plain(doc["record"])
        data = rec.get("data", {})
        units = rec.get("units", {}) if isinstance(rec.get("units"), dict) else {}
        meta = rec.get("meta") if isinstance(rec.get("meta"), dict) else None
    else:  # a foreign file: its top-level numeric variables are the channels
        data = {k: v for k, v in doc.items() if not k.startswith("__") and isinstance(v, np.ndarray) and v.dtype.kind in "fiub"}
        units, meta = {}, None
    channels = {str(c): Channel(np.atleast_1d(np.asarray(v, dtype=np.float64)).reshape(-1), units.get(c) or None) for c, v in data.items()}
    if meta is not None:
        # MATLAB has no None and stores "" as an empty char array.
        meta = {t: {k: ("" if isinstance(v, np.ndarray) and v.size == 0 else v) for k, v in table.items()} for t, table in meta.items()}
    return RawTable(str(path), channels, meta=meta)


# -------------------------------------------------------------- dispatch

_WRITERS: dict[str, Callable[[RigRecord, Path], None]] = {
    "parquet": _write_parquet,
    "mdf": _write_mdf,
    "tdms": _write_tdms,
    "mat": _write_mat,
}
_READERS: dict[str, Callable[[Path], RawTable]] = {
    "parquet": _read_parquet,
    "mdf": _read_mdf,
    "tdms": _read_tdms,
    "mat": _read_mat,
}


def write(record: RigRecord, path: str | Path, fmt: str | None = None) -> list[Path]:
    """Writes ``record`` to ``path`` in ``fmt`` (default: from the suffix);
    returns the files written."""
    p = Path(path)
    name = format_of(p, fmt)
    if name == "record":
        return list(write_record(record, p))
    _WRITERS[name](record, p)
    return [p]


def read_raw(path: str | Path, fmt: str | None = None) -> RawTable:
    """The channels and metadata of a file, as they are in it."""
    p = Path(path)
    name = format_of(p, fmt)
    if name == "record":
        rec = read_record(p)
        return RawTable(str(record_paths(p)[0]), {c: Channel(v, unit_label(c)) for c, v in rec.data.items()}, meta=record_meta(rec))
    if not p.is_file():
        raise RecordError(f"{p}: file not found")
    return _READERS[name](p)


def read(path: str | Path, mapping: ChannelMap | None = None, fmt: str | None = None, name: str | None = None) -> RigRecord:
    """A record from a file in any of :data:`FORMATS`: hpctl's own files
    as they are, foreign ones through ``mapping``."""
    p = Path(path)
    return to_record(read_raw(p, fmt), mapping, name or p.stem)

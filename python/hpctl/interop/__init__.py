"""Meeting engineers in their tools: rig records to and from pandas,
Parquet, MDF4, TDMS and MATLAB files, foreign channel names and units
through a channel-mapping file, and CAN logs decoded with the project's
DBC (docs/interop.md). The heavy libraries are the ``interop`` extra
(``pip install 'hpctl[interop]'``); a missing one raises
:class:`~hpctl.errors.MissingDependencyError` naming it."""

from __future__ import annotations

from hpctl.interop.formats import FORMATS, format_of, from_dataframe, read, read_raw, to_dataframe, write
from hpctl.interop.mapping import ChannelMap, ChannelSpec, RawTable, load_mapping, parse_mapping, to_record

__all__ = [
    "FORMATS",
    "ChannelMap",
    "ChannelSpec",
    "RawTable",
    "format_of",
    "from_dataframe",
    "load_mapping",
    "parse_mapping",
    "read",
    "read_raw",
    "to_dataframe",
    "to_record",
    "write",
]

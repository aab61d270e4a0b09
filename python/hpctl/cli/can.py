"""``hpctl can``: CAN logs decoded with the project's DBC."""

from __future__ import annotations

import csv
import json
from collections.abc import Iterable
from pathlib import Path
from typing import Any

import click
from rich.table import Table

from hpctl.cli._ui import Reporter, errors, finish, force_option, strict_option, with_warnings
from hpctl.data.output import OutputDir
from hpctl.data.records import record_paths
from hpctl.interop import format_of, load_mapping, to_record, write
from hpctl.interop.can_log import CanDecode, decode_log


@click.group("can")
def can_group() -> None:
    """CAN logs: decode with the DBC, check E2E protection."""


def _write_csv(path: Path, header: list[str], rows: Iterable[Iterable[Any]]) -> None:
    # ``path`` is in the run's staging folder: OutputDir moves it into place.
    with path.open("w", newline="") as f:
        w = csv.writer(f, lineterminator="\n")
        w.writerow(header)
        w.writerows(rows)


def _summary(d: CanDecode) -> dict[str, Any]:
    return {
        "log": d.source,
        "frames": d.frames,
        "messages": {
            m: {"outcomes": o, "decoded": len(d.tables.get(m, {}).get("time_s", []))}
            | ({"source_addresses": {f"{a:#04x}": n for a, n in sorted(d.sources[m].items())}} if m in d.sources else {})
            for m, o in sorted(d.outcomes.items())
        },
        "rejected": [{"time_s": i.time_s, "id": i.id, "source_address": i.source, "message": i.message, "reason": i.reason} for i in d.issues],
        "unknown_ids": {f"{k:#x}": v for k, v in sorted(d.unknown_ids.items())},
    }


@can_group.command("decode")
@click.argument("log", type=click.Path(dir_okay=False, path_type=Path))
@click.option("--dbc", type=click.Path(dir_okay=False, path_type=Path), help="CAN database (default: the package's hpctl.dbc).")
@click.option("--out", "out_dir", type=click.Path(file_okay=False, path_type=Path), default=Path("hpctl-can"), show_default=True,
              help="Output folder: one CSV per message (time_s and its signals), rejected.csv and summary.json.")
@click.option("--mapping", type=click.Path(dir_okay=False, path_type=Path),
              help="Channel-mapping TOML (channels named MESSAGE.SIGNAL, [options] raster_s, the record's tables) to make a rig record.")
@click.option("--record", "record_name", default="record", show_default=True,
              help="File name of the record inside --out; its suffix picks the format (none: CSV + TOML; .parquet, .mf4, .tdms, .mat).")
@force_option
@strict_option
@click.option("--quiet", "-q", is_flag=True)
@click.option("--json", "as_json", is_flag=True, help="Print the summary as JSON.")
def decode_cmd(log: Path, dbc: Path | None, out_dir: Path, mapping: Path | None, record_name: str, force: bool, strict: bool, quiet: bool,
               as_json: bool) -> None:
    """Decode a CAN log (candump .log, Vector .asc/.blf, ...) with the DBC.
    J1939 frames (29-bit) are matched by PGN from any source address (the
    source is reported). Every protected frame is checked as the ECU checks
    it (CRC, counter value and sequence, length, ranges); a frame that
    fails is listed in rejected.csv and the summary (a warning), never
    decoded into the tables. The outputs replace the folder's previous ones together when
    the run has finished."""
    rep = Reporter(quiet, as_json)
    with errors(rep):
        record_format = format_of(record_name) if mapping is not None else None
        record_files = _record_files(record_name, record_format) if record_format is not None else []
        with OutputDir(out_dir, "can decode", force=force, protect=("rejected.csv", "summary.json", *record_files)) as out:
            d = decode_log(log, dbc)
            for m, columns in sorted(d.tables.items()):
                cols = list(columns)
                _write_csv(out.path(f"{m}.csv"), cols, zip(*(columns[c].tolist() for c in cols)))
            _write_csv(out.path("rejected.csv"), ["time_s", "id", "source_address", "message", "reason"],
                       ((i.time_s, f"{i.id:#x}", "" if i.source is None else f"{i.source:#04x}", i.message or "", i.reason) for i in d.issues))
            summary = _summary(d)
            if mapping is not None:
                record = to_record(d.to_raw(), load_mapping(mapping), name=Path(record_name).stem)
                write(record, out.path(record_name), fmt=record_format)
                summary["record"] = record_files
            caveats = d.caveats()
            document = with_warnings(summary, caveats)
            out.write_json("summary.json", document)
        if as_json:
            click.echo(json.dumps(document, indent=2))
        else:
            table = Table("message", "decoded", "rejected", "outcomes")
            for m, o in sorted(d.outcomes.items()):
                bad = sum(n for r, n in o.items() if r not in ("next", "synced", "unprotected"))
                table.add_row(m, str(summary["messages"][m]["decoded"]), str(bad), ", ".join(f"{k} {v}" for k, v in sorted(o.items())))
            rep.out.print(table)
            rep.say(f"wrote {len(d.tables)} message table(s), rejected.csv and summary.json to {out_dir}/"
                    + (f"; record: {', '.join(record_files)}" if record_files else ""))
        finish(rep, caveats, strict)


def _record_files(name: str, fmt: str) -> list[str]:
    """The files ``write(record, name, fmt)`` makes, relative to --out."""
    if fmt == "record":
        return [p.as_posix() for p in record_paths(name)]
    return [Path(name).as_posix()]


COMMANDS = (can_group,)

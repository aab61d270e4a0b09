"""``hpctl can``: CAN logs decoded with the project's DBC."""

from __future__ import annotations

import csv
import json
from pathlib import Path
from typing import Any

import click
from rich.table import Table
from rich.text import Text

from hpctl.cli._ui import Reporter, errors, jsonable
from hpctl.interop import load_mapping, to_record, write
from hpctl.interop._support import atomic_path
from hpctl.interop.can_log import CanDecode, decode_log


@click.group("can")
def can_group() -> None:
    """CAN logs: decode with the DBC, check E2E protection."""


def _write_csv(path: Path, header: list[str], rows: Any) -> None:
    with atomic_path(path) as tmp:
        with tmp.open("w", newline="") as f:
            w = csv.writer(f, lineterminator="\n")
            w.writerow(header)
            w.writerows(rows)


def _summary(d: CanDecode) -> dict[str, Any]:
    return {
        "log": d.source,
        "frames": d.frames,
        "messages": {m: {"outcomes": o, "decoded": int(d.tables.get(m, {}).get("time_s", []).__len__())} for m, o in sorted(d.outcomes.items())},
        "rejected": [{"time_s": i.time_s, "id": i.id, "message": i.message, "reason": i.reason} for i in d.issues],
        "unknown_ids": {f"{k:#x}": v for k, v in sorted(d.unknown_ids.items())},
        "warnings": d.warnings(),
    }


@can_group.command("decode")
@click.argument("log", type=click.Path(dir_okay=False, path_type=Path))
@click.option("--dbc", type=click.Path(dir_okay=False, path_type=Path), help="CAN database (default: the package's hpctl.dbc).")
@click.option("--out", "out_dir", type=click.Path(file_okay=False, path_type=Path), default=Path("hpctl-can"), show_default=True,
              help="Writes one CSV per message (time_s and its signals), rejected.csv and summary.json.")
@click.option("--mapping", type=click.Path(dir_okay=False, path_type=Path),
              help="Channel-mapping TOML (channels named MESSAGE.SIGNAL, [options] raster_s, the record's tables) to make a rig record.")
@click.option("--record", "record_path", type=click.Path(path_type=Path), help="Where to write the record (any hpctl convert format; default OUT/record).")
@click.option("--quiet", "-q", is_flag=True)
@click.option("--json", "as_json", is_flag=True, help="Print the summary as JSON.")
def decode_cmd(log: Path, dbc: Path | None, out_dir: Path, mapping: Path | None, record_path: Path | None, quiet: bool, as_json: bool) -> None:
    """Decode a CAN log (candump .log, Vector .asc/.blf, ...) with the DBC.
    Every protected frame is checked as the ECU checks it (CRC, counter
    value and sequence, length, ranges); a frame that fails is listed in
    rejected.csv and the summary, never decoded into the tables."""
    rep = Reporter(quiet, as_json)
    with errors(rep):
        d = decode_log(log, dbc)
        out_dir.mkdir(parents=True, exist_ok=True)
        for m, columns in sorted(d.tables.items()):
            cols = list(columns)
            _write_csv(out_dir / f"{m}.csv", cols, zip(*(columns[c].tolist() for c in cols)))
        _write_csv(out_dir / "rejected.csv", ["time_s", "id", "message", "reason"], ((i.time_s, f"{i.id:#x}", i.message or "", i.reason) for i in d.issues))
        summary = _summary(d)
        if mapping is not None:
            record = to_record(d.to_raw(), load_mapping(mapping), name=log.stem)
            files = write(record, record_path or out_dir / "record")
            summary["record"] = [str(f) for f in files]
        with atomic_path(out_dir / "summary.json") as tmp:
            tmp.write_text(json.dumps(jsonable(summary), indent=2) + "\n")
        if as_json:
            click.echo(json.dumps(jsonable(summary), indent=2))
            return
        table = Table("message", "decoded", "rejected", "outcomes")
        for m, o in sorted(d.outcomes.items()):
            bad = sum(n for r, n in o.items() if r not in ("next", "synced", "unprotected"))
            table.add_row(m, str(summary["messages"][m]["decoded"]), str(bad), ", ".join(f"{k} {v}" for k, v in sorted(o.items())))
        rep.out.print(table)
        for w in d.warnings():
            rep.err.print(Text.assemble(("warning: ", "yellow"), w), soft_wrap=True, highlight=False)
        rep.out.print(f"wrote {len(d.tables)} message table(s), rejected.csv and summary.json to {out_dir}/" + (f"; record: {', '.join(summary['record'])}" if "record" in summary else ""), soft_wrap=True, highlight=False)


COMMANDS = (can_group,)

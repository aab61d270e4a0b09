"""``hpctl convert``: rig records to and from engineers' formats."""

from __future__ import annotations

import json
from pathlib import Path

import click

from hpctl.cli._ui import Reporter, errors, jsonable
from hpctl.interop import FORMATS, load_mapping, read, write

_FORMATS = click.Choice(sorted(FORMATS))


@click.command("convert")
@click.argument("source", type=click.Path(path_type=Path))
@click.argument("target", type=click.Path(path_type=Path))
@click.option("--mapping", type=click.Path(dir_okay=False, path_type=Path), help="Channel-mapping TOML: foreign channel names and units, and the record's metadata (docs/interop.md).")
@click.option("--from", "from_fmt", type=_FORMATS, help="Format of SOURCE (default: from its suffix).")
@click.option("--to", "to_fmt", type=_FORMATS, help="Format of TARGET (default: from its suffix).")
@click.option("--quiet", "-q", is_flag=True)
@click.option("--json", "as_json", is_flag=True, help="Print what was written as JSON.")
def convert_cmd(source: Path, target: Path, mapping: Path | None, from_fmt: str | None, to_fmt: str | None, quiet: bool, as_json: bool) -> None:
    """Convert a rig record between formats: the record's CSV + TOML,
    Parquet (.parquet), MDF4 (.mf4), TDMS (.tdms) and MATLAB (.mat). Files
    hpctl wrote carry their metadata; a foreign file needs --mapping for
    its channel names, units (converted to SI) and the record's tables.
    The result is checked as a rig record before it is written."""
    rep = Reporter(quiet, as_json)
    with errors(rep):
        record = read(source, load_mapping(mapping) if mapping else None, fmt=from_fmt)
        files = write(record, target, fmt=to_fmt)
        t = record.data["time_s"]
        columns = list(record.data)
        files_written = [str(f) for f in files]
        summary: dict[str, object] = {
            "source": str(source),
            "files": files_written,
            "kind": record.kind,
            "columns": columns,
            "samples": int(t.size),
            "duration_s": float(t[-1] - t[0]),
        }
        if as_json:
            click.echo(json.dumps(jsonable(summary), indent=2))
        else:
            rep.out.print(f"{record.kind} record, {t.size} samples over {summary['duration_s']:.3f} s, columns: {', '.join(record.data)}", soft_wrap=True, highlight=False)
            rep.out.print("wrote " + ", ".join(files_written), soft_wrap=True, highlight=False)

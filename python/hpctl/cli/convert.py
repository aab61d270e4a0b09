"""``hpctl convert``: rig records to and from engineers' formats."""

from __future__ import annotations

import json
from pathlib import Path

import click

from hpctl.cli._ui import Reporter, errors, force_option, with_warnings
from hpctl.data.output import OutputDir, reading
from hpctl.data.records import record_paths
from hpctl.interop import FORMATS, format_of, load_mapping, read, write

_FORMATS = click.Choice(sorted(FORMATS))


@click.command("convert")
@click.argument("source", type=click.Path(path_type=Path))
@click.argument("target", type=click.Path(path_type=Path))
@click.option("--mapping", type=click.Path(dir_okay=False, path_type=Path), help="Channel-mapping TOML: foreign channel names and units, and the record's metadata (docs/interop.md).")
@click.option("--from", "from_fmt", type=_FORMATS, help="Format of SOURCE (default: from its suffix).")
@click.option("--to", "to_fmt", type=_FORMATS, help="Format of TARGET (default: from its suffix).")
@force_option
@click.option("--quiet", "-q", is_flag=True)
@click.option("--json", "as_json", is_flag=True, help="Print what was written as JSON.")
def convert_cmd(source: Path, target: Path, mapping: Path | None, from_fmt: str | None, to_fmt: str | None, force: bool, quiet: bool,
                as_json: bool) -> None:
    """Convert a rig record between formats: the record's CSV + TOML,
    Parquet (.parquet), MDF4 (.mf4), TDMS (.tdms) and MATLAB (.mat). Files
    hpctl wrote carry their metadata; a foreign file needs --mapping for
    its channel names, units (converted to SI) and the record's tables.
    The result is checked as a rig record before it is written. TARGET's
    folder is an hpctl output folder: the file lands whole or not at all,
    and a file there that hpctl did not write is not replaced without
    --force."""
    rep = Reporter(quiet, as_json)
    with errors(rep):
        fmt = format_of(target, to_fmt)
        names = [p.name for p in record_paths(target.name)] if fmt == "record" else [target.name]
        # Read before taking TARGET's folder: it may be SOURCE's too, and
        # the reader's shared lock would meet the writer's exclusive one.
        with reading(source.parent):
            record = read(source, load_mapping(mapping) if mapping else None, fmt=from_fmt)
        # One target, one "command" in the folder's manifest: converting
        # another file into the same folder does not make this one stale.
        with OutputDir(target.parent, f"convert {target.name}", force=force, protect=names) as out:
            write(record, out.path(target.name), fmt=fmt)
        t = record.data["time_s"]
        summary = with_warnings({
            "source": str(source),
            "files": [str(target.parent / n) for n in names],
            "kind": record.kind,
            "columns": list(record.data),
            "samples": int(t.size),
            "duration_s": float(t[-1] - t[0]),
        }, [])
        if as_json:
            click.echo(json.dumps(summary, indent=2))
        else:
            rep.say(f"{record.kind} record, {t.size} samples over {summary['duration_s']:.3f} s, columns: {', '.join(record.data)}")
            rep.say("wrote " + ", ".join(summary["files"]))

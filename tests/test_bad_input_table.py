"""Runs every row of the bad-input table (tests/bad_inputs.py) and checks
that docs/bad-inputs.md is the table as generated."""

from __future__ import annotations

import math
import shlex
from collections.abc import Iterator
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner

import hpctl
import hpctl.errors
from bad_inputs import PLACES, ROWS, Row, markdown
from hpctl import _core
from hpctl.cli import main
from hpctl.data.output import OutputDir
from hpctl.data.records import RecordStatic, RecordTest, RecordUnit, RigRecord, write_record
from hpctl.sim.run import sdof_rig

DOC = Path(__file__).resolve().parents[1] / "docs" / "bad-inputs.md"


def test_the_document_is_the_table() -> None:
    assert DOC.read_text() == markdown(), "regenerate: python tests/bad_inputs.py > docs/bad-inputs.md"


def _record(name: str, t0: float = 0.0) -> RigRecord:
    t = t0 + np.linspace(0.0, 20.0, 201)
    x = 0.02 * np.sin(2 * np.pi * 0.1 * (t - t0))
    return RigRecord(
        kind="characterisation", unit=RecordUnit(2e-3, 0.3e-3, 0.7e-3), static=RecordStatic(14811300.0, 293.15, 293.15),
        test=RecordTest("hard", "off", "sine", 0.02, 0.1),
        data={"time_s": t, "disp_m": x, "force_n": 3e4 + 1e6 * x, "p_gas_pa": 14811300.0 + 5e8 * x}, name=name,
    )


def _places(tmp: Path) -> Iterator[dict[str, str]]:
    """Makes the files the placeholders stand for (see PLACES)."""
    out = tmp / "out"
    user = tmp / "user_out"
    user.mkdir()
    (user / "summary.json").write_text('{"mine": true}\n')
    file = tmp / "file"
    file.write_text("x")
    write_record(_record("neg_time", t0=-0.5), tmp / "neg_time")
    csv_path, toml_path = write_record(_record("markup"), tmp / "markup")
    # A record from elsewhere (no checksum), with a user's cell.
    toml_path.write_text("".join(line for line in toml_path.read_text().splitlines(keepends=True) if not line.startswith("csv_sha256")))
    lines = csv_path.read_text().splitlines()
    header = lines[0].split(",")
    cells = lines[2].split(",")
    cells[header.index("force_n")] = "[/x]"
    lines[2] = ",".join(cells)
    csv_path.write_text("\n".join(lines) + "\n")
    _, toml_path = write_record(_record("no_static"), tmp / "no_static")
    text = toml_path.read_text()
    start = text.index("[static]")
    end = text.index("[test]")
    toml_path.write_text(text[:start] + text[end:])
    _, toml_path = write_record(_record("torn"), tmp / "torn")
    old = toml_path.read_text()
    rewritten = _record("torn")
    rewritten.data["disp_m"] = rewritten.data["disp_m"] * 1.01
    write_record(rewritten, tmp / "torn")
    toml_path.write_text(old)
    write_record(_record("good"), tmp / "good")
    busy = tmp / "busy_out"
    with OutputDir(busy, "rig"):
        yield {"OUT": str(out), "USER_OUT": str(user), "BUSY_OUT": str(busy), "FILE": str(file), "NEG_TIME": str(tmp / "neg_time"),
               "MARKUP": str(tmp / "markup"), "NO_STATIC": str(tmp / "no_static"), "TORN": str(tmp / "torn"),
               "RECORD": str(tmp / "good")}


def _substitute(arg: str, values: dict[str, str]) -> str:
    """``PLACE`` or ``PLACE/rest`` with the place's path."""
    head, sep, rest = arg.partition("/")
    return values[head] + sep + rest if head in values else arg


def _run_cli(row: Row, tmp: Path) -> None:
    places = _places(tmp)
    values = next(places)
    assert set(values) == set(PLACES)
    try:
        args = [_substitute(a, values) for a in shlex.split(row.input)]
        r = CliRunner().invoke(main, args[1:])
    finally:
        next(places, None)
    code = int(row.outcome.split()[1])
    assert r.exit_code == code, f"{row.input}: exit {r.exit_code}\n{r.stderr}\n{r.exception!r}"
    assert row.message in r.stderr
    assert "Traceback" not in r.stderr


def _run_python(row: Row) -> None:
    names = {"hpctl": hpctl, "_core": _core, "np": np, "math": math, "unit": hpctl.Unit.seed(), "sdof_rig": sdof_rig,
             "frame": _core.can_encode("HP_CornerMotion_0", 0, {"StrutDisp": 0.01, "BodyAcc": 0.0, "GasTemp": 293.0})}
    kind, _, cls_name = row.outcome.partition(" ")
    if kind == "ok":
        assert row.message in repr(eval(row.input, names))
        return
    cls = getattr(hpctl.errors, cls_name)
    with pytest.raises(cls) as e:
        eval(row.input, names)
    assert row.message in str(e.value)
    assert isinstance(e.value, ValueError)


@pytest.mark.parametrize("row", ROWS, ids=[r.input for r in ROWS])
def test_row(row: Row, tmp_path: Path) -> None:
    if row.input.startswith("hpctl "):
        _run_cli(row, tmp_path)
    else:
        _run_python(row)


def test_parameter_errors_carry_name_value_and_expected() -> None:
    with pytest.raises(hpctl.ParameterError) as e:
        hpctl.run_sdof(hpctl.Unit.seed(), hpctl.Step(0.04), 1.0, dt_s="x")
    assert (e.value.parameter, e.value.value, e.value.expected) == ("dt_s", "x", "a finite real number")  # type: ignore[attr-defined]
    with pytest.raises(hpctl.ParameterError) as e:
        _core.can_decode(-1, bytes(8))
    assert (e.value.parameter, e.value.value) == ("id", -1)  # type: ignore[attr-defined]
    # The core's range errors too.
    with pytest.raises(hpctl.ParameterError) as e:
        hpctl.run_sdof(hpctl.Unit.seed().replace(piston_area_m2=-1.0), hpctl.Step(0.04), 1.0)
    assert (e.value.parameter, e.value.value) == ("piston_area_m2", -1.0)  # type: ignore[attr-defined]
    assert "[1e-5, 1e0]" in e.value.expected  # type: ignore[attr-defined]

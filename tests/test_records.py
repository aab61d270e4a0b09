"""Rig records: written and read back identical; malformed records give
an error naming the file, the line or key, and what was expected."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import hpctl
from hpctl.data.records import (
    RecordStatic,
    RecordTest,
    RecordUnit,
    RigRecord,
    read_record,
    write_record,
)

GOOD_TOML = """\
[record]
kind = "characterisation"
description = "free text"

[unit]
piston_area_m2 = 3.8e-3
small_acc_volume_m3 = 0.3e-3
large_acc_volume_m3 = 0.7e-3
gas = "N2"

[static]
pressure_pa = 7.8e6
temperature_k = 296.15
ambient_k = 296.15

[test]
spring = "soft"
damper = "off"
excitation = "sine"
amplitude_m = 0.08
frequency_hz = 0.1
"""

GOOD_CSV = "time_s,disp_m,force_n,p_gas_pa,mystery\n0.0,0.0,29000.0,7.8e6,1\n0.1,0.001,29100.0,7.81e6,2\n0.2,0.002,29200.0,7.82e6,3\n"


def write(tmp_path: Path, csv: str = GOOD_CSV, toml: str = GOOD_TOML) -> Path:
    (tmp_path / "rec.csv").write_text(csv)
    (tmp_path / "rec.toml").write_text(toml)
    return tmp_path / "rec"


def test_reads_the_documented_example(tmp_path: Path) -> None:
    rec = read_record(write(tmp_path))
    assert rec.kind == "characterisation"
    assert rec.unit.piston_area_m2 == 3.8e-3
    assert rec.static.pressure_pa == 7.8e6
    assert rec.test.frequency_hz == 0.1
    assert list(rec.data) == ["time_s", "disp_m", "force_n", "p_gas_pa", "mystery"]  # unknown column kept
    assert rec.spring_hard().tolist() == [False] * 3  # from the TOML's spring = "soft"


finite = st.floats(min_value=-1e9, max_value=1e9, allow_nan=False, allow_infinity=False)


@settings(max_examples=50)
@given(
    values=st.lists(st.tuples(finite, finite, finite, st.booleans()), min_size=2, max_size=30),
    steps=st.lists(st.floats(min_value=1e-9, max_value=10.0), min_size=30, max_size=30),
    description=st.text(max_size=40),
    sdof=st.booleans(),
)
def test_write_then_read_is_identical(tmp_path_factory: pytest.TempPathFactory, values: list[tuple[float, float, float, bool]], steps: list[float], description: str, sdof: bool) -> None:
    n = len(values)
    t = np.cumsum(np.array(steps[:n]))
    data = {"time_s": t, "disp_m": np.array([v[0] for v in values]), "force_n": np.array([v[1] for v in values])}
    if sdof:
        data["body_disp_m"] = np.array([v[2] for v in values])
        data["base_disp_m"] = -data["body_disp_m"]
    data["spring_hard"] = np.array([float(v[3]) for v in values])
    rec = RigRecord(
        kind="sdof" if sdof else "characterisation",
        description=description,
        unit=RecordUnit(2e-3, 0.3e-3, 0.7e-3),
        static=RecordStatic(14.8e6, 293.15, 293.15),
        test=RecordTest("hard", "on", "step", amplitude_m=0.043),
        data=data,
        sprung_mass_kg=3000.0 if sdof else None,
    )
    path = tmp_path_factory.mktemp("rt") / "r"
    write_record(rec, path)
    back = read_record(path)
    assert (back.kind, back.description, back.unit, back.static, back.test, back.sprung_mass_kg) == (
        rec.kind, rec.description, rec.unit, rec.static, rec.test, rec.sprung_mass_kg)
    assert list(back.data) == list(rec.data)
    for k in rec.data:
        np.testing.assert_array_equal(back.data[k], rec.data[k])
    # And writing it again gives the same bytes.
    path2 = path.parent / "again"
    write_record(back, path2)
    assert (path.with_suffix(".csv")).read_bytes() == (path2.with_suffix(".csv")).read_bytes()
    assert (path.with_suffix(".toml")).read_bytes() == (path2.with_suffix(".toml")).read_bytes()


@pytest.mark.parametrize(
    ("csv", "toml", "message"),
    [
        ("time_s,force_n\n0,1\n1,2\n", GOOD_TOML, r"rec\.csv: line 1: missing required column 'disp_m' for a characterisation record"),
        ("time_s,disp_m\n0,1\n1,2\n", GOOD_TOML, r"rec\.csv: line 1: missing required column 'force_n'"),
        ("time_s,disp_m,force_n\n0,0,1\n0.2,0,1\n0.1,0,1\n", GOOD_TOML, r"rec\.csv: line 4, column 'time_s': 0\.1 does not increase strictly \(previous 0\.2\)"),
        ("time_s,disp_m,force_n\n0,0,1\n0.1,nan,1\n", GOOD_TOML, r"rec\.csv: line 3, column 'disp_m': 'nan' is not a finite number"),
        ("time_s,disp_m,force_n\n0,0,1\n0.1,0,inf\n", GOOD_TOML, r"rec\.csv: line 3, column 'force_n': 'inf' is not a finite number"),
        ("time_s,disp_m,force_n\n0,0,1\n0.1,0,\n", GOOD_TOML, r"rec\.csv: line 3, column 'force_n': '' is not a number"),
        ("time_s,disp_m,force_n\n0,0,1\n0.1,0\n", GOOD_TOML, r"rec\.csv: line 3: 2 fields, expected 3"),
        ("time_s,disp_m,force_n\n0,0,1\n", GOOD_TOML, r"rec\.csv: expected at least two data rows"),
        ("", GOOD_TOML, r"rec\.csv: line 1: expected a header row"),
        ("time_s,disp_m,force_n,spring_hard\n0,0,1,0\n0.1,0,1,2\n", GOOD_TOML, r"line 3, column 'spring_hard': 2\.0, expected 0 or 1"),
        (GOOD_CSV, GOOD_TOML.replace("pressure_pa = 7.8e6", "pressure_pa = 78"), r"rec\.toml: \[static\] pressure_pa: = 78\.0 is outside \[200000, 3e\+08\] \(SI units"),
        (GOOD_CSV, GOOD_TOML.replace("pressure_pa = 7.8e6", 'pressure_pa = "7.8 MPa"'), r"\[static\] pressure_pa: expected a number in SI units \(pa\), got '7\.8 MPa'"),
        (GOOD_CSV, GOOD_TOML.replace("pressure_pa = 7.8e6", "pressure_mpa = 7.8"), r"\[static\] pressure_mpa: unknown key \(hpctl reads SI units only: use a name ending in _pa\)"),
        (GOOD_CSV, GOOD_TOML.replace('gas = "N2"', 'gas = "N2"\ncolour = "red"'), r"rec\.toml: \[unit\] colour: unknown key; expected one of piston_area_m2"),
        (GOOD_CSV, GOOD_TOML + "\n[extras]\na = 1\n", r"rec\.toml: \[extras\]: unknown table"),
        (GOOD_CSV, GOOD_TOML.replace("temperature_k = 296.15\n", ""), r"rec\.toml: \[static\] temperature_k: missing key"),
        (GOOD_CSV, GOOD_TOML.replace('kind = "characterisation"', 'kind = "sdof"'), r"rec\.toml: \[sdof\]: missing table"),
        (GOOD_CSV, GOOD_TOML.replace('spring = "soft"', 'spring = "medium"'), r"\[test\] spring: = 'medium', expected one of 'soft', 'hard'"),
        (GOOD_CSV, GOOD_TOML.replace("[static]", "[static"), r"rec\.toml: not valid TOML"),
    ],
)
def test_malformed_records_say_where_and_what(tmp_path: Path, csv: str, toml: str, message: str) -> None:
    with pytest.raises(hpctl.RecordError, match=message) as e:
        read_record(write(tmp_path, csv, toml))
    assert isinstance(e.value, ValueError)


def test_missing_files(tmp_path: Path) -> None:
    (tmp_path / "only.toml").write_text(GOOD_TOML)
    with pytest.raises(hpctl.RecordError, match=r"only\.csv: file not found"):
        read_record(tmp_path / "only.csv")
    with pytest.raises(hpctl.RecordError, match=r"none\.toml: file not found"):
        read_record(tmp_path / "none")


def test_the_shipped_format_specification_matches_the_reader() -> None:
    """The column table and the TOML example of the specification that ships
    in the package are what the reader implements."""
    import re
    import tomllib

    from hpctl.data import RECORD_FORMAT_PATH
    from hpctl.data.records import _SCHEMA, COLUMNS

    spec = RECORD_FORMAT_PATH.read_text()
    rows = re.findall(r"^\| `(\w+)` \| ([^|]+) \| ([^|]+) \|", spec, flags=re.M)
    documented = {name: (unit.strip(), required.strip()) for name, unit, required in rows}
    assert set(documented) == set(COLUMNS)
    for name, (unit, kinds) in COLUMNS.items():
        assert documented[name][0] == unit, name
        required = documented[name][1]
        if set(kinds) == {"characterisation", "sdof"}:
            assert required == "yes", name
        elif kinds:
            assert required == f"{kinds[0]} tests".replace("sdof", "SDOF"), name
        else:
            assert required == "no", name
    example = tomllib.loads(spec.split("```toml", 1)[1].split("```", 1)[0])
    assert set(example) == set(_SCHEMA)
    for table, keys in example.items():
        assert set(keys) == set(_SCHEMA[table]), table

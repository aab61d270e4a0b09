"""Rig records to and from pandas, Parquet, MDF4, TDMS and MATLAB files
(hpctl.interop, hpctl convert): every format round-trips a record with
its metadata; foreign files come in through a channel-mapping file, their
units converted to SI by pint (checked against the units' definitions,
not against pint), unknown units refused; writes are atomic; a missing
optional library names the extra to install."""

from __future__ import annotations

import json
import sys
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from click.testing import CliRunner

from hpctl.cli import main
from hpctl.data.records import RigRecord, read_record, record_from_parts, record_meta
from hpctl.errors import MappingError, MissingDependencyError, RecordError

pd = pytest.importorskip("pandas", reason="the interop extra is not installed: pip install -e '.[interop]'")
for _module in ("pyarrow", "asammdf", "nptdms", "pint"):
    pytest.importorskip(_module, reason="the interop extra is not installed: pip install -e '.[interop]'")

from hpctl import interop  # noqa: E402

FILE_FORMATS = (".parquet", ".mf4", ".tdms", ".mat", "")  # "" = the record's own CSV + TOML


def _sdof_record() -> RigRecord:
    t = np.round(np.arange(0, 1.0, 1e-3), 12)
    data = {
        "time_s": t,
        "disp_m": 0.01 * np.sin(2 * np.pi * t) + 1e-17,  # not a round number: exact float round trip
        "body_disp_m": 0.043 * (1 - np.exp(-t / 0.1)),
        "base_disp_m": np.where(t > 0.5, 0.043, 0.0),
        "p_gas_pa": 14.81e6 + 1e5 * np.cos(t) / 3,
        "t_gas_k": 293.15 + t / 7,
        "spring_hard": (t > 0.25).astype(float),
        "damper_on": np.ones_like(t),
        "strain_gauge_n": np.random.default_rng(1).normal(size=t.size),  # an extra column survives too
    }
    meta = {
        "record": {"kind": "sdof", "description": ""},
        "unit": {"piston_area_m2": 2e-3, "small_acc_volume_m3": 3e-4, "large_acc_volume_m3": 7e-4, "gas": "N2"},
        "static": {"pressure_pa": 14.81e6, "temperature_k": 293.15, "ambient_k": 294.0},
        "test": {"spring": "hard", "damper": "on", "excitation": "step", "amplitude_m": 0.043},
        "sdof": {"sprung_mass_kg": 3000.0},
    }
    return record_from_parts(meta, data, "test", name="step_43mm")


@pytest.fixture(params=["demo", "sdof"])
def record(request: pytest.FixtureRequest) -> RigRecord:
    if request.param == "sdof":
        return _sdof_record()
    from hpctl.data import DEMO_DIR

    return read_record(sorted(DEMO_DIR.glob("*.csv"))[0])


def assert_same(a: RigRecord, b: RigRecord) -> None:
    """Equal in every column (bit for bit, same order) and every metadata field."""
    assert list(a.data) == list(b.data)
    for c in a.data:
        assert np.array_equal(a.data[c], b.data[c]), c
    assert record_meta(a) == record_meta(b)
    assert (a.kind, a.unit, a.static, a.test, a.description, a.sprung_mass_kg) == (b.kind, b.unit, b.static, b.test, b.description, b.sprung_mass_kg)


@pytest.mark.parametrize("suffix", FILE_FORMATS)
def test_every_format_round_trips_a_record(record: RigRecord, suffix: str, tmp_path: Path) -> None:
    path = tmp_path / f"out{suffix}"
    files = interop.write(record, path)
    assert all(f.is_file() for f in files)
    assert_same(record, interop.read(path))
    assert not list(tmp_path.glob(".*tmp*")), "a temporary file was left behind"


def test_dataframe_round_trips_with_attrs(record: RigRecord) -> None:
    df = interop.to_dataframe(record)
    assert list(df.columns) == list(record.data)
    assert df.attrs["hpctl"] == record_meta(record)
    assert df.attrs["units"]["p_gas_pa"] == "Pa" and df.attrs["units"]["time_s"] == "s"
    back = interop.from_dataframe(df)
    assert_same(record, back)
    assert back.name == record.name


def test_files_carry_units_the_tools_show(tmp_path: Path) -> None:
    """What MDF, TDMS and Parquet viewers show: each channel's SI unit."""
    import asammdf
    import nptdms
    import pyarrow.parquet as pq

    r = _sdof_record()
    interop.write(r, tmp_path / "a.mf4")
    interop.write(r, tmp_path / "a.tdms")
    interop.write(r, tmp_path / "a.parquet")
    with asammdf.MDF(tmp_path / "a.mf4") as m:
        assert m.get("p_gas_pa").unit == "Pa" and m.get("t_gas_k").unit == "K" and m.get("strain_gauge_n").unit == "N"
    ch = nptdms.TdmsFile.read(tmp_path / "a.tdms")["record"]["body_disp_m"]
    assert ch.properties["unit_string"] == "m"
    assert pq.read_table(tmp_path / "a.parquet").schema.field("time_s").metadata[b"unit"] == b"s"


# ---------------------------------------------------------------- foreign files

MAPPING = """
[channels]
time_s = { name = "Zeit", unit = "ms" }
disp_m = { name = "Weg", unit = "mm" }
force_n = { name = "Kraft", unit = "kN" }
p_gas_pa = { name = "p_S", unit = "bar", gauge = true }
p_gas2_pa = { name = "p_L", unit = "psi" }
t_gas_k = { name = "T_S", unit = "degC" }

[record]
kind = "characterisation"
description = "foreign rig"
[unit]
piston_area_m2 = 2e-3
small_acc_volume_m3 = 3e-4
large_acc_volume_m3 = 7e-4
[static]
pressure_pa = 14.8e6
temperature_k = 293.15
ambient_k = 293.15
[test]
spring = "soft"
damper = "on"
excitation = "sine"
"""

FOREIGN = {
    "Zeit": np.arange(0.0, 500.0, 10.0),  # ms
    "Weg": np.linspace(-20.0, 20.0, 50),  # mm
    "Kraft": np.linspace(25.0, 35.0, 50),  # kN
    "p_S": np.linspace(147.0, 150.0, 50),  # bar, gauge
    "p_L": np.linspace(2100.0, 2200.0, 50),  # psi, absolute
    "T_S": np.linspace(20.0, 30.0, 50),  # degC
    "Unbenutzt": np.zeros(50),  # not mapped: ignored
}


def _expected_si() -> dict[str, np.ndarray]:
    """The definitions: 1 ms = 1e-3 s, 1 mm = 1e-3 m, 1 kN = 1e3 N, 1 bar =
    1e5 Pa (+ 101325 Pa for gauge), 1 psi = 0.45359237 kg * 9.80665 m/s^2 /
    (0.0254 m)^2, 0 degC = 273.15 K."""
    psi = 0.45359237 * 9.80665 / 0.0254**2
    return {
        "time_s": FOREIGN["Zeit"] * 1e-3,
        "disp_m": FOREIGN["Weg"] * 1e-3,
        "force_n": FOREIGN["Kraft"] * 1e3,
        "p_gas_pa": FOREIGN["p_S"] * 1e5 + 101325.0,
        "p_gas2_pa": FOREIGN["p_L"] * psi,
        "t_gas_k": FOREIGN["T_S"] + 273.15,
    }


def _write_foreign(suffix: str, path: Path) -> None:
    """A foreign file as another tool would write it: its own names, its
    units, no hpctl metadata."""
    if suffix == ".mf4":
        import asammdf

        t = FOREIGN["Zeit"] * 1e-3
        mdf = asammdf.MDF(version="4.10")
        mdf.append([asammdf.Signal(v, t, name=n) for n, v in FOREIGN.items()])
        mdf.save(path, overwrite=True)
    elif suffix == ".tdms":
        import nptdms

        with nptdms.TdmsWriter(path) as w:
            w.write_segment([nptdms.ChannelObject("Messung", n, v) for n, v in FOREIGN.items()])
    elif suffix == ".mat":
        import scipy.io

        scipy.io.savemat(path, {n: v for n, v in FOREIGN.items()})
    elif suffix == ".parquet":
        pd.DataFrame(FOREIGN).to_parquet(path)


@pytest.mark.parametrize("suffix", [".mf4", ".tdms", ".mat", ".parquet", "dataframe"])
def test_foreign_files_come_in_through_a_mapping(suffix: str, tmp_path: Path) -> None:
    mapping_path = tmp_path / "map.toml"
    mapping_path.write_text(MAPPING)
    mapping = interop.load_mapping(mapping_path)
    if suffix == "dataframe":
        rec = interop.from_dataframe(pd.DataFrame(FOREIGN), mapping)
    else:
        path = tmp_path / f"foreign{suffix}"
        _write_foreign(suffix, path)
        rec = interop.read(path, mapping)
    expected = _expected_si()
    assert list(rec.data) == list(expected)
    for c, x in expected.items():
        np.testing.assert_allclose(rec.data[c], x, rtol=1e-12, atol=1e-12 * np.max(np.abs(x)), err_msg=c)
    assert rec.description == "foreign rig" and rec.test.spring == "soft"


def _mapping_with(channels: str) -> interop.ChannelMap:
    base = MAPPING.split("[record]")[1]
    return interop.parse_mapping(__import__("tomllib").loads(channels + "\n[record]" + base), "map.toml")


@pytest.mark.parametrize(
    ("channels", "message"),
    [
        ('[channels]\ntime_s = { name = "Zeit", unit = "ms" }\ndisp_m = { name = "Weg", unit = "furlongz" }', "'furlongz' is not known"),
        ('[channels]\ntime_s = { name = "Zeit", unit = "ms" }\ndisp_m = { name = "Weg", unit = "bar" }', "needs [length]"),
        ('[channels]\ntime_s = { name = "Zeit", unit = "ms" }\ndisp_m = { name = "Wegg", unit = "mm" }', "'Wegg' (for disp_m) is not in"),
        ('[channels]\ntime_s = { name = "Zeit", unit = "ms" }\nweg = { name = "Weg" }', "not a record column or a name with an SI unit suffix"),
        ('[channels]\ndisp_m = { name = "Weg", unit = "mm", gauge = true }', "only for pressures"),
        ('[channels]\ndisp_m = { name = "Weg", scale = 2 }', "unknown key 'scale'"),
    ],
)
def test_bad_mappings_are_refused_with_a_clear_error(channels: str, message: str) -> None:
    with pytest.raises(MappingError) as e:
        mapping = _mapping_with(channels)
        interop.from_dataframe(pd.DataFrame(FOREIGN), mapping)
    assert message in str(e.value)


def test_a_foreign_file_without_mapping_is_refused(tmp_path: Path) -> None:
    with pytest.raises(MappingError, match="give a channel-mapping file"):
        interop.from_dataframe(pd.DataFrame(FOREIGN))
    df = pd.DataFrame({"time_s": [0.0, 1.0], "disp_m": [0.0, 0.1], "force_n": [1.0, 2.0]})
    with pytest.raises(RecordError, match="no hpctl record metadata"):
        interop.from_dataframe(df)


def test_channels_on_different_time_bases_are_resampled_on_the_raster(tmp_path: Path) -> None:
    """An MDF file with a 1 kHz and a 100 Hz channel: refused without a
    raster, resampled with one (linear signals are reproduced exactly)."""
    import asammdf

    fast = np.arange(0.0, 1.0 + 1e-9, 1e-3)
    slow = np.arange(0.0, 1.0 + 1e-9, 1e-2)
    mdf = asammdf.MDF(version="4.10")
    mdf.append([asammdf.Signal(2.0 * fast, fast, name="Weg", unit="mm")])
    mdf.append([asammdf.Signal(5.0 + slow, slow, name="Kraft", unit="kN")])
    path = tmp_path / "mixed.mf4"
    mdf.save(path, overwrite=True)
    channels = '[channels]\ndisp_m = { name = "Weg" }\nforce_n = { name = "Kraft" }\n'
    with pytest.raises(RecordError, match="raster_s"):
        interop.read(path, _mapping_with(channels))
    rec = interop.read(path, _mapping_with(channels + "[options]\nraster_s = 0.005\n"))
    t = rec.data["time_s"]
    np.testing.assert_allclose(np.diff(t), 0.005, rtol=1e-9)
    np.testing.assert_allclose(rec.data["disp_m"], 2e-3 * t, rtol=1e-12, atol=1e-15)
    np.testing.assert_allclose(rec.data["force_n"], 1e3 * (5.0 + t), rtol=1e-12)


def test_a_failed_write_keeps_the_old_file_and_leaves_no_temporary(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    import pyarrow.parquet as pq

    r = _sdof_record()
    path = tmp_path / "r.parquet"
    interop.write(r, path)
    before = path.read_bytes()

    def broken(table: Any, where: Any, **kw: Any) -> None:
        Path(where).write_bytes(b"half a file")
        raise OSError("disk full")

    monkeypatch.setattr(pq, "write_table", broken)
    with pytest.raises(OSError, match="disk full"):
        interop.write(r, path)
    assert path.read_bytes() == before
    assert sorted(p.name for p in tmp_path.iterdir()) == ["r.parquet"]


def test_a_missing_library_names_the_extra(monkeypatch: pytest.MonkeyPatch, tmp_path: Path) -> None:
    monkeypatch.setitem(sys.modules, "asammdf", None)  # import asammdf now raises ImportError
    with pytest.raises(MissingDependencyError, match=r"pip install 'hpctl\[interop\]'"):
        interop.write(_sdof_record(), tmp_path / "x.mf4")


def test_corrupt_files_are_record_errors(tmp_path: Path) -> None:
    for suffix in (".parquet", ".mf4", ".tdms", ".mat"):
        p = tmp_path / f"bad{suffix}"
        p.write_bytes(b"this is not a measurement file" * 10)
        with pytest.raises(RecordError, match=str(p)):
            interop.read(p)


def test_hpctl_convert(tmp_path: Path) -> None:
    from hpctl.data import DEMO_DIR

    src = sorted(DEMO_DIR.glob("*.csv"))[0]
    runner = CliRunner()
    r = runner.invoke(main, ["convert", str(src), str(tmp_path / "a.tdms"), "--json"])
    assert r.exit_code == 0, r.output
    assert json.loads(r.output)["files"] == [str(tmp_path / "a.tdms")]
    r = runner.invoke(main, ["convert", str(tmp_path / "a.tdms"), str(tmp_path / "back")])
    assert r.exit_code == 0, r.output
    assert_same(read_record(src), read_record(tmp_path / "back"))
    # A foreign file with a bad unit: exit 2 and the message.
    _write_foreign(".tdms", tmp_path / "f.tdms")
    (tmp_path / "m.toml").write_text(MAPPING.replace('unit = "kN"', 'unit = "kilonewtonz"'))
    r = runner.invoke(main, ["convert", str(tmp_path / "f.tdms"), str(tmp_path / "f"), "--mapping", str(tmp_path / "m.toml")])
    assert r.exit_code == 2
    assert "'kilonewtonz' is not known" in r.output


def test_hpctl_convert_never_overwrites_what_it_did_not_write(tmp_path: Path) -> None:
    """TARGET's folder is an hpctl output folder: a file there hpctl did
    not write is not replaced (exit 2, untouched) unless --force; hpctl's
    own output is replaced by a rerun; converting a second file into the
    folder leaves the first in place; the JSON carries "warnings"."""
    from hpctl.data import DEMO_DIR

    src = sorted(DEMO_DIR.glob("*.csv"))[0]
    runner = CliRunner()
    (tmp_path / "a.parquet").write_bytes(b"the user's own file")
    r = runner.invoke(main, ["convert", str(src), str(tmp_path / "a.parquet")])
    assert r.exit_code == 2 and "a.parquet" in r.stderr and "--force" in r.stderr
    assert (tmp_path / "a.parquet").read_bytes() == b"the user's own file"
    r = runner.invoke(main, ["convert", str(src), str(tmp_path / "a.parquet"), "--force", "--json"])
    assert r.exit_code == 0, r.output
    assert json.loads(r.stdout)["warnings"] == []
    assert_same(read_record(src), interop.read(tmp_path / "a.parquet"))
    for _ in range(2):  # its own file: replaced without --force
        r = runner.invoke(main, ["convert", str(src), str(tmp_path / "b.mf4")])
        assert r.exit_code == 0, r.output
    r = runner.invoke(main, ["convert", str(tmp_path / "b.mf4"), str(tmp_path / "c")])
    assert r.exit_code == 0, r.output
    assert all((tmp_path / n).is_file() for n in ("a.parquet", "b.mf4", "c.csv", "c.toml"))
    assert_same(read_record(src), read_record(tmp_path / "c"))
    # A record pair whose TOML is the user's: neither half replaced.
    (tmp_path / "d.toml").write_text("# mine\n")
    r = runner.invoke(main, ["convert", str(src), str(tmp_path / "d")])
    assert r.exit_code == 2 and "d.toml" in r.stderr
    assert not (tmp_path / "d.csv").exists() and (tmp_path / "d.toml").read_text() == "# mine\n"

"""CAN logs decoded with the DBC (hpctl.interop.can_log, hpctl can decode):
candump, ASC and BLF logs written by python-can's own writers, frames made
by the codec or by cantools with the E2E CRC computed here (an independent
implementation of the DBC's comment); J1939 frames matched by PGN from any
source address and priority, the source reported, one counter sequence per
sender; a frame with a bad CRC, a repeated or a skipped alive counter is
reported and not decoded; the values are the encoded ones (cantools); a
message the codec does not protect is decoded and marked; the ECU's own
traffic (address claim, DM1, its Proprietary B messages) decodes without a
rejection; a mapping makes a rig record. Message choice follows whatever
the DBC holds."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from click.testing import CliRunner

from hpctl import _core
from hpctl.caveats import Code
from hpctl.cli import main
from hpctl.data import DBC_PATH

can = pytest.importorskip("can", reason="python-can is not installed: pip install -e '.[interop]'")
cantools = pytest.importorskip("cantools", reason="cantools is not installed: pip install -e '.[interop]'")

from cantools import j1939  # noqa: E402

from hpctl.interop.can_log import decode_log  # noqa: E402

DB = cantools.database.load_file(str(DBC_PATH))


def _crc8_e2e(data_id: int, payload: bytes) -> int:
    """CRC-8 as the DBC's comment defines it (polynomial 0x1D, init 0, no
    final XOR) over the data ID's low and high byte and bytes 1..7."""
    crc = 0
    for byte in bytes([data_id & 0xFF, data_id >> 8]) + payload[1:8]:
        crc ^= byte
        for _ in range(8):
            crc = ((crc << 1) ^ 0x1D) & 0xFF if crc & 0x80 else (crc << 1) & 0xFF
    return crc


def _cantools_frame(msg: Any, counter: int, values: dict[str, float]) -> bytes:
    """``msg`` encoded by cantools, then protected by :func:`_crc8_e2e`."""
    raw = bytearray(msg.encode({**values, "E2E_CRC": 0, "E2E_Counter": counter}))
    raw[0] = _crc8_e2e(int(msg.dbc.attributes["E2E_DataID"].value), bytes(raw))
    return bytes(raw)


def _with(frame_id: int, priority: int | None = None, source: int | None = None) -> int:
    """``frame_id`` with another priority and/or source address."""
    f = j1939.frame_id_unpack(frame_id)
    return j1939.frame_id_pack(f.priority if priority is None else priority, f.reserved, f.data_page, f.pdu_format, f.pdu_specific,
                               f.source_address if source is None else source)


def _payload(msg: Any) -> list[Any]:
    return [s for s in msg.signals if not s.name.startswith("E2E_")]


def _protected_with_unit(unit: str) -> Any:
    """A message the codec protects with a signal in ``unit``."""
    for msg in DB.messages:
        sigs = _payload(msg)
        if any(s.unit == unit for s in sigs):
            try:
                _core.can_encode(msg.name, 0, {s.name: _mid(s) for s in sigs})
            except Exception:  # not an input message of the codec
                continue
            return msg
    pytest.fail(f"the DBC has no protected message with a signal in {unit}")


def _mid(s: Any, k: int = 0) -> float:
    """A value on the signal's grid inside its range, varying with k."""
    lo = s.minimum if s.minimum is not None else 0.0
    hi = s.maximum if s.maximum is not None else lo + 100 * s.scale
    x = lo + (hi - lo) * (0.3 + 0.01 * (k % 20))
    return float(np.round((x - s.offset) / s.scale) * s.scale + s.offset)


EXTRA_DBC = """
BO_ 2032 RIG_Force: 8 RIG
 SG_ Force : 0|32@1- (0.01,0) [-200000|200000] "N" HPECU
"""


@pytest.fixture(scope="module")
def rig_dbc(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The project's DBC plus one unprotected rig message (a load cell)."""
    path = tmp_path_factory.mktemp("dbc") / "rig.dbc"
    path.write_text(DBC_PATH.read_text() + EXTRA_DBC)
    return path


def _frames(n: int = 40) -> tuple[Any, list[tuple[float, int, bool, bytes]], dict[int, float]]:
    msg = _protected_with_unit("m")
    sig = next(s for s in _payload(msg) if s.unit == "m")
    frames = []
    truth = {}
    force = cantools.database.load_string(DBC_PATH.read_text() + EXTRA_DBC, database_format="dbc").get_message_by_name("RIG_Force")
    for k in range(n):
        values = {s.name: _mid(s, k) for s in _payload(msg)}
        fid, raw = _core.can_encode(msg.name, k % 15, values)
        frames.append((0.01 * k, fid, fid > 0x7FF, raw))
        truth[k] = values[sig.name]
        frames.append((0.01 * k + 0.005, force.frame_id, False, force.encode({"Force": 1000.0 * k})))
    return msg, frames, truth


def _corrupt(frames: list[tuple[float, int, bool, bytes]], msg: Any) -> list[tuple[float, int, bool, bytes]]:
    """Frame 5 of ``msg``: CRC byte flipped; frame 10: a copy of frame 9
    (repeated counter); frame 20 dropped (the next one skips a counter)."""
    own = [i for i, f in enumerate(frames) if f[1] == msg.frame_id]
    out = list(frames)
    t, fid, ext, raw = out[own[5]]
    out[own[5]] = (t, fid, ext, bytes([raw[0] ^ 0xA5]) + raw[1:])
    t, fid, ext, _ = out[own[10]]
    out[own[10]] = (t, fid, ext, out[own[9]][3])
    del out[own[20]]
    return out


def _write_log(path: Path, frames: list[tuple[float, int, bool, bytes]]) -> None:
    with can.Logger(str(path)) as w:
        for t, fid, ext, raw in frames:
            w.on_message_received(can.Message(timestamp=1700000000.0 + t, arbitration_id=fid, is_extended_id=ext, data=raw))


@pytest.mark.parametrize("suffix", [".log", ".asc", ".blf"])
def test_bad_frames_are_reported_not_decoded(suffix: str, tmp_path: Path, rig_dbc: Path) -> None:
    msg, frames, truth = _frames()
    path = tmp_path / f"drive{suffix}"
    _write_log(path, _corrupt(frames, msg))
    d = decode_log(path, rig_dbc)
    issues = [(round(i.time_s, 3), i.reason) for i in d.issues if i.message == msg.name]
    # CRC at frame 5 (frame 6 then skips the lost counter), repeated at 10
    # (11 then skips), frame 20 missing (21 skips).
    assert issues == [(0.05, "crc"), (0.06, "skipped"), (0.1, "repeated"), (0.11, "skipped"), (0.21, "skipped")]
    o = d.outcomes[msg.name]
    assert o == {"synced": 1, "next": 33, "crc": 1, "repeated": 1, "skipped": 3}
    table = d.tables[msg.name]
    decoded_k = np.round(table["time_s"] / 0.01).astype(int)
    assert set(decoded_k) == set(range(40)) - {5, 6, 10, 11, 20, 21}
    sig = next(s for s in _payload(msg) if s.unit == "m")
    np.testing.assert_allclose(table[sig.name], [truth[k] for k in decoded_k], rtol=0, atol=sig.scale * 1e-6)
    # The unprotected load cell: every frame decoded and marked.
    assert d.outcomes["RIG_Force"] == {"unprotected": 40}
    np.testing.assert_allclose(d.tables["RIG_Force"]["Force"], 1000.0 * np.arange(40))
    (w,) = d.caveats()
    assert w.code == Code.CAN_FRAMES_REJECTED and w.details["message"] == msg.name and w.details["frames"] == 5
    assert dict(zip(w.details["reasons"], w.details["counts"])) == {"crc": 1, "repeated": 1, "skipped": 3}


def test_unknown_identifiers_are_counted(tmp_path: Path) -> None:
    path = tmp_path / "x.log"
    _write_log(path, [(0.0, 0x7AB, False, bytes(8)), (0.01, 0x7AB, False, bytes(8))])
    d = decode_log(path)
    assert d.unknown_ids == {0x7AB: 2} and d.tables == {}
    (w,) = d.caveats()
    assert w.code == Code.CAN_UNKNOWN_IDS and w.details == {"frames": 2, "ids": [0x7AB]}
    assert "identifier(s) the DBC does not know: 0x7ab" in w.message


MAPPING = """
[channels]
disp_m = {{ name = "{msg}.{sig}" }}
force_n = {{ name = "RIG_Force.Force", unit = "N" }}

[options]
raster_s = 0.01

[record]
kind = "characterisation"
[unit]
piston_area_m2 = 2e-3
small_acc_volume_m3 = 3e-4
large_acc_volume_m3 = 7e-4
[static]
pressure_pa = 14.8e6
temperature_k = 293.15
ambient_k = 293.15
[test]
spring = "hard"
damper = "on"
excitation = "random"
"""


def test_hpctl_can_decode_writes_tables_a_report_and_a_record(tmp_path: Path, rig_dbc: Path) -> None:
    msg, frames, _ = _frames()
    log = tmp_path / "drive.asc"
    _write_log(log, _corrupt(frames, msg))
    sig = next(s for s in _payload(msg) if s.unit == "m")
    (tmp_path / "map.toml").write_text(MAPPING.format(msg=msg.name, sig=sig.name))
    out = tmp_path / "out"
    r = CliRunner().invoke(main, ["can", "decode", str(log), "--dbc", str(rig_dbc), "--out", str(out), "--mapping", str(tmp_path / "map.toml"),
                                  "--record", "rec.tdms", "--json"])
    assert r.exit_code == 0, r.output
    summary = json.loads(r.stdout)
    assert len(summary["rejected"]) == 5 and summary["record"] == ["rec.tdms"]
    assert [w["code"] for w in summary["warnings"]] == ["can_frames_rejected"] and summary["warnings"][0]["details"]["frames"] == 5
    assert (out / f"{msg.name}.csv").is_file() and (out / "rejected.csv").read_text().count("\n") == 6
    assert json.loads((out / "summary.json").read_text()) == summary
    from hpctl import interop

    rec = interop.read(out / "rec.tdms")
    assert rec.kind == "characterisation" and rec.data["time_s"][1] - rec.data["time_s"][0] == pytest.approx(0.01)
    # The load cell's force on the raster, linear in time: 1000 N per 10 ms.
    np.testing.assert_allclose(rec.data["force_n"], 1000.0 * (rec.data["time_s"] - 0.005) / 0.01, rtol=1e-9)


def test_can_decode_output_folder_rules(tmp_path: Path, rig_dbc: Path) -> None:
    """The output folder's rules (hpctl.data.output): warnings with
    --strict exit 3 with every output written; a summary.json hpctl did
    not write is not replaced (exit 2, nothing changed) unless --force; a
    second decode replaces the first's tables and removes those of
    messages the new log lacks; a failed decode (a log that is not one)
    leaves the previous outputs byte for byte."""
    msg, frames, _ = _frames()
    log = tmp_path / "drive.log"
    _write_log(log, _corrupt(frames, msg))
    out = tmp_path / "out"
    runner = CliRunner()
    r = runner.invoke(main, ["can", "decode", str(log), "--dbc", str(rig_dbc), "--out", str(out), "--strict", "-q"])
    assert r.exit_code == 3, r.output
    assert "can_frames_rejected" in r.stderr
    assert json.loads((out / "summary.json").read_text())["warnings"][0]["code"] == "can_frames_rejected"
    assert (out / "RIG_Force.csv").is_file() and (out / f"{msg.name}.csv").is_file()
    before = {p.name: p.read_bytes() for p in out.iterdir() if p.is_file()}

    # A log that is not one: exit 2, the folder as it was.
    bad = tmp_path / "bad.blf"
    bad.write_bytes(b"not a BLF file" * 20)
    r = runner.invoke(main, ["can", "decode", str(bad), "--out", str(out), "-q"])
    assert r.exit_code == 2, r.output
    assert {p.name: p.read_bytes() for p in out.iterdir() if p.is_file()} == before

    # Only the load cell this time: the protected message's table goes.
    only_force = tmp_path / "force.log"
    _write_log(only_force, [f for f in frames if f[1] != msg.frame_id])
    r = runner.invoke(main, ["can", "decode", str(only_force), "--dbc", str(rig_dbc), "--out", str(out), "-q"])
    assert r.exit_code == 0, r.output
    assert not (out / f"{msg.name}.csv").exists() and (out / "RIG_Force.csv").is_file()
    assert json.loads((out / "summary.json").read_text())["warnings"] == []

    # The user's own summary.json is theirs.
    user = tmp_path / "user"
    user.mkdir()
    (user / "summary.json").write_text("mine\n")
    r = runner.invoke(main, ["can", "decode", str(only_force), "--dbc", str(rig_dbc), "--out", str(user), "-q"])
    assert r.exit_code == 2 and "summary.json" in r.stderr
    assert (user / "summary.json").read_text() == "mine\n" and not (user / "RIG_Force.csv").exists()
    r = runner.invoke(main, ["can", "decode", str(only_force), "--dbc", str(rig_dbc), "--out", str(user), "-q", "--force"])
    assert r.exit_code == 0, r.output
    assert json.loads((user / "summary.json").read_text())["log"] == str(only_force)


@pytest.mark.parametrize("suffix", [".log", ".asc", ".blf"])
def test_a_file_that_is_not_a_log_is_a_record_error(suffix: str, tmp_path: Path) -> None:
    """Whatever python-can's reader raises on garbage (the BLF reader's
    BLFParseError is not a ValueError) is a RecordError naming the file."""
    from hpctl.errors import RecordError

    p = tmp_path / f"garbage{suffix}"
    p.write_bytes(b"(1.0) can0 not a frame at all ##\x00\xff" * 30)
    with pytest.raises(RecordError, match="garbage"):
        decode_log(p)


@pytest.mark.parametrize("suffix", [".log", ".asc", ".blf"])
def test_j1939_frames_match_by_pgn_from_any_sender(suffix: str, tmp_path: Path) -> None:
    """Two sensor clusters send corner 2's motion (one at the DBC's source
    address 0x90 and priority, one at 0x92 with priority 6), each with its
    own alive-counter sequence: every frame is matched by its PGN, accepted
    and decoded with its sender; a corrupted frame of the second sender is
    reported with that sender and not decoded; a PGN the DBC does not have
    is an unknown identifier."""
    msg = DB.get_message_by_name("HP_CornerMotion_2")
    assert j1939.frame_id_unpack(msg.frame_id).source_address == 0x90
    other = _with(msg.frame_id, priority=6, source=0x92)
    frames, truth = [], {}
    for k in range(30):
        for n, (fid, src) in enumerate(((msg.frame_id, 0x90), (other, 0x92))):
            values = {s.name: _mid(s, k + 7 * n) for s in _payload(msg)}
            raw = _cantools_frame(msg, (k + 5 * n) % 15, values)
            if src == 0x92 and k == 12:
                raw = raw[:3] + bytes([raw[3] ^ 0x01]) + raw[4:]  # one payload bit flipped
            frames.append((0.01 * k + 0.001 * n, fid, True, raw))
            truth[(k, src)] = values["StrutDisp"]
    unknown = j1939.frame_id_pack(3, 0, 0, 0xFF, 0x7E, 0x90)  # Proprietary B PGN 0xFF7E: not in the DBC
    frames.append((0.5, unknown, True, bytes(8)))
    path = tmp_path / f"j1939{suffix}"
    _write_log(path, frames)
    d = decode_log(path)
    assert d.sources == {"HP_CornerMotion_2": {0x90: 30, 0x92: 30}}
    # The flipped bit: a CRC error from 0x92, then 0x92's next frame skips
    # the lost counter; 0x90's sequence is not disturbed.
    assert [(round(i.time_s, 3), i.source, i.reason) for i in d.issues] == [(0.121, 0x92, "crc"), (0.131, 0x92, "skipped")]
    assert d.outcomes["HP_CornerMotion_2"] == {"synced": 2, "next": 56, "crc": 1, "skipped": 1}
    table = d.tables["HP_CornerMotion_2"]
    got = {(round(t / 0.01 - 0.1 * (a == 0x92)), int(a)): x for t, a, x in zip(table["time_s"], table["source_address"], table["StrutDisp"])}
    assert set(got) == set(truth) - {(12, 0x92), (13, 0x92)}
    sig = DB.get_message_by_name("HP_CornerMotion_2").get_signal_by_name("StrutDisp")
    np.testing.assert_allclose([got[key] for key in sorted(got)], [truth[key] for key in sorted(got)], rtol=0, atol=sig.scale * 1e-6)
    assert d.unknown_ids == {unknown: 1}


def test_pdu1_requests_match_by_destination(tmp_path: Path) -> None:
    """The request PGN (0xEA00, PDU1) to the ECU and to everyone are two
    messages of the DBC: matched by their destination, from any sender;
    a request to another node is still the request PGN (the global
    message), unprotected and decoded."""
    to_ecu, glob = DB.get_message_by_name("J1939_RequestToEcu"), DB.get_message_by_name("J1939_RequestGlobal")
    to_other = j1939.frame_id_pack(6, 0, 0, 0xEA, 0x33, 0x17)
    frames = [(0.0, _with(to_ecu.frame_id, source=0x17), True, to_ecu.encode({"RequestedPgn": 0xFECA})),
              (0.1, glob.frame_id, True, glob.encode({"RequestedPgn": 0xEE00})),
              (0.2, to_other, True, glob.encode({"RequestedPgn": 0xFECA}))]  # fmt: skip
    path = tmp_path / "requests.log"
    _write_log(path, frames)
    d = decode_log(path)
    assert d.issues == [] and d.unknown_ids == {}
    assert d.outcomes == {"J1939_RequestToEcu": {"unprotected": 1}, "J1939_RequestGlobal": {"unprotected": 2}}
    assert d.sources == {"J1939_RequestToEcu": {0x17: 1}, "J1939_RequestGlobal": {0xF9: 1, 0x17: 1}}
    assert list(d.tables["J1939_RequestGlobal"]["RequestedPgn"]) == [0xEE00, 0xFECA]


@pytest.mark.parametrize("suffix", [".log", ".blf"])
def test_the_ecus_own_traffic_decodes_without_a_rejection(suffix: str, tmp_path: Path) -> None:
    """What the ECU application sends (``_core.Ecu``, the firmware's code):
    its address claim, DM1 and its Proprietary B messages, 1000 periods
    with its sensors silent (every corner in the safe state with a trouble
    code, so DM1 goes out as a broadcast transfer, TP.CM + TP.DT): every
    frame matched, none rejected; the address claim and the transport
    frames are unprotected network management from 0x2F, the protected
    messages' counters run in sequence."""
    ecu = _core.Ecu(corners=4)
    frames = []
    for k in range(1000):
        frames += [(0.001 * k, fid, True, bytes(raw)) for fid, raw in ecu.period()]
    path = tmp_path / f"ecu{suffix}"
    _write_log(path, frames)
    d = decode_log(path)
    assert d.frames == len(frames) and d.issues == [] and d.unknown_ids == {}
    assert d.outcomes["J1939_AddressClaimed"] == {"unprotected": 1} and d.sources["J1939_AddressClaimed"] == {0x2F: 1}
    # DM1 (PGN 0xFECA) with several codes: a BAM announcing it, then its packets.
    assert set(d.outcomes["J1939_TP_CM"]) == {"unprotected"} and d.sources["J1939_TP_CM"] == {0x2F: d.outcomes["J1939_TP_CM"]["unprotected"]}
    bam = d.tables["J1939_TP_CM"]
    assert set(bam["Control"]) == {32} and set(bam["TransferredPgn"]) == {0xFECA}
    packets = int(bam["Packets"][0])
    assert list(d.tables["J1939_TP_DT"]["Sequence"][:packets]) == list(range(1, packets + 1))
    protected = [m for m, o in d.outcomes.items() if m.startswith("HP_")]
    assert "HP_Valves" in protected and "HP_CornerStatus_3" in protected
    for m in protected:
        o = d.outcomes[m]
        assert o["synced"] == 1 and set(o) <= {"synced", "next"}, (m, o)
        assert d.sources[m] == {0x2F: sum(o.values())}
    np.testing.assert_array_equal(d.tables["HP_Valves"]["source_address"], 0x2F)

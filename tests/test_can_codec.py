"""The Rust CAN codec against the DBC (SAE J1939) as cantools reads it: the
ECU's own, E2E-protected messages (the standard J1939 groups are
test_can_j1939.py's).

The Rust side runs as `crates/hp-ctrl/examples/can_codec.rs` (a line
filter over stdin/stdout), the same code the ECU runs. cantools is the
independent DBC implementation, crccheck's CRC-8/GSM-A the independent
profile-11 CRC (see test_can_e2e.py).
"""

import json
import math
import subprocess
from pathlib import Path

import cantools
import pytest
from crccheck.crc import Crc8GsmA
from hypothesis import given, settings
from hypothesis import strategies as st

from hpctl.data import DBC_PATH

ROOT = Path(__file__).resolve().parent.parent
DBC = cantools.database.load_file(str(DBC_PATH))
HEADER = ("E2E_CRC", "E2E_Counter")

# Which input field each input signal feeds (the vehicle step's contract);
# corner signals are prefixed with their corner in the `period` answer.
INPUT_FIELD = {
    "PressureSmall": "p_gas_pa",
    "PressureLarge": "p_gas2_pa",
    "StrutDisp": "strut_disp_m",
    "BodyAcc": "body_acc_m_s2",
    "GasTemp": "t_gas_k",
    "VehicleSpeed": "speed_m_s",
    "BrakePressed": "brake_pressed",
    "LatAcc": "lat_acc_m_s2",
    "LongAcc": "long_acc_m_s2",
    "SteerAngle": "steer_angle_rad",
    "SteerRate": "steer_rate_rad_s",
    "DriverMode": "driver_mode",
    "HeightMode": "height_mode",
    "RideHeightRequest": "ride_height_request_m",
    "BodyPitch": "pitch_rad",
    "BodyRoll": "roll_rad",
}
# Input-group bits (hp_ctrl::input_group, vehicle_group) per input message.
PRESSURES, STRUT, BODY, TEMPERATURE = 1 << 0, 1 << 1, 1 << 2, 1 << 5
GROUP = {
    "HP_Vehicle": 1 << 3,
    "HP_Steering": 1 << 4,
    "HP_Driver": 1 << 6,
    "HP_Inclination": 1 << 7,
    **{f"HP_CornerPressures_{k}": PRESSURES for k in range(8)},
    **{f"HP_CornerMotion_{k}": STRUT | BODY | TEMPERATURE for k in range(8)},
}
# The codec example's receiver has four corners.
RX_CORNERS = 4


def corner_of(name: str) -> int | None:
    return int(name.rsplit("_", 1)[1]) if name.startswith("HP_Corner") else None


def build_codec() -> Path:
    """Builds the example and returns its path (cargo reports it)."""
    out = subprocess.run(
        ["cargo", "build", "-q", "--profile", "test-release", "-p", "hp-ctrl", "--example", "can_codec", "--message-format=json"],
        cwd=ROOT,
        check=True,
        capture_output=True,
        text=True,
    ).stdout
    for line in out.splitlines():
        msg = json.loads(line)
        if msg.get("reason") == "compiler-artifact" and msg["target"]["name"] == "can_codec" and msg.get("executable"):
            return Path(msg["executable"])
    raise RuntimeError("cargo did not report the can_codec executable")


class Codec:
    def __init__(self, exe: Path):
        self.proc = subprocess.Popen([str(exe)], stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True, bufsize=1)

    def ask(self, line: str) -> str:
        assert self.proc.stdin and self.proc.stdout
        self.proc.stdin.write(line + "\n")
        self.proc.stdin.flush()
        return self.proc.stdout.readline().strip()

    def table(self) -> list[str]:
        lines = [self.ask("table")]
        while lines[-1] != "end":
            lines.append(self.proc.stdout.readline().strip())
        return lines[:-1]

    def close(self):
        self.proc.stdin.close()
        self.proc.wait(timeout=10)


@pytest.fixture(scope="session")
def codec_exe() -> Path:
    return build_codec()


@pytest.fixture(scope="session")
def codec(codec_exe):
    c = Codec(codec_exe)
    yield c
    c.close()


@pytest.fixture
def fresh_codec(codec_exe):
    c = Codec(codec_exe)
    yield c
    c.close()


def data_id(msg) -> int:
    return msg.dbc.attributes["E2E_DataID"].value


def protect(msg, payload: bytearray) -> bytes:
    """Writes the profile-11 CRC (independent implementation) into byte 0."""
    d = data_id(msg)
    payload[0] = Crc8GsmA.calc(bytes([d & 0xFF, d >> 8]) + bytes(payload[1:]))
    return bytes(payload)


def payload_signals(msg):
    return [s for s in msg.signals if s.name not in HEADER]


def raw_bounds(sig) -> tuple[int, int]:
    return round((sig.minimum - sig.offset) / sig.scale), round((sig.maximum - sig.offset) / sig.scale)


def on_grid(sig, raw: int) -> float:
    return raw * sig.scale + sig.offset


def signal_values(msg, on_lsb_grid: bool):
    """Per signal: raw values with the range edges emphasised, or floats
    anywhere in the physical range."""
    strategies = {}
    for sig in payload_signals(msg):
        lo, hi = raw_bounds(sig)
        raws = st.one_of(st.sampled_from([lo, hi, lo + 1, hi - 1, (lo + hi) // 2]), st.integers(lo, hi))
        if on_lsb_grid or sig.length == 1 or sig.choices or sig.scale == 1:
            strategies[sig.name] = raws.map(lambda r, s=sig: on_grid(s, r))
        else:
            strategies[sig.name] = st.floats(sig.minimum, sig.maximum)
    return st.fixed_dictionaries(strategies)


def encode_line(msg, counter, values) -> str:
    return f"encode {msg.name} {counter} " + " ".join(f"{k}={v!r}" for k, v in values.items())


def cantools_frame(msg, counter: int, values: dict) -> bytes:
    data = bytearray(msg.encode({"E2E_CRC": 0, "E2E_Counter": counter, **values}, scaling=True, strict=True))
    return protect(msg, data)


def parse_values(words):
    return {k: float(v) for k, v in (w.split("=") for w in words)}


# The ECU's own messages: the E2E-protected Proprietary B groups.
MESSAGES = [m for m in DBC.messages if any(s.name == "E2E_CRC" for s in m.signals)]
# The corners' messages share their layout (the table test checks all of
# them): the property tests take the first and the last corner's.
SAMPLED = [m for m in MESSAGES if corner_of(m.name) in (None, 0, 7)]


def test_rust_table_matches_the_dbc(codec):
    rust_msgs = {}
    rust_sigs = {}
    for line in codec.table():
        kind, *f = line.split()
        if kind == "msg":
            rust_msgs[f[0]] = f[1:]
        else:
            rust_sigs[(f[0], f[1])] = f[2:]
    assert set(rust_msgs) == {m.name for m in MESSAGES}
    for m in MESSAGES:
        frame_id, did, cycle, delay, timeout, group, pgn, priority, source = rust_msgs[m.name]
        attrs = m.dbc.attributes
        assert int(frame_id, 16) == m.frame_id and m.is_extended_frame and m.protocol == "j1939"
        parts = cantools.j1939.frame_id_unpack(m.frame_id)
        assert int(pgn, 16) == cantools.j1939.pgn_pack(parts.reserved, parts.data_page, parts.pdu_format, parts.pdu_specific)
        assert 0xFF00 <= int(pgn, 16) <= 0xFFFF, "Proprietary B"
        assert (int(priority), int(source, 16)) == (parts.priority, parts.source_address)
        assert m.length == 8
        assert int(did, 16) == attrs["E2E_DataID"].value
        assert int(cycle) == attrs["GenMsgCycleTime"].value
        delay_attr = attrs.get("GenMsgStartDelayTime")
        assert int(delay) == (delay_attr.value if delay_attr else DBC.dbc.attribute_definitions["GenMsgStartDelayTime"].default_value)
        assert int(timeout) == attrs["E2E_TimeoutMs"].value
        assert int(group) == GROUP.get(m.name, 0)
        # The E2E header as profile 11 lays it out.
        crc, ctr = m.get_signal_by_name("E2E_CRC"), m.get_signal_by_name("E2E_Counter")
        assert (crc.start, crc.length, ctr.start, ctr.length, ctr.maximum) == (0, 8, 8, 4, 14)
        sigs = payload_signals(m)
        assert {name for (mn, name) in rust_sigs if mn == m.name} == {s.name for s in sigs}
        for s in sigs:
            start, length, signed, factor, offset, raw_min, raw_max, unit = rust_sigs[(m.name, s.name)]
            assert s.byte_order == "little_endian"
            assert (int(start), int(length), bool(int(signed))) == (s.start, s.length, s.is_signed)
            assert float(factor) == s.scale and float(offset) == s.offset
            assert (int(raw_min), int(raw_max)) == raw_bounds(s)
            assert (unit if unit != "-" else None) == (s.unit or None)


@pytest.mark.parametrize("msg", SAMPLED, ids=lambda m: m.name)
@settings(max_examples=40, deadline=None)
@given(data=st.data())
def test_rust_encodes_what_cantools_decodes(codec, msg, data):
    values = data.draw(signal_values(msg, on_lsb_grid=False))
    counter = data.draw(st.integers(0, 14))
    answer = codec.ask(encode_line(msg, counter, values)).split()
    assert answer[0] == "frame", answer
    assert int(answer[1], 16) == msg.frame_id
    raw = bytes.fromhex(answer[2])
    assert len(raw) == 8
    decoded = msg.decode(raw, decode_choices=False, scaling=True)
    assert decoded["E2E_Counter"] == counter
    assert raw == protect(msg, bytearray(raw)), "CRC differs from the independent implementation"
    for s in payload_signals(msg):
        assert abs(decoded[s.name] - values[s.name]) <= s.scale / 2 * (1 + 1e-9), s.name
    # On the LSB grid the bytes are exactly what cantools writes.
    grid = {s.name: decoded[s.name] for s in payload_signals(msg)}
    assert cantools_frame(msg, counter, grid) == raw


@pytest.mark.parametrize("msg", SAMPLED, ids=lambda m: m.name)
@settings(max_examples=40, deadline=None)
@given(data=st.data())
def test_rust_decodes_what_cantools_encodes(codec, msg, data):
    values = data.draw(signal_values(msg, on_lsb_grid=True))
    counter = data.draw(st.integers(0, 14))
    raw = cantools_frame(msg, counter, values)
    answer = codec.ask(f"decode {msg.frame_id:X} {raw.hex()}").split()
    assert answer[:3] == ["message", msg.name, str(counter)], answer
    got = parse_values(answer[3:])
    assert set(got) == set(values)
    for name, v in values.items():
        assert math.isclose(got[name], v, rel_tol=1e-12, abs_tol=1e-12), name


@settings(max_examples=200, deadline=None)
@given(st.data())
def test_out_of_range_raw_values_are_rejected(codec, data):
    msg = data.draw(st.sampled_from([m for m in MESSAGES if any(raw_bounds(s)[1] < (1 << s.length) - 1 or raw_bounds(s)[0] > (-(1 << (s.length - 1)) if s.is_signed else 0) for s in payload_signals(m))]))
    bad = data.draw(
        st.sampled_from(
            [s for s in payload_signals(msg) if raw_bounds(s)[1] < (1 << s.length) - 1 or raw_bounds(s)[0] > (-(1 << (s.length - 1)) if s.is_signed else 0)]
        )
    )
    lo, hi = raw_bounds(bad)
    field_lo, field_hi = (-(1 << (bad.length - 1)), (1 << (bad.length - 1)) - 1) if bad.is_signed else (0, (1 << bad.length) - 1)
    outside = [r for r in (lo - 1, hi + 1, field_lo, field_hi) if field_lo <= r <= field_hi and not lo <= r <= hi]
    raw_value = data.draw(st.sampled_from(outside))
    values = {s.name: raw_bounds(s)[0] for s in payload_signals(msg)}
    values[bad.name] = raw_value
    payload = bytearray(msg.encode({"E2E_CRC": 0, "E2E_Counter": 0, **values}, scaling=False, strict=False))
    raw = protect(msg, payload)
    assert codec.ask(f"decode {msg.frame_id:X} {raw.hex()}") == "reject range"
    # The encoder refuses the same physical value.
    phys = {s.name: on_grid(s, values[s.name]) for s in payload_signals(msg)}
    assert codec.ask(encode_line(msg, 0, phys)).startswith("error")


@settings(max_examples=200, deadline=None)
@given(st.data())
def test_wrong_crc_is_rejected(codec, data):
    msg = data.draw(st.sampled_from(MESSAGES))
    raw = bytearray(cantools_frame(msg, data.draw(st.integers(0, 14)), data.draw(signal_values(msg, on_lsb_grid=True))))
    raw[0] ^= data.draw(st.integers(1, 255))
    assert codec.ask(f"decode {msg.frame_id:X} {raw.hex()}") == "reject crc"


def test_counter_15_and_bad_lengths_are_rejected(codec):
    msg = DBC.get_message_by_name("HP_CornerMotion_0")
    raw = bytearray(8)
    raw[1] = 0x0F
    assert codec.ask(f"decode {msg.frame_id:X} {protect(msg, raw).hex()}") == "reject range"
    good = cantools_frame(msg, 0, {"StrutDisp": 0.0, "BodyAcc": 0.0, "GasTemp": 300.0})
    assert codec.ask(f"decode {msg.frame_id:X} {good[:7].hex()}") == "reject length"
    assert codec.ask(f"decode 7FF {good.hex()}") == "reject unknown_id"


INPUT_MESSAGES = [m for m in MESSAGES if m.name in GROUP and (corner_of(m.name) or 0) < RX_CORNERS]


def accepted(name: str) -> str:
    k = corner_of(name)
    return f"vehicle {GROUP[name]}" if k is None else f"corner {k} {GROUP[name]}"


@settings(max_examples=40, deadline=None)
@given(st.data())
def test_receiver_fills_inputs_from_cantools_frames(codec_exe, data):
    codec = Codec(codec_exe)
    try:
        values = {m.name: data.draw(signal_values(m, on_lsb_grid=True)) for m in INPUT_MESSAGES}
        # Counter sequence of any start; the first frame only synchronises.
        start = data.draw(st.integers(0, 14))
        for k, expect in ((0, "synced"), (1, None)):
            for m in INPUT_MESSAGES:
                raw = cantools_frame(m, (start + k) % 15, values[m.name])
                answer = codec.ask(f"rx {m.frame_id:X} {raw.hex()}")
                assert answer == (expect or accepted(m.name)), (m.name, answer)
            line = codec.ask("period").split()
        inputs = parse_values(line[1:])
        assert inputs["fresh"] == GROUP["HP_Vehicle"] | GROUP["HP_Steering"] | GROUP["HP_Driver"] | GROUP["HP_Inclination"]
        assert inputs["link_fault"] == 0 and inputs["inclination_stale"] == 0
        for k in range(RX_CORNERS):
            assert inputs[f"c{k}.fresh"] == PRESSURES | STRUT | BODY | TEMPERATURE and inputs[f"c{k}.link_fault"] == 0
        for m in INPUT_MESSAGES:
            k = corner_of(m.name)
            for name, v in values[m.name].items():
                field = INPUT_FIELD[name] if k is None else f"c{k}.{INPUT_FIELD[name]}"
                assert math.isclose(inputs[field], v, rel_tol=1e-12, abs_tol=1e-12), name
    finally:
        codec.close()


def test_receiver_counts_rejects_per_reason(fresh_codec):
    m = DBC.get_message_by_name("HP_CornerMotion_2")
    frame = lambda c: cantools_frame(m, c, {"StrutDisp": 0.01, "BodyAcc": 1.0, "GasTemp": 300.0}).hex()  # noqa: E731
    answers = [fresh_codec.ask(f"rx {m.frame_id:X} {frame(c)}") for c in (3, 4, 4, 6, 7)]
    assert answers == ["synced", "corner 2 38", "reject repeated", "reject skipped", "corner 2 38"]
    bad = bytearray(bytes.fromhex(frame(8)))
    bad[0] ^= 1
    assert fresh_codec.ask(f"rx {m.frame_id:X} {bad.hex()}") == "reject crc"
    assert fresh_codec.ask(f"rx 7FF {frame(8)}") == "reject unknown_id"
    diag = dict(w.split("=") for w in fresh_codec.ask("diag").split()[1:])
    assert (diag["crc"], diag["repeated"], diag["skipped"], diag["unknown_id"]) == ("1", "1", "1", "1")
    assert diag["window"] == "4"

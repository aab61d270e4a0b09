"""The CAN codec and the ECU application through the bindings
(hpctl._core.can_encode, can_decode, Ecu) against the DBC as cantools reads
it and crccheck's CRC-8/GSM-A (the independent references of
test_can_codec.py), and the bindings' argument checks."""

import math

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from hpctl import _core
from test_can_codec import (
    DBC,
    SAMPLED,
    cantools_frame,
    payload_signals,
    protect,
    signal_values,
)

SAFE_STATE = 1 << 0
LINK_FAULT = 1 << 3


@pytest.mark.parametrize("msg", SAMPLED, ids=lambda m: m.name)
@settings(max_examples=30, deadline=None)
@given(data=st.data())
def test_encode_is_what_cantools_decodes(msg, data):
    values = data.draw(signal_values(msg, on_lsb_grid=False))
    counter = data.draw(st.integers(0, 14))
    frame_id, raw = _core.can_encode(msg.name, counter, values)
    assert frame_id == msg.frame_id and len(raw) == 8
    assert raw == protect(msg, bytearray(raw)), "CRC differs from the independent implementation"
    decoded = msg.decode(raw, decode_choices=False)
    assert decoded["E2E_Counter"] == counter
    for s in payload_signals(msg):
        assert abs(decoded[s.name] - values[s.name]) <= s.scale / 2 * (1 + 1e-9), s.name
    grid = {s.name: decoded[s.name] for s in payload_signals(msg)}
    assert cantools_frame(msg, counter, grid) == raw


@pytest.mark.parametrize("msg", SAMPLED, ids=lambda m: m.name)
@settings(max_examples=30, deadline=None)
@given(data=st.data())
def test_decode_is_what_cantools_encodes(msg, data):
    values = data.draw(signal_values(msg, on_lsb_grid=True))
    counter = data.draw(st.integers(0, 14))
    name, got_counter, got = _core.can_decode(msg.frame_id, cantools_frame(msg, counter, values))
    assert (name, got_counter) == (msg.name, counter)
    assert set(got) == set(values)
    for k, v in values.items():
        assert math.isclose(got[k], v, rel_tol=1e-12, abs_tol=1e-12), k


MOTION = {"StrutDisp": 0.01, "BodyAcc": 0.0, "GasTemp": 300.0}


def test_rejected_frames_raise_with_their_reason():
    msg = DBC.get_message_by_name("HP_CornerMotion_0")
    good = cantools_frame(msg, 0, MOTION)
    bad_crc = bytes([good[0] ^ 1]) + good[1:]
    counter_15 = bytearray(8)
    counter_15[1] = 0x0F
    out_of_range = bytearray(msg.encode({"E2E_CRC": 0, "E2E_Counter": 0, **MOTION, "StrutDisp": 30000}, scaling=False, strict=False))
    foreign_pgn = (6 << 26) | (0xFEF1 << 8) | 0x00  # a standard J1939 group (CCVS1)
    cases = [
        ((msg.frame_id, bad_crc), "crc"),
        ((msg.frame_id, good[:7]), "length"),
        ((0x7FF, good, False), "unknown_id"),
        ((foreign_pgn, good), "unknown_id"),
        ((msg.frame_id, protect(msg, counter_15)), "range"),
        ((msg.frame_id, protect(msg, out_of_range)), "range"),
    ]
    for args, reason in cases:
        with pytest.raises(_core.CanRejectError) as e:
            _core.can_decode(*args)
        assert e.value.args[1] == reason, args
        assert isinstance(e.value, ValueError)
    # Any source address: the PGN decides.
    assert _core.can_decode((msg.frame_id & ~0xFF) | 0x42, good)[0] == "HP_CornerMotion_0"


@pytest.mark.parametrize(
    ("call", "match"),
    [
        (lambda: _core.can_encode("HP_Nothing", 0, {}), "unknown message"),
        (lambda: _core.can_encode("HP_CornerMotion_0", 15, MOTION), "counter"),
        (lambda: _core.can_encode("HP_CornerMotion_0", 0, {}), "missing key values.StrutDisp"),
        (lambda: _core.can_encode("HP_CornerMotion_0", 0, {**MOTION, "Extra": 1.0}), "unknown key values.Extra"),
        (lambda: _core.can_encode("HP_CornerMotion_0", 0, {**MOTION, "StrutDisp": math.nan}), "StrutDisp"),
        (lambda: _core.can_encode("HP_CornerMotion_0", 0, {**MOTION, "StrutDisp": 0.26}), "StrutDisp"),
        (lambda: _core.can_decode(0x800, bytes(8), False), "standard identifier"),
        (lambda: _core.can_decode(0x20000000, bytes(8)), "extended id"),
        (lambda: _core.can_decode(0x18FF1090, bytes(9)), "at most 8"),
        (lambda: _core.Ecu().receive(0x18FF1090, bytes(9)), "at most 8"),
        (lambda: _core.Ecu(corners=6), "corners"),
    ],
)
def test_malformed_calls_raise_parameter_error(call, match):
    with pytest.raises(_core.ParameterError, match=match):
        call()


def ecu_frames(frames):
    out = {}
    for i, d in frames:
        msg = DBC.get_message_by_frame_id(i)
        out[msg.name] = msg.decode(d, decode_choices=False)
    return out


@pytest.mark.parametrize("corners", [4, 8])
def test_ecu_without_inputs_claims_its_address_and_sends_the_safe_state_on_the_dbc_schedule(corners):
    ecu = _core.Ecu(corners)
    assert ecu.address == 0x2F
    for period in range(200):
        frames = ecu.period()
        names = [DBC.get_message_by_frame_id(i).name for i, _ in frames]
        for (i, d), name in zip(frames, names, strict=True):
            msg = DBC.get_message_by_frame_id(i)
            if name.startswith("HP_"):
                assert d == protect(msg, bytearray(d)), name
        own = [n for n in names if n.startswith("HP_")]
        expect = [f"HP_CornerStatus_{k}" for k in range(corners) if period >= 1 + k and (period - 1 - k) % 10 == 0]
        expect += [f"HP_CornerCtrl_{k}" for k in range(corners) if period >= 20 + k and (period - 20 - k) % 100 == 0]
        expect += [f"HP_CornerDiag_{k}" for k in range(corners) if period >= 40 + k and (period - 40 - k) % 100 == 0]
        expect += ["HP_DiagE2E", "HP_DiagLink"] if period % 100 == 99 else []
        expect += ["HP_Valves"]
        assert own == expect, period
        if period == 0:
            # The claim first, then the DM1 (by BAM: every sensor is missing).
            assert names[:2] == ["J1939_AddressClaimed", "J1939_TP_CM"]
        v = ecu_frames(frames)["HP_Valves"]
        assert v["LinkFault"] == 1 and v["StepIndex"] == period
        assert all(v[f"CornerSafe_{k}"] == 1 and v[f"Valve6Open_{k}"] == 0 and v[f"Valve5Open_{k}"] == 0 for k in range(corners))
    assert ecu.tx_dropped == 0
    assert len(ecu.dtcs()) >= 5 * corners


def test_ecu_at_rest_leaves_the_safe_state_and_reports_the_load_pressure():
    """Every corner at rest at a constant pressure: the ECU leaves the safe
    state, clears its trouble codes, and each corner's load-pressure
    estimate (HP_CornerCtrl) is that pressure to the signal's 10 Pa."""
    unit = _core.ctrl_seed_config()["unit"]
    p_pa = 15_123_450.0
    inputs = {
        "HP_Vehicle": {"VehicleSpeed": 0.0, "BrakePressed": 0, "LatAcc": 0.0, "LongAcc": 0.0},
        "HP_Steering": {"SteerAngle": 0.0, "SteerRate": 0.0},
        "HP_Driver": {"DriverMode": 0, "HeightMode": 0, "RideHeightRequest": 0.0},
        "HP_Inclination": {"BodyPitch": 0.0, "BodyRoll": 0.0},
    }
    for k in range(4):
        inputs[f"HP_CornerPressures_{k}"] = {"PressureSmall": p_pa, "PressureLarge": p_pa}
        inputs[f"HP_CornerMotion_{k}"] = {"StrutDisp": 0.0, "BodyAcc": 0.0, "GasTemp": unit["static_temperature_k"]}
    ecu = _core.Ecu(4)
    counters: dict[str, int] = {}
    ctrl = {}
    for period in range(2000):
        for name, values in inputs.items():
            msg = DBC.get_message_by_name(name)
            if period % msg.dbc.attributes["GenMsgCycleTime"].value == 0:
                c = counters.get(name, 0)
                counters[name] = (c + 1) % 15
                assert ecu.receive(msg.frame_id, cantools_frame(msg, c, values)) is None
        last = ecu_frames(ecu.period())
        ctrl.update({n: v for n, v in last.items() if n.startswith("HP_CornerCtrl_")})
    assert last["HP_Valves"]["LinkFault"] == 0
    assert all(last["HP_Valves"][f"CornerSafe_{k}"] == 0 for k in range(4))
    assert ecu.dtcs() == []
    assert sorted(ctrl) == [f"HP_CornerCtrl_{k}" for k in range(4)]
    assert all(abs(v["PressureLoad"] - p_pa) <= 10.0 for v in ctrl.values())

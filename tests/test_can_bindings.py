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
    MESSAGES,
    cantools_frame,
    payload_signals,
    protect,
    signal_values,
)

SAFE_STATE = 1 << 0
LINK_FAULT = 1 << 3


@pytest.mark.parametrize("msg", MESSAGES, ids=lambda m: m.name)
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


@pytest.mark.parametrize("msg", MESSAGES, ids=lambda m: m.name)
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


def test_rejected_frames_raise_with_their_reason():
    msg = DBC.get_message_by_name("HP_Strut")
    good = cantools_frame(msg, 0, {"StrutDisp": 0.01})
    bad_crc = bytes([good[0] ^ 1]) + good[1:]
    counter_15 = bytearray(8)
    counter_15[1] = 0x0F
    out_of_range = bytearray(msg.encode({"E2E_CRC": 0, "E2E_Counter": 0, "StrutDisp": 30000}, scaling=False, strict=False))
    cases = [
        ((msg.frame_id, bad_crc), "crc"),
        ((msg.frame_id, good[:7]), "length"),
        ((0x7FF, good), "unknown_id"),
        ((msg.frame_id, good, True), "unknown_id"),
        ((msg.frame_id, protect(msg, counter_15)), "range"),
        ((msg.frame_id, protect(msg, out_of_range)), "range"),
    ]
    for args, reason in cases:
        with pytest.raises(_core.CanRejectError) as e:
            _core.can_decode(*args)
        assert e.value.args[1] == reason, args
        assert isinstance(e.value, ValueError)


@pytest.mark.parametrize(
    ("call", "match"),
    [
        (lambda: _core.can_encode("HP_Nothing", 0, {}), "unknown message"),
        (lambda: _core.can_encode("HP_Strut", 15, {"StrutDisp": 0.0}), "counter"),
        (lambda: _core.can_encode("HP_Strut", 0, {}), "missing key values.StrutDisp"),
        (lambda: _core.can_encode("HP_Strut", 0, {"StrutDisp": 0.0, "Extra": 1.0}), "unknown key values.Extra"),
        (lambda: _core.can_encode("HP_Strut", 0, {"StrutDisp": math.nan}), "StrutDisp"),
        (lambda: _core.can_encode("HP_Strut", 0, {"StrutDisp": 0.26}), "StrutDisp"),
        (lambda: _core.can_decode(0x800, bytes(8)), "standard identifier"),
        (lambda: _core.can_decode(0x100, bytes(9)), "at most 8"),
        (lambda: _core.Ecu().receive(0x100, bytes(9)), "at most 8"),
    ],
)
def test_malformed_calls_raise_parameter_error(call, match):
    with pytest.raises(_core.ParameterError, match=match):
        call()


def ecu_frames(frames):
    return {DBC.get_message_by_frame_id(i).name: DBC.get_message_by_frame_id(i).decode(d, decode_choices=False) for i, d in frames}


def test_ecu_without_inputs_sends_the_safe_state_on_the_dbc_schedule():
    ecu = _core.Ecu()
    assert ecu.has_params
    for period in range(200):
        frames = ecu.period()
        for i, d in frames:
            msg = DBC.get_message_by_frame_id(i)
            assert d == protect(msg, bytearray(d)), msg.name
        names = [DBC.get_message_by_frame_id(i).name for i, _ in frames]
        expect = ["HP_ValveCmd", "HP_Status"]
        expect += ["HP_HeightCtrl"] if period % 10 == 3 else []
        expect += ["HP_Motion"] if period % 10 == 6 else []
        expect += ["HP_DiagE2E", "HP_DiagLink"] if period % 100 == 99 else []
        assert names == expect, period
        v = ecu_frames(frames)
        assert v["HP_ValveCmd"]["LinkFault"] == 1 and v["HP_ValveCmd"]["Valve6Open"] == 0 and v["HP_ValveCmd"]["StepIndex"] == period
        assert int(v["HP_Status"]["Diag"]) & (SAFE_STATE | LINK_FAULT) == SAFE_STATE | LINK_FAULT
    assert ecu.tx_dropped == 0


def test_ecu_at_rest_leaves_the_safe_state_and_reports_the_load_pressure():
    """The unit at rest at a constant pressure: the ECU leaves the safe
    state, and its load-pressure estimate (HP_HeightCtrl) is that pressure,
    to the signal's 10 Pa resolution."""
    unit = _core.ctrl_seed_config()["unit"]
    p_pa = 15_123_450.0
    inputs = {
        "HP_Pressures": {"PressureSmall": p_pa, "PressureLarge": p_pa},
        "HP_Strut": {"StrutDisp": 0.0},
        "HP_Body": {"BodyAcc": 0.0},
        "HP_Vehicle": {"VehicleSpeed": 0.0, "BrakePressed": 0, "LatAcc": 0.0, "LongAcc": 0.0},
        "HP_Steering": {"SteerAngle": 0.0, "SteerRate": 0.0},
        "HP_Temperature": {"GasTemp": unit["static_temperature_k"]},
        "HP_Driver": {"DriverMode": 0, "RideHeightRequest": 0.0},
    }
    ecu = _core.Ecu()
    counters: dict[str, int] = {}
    height_ctrl = None
    for period in range(2000):
        for name, values in inputs.items():
            msg = DBC.get_message_by_name(name)
            if period % msg.dbc.attributes["GenMsgCycleTime"].value == 0:
                c = counters.get(name, 0)
                counters[name] = (c + 1) % 15
                assert ecu.receive(msg.frame_id, cantools_frame(msg, c, values)) is None
        last = ecu_frames(ecu.period())
        height_ctrl = last.get("HP_HeightCtrl", height_ctrl)
    assert last["HP_ValveCmd"]["LinkFault"] == 0
    assert int(last["HP_Status"]["Diag"]) & SAFE_STATE == 0
    assert height_ctrl is not None and abs(height_ctrl["PressureLoad"] - p_pa) <= 10.0

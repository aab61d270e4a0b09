"""The ECU's J1939 network management and diagnostics against an
independent J1939 stack: the `can-j1939` package (python-can's J1939
implementation) on a python-can virtual bus, with the host build of the
ECU application (`hpctl._core.Ecu`, the code the firmware runs) stepped one
1 ms period at a time in real time.

- DM1: with every sensor missing the ECU reports many trouble codes, so
  its DM1 goes out by BAM; can-j1939 reassembles it and parses lamps and
  codes, which must be the ECU's own list (SPN, FMI, occurrence count).
- Address claim: the ECU claims 0x2F with its NAME at power-on; a NAME
  that wins arbitration claims 0x2F, and the ECU moves to 128 (it is
  arbitrary address capable) and claims that, as can-j1939 sees.
"""

import time

import can
import pytest

j1939 = pytest.importorskip("j1939", reason="can-j1939 not installed (pip install -e '.[test]')")

from hpctl import _core  # noqa: E402

PGN_ADDRESS_CLAIMED = 0xEE00
PGN_DM1 = 0xFECA


def run_periods(ecu, bus, periods: int, period_s: float = 1e-3) -> None:
    """Steps the host ECU in real time: frames from the bus in, the
    period's frames out."""
    t0 = time.monotonic()
    for k in range(periods):
        while (msg := bus.recv(0)) is not None:
            ecu.receive(msg.arbitration_id, bytes(msg.data), msg.is_extended_id)
        for frame_id, data in ecu.period():
            bus.send(can.Message(arbitration_id=frame_id, is_extended_id=True, data=data))
        delay = t0 + (k + 1) * period_s - time.monotonic()
        if delay > 0:
            time.sleep(delay)


@pytest.fixture
def network():
    channel = f"hpctl-j1939-{time.monotonic_ns()}"
    ecu_bus = can.Bus(interface="virtual", channel=channel)
    sniffer = can.Bus(interface="virtual", channel=channel)
    tool = j1939.ElectronicControlUnit()
    tool.connect(interface="virtual", channel=channel)
    ca = j1939.ControllerApplication(j1939.Name(manufacturer_code=1000, identity_number=7, arbitrary_address_capable=0), 0xF9)
    tool.add_ca(controller_application=ca)
    ca.start()
    try:
        yield ecu_bus, tool, ca, sniffer
    finally:
        ca.stop()
        tool.disconnect()
        ecu_bus.shutdown()
        sniffer.shutdown()


def test_dm1_by_bam_is_what_can_j1939_reassembles(network):
    ecu_bus, tool, ca, _ = network
    ecu = _core.Ecu(4)
    dm1 = j1939.Dm1(ca)
    got: list[tuple[dict, list[dict]]] = []
    dm1.subscribe(lambda *args: got.append((dict(dm1.lamp_status), [dict(d) for d in dm1.dtc_dic_list])))
    run_periods(ecu, ecu_bus, 1500)
    time.sleep(0.2)
    assert got, "no DM1 reassembled"
    lamps, dtcs = got[0]
    expected = sorted(ecu.dtcs())
    assert len(expected) > 1, "more than one code: the BAM path"
    assert sorted((d["spn"], d["fmi"], d["oc"]) for d in dtcs) == expected
    assert lamps["awl"] == 1 and lamps["rsl"] == 0 and lamps["mil"] == 0
    # Every code is proprietary (J1939-73: SPN 520192-524287).
    assert all(520192 <= spn <= 524287 for spn, _, _ in expected)


def sniffed(bus) -> list[tuple[int, int, bytes]]:
    """(PGN, source address, data) of every frame on the bus so far."""
    out = []
    while (msg := bus.recv(0)) is not None:
        mid = j1939.MessageId(can_id=msg.arbitration_id)
        pgn = j1939.ParameterGroupNumber()
        pgn.from_message_id(mid)
        out.append((pgn.value & (0x3FF00 if pgn.pdu_format < 240 else 0x3FFFF), mid.source_address, bytes(msg.data)))
    return out


def test_address_claim_and_conflict_as_can_j1939_sees_them(network):
    ecu_bus, tool, ca, sniffer = network
    seen: list[tuple[int, int, bytes]] = []
    ecu = _core.Ecu(4)
    run_periods(ecu, ecu_bus, 50)
    time.sleep(0.1)
    seen += sniffed(sniffer)
    claims = [(sa, data) for pgn, sa, data in seen if pgn == PGN_ADDRESS_CLAIMED]
    assert claims and claims[0][0] == 0x2F
    ecu_name = j1939.Name(bytes=list(claims[0][1]))
    assert ecu_name.arbitrary_address_capable == 1 and ecu_name.function == 47
    # A second tool application whose NAME wins arbitration claims 0x2F.
    rival = j1939.ControllerApplication(j1939.Name(manufacturer_code=5, identity_number=9, arbitrary_address_capable=0), 0x2F)
    tool.add_ca(controller_application=rival)
    rival.start()
    run_periods(ecu, ecu_bus, 1200)
    time.sleep(0.1)
    rival.stop()
    seen += sniffed(sniffer)
    assert ecu.address == 128
    moved = [(sa, data) for pgn, sa, data in seen if pgn == PGN_ADDRESS_CLAIMED and sa == 128]
    assert moved and moved[0][1] == claims[0][1]
    # After the contention window the ECU's own messages come from 128.
    own = {sa for pgn, sa, _ in seen if 0xFF80 <= pgn <= 0xFFFF}
    assert 128 in own

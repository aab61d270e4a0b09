"""E2E profile-11 CRC parameters, pinned against independent implementations.

The AUTOSAR profile-11 CRC is CRC-8 with polynomial 0x1D, but its
*effective* start value and final XOR are both 0x00 (catalogue name
CRC-8/GSM-A), not the 0xFF/0xFF of the "CRC-8/SAE-J1850" entry that the
AUTOSAR CRC library's Crc_CalculateCRC8 implements: the profile starts the
library with 0xFF and IsFirstCall=FALSE (the library XORs it with 0xFF on
entry) and XORs the library's result with 0xFF again.

References used here: crccheck's catalogue classes, the AUTOSAR profile-11
example values (data ID 0x123, zero payload: CRC 0xCC with counter 0, 0x91
with counter 1) and, if installed, the `autosar-e2e` package (module `e2e`,
a C implementation of the AUTOSAR E2E library). The Rust codec is checked
against the same references in test_can_codec.py.
"""

import pytest
from crccheck.crc import Crc8GsmA, Crc8SaeJ1850
from hypothesis import given
from hypothesis import strategies as st

POLY = 0x1D


def crc8_bitwise(data: bytes, init: int, xorout: int) -> int:
    """Textbook MSB-first CRC-8, one bit at a time."""
    crc = init
    for byte in data:
        crc ^= byte
        for _ in range(8):
            crc = ((crc << 1) ^ POLY) & 0xFF if crc & 0x80 else (crc << 1) & 0xFF
    return crc ^ xorout


def p11_crc_from_library_calls(data_id: int, payload: bytes) -> int:
    """Profile 11 as the AUTOSAR E2E library composes it from the CRC
    library's Crc_CalculateCRC8 (init 0xFF, xor 0xFF), call by call."""

    def crc_calculate_crc8(data: bytes, start: int, first_call: bool) -> int:
        reg = 0xFF if first_call else start ^ 0xFF
        return crc8_bitwise(data, reg, 0xFF)

    crc = crc_calculate_crc8(bytes([data_id & 0xFF]), 0xFF, False)
    crc = crc_calculate_crc8(bytes([data_id >> 8]), crc, False)
    crc = crc_calculate_crc8(payload[1:], crc, False)
    return crc ^ 0xFF


def test_catalogue_check_values():
    assert Crc8GsmA.calc(b"123456789") == 0x37
    assert Crc8SaeJ1850.calc(b"123456789") == 0x4B
    assert crc8_bitwise(b"123456789", 0x00, 0x00) == 0x37
    assert crc8_bitwise(b"123456789", 0xFF, 0xFF) == 0x4B


def test_autosar_profile_11_examples():
    zero = bytes(8)
    one = bytes([0, 1, 0, 0, 0, 0, 0, 0])
    id_bytes = bytes([0x23, 0x01])
    assert p11_crc_from_library_calls(0x123, zero) == 0xCC
    assert p11_crc_from_library_calls(0x123, one) == 0x91
    assert Crc8GsmA.calc(id_bytes + zero[1:]) == 0xCC
    assert Crc8GsmA.calc(id_bytes + one[1:]) == 0x91
    # The SAE-J1850 catalogue parameters give a different CRC.
    assert Crc8SaeJ1850.calc(id_bytes + zero[1:]) != 0xCC


@given(st.integers(0, 0xFFFF), st.binary(min_size=8, max_size=8))
def test_library_composition_equals_gsm_a(data_id, payload):
    id_bytes = bytes([data_id & 0xFF, data_id >> 8])
    assert p11_crc_from_library_calls(data_id, payload) == Crc8GsmA.calc(id_bytes + payload[1:])


@given(st.integers(0, 0xFFFF), st.binary(min_size=8, max_size=8), st.integers(0, 14))
def test_autosar_e2e_package_agrees(data_id, payload, counter):
    p11 = pytest.importorskip("e2e.p11")
    data = bytearray(payload)
    data[1] = counter
    p11.e2e_p11_protect(data, data_id, data_id_mode=p11.E2E_P11_DATAID_BOTH, increment_counter=False)
    id_bytes = bytes([data_id & 0xFF, data_id >> 8])
    assert data[0] == Crc8GsmA.calc(id_bytes + bytes(data[1:]))
    assert p11.e2e_p11_check(data, data_id, data_id_mode=p11.E2E_P11_DATAID_BOTH)

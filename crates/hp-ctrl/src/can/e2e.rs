//! End-to-end protection in the style of AUTOSAR E2E profile 11
//! (DataIDMode BOTH) on an 8-byte classic CAN payload.
//!
//! Layout: byte 0 is the CRC, the low nibble of byte 1 the alive counter
//! (0..=14, 15 is invalid), the high nibble of byte 1 is reserved (sent as
//! 0, covered by the CRC), bytes 2..=7 carry the signals.
//!
//! The CRC is CRC-8 with polynomial 0x1D over the data ID's low byte, its
//! high byte, then payload bytes 1..=7. Profile 11 calls the AUTOSAR CRC
//! library's `Crc_CalculateCRC8` with start value 0xFF and
//! `IsFirstCall = FALSE`; the library XORs the start value with 0xFF on
//! entry and the result with 0xFF on exit, and the profile XORs the final
//! result with 0xFF once more. The effective parameters are therefore
//! init 0x00, no reflection, final XOR 0x00 (the catalogue's
//! "CRC-8/GSM-A", check value 0x37), not the "CRC-8/SAE-J1850" entry
//! (init 0xFF, final XOR 0xFF, check 0x4B) that the CRC library itself
//! implements. Test vectors (AUTOSAR E2E protocol specification, profile
//! 11 examples, data ID 0x123, zero payload): counter 0 -> CRC 0xCC,
//! counter 1 -> CRC 0x91.

/// The CRC polynomial (x^8 + x^4 + x^3 + x^2 + 1), normal form.
pub const CRC8_POLY: u8 = 0x1D;
/// The effective register start value of profile 11.
pub const CRC8_INIT: u8 = 0x00;
/// The effective final XOR of profile 11.
pub const CRC8_XOR_OUT: u8 = 0x00;
/// The largest valid alive counter; the counter wraps from 14 to 0.
pub const COUNTER_MAX: u8 = 14;

/// Byte-wise lookup table of the polynomial, built at compile time.
const TABLE: [u8; 256] = table();

#[allow(clippy::indexing_slicing)] // i < 256 by the loop bound; const fn cannot use get_mut.
const fn table() -> [u8; 256] {
    let mut t = [0u8; 256];
    let mut i = 0;
    while i < 256 {
        let mut c = i as u8;
        let mut bit = 0;
        while bit < 8 {
            c = if c & 0x80 != 0 { (c << 1) ^ CRC8_POLY } else { c << 1 };
            bit += 1;
        }
        t[i] = c;
        i += 1;
    }
    t
}

/// Continues a CRC-8 (poly 0x1D, not reflected) register over `bytes`.
///
/// ```
/// use hp_ctrl::can::e2e::crc8_update;
/// // Catalogue check values over "123456789".
/// assert_eq!(crc8_update(0x00, b"123456789"), 0x37); // CRC-8/GSM-A
/// assert_eq!(crc8_update(0xFF, b"123456789") ^ 0xFF, 0x4B); // CRC-8/SAE-J1850
/// ```
pub fn crc8_update(mut crc: u8, bytes: &[u8]) -> u8 {
    for &b in bytes {
        // The index is a u8, so it is always inside the 256-entry table.
        #[allow(clippy::indexing_slicing)]
        {
            crc = TABLE[usize::from(crc ^ b)];
        }
    }
    crc
}

/// The profile-11 CRC of an 8-byte payload: over the data ID (low byte,
/// high byte) and bytes 1..=7 (byte 0, the CRC itself, is skipped).
///
/// ```
/// use hp_ctrl::can::e2e::crc;
/// assert_eq!(crc(0x123, &[0; 8]), 0xCC);
/// assert_eq!(crc(0x123, &[0, 1, 0, 0, 0, 0, 0, 0]), 0x91);
/// ```
pub fn crc(data_id: u16, payload: &[u8; 8]) -> u8 {
    let [id_lo, id_hi] = data_id.to_le_bytes();
    let [_, rest @ ..] = payload;
    crc8_update(crc8_update(CRC8_INIT, &[id_lo, id_hi]), rest) ^ CRC8_XOR_OUT
}

/// The alive counter in byte 1 (low nibble); may be the invalid 15.
pub fn counter(payload: &[u8; 8]) -> u8 {
    payload[1] & 0x0F
}

/// Writes `counter` (taken modulo 15) and the CRC into `payload`, clearing
/// the reserved high nibble of byte 1.
pub fn protect(payload: &mut [u8; 8], data_id: u16, counter: u8) {
    payload[1] = counter % (COUNTER_MAX + 1);
    payload[0] = crc(data_id, payload);
}

/// True if the CRC in byte 0 matches the payload and `data_id`.
pub fn crc_ok(payload: &[u8; 8], data_id: u16) -> bool {
    payload[0] == crc(data_id, payload)
}

/// The next alive counter after `counter` (14 wraps to 0).
pub fn next_counter(counter: u8) -> u8 {
    if counter >= COUNTER_MAX {
        0
    } else {
        counter + 1
    }
}

/// Outcome of the alive-counter check of one CRC-valid frame.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Sequence {
    /// Exactly one more than the previous counter: accept.
    Next,
    /// The same counter as before: a repeated frame, reject.
    Repeated,
    /// Any other step: frames were lost or reordered, reject; the counter
    /// becomes the new reference, so the next frame in sequence is accepted.
    Skipped,
    /// No reference yet (power-on or after a timeout): this frame only sets
    /// the reference and is not used; the next one in sequence is accepted.
    Synced,
}

/// Receiver state of one message: the last alive counter seen.
///
/// ```
/// use hp_ctrl::can::e2e::{CounterState, Sequence};
/// let mut rx = CounterState::new();
/// assert_eq!(rx.check(13), Sequence::Synced);
/// assert_eq!(rx.check(14), Sequence::Next);
/// assert_eq!(rx.check(0), Sequence::Next); // wraps 14 -> 0
/// assert_eq!(rx.check(0), Sequence::Repeated);
/// assert_eq!(rx.check(2), Sequence::Skipped);
/// assert_eq!(rx.check(3), Sequence::Next);
/// rx.reset(); // e.g. after a timeout
/// assert_eq!(rx.check(9), Sequence::Synced);
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct CounterState {
    last: Option<u8>,
}

impl CounterState {
    /// No reference counter: the next valid frame re-synchronises.
    pub const fn new() -> Self {
        CounterState { last: None }
    }

    /// Forgets the reference (after a timeout).
    pub fn reset(&mut self) {
        self.last = None;
    }

    /// Checks a valid counter (0..=14) against the reference and updates it.
    pub fn check(&mut self, counter: u8) -> Sequence {
        let Some(last) = self.last else {
            self.last = Some(counter);
            return Sequence::Synced;
        };
        if counter == last {
            return Sequence::Repeated;
        }
        self.last = Some(counter);
        if counter == next_counter(last) {
            Sequence::Next
        } else {
            Sequence::Skipped
        }
    }
}

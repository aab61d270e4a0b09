//! Fixed-point signals in an 8-byte payload, Intel (little-endian) byte
//! order, as a DBC `SG_` line describes them.

/// Why a physical value cannot be encoded.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum EncodeError {
    /// NaN, infinite, or outside the signal's DBC range.
    OutOfRange,
}

/// One signal: `physical = raw * factor + offset`, valid for
/// `raw_min <= raw <= raw_max` (the DBC's `[min|max]` in raw units).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Signal {
    /// Bit position of the least significant bit (DBC start bit, `@1`).
    pub start_bit: u8,
    /// Width in bits, 1..=64 - start_bit.
    pub bit_len: u8,
    /// Two's-complement raw value (DBC `-`).
    pub signed: bool,
    /// Physical units per raw LSB.
    pub factor: f64,
    /// Physical value of raw 0.
    pub offset: f64,
    /// Smallest valid raw value.
    pub raw_min: i64,
    /// Largest valid raw value.
    pub raw_max: i64,
}

impl Signal {
    /// A signal definition, checked when evaluated in a `const`.
    pub const fn new(start_bit: u8, bit_len: u8, signed: bool, factor: f64, offset: f64, raw_min: i64, raw_max: i64) -> Self {
        assert!(bit_len >= 1 && bit_len < 64 && start_bit as u32 + bit_len as u32 <= 64);
        assert!(raw_min <= raw_max);
        Signal { start_bit, bit_len, signed, factor, offset, raw_min, raw_max }
    }

    /// A one-bit flag.
    pub const fn flag(start_bit: u8) -> Self {
        Signal::new(start_bit, 1, false, 1.0, 0.0, 0, 1)
    }

    /// An unsigned integer (enumeration, counter) with range `0..=max`.
    pub const fn uint(start_bit: u8, bit_len: u8, max: i64) -> Self {
        Signal::new(start_bit, bit_len, false, 1.0, 0.0, 0, max)
    }

    fn mask(&self) -> u64 {
        (1u64 << self.bit_len) - 1
    }

    /// The raw bit field, sign-extended if signed (no range check).
    pub fn raw(&self, payload: &[u8; 8]) -> i64 {
        let field = (u64::from_le_bytes(*payload) >> self.start_bit) & self.mask();
        let sign_bit = 1u64 << (self.bit_len - 1);
        if self.signed && field & sign_bit != 0 {
            (field | !self.mask()) as i64
        } else {
            field as i64
        }
    }

    /// Writes a raw value (truncated to the field width).
    pub fn put_raw(&self, payload: &mut [u8; 8], raw: i64) {
        let mask = self.mask() << self.start_bit;
        let word = u64::from_le_bytes(*payload) & !mask | ((raw as u64) << self.start_bit) & mask;
        *payload = word.to_le_bytes();
    }

    /// The raw value if it is inside the valid range.
    pub fn checked_raw(&self, payload: &[u8; 8]) -> Option<i64> {
        let raw = self.raw(payload);
        (self.raw_min..=self.raw_max).contains(&raw).then_some(raw)
    }

    /// The physical value if the raw value is inside the valid range.
    pub fn get(&self, payload: &[u8; 8]) -> Option<f64> {
        self.checked_raw(payload).map(|raw| raw as f64 * self.factor + self.offset)
    }

    /// The nearest raw value of a physical value, if valid.
    pub fn to_raw(&self, physical: f64) -> Result<i64, EncodeError> {
        let raw = libm::round((physical - self.offset) / self.factor);
        // NaN fails both comparisons.
        if raw >= self.raw_min as f64 && raw <= self.raw_max as f64 {
            Ok(raw as i64)
        } else {
            Err(EncodeError::OutOfRange)
        }
    }

    /// Encodes a physical value (rounded to the nearest LSB).
    pub fn put(&self, payload: &mut [u8; 8], physical: f64) -> Result<(), EncodeError> {
        let raw = self.to_raw(physical)?;
        self.put_raw(payload, raw);
        Ok(())
    }

    /// Encodes a flag.
    pub fn put_flag(&self, payload: &mut [u8; 8], on: bool) {
        self.put_raw(payload, i64::from(on));
    }

    /// Encodes an in-range unsigned integer.
    pub fn put_uint(&self, payload: &mut [u8; 8], value: u32) -> Result<(), EncodeError> {
        let raw = i64::from(value);
        if raw < self.raw_min || raw > self.raw_max {
            return Err(EncodeError::OutOfRange);
        }
        self.put_raw(payload, raw);
        Ok(())
    }
}

#[cfg(test)]
#[allow(clippy::unwrap_used, clippy::indexing_slicing)] // Tests may unwrap.
mod tests {
    use super::*;

    #[test]
    fn signed_field_round_trips_at_its_extremes() {
        let s = Signal::new(16, 16, true, 1e-5, 0.0, -32768, 32767);
        for raw in [-32768, -1, 0, 1, 32767] {
            let mut p = [0xAAu8; 8];
            s.put_raw(&mut p, raw);
            assert_eq!(s.raw(&p), raw);
            // Neighbouring bytes untouched.
            assert_eq!(p[1], 0xAA);
            assert_eq!(p[4], 0xAA);
        }
    }

    #[test]
    fn field_spanning_bytes_lands_little_endian() {
        let s = Signal::new(16, 24, false, 10.0, 0.0, 0, 12_000_000);
        let mut p = [0u8; 8];
        s.put_raw(&mut p, 0x123456);
        assert_eq!(p, [0, 0, 0x56, 0x34, 0x12, 0, 0, 0]);
    }

    #[test]
    fn non_finite_and_out_of_range_are_refused() {
        let s = Signal::new(16, 16, true, 0.001, 0.0, -30000, 30000);
        for bad in [f64::NAN, f64::INFINITY, f64::NEG_INFINITY, 30.001, -30.0006] {
            assert_eq!(s.to_raw(bad), Err(EncodeError::OutOfRange), "{bad}");
        }
        assert_eq!(s.to_raw(30.0), Ok(30000));
        assert_eq!(s.to_raw(-30.0004), Ok(-30000));
    }
}

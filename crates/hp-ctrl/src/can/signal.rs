//! Fixed-point signals in an 8-byte payload, Intel (little-endian) byte
//! order, as a DBC `SG_` line describes them.

/// Why a physical value cannot be encoded.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum EncodeError {
    /// NaN, infinite, or outside the signal's DBC range.
    OutOfRange,
}

/// How a signal's raw values become physical ones, chosen when the signal
/// is defined so that the ECU (a single-precision FPU: every `f64`
/// operation is a software routine of a hundred instructions or more) does
/// only the `f64` work the DBC's arithmetic needs.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Scale {
    /// An integer factor and raw values for which `raw * factor` fits an
    /// `i32`: the product is formed in integers and converted once (exact,
    /// so the same value as the `f64` product).
    Integer(i32),
    /// Any other factor, raw values within `i32`: the `f64` product,
    /// formed in integers ([`times_factor`]).
    Real,
    /// Raw values beyond `i32` (32-bit counters and flag words).
    Wide,
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
    scale: Scale,
    /// `2 / factor`, for encoding without an `f64` division.
    twice_inv_factor: f64,
}

/// Raw values below this magnitude use the `i32` paths (`2 raw` still
/// fits, with room for the encoder's saturating cast).
const RAW_I32_LIMIT: i64 = (1 << 30) - 1;

impl Signal {
    /// A signal definition, checked when evaluated in a `const`.
    pub const fn new(start_bit: u8, bit_len: u8, signed: bool, factor: f64, offset: f64, raw_min: i64, raw_max: i64) -> Self {
        assert!(bit_len >= 1 && bit_len < 64 && start_bit as u32 + bit_len as u32 <= 64);
        assert!(raw_min <= raw_max);
        assert!(factor > 0.0 && factor.is_finite() && offset.is_finite());
        let int_factor = factor as i64;
        let small = raw_min >= -RAW_I32_LIMIT && raw_max <= RAW_I32_LIMIT;
        let scale = if !small {
            Scale::Wide
        } else if int_factor as f64 == factor
            && int_factor <= i32::MAX as i64
            && raw_max * int_factor <= i32::MAX as i64
            && raw_min * int_factor >= i32::MIN as i64
        {
            Scale::Integer(int_factor as i32)
        } else {
            // times_factor's domain: a normal factor whose products with
            // |raw| <= 2^31 stay normal.
            let exponent = (factor.to_bits() >> 52) & 0x7FF;
            assert!(exponent >= 1 && exponent + 32 <= 2046);
            Scale::Real
        };
        Signal { start_bit, bit_len, signed, factor, offset, raw_min, raw_max, scale, twice_inv_factor: 2.0 / factor }
    }

    /// A non-zero offset (a bit test: a float comparison is a software
    /// call on the ECU). Adding or subtracting +0.0 changes no value here.
    fn has_offset(&self) -> bool {
        self.offset.to_bits() != 0
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

    /// The bits of a payload (as a little-endian `u64`) this signal uses.
    pub const fn field_mask(&self) -> u64 {
        ((1u64 << self.bit_len) - 1) << self.start_bit
    }

    // The codec works on the payload as one little-endian u64 word (read
    // once per frame); the `[u8; 8]` forms below are for tools and tests.

    /// The raw bit field of payload word `w`, sign-extended if signed (no
    /// range check).
    pub fn raw_in(&self, w: u64) -> i64 {
        let field = (w >> self.start_bit) & self.mask();
        let sign_bit = 1u64 << (self.bit_len - 1);
        if self.signed && field & sign_bit != 0 {
            (field | !self.mask()) as i64
        } else {
            field as i64
        }
    }

    /// The raw value in payload word `w` if it is inside the valid range.
    pub fn checked_raw_in(&self, w: u64) -> Option<i64> {
        let raw = self.raw_in(w);
        (raw >= self.raw_min && raw <= self.raw_max).then_some(raw)
    }

    /// The physical value in payload word `w` if its raw value is inside
    /// the valid range: `raw * factor + offset` in `f64`, exactly as the
    /// DBC (and cantools) compute it.
    pub fn value_in(&self, w: u64) -> Option<f64> {
        self.checked_raw_in(w).map(|raw| self.physical(raw))
    }

    /// A raw value (truncated to the field width) as payload bits.
    pub fn raw_bits(&self, raw: i64) -> u64 {
        ((raw as u64) & self.mask()) << self.start_bit
    }

    /// A physical value, rounded to the nearest LSB ([`Signal::to_raw`]),
    /// as payload bits.
    pub fn bits_of(&self, physical: f64) -> Result<u64, EncodeError> {
        self.to_raw(physical).map(|raw| self.raw_bits(raw))
    }

    /// A flag as payload bits.
    pub fn flag_bits(&self, on: bool) -> u64 {
        self.raw_bits(i64::from(on))
    }

    /// An in-range unsigned integer as payload bits.
    pub fn uint_bits(&self, value: u32) -> Result<u64, EncodeError> {
        let raw = i64::from(value);
        if raw < self.raw_min || raw > self.raw_max {
            return Err(EncodeError::OutOfRange);
        }
        Ok(self.raw_bits(raw))
    }

    /// The raw bit field, sign-extended if signed (no range check).
    pub fn raw(&self, payload: &[u8; 8]) -> i64 {
        self.raw_in(u64::from_le_bytes(*payload))
    }

    /// Writes a raw value (truncated to the field width).
    pub fn put_raw(&self, payload: &mut [u8; 8], raw: i64) {
        let word = u64::from_le_bytes(*payload) & !self.field_mask() | self.raw_bits(raw);
        *payload = word.to_le_bytes();
    }

    /// The raw value if it is inside the valid range.
    pub fn checked_raw(&self, payload: &[u8; 8]) -> Option<i64> {
        self.checked_raw_in(u64::from_le_bytes(*payload))
    }

    /// The physical value if the raw value is inside the valid range:
    /// `raw * factor + offset` in `f64`, exactly as the DBC (and cantools)
    /// compute it.
    pub fn get(&self, payload: &[u8; 8]) -> Option<f64> {
        self.value_in(u64::from_le_bytes(*payload))
    }

    /// `raw * factor + offset` for a raw value inside the valid range.
    fn physical(&self, raw: i64) -> f64 {
        // In range, so the casts to i32 are exact (see `Signal::new`).
        let product = match self.scale {
            Scale::Integer(k) => f64::from((raw as i32).wrapping_mul(k)),
            Scale::Real => times_factor(raw as i32, self.factor),
            Scale::Wide => raw as f64 * self.factor,
        };
        // x + 0.0 == x for every product here (none is -0.0), so a zero
        // offset is skipped rather than added in software.
        if self.has_offset() {
            product + self.offset
        } else {
            product
        }
    }

    /// The nearest raw value of a physical value (ties away from zero), if
    /// valid.
    ///
    /// The quotient `(physical - offset) / factor` is formed as
    /// `(physical - offset) * (2 / factor)` and halved in integers: one
    /// `f64` product instead of a division and a rounding call. It is
    /// within two units in the last place of the exact quotient, so the
    /// raw value is the nearest one except for values within about 1e-16
    /// (relative) of a tie, which may round either way.
    ///
    /// ```
    /// use hp_ctrl::can::signal::Signal;
    /// let s = Signal::new(16, 16, true, 1e-5, 0.0, -30_000, 30_000);
    /// assert_eq!(s.to_raw(0.123_454_9), Ok(12_345));
    /// assert_eq!(s.to_raw(-0.123_455_1), Ok(-12_346));
    /// assert!(s.to_raw(f64::NAN).is_err() && s.to_raw(0.300_01).is_err());
    /// ```
    pub fn to_raw(&self, physical: f64) -> Result<i64, EncodeError> {
        let x = if self.has_offset() { physical - self.offset } else { physical };
        let twice = x * self.twice_inv_factor;
        // NaN has no raw value (tested on the bits: no software compare);
        // the saturating casts put infinities and huge values outside
        // every valid range.
        if twice.to_bits() & !(1 << 63) > f64::INFINITY.to_bits() {
            return Err(EncodeError::OutOfRange);
        }
        let t = match self.scale {
            Scale::Integer(_) | Scale::Real => i64::from(twice as i32),
            Scale::Wide => twice as i64,
        };
        // t = trunc(2q); (t + 1) / 2 for t >= 0 and (t - 1) / 2 below
        // (division truncates towards zero) is q rounded half away from 0.
        let raw = t.saturating_add(if t < 0 { -1 } else { 1 }) / 2;
        if raw >= self.raw_min && raw <= self.raw_max {
            Ok(raw)
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
        self.uint_bits(value)?;
        self.put_raw(payload, i64::from(value));
        Ok(())
    }
}

/// `raw * factor` in `f64`, bit for bit what the IEEE multiplication
/// `f64::from(raw) * factor` gives (round to nearest, ties to even), for a
/// positive normal `factor` whose products stay normal (`Signal::new`
/// checks this), with a handful of integer instructions instead of the
/// software `f64` multiply (about 200 instructions on the ECU). Tested
/// against the multiplication for every raw value of every signal.
fn times_factor(raw: i32, factor: f64) -> f64 {
    if raw == 0 {
        return 0.0;
    }
    let bits = factor.to_bits();
    let exponent = (bits >> 52) & 0x7FF;
    let mantissa = bits & ((1 << 52) - 1) | (1 << 52); // 53 significant bits
    let r = u64::from(raw.unsigned_abs());
    // The exact product mantissa * r = hi * 2^32 + lo, at most 85 bits; hi
    // has at least 21 of them (mantissa >= 2^52, r >= 1).
    let low = (mantissa & 0xFFFF_FFFF) * r;
    let hi = (mantissa >> 32) * r + (low >> 32);
    let lo = low & 0xFFFF_FFFF;
    // Drop the s low bits that do not fit 53: s = bits(hi) + 32 - 53, 0..=32.
    let s = 64 - hi.leading_zeros() - 21;
    let mut kept = (hi << (32 - s)) | (lo >> s);
    if s > 0 {
        let dropped = lo & ((1 << s) - 1);
        let half = 1 << (s - 1);
        if dropped > half || (dropped == half && kept & 1 == 1) {
            // May carry into bit 53: the exponent field below absorbs it.
            kept += 1;
        }
    }
    // kept * 2^(exponent + s - 1075): the implicit bit (bit 52 of kept)
    // adds the last 1 to the biased exponent field.
    let magnitude = ((exponent + u64::from(s) - 1) << 52) + kept;
    f64::from_bits(magnitude | u64::from(raw < 0) << 63)
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

    #[test]
    fn integer_products_equal_the_float_multiplication_for_every_raw_value_of_every_signal() {
        let mut checked = 0u32;
        for kind in crate::can::Kind::ALL {
            for sd in kind.signals() {
                let s = &sd.signal;
                if s.scale != Scale::Real {
                    continue;
                }
                for raw in s.raw_min..=s.raw_max {
                    let raw = i32::try_from(raw).unwrap();
                    let expect = f64::from(raw) * s.factor;
                    assert_eq!(times_factor(raw, s.factor).to_bits(), expect.to_bits(), "{} raw {raw}", sd.name);
                    checked += 1;
                }
            }
        }
        assert!(checked > 400_000, "only {checked} values checked");
    }

    proptest::proptest! {
        /// Any raw value, any factor in the domain (normal, products
        /// normal): the same bits as the multiplication, ties included.
        /// The factor's mantissa is cut so the exact product is about
        /// `53 + extra_bits` bits long: with few extra bits, exact halves
        /// (ties) are common.
        #[test]
        fn integer_products_equal_the_float_multiplication(
            raw: i32,
            exponent in 1u64..=2014,
            mantissa: u64,
            extra_bits in 0u32..=34,
        ) {
            let raw_bits = 32 - raw.unsigned_abs().leading_zeros();
            let trailing_zeros = raw_bits.saturating_sub(extra_bits).min(52);
            let mantissa = mantissa & ((1 << 52) - 1) & (u64::MAX << trailing_zeros);
            let factor = f64::from_bits(exponent << 52 | mantissa);
            let expect = f64::from(raw) * factor;
            proptest::prop_assert_eq!(times_factor(raw, factor).to_bits(), expect.to_bits(), "{} * {:e}", raw, factor);
        }
    }
}

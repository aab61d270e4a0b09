//! Controller time in whole microseconds.
//!
//! Every timer (staleness, recovery, dwell, valve intervals) counts integer
//! microseconds: exact, cheap on the ECU, and free of the drift a
//! floating-point sum of step sizes has. Each step advances the clock by
//! `dt_s` rounded to the nearest microsecond.

/// Smallest step size the controller accepts, s (one clock tick).
pub const MIN_DT_S: f64 = 1.0e-6;

/// The step size in microseconds, or `None` when `dt_s` is not finite,
/// below [`MIN_DT_S`] or above `dt_max_s`.
pub fn dt_us(dt_s: f64, dt_max_s: f64) -> Option<u32> {
    if dt_s.is_finite() && dt_s >= MIN_DT_S && dt_s <= dt_max_s {
        Some(seconds_to_us(dt_s))
    } else {
        None
    }
}

/// A duration in seconds as whole microseconds (rounded to nearest,
/// saturating; NaN and negative durations become 0).
pub fn seconds_to_us(s: f64) -> u32 {
    // `as` saturates and maps NaN to 0.
    (s * 1.0e6 + 0.5) as u32
}

/// A duration in microseconds as seconds, for the filters (single precision).
pub fn us_to_seconds(us: u32) -> f32 {
    us as f32 * 1.0e-6
}

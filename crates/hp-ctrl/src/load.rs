//! The static load pressure: the zero-offset reference of the ride height.
//!
//! At rest the gas carries the load, `p_S A = m g`, whatever valve 6 does,
//! and with valve 6 open L's gas sits at that same pressure. So the state
//! valve 6 would leave at rest in soft mode is "L's gas at the load
//! pressure", and the ride-height sequencer works relative to it (see
//! [`crate::ride_height`]). The load pressure is not a constant of the
//! unit: it changes with the payload, and the configured static pressure
//! is only the nominal one. It is estimated on line as a slow low-pass of
//! the measured `p_S`.
//!
//! - Only calm, valid periods update it: not in the safe state, pressures
//!   usable, and no manoeuvre that pauses sequencing (the load transfer of
//!   cornering or braking is not the static load).
//! - Before the first calm sample it is the configured static pressure.
//!   Until it has averaged `ride_height.load_pressure_tau_s` (20 s) of
//!   calm periods it is the running mean of all of them, so the first
//!   samples are not weighted against a guessed start value; after that
//!   it is a first-order low-pass with that time constant. Sequencing
//!   waits until it has averaged `ride_height.load_settle_s` (5 s), see
//!   [`crate::ride_height`].
//! - The mean of `p_S` over road input is the load pressure less the mean
//!   pressure drop of the damper (an asymmetric damper "jacks" the strut):
//!   that is exactly the mean pressure at which valve 6, open, would leave
//!   L's gas on that road, so it is the right reference there too.
//!
//! Numerics: the averaged time counts whole microseconds like every
//! timer; the estimate is kept in `f32` as the deviation from the
//! configured static pressure, so that the small increments of a long time
//! constant (5e-5 of the error per 1 ms period at 20 s) are not lost to
//! rounding at 15 MPa: near a 3 MPa deviation one `f32` step is 0.25 Pa,
//! so the estimate settles within 5 kPa (0.1 mm of ride height) of a
//! constant pressure.

use crate::clock::seconds_to_us;

/// The load-pressure estimator compiled for the step.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LoadParams {
    /// The configured static pressure: start value and offset of the state.
    static_pressure_pa: f32,
    tau_us: u32,
}

impl LoadParams {
    /// `tau_s` is `ride_height.load_pressure_tau_s`, `static_pressure_pa`
    /// the unit's configured static pressure.
    pub fn new(tau_s: f64, static_pressure_pa: f64) -> Self {
        LoadParams { static_pressure_pa: static_pressure_pa as f32, tau_us: seconds_to_us(tau_s) }
    }
}

/// The estimate.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct LoadState {
    /// Estimate minus the configured static pressure, Pa.
    deviation_pa: f32,
    /// Calm time averaged so far, us (stops growing at the time constant).
    averaged_us: u32,
}

impl LoadState {
    /// No sample yet: the configured static pressure.
    pub const fn new() -> Self {
        LoadState { deviation_pa: 0.0, averaged_us: 0 }
    }

    /// The estimated load pressure, Pa.
    pub fn pressure_pa(&self, p: &LoadParams) -> f32 {
        p.static_pressure_pa + self.deviation_pa
    }

    /// Calm time the estimate has averaged, us, up to the time constant.
    pub fn averaged_us(&self) -> u32 {
        self.averaged_us
    }
}

/// Updates the estimate with `p_small_pa` when it is `Some` (a calm, valid
/// period of `dt_us` microseconds) and returns the estimate, Pa.
///
/// ```
/// use hp_ctrl::load::{self, LoadParams, LoadState};
/// let p = LoadParams::new(20.0, 15.0e6);
/// let mut s = LoadState::new();
/// assert_eq!(load::step(&p, &mut s, None, 1000), 15.0e6);
/// // The first calm samples are averaged with equal weights.
/// load::step(&p, &mut s, Some(16.0e6), 1000);
/// let estimate = load::step(&p, &mut s, Some(17.0e6), 1000);
/// assert!((estimate - 16.5e6).abs() < 1.0);
/// ```
pub fn step(p: &LoadParams, s: &mut LoadState, p_small_pa: Option<f32>, dt_us: u32) -> f32 {
    if let Some(p_small_pa) = p_small_pa {
        if dt_us > 0 {
            s.averaged_us = s.averaged_us.saturating_add(dt_us).min(p.tau_us.max(dt_us));
            // Running mean while young, then the low-pass: the weight of
            // the new sample is dt over the averaged time (at most 1).
            let weight = dt_us as f32 / s.averaged_us as f32;
            let deviation_pa = p_small_pa - p.static_pressure_pa;
            s.deviation_pa += weight * (deviation_pa - s.deviation_pa);
        }
    }
    s.pressure_pa(p)
}

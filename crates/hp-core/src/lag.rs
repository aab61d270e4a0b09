//! A first-order lag, `tau dy/dt = x - y`: what a transducer of time
//! constant `tau` reports of the quantity `x` it measures.
//!
//! One block, two uses: inside an ODE (the unit's lagging sensors, the
//! virtual rig's truth) it is a state with [`rate`]; on a sampled signal
//! (the fit, which lags its simulated outputs instead, so a record hours
//! long is not integrated at the lag's time scale) it is the exact
//! discrete filter [`step`], which assumes the input linear between
//! samples (first-order hold). For an input that is linear between the
//! samples both give the same output; otherwise the filter's error is of
//! the order of the input's curvature times `h^2 / 8` (`h` the sample
//! spacing), attenuated by the lag.
//!
//! ```
//! use hp_core::lag::{step, Lag, LagSample, LagState};
//! // A ramp x = 2 t from rest: exactly y(t) = 2 (t - tau (1 - e^(-t/tau))).
//! let lag = Lag { time_constant_s: 0.01 };
//! let mut state = LagState::settled(0.0);
//! let (mut t, mut x) = (0.0_f64, 0.0);
//! for dt_s in [0.004, 0.001, 0.02, 0.007] {
//!     let x_next = 2.0 * (t + dt_s);
//!     step(&lag, &mut state, &LagSample { input_prev: x, input: x_next, dt_s });
//!     t += dt_s;
//!     x = x_next;
//! }
//! let exact = 2.0 * (t - 0.01 * (1.0 - (-t / 0.01_f64).exp()));
//! assert!((state.output - exact).abs() < 1e-15);
//! ```

use crate::ranges::Range;

/// The valid range of a transducer lag's time constant (the unit's sensor
/// effect and the fit's filter of sampled outputs check the same one).
pub const TIME_CONSTANT_S: Range = Range::new("sensor_time_constant_s", 0.0, 10.0);

/// The lag's parameter.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Lag {
    /// Time constant, s (0 = no lag: the output is the input).
    pub time_constant_s: f64,
}

/// The lag's state: its output.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LagState {
    /// What the lag reports, in the input's unit.
    pub output: f64,
}

impl LagState {
    /// Settled on a constant input `input` (the state at rest).
    pub fn settled(input: f64) -> Self {
        LagState { output: input }
    }
}

/// One sample of the input: its previous and its new value, `dt_s` apart.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LagSample {
    /// The input at the previous sample.
    pub input_prev: f64,
    /// The input at this sample.
    pub input: f64,
    /// Time since the previous sample, s.
    pub dt_s: f64,
}

/// The continuous form: `dy/dt` of the output for the input `input` now.
/// A lag without time constant has no state (0).
///
/// ```
/// use hp_core::lag::{rate, Lag, LagState};
/// let r = rate(&Lag { time_constant_s: 0.5 }, &LagState { output: 1.0 }, 2.0);
/// assert_eq!(r, 2.0);
/// ```
pub fn rate(lag: &Lag, state: &LagState, input: f64) -> f64 {
    if lag.time_constant_s > 0.0 {
        (input - state.output) / lag.time_constant_s
    } else {
        0.0
    }
}

/// The exact discrete form: advances the state over one sample interval,
/// the input linear in between (first-order hold), and returns the new
/// output. With the error `e = y - x` and the input's slope `m`,
/// `de/dt = -e/tau - m`, so `e1 = a e0 - m tau (1 - a)`, `a = e^(-h/tau)`.
/// No time constant: the output is the input. A non-positive or non-finite
/// `dt_s` leaves the state as it is (no time has passed).
pub fn step(lag: &Lag, state: &mut LagState, sample: &LagSample) -> f64 {
    let tau = lag.time_constant_s;
    let h = sample.dt_s;
    if !(tau > 0.0) {
        state.output = sample.input;
    } else if h > 0.0 && h.is_finite() {
        let r = h / tau;
        let decay = libm::exp(-r);
        // (1 - a) / r without cancellation for short samples (the series'
        // first omitted term, r^5 / 720, is below the rounding there).
        let ramp = if r > 1e-3 { -libm::expm1(-r) / r } else { 1.0 - r / 2.0 + r * r / 6.0 - r * r * r / 24.0 + r * r * r * r / 120.0 };
        let error = decay * (state.output - sample.input_prev) - (sample.input - sample.input_prev) * ramp;
        state.output = sample.input + error;
    }
    state.output
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_step_input_decays_exponentially() {
        // A constant input the lag has not followed yet: pure decay.
        let lag = Lag { time_constant_s: 0.1 };
        let mut s = LagState::settled(0.0);
        step(&lag, &mut s, &LagSample { input_prev: 1.0, input: 1.0, dt_s: 0.05 });
        assert!((s.output - (1.0 - libm::exp(-0.5))).abs() < 1e-15);
    }

    #[test]
    fn the_ramp_series_is_continuous_at_the_switch() {
        // Both branches of the ramp factor agree where they meet.
        let lag = Lag { time_constant_s: 1.0 };
        let run = |h: f64| {
            let mut s = LagState::settled(0.0);
            step(&lag, &mut s, &LagSample { input_prev: 0.0, input: h, dt_s: h })
        };
        let below = run(1e-3 * (1.0 - 1e-9));
        let above = run(1e-3 * (1.0 + 1e-9));
        let exact = |h: f64| h + libm::expm1(-h);
        assert!((below - exact(1e-3 * (1.0 - 1e-9))).abs() < 1e-18);
        assert!((above - exact(1e-3 * (1.0 + 1e-9))).abs() < 1e-18);
    }

    #[test]
    fn a_sine_reaches_the_analytic_steady_state() {
        // Amplitude 1/sqrt(1 + (w tau)^2), phase -atan(w tau). 500 samples
        // per period: the first-order hold's error is of the order of
        // (w h)^2 / 8 = 2e-5 of the amplitude.
        let (tau, w, h) = (0.01, core::f64::consts::TAU, 1.0 / 500.0);
        let lag = Lag { time_constant_s: tau };
        let mut s = LagState::settled(0.0);
        let mut worst: f64 = 0.0;
        for i in 1..2500 {
            let (t0, t1) = ((i - 1) as f64 * h, i as f64 * h);
            let y = step(&lag, &mut s, &LagSample { input_prev: libm::sin(w * t0), input: libm::sin(w * t1), dt_s: h });
            if i >= 2000 {
                let reference = libm::sin(w * t1 - libm::atan(w * tau)) / libm::sqrt(1.0 + (w * tau) * (w * tau));
                worst = worst.max((y - reference).abs());
            }
        }
        assert!(worst < 2e-5, "{worst}");
    }

    #[test]
    fn no_time_constant_passes_the_input_and_no_time_changes_nothing() {
        let mut s = LagState::settled(3.0);
        assert_eq!(step(&Lag { time_constant_s: 0.0 }, &mut s, &LagSample { input_prev: 3.0, input: 5.0, dt_s: 0.1 }), 5.0);
        let lag = Lag { time_constant_s: 0.1 };
        assert_eq!(step(&lag, &mut s, &LagSample { input_prev: 5.0, input: 9.0, dt_s: 0.0 }), 5.0);
        assert_eq!(step(&lag, &mut s, &LagSample { input_prev: 5.0, input: 9.0, dt_s: f64::NAN }), 5.0);
        assert_eq!(rate(&Lag { time_constant_s: 0.0 }, &s, 9.0), 0.0);
    }
}

//! Fixed-step classical Runge-Kutta (RK4) on a fixed-size state.
//!
//! No allocation: the state is a `[f64; N]`, the caller picks the step.

use crate::error::{check_range, Error, Result};

/// A first-order ODE system `dy/dt = f(t, y)` with `N` states.
pub trait OdeSystem<const N: usize> {
    /// The derivative of `y` at time `t_s`. Fails if `y` left the region
    /// where the model is defined.
    fn derivatives(&self, t_s: f64, y: &[f64; N]) -> Result<[f64; N]>;
}

fn add_scaled<const N: usize>(y: &[f64; N], h: f64, k: &[f64; N]) -> [f64; N] {
    let mut out = *y;
    for (o, dk) in out.iter_mut().zip(k) {
        *o += h * dk;
    }
    out
}

/// One classical RK4 step of size `dt_s` from `(t_s, y)`.
///
/// ```
/// use hp_core::ode::{rk4_step, OdeSystem};
/// struct Decay;
/// impl OdeSystem<1> for Decay {
///     fn derivatives(&self, _t: f64, y: &[f64; 1]) -> hp_core::Result<[f64; 1]> { Ok([-y[0]]) }
/// }
/// let y = rk4_step(&Decay, 0.0, &[1.0], 0.1).unwrap();
/// assert!((y[0] - (-0.1f64).exp()).abs() < 1e-7);
/// ```
pub fn rk4_step<const N: usize, S: OdeSystem<N> + ?Sized>(
    system: &S,
    t_s: f64,
    y: &[f64; N],
    dt_s: f64,
) -> Result<[f64; N]> {
    let k1 = system.derivatives(t_s, y)?;
    rk4_step_from(system, t_s, y, dt_s, &k1)
}

/// [`rk4_step`] with the first stage `k1 = f(t, y)` already known (the
/// caller evaluated it anyway, e.g. to report outputs at `t`).
pub fn rk4_step_from<const N: usize, S: OdeSystem<N> + ?Sized>(
    system: &S,
    t_s: f64,
    y: &[f64; N],
    dt_s: f64,
    k1: &[f64; N],
) -> Result<[f64; N]> {
    let half = 0.5 * dt_s;
    let k2 = system.derivatives(t_s + half, &add_scaled(y, half, k1))?;
    let k3 = system.derivatives(t_s + half, &add_scaled(y, half, &k2))?;
    let k4 = system.derivatives(t_s + dt_s, &add_scaled(y, dt_s, &k3))?;
    let mut out = *y;
    for ((((o, a), b), c), d) in out.iter_mut().zip(k1).zip(&k2).zip(&k3).zip(&k4) {
        *o += dt_s / 6.0 * (a + 2.0 * b + 2.0 * c + d);
    }
    Ok(out)
}

/// Largest number of steps between two instants (output samples, control
/// periods).
pub const MAX_SUBSTEPS: f64 = 1.0e7;

/// How much longer than the largest step a step may be, relative: what the
/// rounding of the instants adds. `(k + 1) dt - k dt` is a few ulps above
/// `dt` for most `k`, and taking the ceiling of the ratio without this
/// allowance split such periods into two half steps (96 % of the 8x8's
/// 1 ms periods: twice the work, and not the step anyone asked for).
const STEP_ROUNDING: f64 = 1e-9;

/// The number of equal steps from `t_s` to `t_end_s` none of which is
/// longer than `max_dt_s` (give or take a relative 1e-9, the instants'
/// rounding), and their length: the one step count every fixed-step
/// integration between two instants uses (the rigs, the vehicles, the
/// bindings' plants).
///
/// ```
/// use hp_core::ode::steps;
/// assert_eq!(steps(0.0, 4e-3, 1e-3).unwrap(), (4, 1e-3));
/// let (k, dt) = (7.0, 1e-3);
/// let (n, h) = steps(k * dt, (k + 1.0) * dt, dt).unwrap(); // 0.0010000000000000009 s
/// assert_eq!(n, 1);
/// assert!((h - dt).abs() < 1e-15);
/// assert_eq!(steps(0.0, 1.0001e-3, 1e-3).unwrap().0, 2);
/// assert!(steps(1.0, 1.0, 1e-3).is_err());
/// ```
pub fn steps(t_s: f64, t_end_s: f64, max_dt_s: f64) -> Result<(u64, f64)> {
    check_range("max_dt_s", max_dt_s, 1e-9, 10.0)?;
    let span = t_end_s - t_s;
    let n = libm::ceil(span / max_dt_s * (1.0 - STEP_ROUNDING));
    if !(1.0..=MAX_SUBSTEPS).contains(&n) {
        return Err(Error::OutOfRange { name: "t_end_s - t_s", value: span, min: 0.0, max: max_dt_s * MAX_SUBSTEPS });
    }
    Ok((n as u64, span / n))
}

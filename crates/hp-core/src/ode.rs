//! Fixed-step classical Runge-Kutta (RK4) on a fixed-size state.
//!
//! No allocation: the state is a `[f64; N]`, the caller picks the step.

use crate::error::Result;

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

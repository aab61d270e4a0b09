//! Advancing a system between two control instants in equal RK4 steps
//! (hp-core's integrator), with a projection and check after every step.

use hp_core::error::Result;
use hp_core::ode::{rk4_step, rk4_step_from, steps, OdeSystem};

/// Advances `y` from `t_s` to `t_end_s` in equal RK4 steps of at most
/// `max_dt_s` ([`hp_core::ode::steps`]). `k1` is the rate at `(t_s, y)` (the caller evaluated it for
/// its sample; it is the first stage of the first step). After each step
/// `finish(t, &mut y)` projects the state onto its constraints and checks it.
pub fn advance<const N: usize, S: OdeSystem<N>>(
    system: &S,
    t_s: f64,
    t_end_s: f64,
    y: &[f64; N],
    k1: &[f64; N],
    max_dt_s: f64,
    mut finish: impl FnMut(f64, &mut [f64; N]) -> Result<()>,
) -> Result<[f64; N]> {
    let (n, h) = steps(t_s, t_end_s, max_dt_s)?;
    let mut next = rk4_step_from(system, t_s, y, h, k1)?;
    finish(t_s + h, &mut next)?;
    for k in 1..n {
        let t = t_s + h * k as f64;
        next = rk4_step(system, t, &next, h)?;
        finish(t + h, &mut next)?;
    }
    Ok(next)
}

//! Advancing a system between two control instants in equal RK4 steps
//! (hp-core's integrator), with a projection and check after every step.

use hp_core::error::{check_range, Error, Result};
use hp_core::ode::{rk4_step, rk4_step_from, OdeSystem};
use hp_core::rig::MAX_SUBSTEPS;

/// Advances `y` from `t_s` to `t_end_s` in equal RK4 steps of at most
/// `max_dt_s`. `k1` is the rate at `(t_s, y)` (the caller evaluated it for
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
    check_range("max_dt_s", max_dt_s, 1e-9, 10.0)?;
    let span = t_end_s - t_s;
    let n = libm::ceil(span / max_dt_s);
    if !(1.0..=MAX_SUBSTEPS).contains(&n) {
        return Err(Error::OutOfRange { name: "dt_s", value: span, min: max_dt_s / MAX_SUBSTEPS, max: max_dt_s * MAX_SUBSTEPS });
    }
    let h = span / n;
    let mut next = rk4_step_from(system, t_s, y, h, k1)?;
    finish(t_s + h, &mut next)?;
    for k in 1..(n as u64) {
        let t = t_s + h * k as f64;
        next = rk4_step(system, t, &next, h)?;
        finish(t + h, &mut next)?;
    }
    Ok(next)
}

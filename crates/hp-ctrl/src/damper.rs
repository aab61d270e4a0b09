//! Valve 5: the two-state damper under on-off skyhook.
//!
//! On-off skyhook (Karnopp): high damping when the damper force would push
//! the body against its own velocity, i.e. when the body velocity and the
//! extension rate have the same sign, `v_body * (-v_strut) > 0` (strut
//! velocity positive in compression); low damping otherwise. Chosen over
//! the mixed skyhook/acceleration-driven law because its benefit is at the
//! body mode (about 1 Hz soft), where a one-strut unit's comfort is
//! decided, while the acceleration-driven part earns its keep above it by
//! switching at wheel-hop rates, which a valve with a 10-20 ms response
//! cannot follow. A deadband on the product keeps sensor noise at rest from
//! toggling the law, and the valve changes at most once per
//! `valve5_min_interval_s` (about its response time; faster switching only
//! heats the coil).
//!
//! Handling mode and the safe state force high damping (valve 5 closed) at
//! once, bypassing the interval. So *valve 5 never opens sooner than
//! `valve5_min_interval_s` after its last change*.

use crate::clock::seconds_to_us;
use crate::config::{check, ParamError};
use crate::DamperMode;

/// Skyhook tuning.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DamperConfig {
    /// Deadband on `-v_body * v_strut`, m^2/s^2.
    pub skyhook_deadband_m2_s2: f64,
    /// Minimum time between valve-5 changes made by the skyhook law, s.
    pub valve5_min_interval_s: f64,
}

impl Default for DamperConfig {
    fn default() -> Self {
        // 1e-4 m^2/s^2 = 1 cm/s body velocity against 1 cm/s strut velocity.
        DamperConfig { skyhook_deadband_m2_s2: 1.0e-4, valve5_min_interval_s: 0.02 }
    }
}

impl DamperConfig {
    pub(crate) fn validate(&self) -> Result<(), ParamError> {
        check("damper.skyhook_deadband_m2_s2", self.skyhook_deadband_m2_s2, 0.0, 1.0)?;
        check("damper.valve5_min_interval_s", self.valve5_min_interval_s, 0.0, 1.0)
    }
}

/// [`DamperConfig`] compiled for the step.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DamperParams {
    pub(crate) deadband_m2_s2: f32,
    pub(crate) min_interval_us: u32,
}

impl DamperParams {
    pub(crate) fn new(c: &DamperConfig) -> Self {
        DamperParams {
            deadband_m2_s2: c.skyhook_deadband_m2_s2 as f32,
            min_interval_us: seconds_to_us(c.valve5_min_interval_s),
        }
    }
}

/// Valve-5 state.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DamperState {
    open: bool,
    /// Time since valve 5 last changed, us.
    since_change_us: u32,
    /// What the skyhook law wants, with its deadband.
    skyhook_high: bool,
}

impl DamperState {
    /// Power-on: closed (high damping).
    pub const fn new() -> Self {
        DamperState { open: false, since_change_us: 0, skyhook_high: true }
    }
}

impl Default for DamperState {
    fn default() -> Self {
        Self::new()
    }
}

/// Commands valve 5 from the velocity estimates; `force_high` (Handling or
/// the safe state) closes it at once.
pub fn step(
    p: &DamperParams,
    s: &mut DamperState,
    body_vel_m_s: f32,
    strut_vel_m_s: f32,
    force_high: bool,
    dt_us: u32,
) -> DamperMode {
    s.since_change_us = s.since_change_us.saturating_add(dt_us);
    let against_body = -body_vel_m_s * strut_vel_m_s;
    if against_body > p.deadband_m2_s2 {
        s.skyhook_high = true;
    } else if against_body < -p.deadband_m2_s2 {
        s.skyhook_high = false;
    }
    let want_open = !force_high && !s.skyhook_high;
    if want_open != s.open && (force_high || s.since_change_us >= p.min_interval_us) {
        s.open = want_open;
        s.since_change_us = 0;
    }
    if s.open {
        DamperMode::Low
    } else {
        DamperMode::High
    }
}

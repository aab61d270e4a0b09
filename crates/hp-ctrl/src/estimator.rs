//! Velocity estimates for the skyhook law.
//!
//! - Strut velocity from the measured displacement: a filtered derivative
//!   `v = s / (1 + tau s) x`, which passes the body and wheel modes and
//!   rolls the differentiated sensor noise off above `1 / (2 pi tau)`.
//! - Body velocity from the measured body acceleration: a leaky integrator
//!   `v = tau s / (1 + tau s) (a / s)`, a high-pass at `1 / (2 pi tau)` so a
//!   small accelerometer offset cannot wind the velocity up; a slow tracker
//!   removes the offset itself before integration.
//!
//! Both restart from rest when their input returns after being unusable.

use crate::config::{check, ParamError};

/// Filter time constants.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct EstimatorConfig {
    /// Time constant of the strut-velocity filter, s (16 Hz corner at 10 ms).
    pub strut_velocity_tau_s: f64,
    /// Time constant of the body-velocity leaky integrator, s.
    pub body_velocity_tau_s: f64,
    /// Time constant of the accelerometer-offset tracker, s.
    pub body_acc_bias_tau_s: f64,
}

impl Default for EstimatorConfig {
    fn default() -> Self {
        // The body mode is near 1 Hz: a 0.16 Hz high-pass (tau = 1 s) adds
        // 9 degrees of phase lead there; the offset tracker is ten times slower.
        EstimatorConfig { strut_velocity_tau_s: 0.01, body_velocity_tau_s: 1.0, body_acc_bias_tau_s: 10.0 }
    }
}

impl EstimatorConfig {
    /// The filters are integrated with the step size, so each time constant
    /// must be at least the largest step.
    pub(crate) fn validate(&self, dt_max_s: f64) -> Result<(), ParamError> {
        check("estimator.strut_velocity_tau_s", self.strut_velocity_tau_s, dt_max_s, 1.0)?;
        check("estimator.body_velocity_tau_s", self.body_velocity_tau_s, dt_max_s, 100.0)?;
        check("estimator.body_acc_bias_tau_s", self.body_acc_bias_tau_s, dt_max_s, 1.0e4)
    }
}

/// [`EstimatorConfig`] compiled for the step.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct EstimatorParams {
    pub(crate) inv_strut_tau_per_s: f32,
    pub(crate) inv_body_tau_per_s: f32,
    pub(crate) inv_bias_tau_per_s: f32,
}

impl EstimatorParams {
    pub(crate) fn new(c: &EstimatorConfig) -> Self {
        EstimatorParams {
            inv_strut_tau_per_s: (1.0 / c.strut_velocity_tau_s) as f32,
            inv_body_tau_per_s: (1.0 / c.body_velocity_tau_s) as f32,
            inv_bias_tau_per_s: (1.0 / c.body_acc_bias_tau_s) as f32,
        }
    }
}

/// The filter states.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct EstimatorState {
    /// Low-passed displacement, m (`None`: restart on the next sample).
    disp_filtered_m: Option<f32>,
    strut_vel_m_s: f32,
    /// Tracked accelerometer offset, m/s^2 (`None`: restart).
    acc_offset_m_s2: Option<f32>,
    body_vel_m_s: f32,
}

impl EstimatorState {
    pub const fn new() -> Self {
        EstimatorState { disp_filtered_m: None, strut_vel_m_s: 0.0, acc_offset_m_s2: None, body_vel_m_s: 0.0 }
    }

    /// Estimated strut compression rate, m/s.
    pub fn strut_vel_m_s(&self) -> f32 {
        self.strut_vel_m_s
    }

    /// Estimated body vertical velocity, m/s.
    pub fn body_vel_m_s(&self) -> f32 {
        self.body_vel_m_s
    }

    /// The tracked accelerometer offset, m/s^2 (0 before the first sample).
    pub fn body_acc_offset_m_s2(&self) -> f32 {
        self.acc_offset_m_s2.unwrap_or(0.0)
    }
}

/// Advances both estimates by `dt_s`; `None` marks an unusable input.
pub fn step(p: &EstimatorParams, s: &mut EstimatorState, disp_m: Option<f32>, body_acc_m_s2: Option<f32>, dt_s: f32) {
    match (disp_m, s.disp_filtered_m) {
        (Some(x), Some(x_f)) => {
            s.strut_vel_m_s = (x - x_f) * p.inv_strut_tau_per_s;
            let k = (dt_s * p.inv_strut_tau_per_s).min(1.0);
            s.disp_filtered_m = Some(x_f + k * (x - x_f));
        }
        (x, _) => {
            s.disp_filtered_m = x;
            s.strut_vel_m_s = 0.0;
        }
    }
    match (body_acc_m_s2, s.acc_offset_m_s2) {
        (Some(a), Some(offset)) => {
            let a_hp = a - offset;
            s.body_vel_m_s += dt_s * (a_hp - s.body_vel_m_s * p.inv_body_tau_per_s);
            let k = (dt_s * p.inv_bias_tau_per_s).min(1.0);
            s.acc_offset_m_s2 = Some(offset + k * a_hp);
        }
        (a, _) => {
            s.acc_offset_m_s2 = a;
            s.body_vel_m_s = 0.0;
        }
    }
}

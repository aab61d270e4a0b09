//! Ride/handling mode selection.
//!
//! Handling (hard spring, high damping) is entered in the period any
//! trigger fires, as production switchable hydro-pneumatic suspensions firm
//! up within about 0.05 s: stiffness is what keeps the body flat and the
//! wheels loaded, so it must not wait. Ride is re-entered only after no
//! trigger has fired for `handling_hold_s`. Each trigger latches with
//! hysteresis (an entry and a lower exit threshold), so the triggers
//! themselves do not chatter, and the hold bounds the mode to at most one
//! ride-handling-ride cycle per hold time. Hence the property the tests
//! check: *the mode never returns to Ride sooner than `handling_hold_s`
//! after it entered Handling, nor after the last period any trigger fired*.
//!
//! Triggers: lateral acceleration (the larger of the measured one and the
//! one the steering predicts, `v^2 delta / (i_s L)`, which leads it by the
//! tyre lag), steering-wheel rate above a minimum speed, longitudinal
//! acceleration (braking or accelerating), the brake pedal above a minimum
//! speed, and vehicle speed. The driver's Sport forces Handling; Comfort
//! keeps Ride except for the body-motion safety triggers (lateral and
//! longitudinal acceleration). The safe state forces Handling and restarts
//! the hold.

use crate::clock::seconds_to_us;
use crate::config::{check, check_below, ParamError};
use crate::diag;
use crate::{DriveMode, DriverMode};

/// Trigger thresholds and the hold time.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ModeConfig {
    /// Lateral acceleration that enters Handling, m/s^2.
    pub lat_acc_enter_m_s2: f64,
    /// Lateral acceleration below which the lateral trigger clears, m/s^2.
    pub lat_acc_exit_m_s2: f64,
    /// Steering-wheel angle per road-wheel angle.
    pub steering_ratio: f64,
    /// Wheelbase, m.
    pub wheelbase_m: f64,
    /// Steering-wheel rate that enters Handling, rad/s.
    pub steer_rate_enter_rad_s: f64,
    /// Steering-wheel rate below which the steering trigger clears, rad/s.
    pub steer_rate_exit_rad_s: f64,
    /// Speed below which steering rate does not trigger (manoeuvring), m/s.
    pub steer_min_speed_m_s: f64,
    /// Longitudinal acceleration magnitude that enters Handling, m/s^2.
    pub long_acc_enter_m_s2: f64,
    /// Longitudinal acceleration magnitude below which it clears, m/s^2.
    pub long_acc_exit_m_s2: f64,
    /// Speed above which the brake pedal triggers Handling, m/s.
    pub brake_min_speed_m_s: f64,
    /// Speed that enters Handling, m/s.
    pub speed_enter_m_s: f64,
    /// Speed below which the speed trigger clears, m/s.
    pub speed_exit_m_s: f64,
    /// Minimum time in Handling after the last trigger, s.
    pub handling_hold_s: f64,
}

impl Default for ModeConfig {
    fn default() -> Self {
        ModeConfig {
            lat_acc_enter_m_s2: 2.5,
            lat_acc_exit_m_s2: 1.5,
            steering_ratio: 18.0,
            wheelbase_m: 3.5,
            steer_rate_enter_rad_s: 2.0,
            steer_rate_exit_rad_s: 1.0,
            steer_min_speed_m_s: 8.0,
            long_acc_enter_m_s2: 2.5,
            long_acc_exit_m_s2: 1.5,
            brake_min_speed_m_s: 8.0,
            speed_enter_m_s: 33.3,
            speed_exit_m_s: 30.6,
            handling_hold_s: 2.0,
        }
    }
}

impl ModeConfig {
    pub(crate) fn validate(&self) -> Result<(), ParamError> {
        check("mode.lat_acc_enter_m_s2", self.lat_acc_enter_m_s2, 0.1, 30.0)?;
        check("mode.lat_acc_exit_m_s2", self.lat_acc_exit_m_s2, 0.0, 30.0)?;
        check_below("mode.lat_acc_exit_m_s2", self.lat_acc_exit_m_s2, "mode.lat_acc_enter_m_s2", self.lat_acc_enter_m_s2)?;
        check("mode.steering_ratio", self.steering_ratio, 1.0, 100.0)?;
        check("mode.wheelbase_m", self.wheelbase_m, 0.5, 20.0)?;
        check("mode.steer_rate_enter_rad_s", self.steer_rate_enter_rad_s, 0.1, 30.0)?;
        check("mode.steer_rate_exit_rad_s", self.steer_rate_exit_rad_s, 0.0, 30.0)?;
        check_below(
            "mode.steer_rate_exit_rad_s",
            self.steer_rate_exit_rad_s,
            "mode.steer_rate_enter_rad_s",
            self.steer_rate_enter_rad_s,
        )?;
        check("mode.steer_min_speed_m_s", self.steer_min_speed_m_s, 0.0, 80.0)?;
        check("mode.long_acc_enter_m_s2", self.long_acc_enter_m_s2, 0.1, 30.0)?;
        check("mode.long_acc_exit_m_s2", self.long_acc_exit_m_s2, 0.0, 30.0)?;
        check_below(
            "mode.long_acc_exit_m_s2",
            self.long_acc_exit_m_s2,
            "mode.long_acc_enter_m_s2",
            self.long_acc_enter_m_s2,
        )?;
        check("mode.brake_min_speed_m_s", self.brake_min_speed_m_s, 0.0, 80.0)?;
        check("mode.speed_enter_m_s", self.speed_enter_m_s, 1.0, 200.0)?;
        check("mode.speed_exit_m_s", self.speed_exit_m_s, 0.0, 200.0)?;
        check_below("mode.speed_exit_m_s", self.speed_exit_m_s, "mode.speed_enter_m_s", self.speed_enter_m_s)?;
        check("mode.handling_hold_s", self.handling_hold_s, 0.0, 60.0)
    }
}

/// [`ModeConfig`] compiled for the step.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ModeParams {
    pub(crate) lat_acc_m_s2: (f32, f32),
    /// `1 / (i_s L)`, 1/m: lateral acceleration per `v^2 delta_wheel`.
    pub(crate) lat_acc_per_v2_rad: f32,
    pub(crate) steer_rate_rad_s: (f32, f32),
    pub(crate) steer_min_speed_m_s: f32,
    pub(crate) long_acc_m_s2: (f32, f32),
    pub(crate) brake_min_speed_m_s: f32,
    pub(crate) speed_m_s: (f32, f32),
    pub(crate) hold_us: u32,
}

impl ModeParams {
    pub(crate) fn new(c: &ModeConfig) -> Self {
        ModeParams {
            lat_acc_m_s2: (c.lat_acc_enter_m_s2 as f32, c.lat_acc_exit_m_s2 as f32),
            lat_acc_per_v2_rad: (1.0 / (c.steering_ratio * c.wheelbase_m)) as f32,
            steer_rate_rad_s: (c.steer_rate_enter_rad_s as f32, c.steer_rate_exit_rad_s as f32),
            steer_min_speed_m_s: c.steer_min_speed_m_s as f32,
            long_acc_m_s2: (c.long_acc_enter_m_s2 as f32, c.long_acc_exit_m_s2 as f32),
            brake_min_speed_m_s: c.brake_min_speed_m_s as f32,
            speed_m_s: (c.speed_enter_m_s as f32, c.speed_exit_m_s as f32),
            hold_us: seconds_to_us(c.handling_hold_s),
        }
    }
}

/// What mode selection measures (single precision).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct ModeInputs {
    pub speed_m_s: f32,
    pub lat_acc_m_s2: f32,
    pub long_acc_m_s2: f32,
    pub steer_angle_rad: f32,
    pub steer_rate_rad_s: f32,
    pub brake_pressed: bool,
}

/// Mode selection state.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ModeState {
    handling: bool,
    /// Time since a trigger last fired, us.
    quiet_us: u32,
    /// Latched triggers ([`diag`] trigger bits).
    latched: u32,
}

impl ModeState {
    /// Power-on: Handling (the safe state's mode).
    pub const fn new() -> Self {
        ModeState { handling: true, quiet_us: 0, latched: 0 }
    }
}

impl Default for ModeState {
    fn default() -> Self {
        Self::new()
    }
}

/// Sets `flag` in `bits` when `enter`, clears it when `exit`.
fn latch(bits: u32, flag: u32, enter: bool, exit: bool) -> u32 {
    if enter {
        bits | flag
    } else if exit {
        bits & !flag
    } else {
        bits
    }
}

/// Selects the mode; returns it with the [`diag`] trigger flags.
pub fn step(
    p: &ModeParams,
    s: &mut ModeState,
    m: &ModeInputs,
    driver: DriverMode,
    safe: bool,
    dt_us: u32,
) -> (DriveMode, u32) {
    if safe {
        // The inputs may be garbage: leave the latches alone.
        *s = ModeState { handling: true, quiet_us: 0, latched: s.latched };
        return (DriveMode::Handling, 0);
    }
    let speed = m.speed_m_s.abs();
    let lat = m
        .lat_acc_m_s2
        .abs()
        .max(speed * speed * m.steer_angle_rad.abs() * p.lat_acc_per_v2_rad);
    let steer_rate = m.steer_rate_rad_s.abs();
    let long = m.long_acc_m_s2.abs();
    let mut t = s.latched;
    t = latch(t, diag::TRIGGER_LATERAL, lat > p.lat_acc_m_s2.0, lat < p.lat_acc_m_s2.1);
    t = latch(
        t,
        diag::TRIGGER_STEER_RATE,
        steer_rate > p.steer_rate_rad_s.0 && speed > p.steer_min_speed_m_s,
        steer_rate < p.steer_rate_rad_s.1 || speed < p.steer_min_speed_m_s,
    );
    t = latch(t, diag::TRIGGER_LONGITUDINAL, long > p.long_acc_m_s2.0, long < p.long_acc_m_s2.1);
    t = latch(t, diag::TRIGGER_BRAKE, m.brake_pressed && speed > p.brake_min_speed_m_s, !m.brake_pressed);
    t = latch(t, diag::TRIGGER_SPEED, speed > p.speed_m_s.0, speed < p.speed_m_s.1);
    s.latched = t;
    let active = match driver {
        DriverMode::Auto => t,
        DriverMode::Comfort => t & (diag::TRIGGER_LATERAL | diag::TRIGGER_LONGITUDINAL),
        DriverMode::Sport => t | diag::TRIGGER_SPORT,
    };
    if active != 0 {
        s.handling = true;
        s.quiet_us = 0;
    } else {
        s.quiet_us = s.quiet_us.saturating_add(dt_us);
        if s.quiet_us >= p.hold_us {
            s.handling = false;
        }
    }
    if s.handling {
        let hold = if active == 0 { diag::HANDLING_HOLD } else { 0 };
        (DriveMode::Handling, active | hold)
    } else {
        (DriveMode::Ride, 0)
    }
}

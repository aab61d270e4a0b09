//! The controller's interface: what it measures, what it commands.
//!
//! These types are the contract between the controller, the CAN codec and
//! the firmware. Every field is SI with the unit in its name.

/// The driver's mode switch.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[repr(u8)]
pub enum DriverMode {
    /// Automatic selection between ride and handling.
    #[default]
    Auto = 0,
    /// Ride mode unless a body-motion safety trigger (lateral or
    /// longitudinal acceleration) asks for handling.
    Comfort = 1,
    /// Forced handling mode (hard spring, high damping).
    Sport = 2,
}

/// Spring state selected by the controller: valve 6 open (soft, S + L) or
/// closed (hard, S only). While the ride-height sequencer pulses valve 6 the
/// spring mode stays `Hard` and [`Outputs::valve6_open`] shows the pulses.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[repr(u8)]
pub enum SpringMode {
    #[default]
    Hard = 0,
    Soft = 1,
}

/// Damper state: valve 5 closed (high damping) or open (bypass, low).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[repr(u8)]
pub enum DamperMode {
    #[default]
    High = 0,
    Low = 1,
}

/// The selected driving mode.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[repr(u8)]
pub enum DriveMode {
    /// Soft spring, skyhook damping on a low base.
    Ride = 0,
    /// Hard spring, high damping.
    #[default]
    Handling = 1,
}

/// The pump-free ride-height sequencer.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[repr(u8)]
pub enum SequencerState {
    /// Ride-height control not engaged: no offset requested or held and
    /// the spring is soft (valve 6 open, S and L equalise).
    #[default]
    Idle = 0,
    /// Moving oil from S into L (lowering); valve 6 pulses while p_S > p_L.
    Lowering = 1,
    /// Moving oil from L back into S (raising); valve 6 pulses while p_L > p_S.
    Raising = 2,
    /// Target reached; valve 6 held closed to keep the oil where it is.
    Holding = 3,
    /// Ride-height control engaged but paused (cornering, braking, hard
    /// acceleration, waiting for calm or for the load estimate, or a
    /// fault); valve 6 held closed.
    Blocked = 4,
}

/// Groups of inputs, one bit each, used for freshness and fault flags.
///
/// | group | fields |
/// |---|---|
/// | `PRESSURES` | `p_gas_pa`, `p_gas2_pa` |
/// | `STRUT` | `strut_disp_m` |
/// | `BODY` | `body_acc_m_s2` |
/// | `VEHICLE` | `speed_m_s`, `lat_acc_m_s2`, `long_acc_m_s2`, `brake_pressed` |
/// | `STEERING` | `steer_angle_rad`, `steer_rate_rad_s` |
/// | `TEMPERATURE` | `t_gas_k` |
/// | `DRIVER` | `driver_mode`, `ride_height_request_m` |
pub mod input_group {
    pub const PRESSURES: u16 = 1 << 0;
    pub const STRUT: u16 = 1 << 1;
    pub const BODY: u16 = 1 << 2;
    pub const VEHICLE: u16 = 1 << 3;
    pub const STEERING: u16 = 1 << 4;
    pub const TEMPERATURE: u16 = 1 << 5;
    pub const DRIVER: u16 = 1 << 6;
    pub const ALL: u16 = (1 << 7) - 1;
    /// Number of groups.
    pub const COUNT: usize = 7;
}

/// What the ECU measures, in SI units. One instance per control period.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Inputs {
    /// Gas pressure in the always-connected accumulator S, Pa.
    pub p_gas_pa: f64,
    /// Gas pressure in the switchable accumulator L, Pa.
    pub p_gas2_pa: f64,
    /// Strut compression from the nominal static position, m (positive = compression).
    pub strut_disp_m: f64,
    /// Body vertical acceleration, gravity removed, m/s^2 (positive = up).
    pub body_acc_m_s2: f64,
    /// Vehicle speed, m/s (negative = reversing).
    pub speed_m_s: f64,
    /// Lateral acceleration, m/s^2.
    pub lat_acc_m_s2: f64,
    /// Longitudinal acceleration, m/s^2 (negative = braking).
    pub long_acc_m_s2: f64,
    /// Steering wheel angle, rad.
    pub steer_angle_rad: f64,
    /// Steering wheel rate, rad/s.
    pub steer_rate_rad_s: f64,
    /// Brake pedal pressed.
    pub brake_pressed: bool,
    /// Gas temperature, K (taken as the temperature of the gas in L too).
    pub t_gas_k: f64,
    /// The driver's mode switch.
    pub driver_mode: DriverMode,
    /// Requested ride height relative to the soft-mode rest height, m
    /// (negative = lower).
    pub ride_height_request_m: f64,
    /// Which input groups ([`input_group`]) received a new value this period.
    pub fresh: u16,
    /// The communication layer reports a fault (too many rejected frames).
    pub link_fault: bool,
}

/// What the controller commands and reports.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Outputs {
    /// Valve 5 (damper bypass) energised open: low damping.
    pub valve5_open: bool,
    /// Valve 6 energised open: large accumulator connected.
    pub valve6_open: bool,
    pub drive_mode: DriveMode,
    pub spring_mode: SpringMode,
    pub damper_mode: DamperMode,
    pub sequencer: SequencerState,
    /// Diagnostic flags, see [`crate::diag`].
    pub diag: u32,
    /// Estimated ride-height offset held by the oil in L, m (negative =
    /// lowered), from the height the soft spring would settle at (L's gas
    /// at the load pressure); see `docs/controller.md`.
    pub ride_height_m: f64,
    /// The pressure in L that holds the (clamped) ride-height request at
    /// the measured gas temperature and the estimated load pressure, Pa.
    pub p_gas2_target_pa: f64,
    /// Estimated static load pressure (slow low-pass of `p_S`), Pa.
    pub p_load_pa: f64,
    /// Estimated strut compression rate, m/s (positive = compressing).
    pub strut_vel_m_s: f64,
    /// Estimated body vertical velocity, m/s (positive = up).
    pub body_vel_m_s: f64,
}

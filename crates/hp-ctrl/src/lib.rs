//! Valve-switching controller of the hydro-pneumatic unit.
//!
//! One pure function, [`step`], in the shape `step(&params, &mut state,
//! &inputs, dt) -> outputs`: immutable parameters, mutable state, measured
//! inputs in, valve commands out. It is `no_std`, allocation-free,
//! panic-free and deterministic, so the same code runs on the host (tests,
//! simulation, Python) and on the ECU.
//!
//! INTERFACE DRAFT: the types below are the contract between the controller,
//! the CAN codec and the firmware. The logic is being written.
#![no_std]

pub mod can;

/// The driver's mode switch.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[repr(u8)]
pub enum DriverMode {
    /// Automatic selection between ride and handling.
    #[default]
    Auto = 0,
    /// Forced ride mode (soft spring, low damping base).
    Comfort = 1,
    /// Forced handling mode (hard spring, high damping base).
    Sport = 2,
}

/// Spring state: valve 6 open (soft, S + L) or closed (hard, S only).
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
    /// No ride-height change requested or in progress.
    #[default]
    Idle = 0,
    /// Moving oil from S into L (lowering); valve 6 pulses while p_S > p_L.
    Lowering = 1,
    /// Moving oil from L back into S (raising); valve 6 pulses while p_L > p_S.
    Raising = 2,
    /// Target reached; valve 6 held closed to keep the oil where it is.
    Holding = 3,
    /// A change is requested but blocked (cornering, braking, hard acceleration, fault).
    Blocked = 4,
}

/// Groups of inputs, one bit each, used for freshness and fault flags.
pub mod input_group {
    pub const PRESSURES: u16 = 1 << 0;
    pub const STRUT: u16 = 1 << 1;
    pub const BODY: u16 = 1 << 2;
    pub const VEHICLE: u16 = 1 << 3;
    pub const STEERING: u16 = 1 << 4;
    pub const TEMPERATURE: u16 = 1 << 5;
    pub const DRIVER: u16 = 1 << 6;
    pub const ALL: u16 = (1 << 7) - 1;
}

/// What the ECU measures, in SI units. One instance per control period.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Inputs {
    /// Gas pressure in the always-connected accumulator S, Pa.
    pub p_small_pa: f64,
    /// Gas pressure in the switchable accumulator L, Pa.
    pub p_large_pa: f64,
    /// Strut compression from the nominal static position, m (positive = compression).
    pub strut_disp_m: f64,
    /// Body vertical acceleration, gravity removed, m/s^2 (positive = up).
    pub body_acc_m_s2: f64,
    /// Vehicle speed, m/s.
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
    /// Gas temperature, K.
    pub t_gas_k: f64,
    /// The driver's mode switch.
    pub driver_mode: DriverMode,
    /// Requested ride height relative to nominal, m (negative = lower).
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
    /// Diagnostic flags (see the `diag` module when it lands).
    pub diag: u32,
    /// Estimated ride-height offset from nominal, m.
    pub ride_height_m: f64,
}

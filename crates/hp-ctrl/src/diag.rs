//! Diagnostic flags reported in [`crate::Outputs::diag`].
//!
//! Bits 0-7 say whether the outputs are the safe state and why, bits 8-14
//! say which input group caused it (bit `8 + n` for group bit `1 << n` of
//! [`crate::input_group`]), bits 16 and up report normal-operation events.
//! `docs/controller.md` explains each flag.

/// The outputs are the safe state (both valves de-energised).
pub const SAFE_STATE: u32 = 1 << 0;
/// All inputs are good again; the safe state is held until they have been
/// good for the recovery time.
pub const RECOVERING: u32 = 1 << 1;
/// `dt_s` was not finite, below 1 us or above the configured maximum.
pub const BAD_DT: u32 = 1 << 2;
/// The communication layer reported a link fault.
pub const LINK_FAULT: u32 = 1 << 3;
/// An input was NaN or infinite.
pub const NOT_FINITE: u32 = 1 << 4;
/// An input was outside its physical range.
pub const OUT_OF_RANGE: u32 = 1 << 5;
/// An input changed faster than physics allows.
pub const RATE_LIMIT: u32 = 1 << 6;
/// An input group received no new value for longer than its timeout.
pub const STALE: u32 = 1 << 7;

/// First bit of the per-group fault flags.
pub const GROUP_SHIFT: u32 = 8;
/// Mask of the per-group fault flags.
pub const GROUP_MASK: u32 = (crate::input_group::ALL as u32) << GROUP_SHIFT;

/// The flag saying that input group `group` (a bit of
/// [`crate::input_group`]) caused a fault.
///
/// ```
/// use hp_ctrl::{diag, input_group};
/// assert_eq!(diag::group(input_group::PRESSURES), 1 << 8);
/// ```
pub const fn group(group: u16) -> u32 {
    (group as u32) << GROUP_SHIFT
}

/// The ride-height request was outside the configured range and was clamped.
pub const REQUEST_CLAMPED: u32 = 1 << 16;
/// Ride-height sequencing is paused by driving dynamics (cornering, braking,
/// hard acceleration), waiting for the calm time after them, or (after
/// power-on) for the load-pressure estimate to settle.
pub const SEQUENCER_PAUSED: u32 = 1 << 17;
/// Ride mode wants the soft spring but a ride-height offset is requested or
/// held, so valve 6 stays closed (the ride height has priority).
pub const HEIGHT_HOLDS_SPRING: u32 = 1 << 18;
/// `ride_height_m` (and `p_gas2_target_pa`) are held from an earlier
/// period because the pressures or the temperature are not valid now.
pub const HEIGHT_ESTIMATE_HELD: u32 = 1 << 19;

/// Handling trigger: measured or steering-predicted lateral acceleration.
pub const TRIGGER_LATERAL: u32 = 1 << 20;
/// Handling trigger: steering-wheel rate (above the minimum speed).
pub const TRIGGER_STEER_RATE: u32 = 1 << 21;
/// Handling trigger: longitudinal acceleration (braking or accelerating).
pub const TRIGGER_LONGITUDINAL: u32 = 1 << 22;
/// Handling trigger: brake pedal pressed (above the minimum speed).
pub const TRIGGER_BRAKE: u32 = 1 << 23;
/// Handling trigger: vehicle speed.
pub const TRIGGER_SPEED: u32 = 1 << 24;
/// Handling trigger: the driver selected Sport.
pub const TRIGGER_SPORT: u32 = 1 << 25;
/// In handling mode only because the minimum handling time has not passed
/// since the last trigger.
pub const HANDLING_HOLD: u32 = 1 << 26;

/// All handling-trigger flags.
pub const TRIGGERS: u32 =
    TRIGGER_LATERAL | TRIGGER_STEER_RATE | TRIGGER_LONGITUDINAL | TRIGGER_BRAKE | TRIGGER_SPEED | TRIGGER_SPORT;

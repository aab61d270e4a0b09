//! The sending side: one alive counter per message, and the ECU's output
//! frames built from the controller's [`Outputs`].

use super::messages::{HeightCtrl, Kind, Motion, Status, ValveCmd};
use super::{e2e, encode, CanFrame, EncodeError, Message};
use crate::Outputs;

/// Alive counters of every message, so each message's frames count
/// 0, 1, ..., 14, 0, ... independently.
///
/// ```
/// use hp_ctrl::can::{decode, messages::PilTick, Message, Transmitter};
/// let mut tx = Transmitter::new();
/// for expected in [0, 1, 2] {
///     let frame = tx.frame(&Message::PilTick(PilTick { index: 7 })).unwrap();
///     assert_eq!(decode(&frame).unwrap().1, expected);
/// }
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct Transmitter {
    counters: [u8; Kind::ALL.len()],
}

impl Transmitter {
    /// All counters at 0.
    pub const fn new() -> Self {
        Transmitter { counters: [0; Kind::ALL.len()] }
    }

    /// Encodes `msg` with its message's next counter. The counter advances
    /// only if encoding succeeds.
    pub fn frame(&mut self, msg: &Message) -> Result<CanFrame, EncodeError> {
        let kind = msg.kind();
        let index = Kind::ALL.iter().position(|&k| k == kind).unwrap_or(0);
        let counter = self.counters.get_mut(index).ok_or(EncodeError::OutOfRange)?;
        let frame = encode(msg, *counter)?;
        *counter = e2e::next_counter(*counter);
        Ok(frame)
    }
}

/// The largest ride height `HP_Status` can carry, m (DBC range).
const RIDE_HEIGHT_LIMIT_M: f64 = 0.3;
/// The largest pressure `HP_HeightCtrl` can carry, Pa (DBC range).
const PRESSURE_LIMIT_PA: f64 = 1.2e8;
/// The largest velocity `HP_Motion` can carry, m/s (DBC range).
const VELOCITY_LIMIT_M_S: f64 = 10.0;

/// `x` limited to `lo..=hi`, and 0 if not finite, so an output frame is
/// always sent; the DBC's range is the frame's, not the controller's.
fn sendable(x: f64, lo: f64, hi: f64) -> f64 {
    if x.is_finite() {
        x.max(lo).min(hi)
    } else {
        0.0
    }
}

impl ValveCmd {
    /// The valve command of one period.
    pub fn from_outputs(out: &Outputs, link_fault: bool, step_index: u16) -> Self {
        ValveCmd {
            valve5_open: out.valve5_open,
            valve6_open: out.valve6_open,
            drive_mode: out.drive_mode,
            spring_mode: out.spring_mode,
            damper_mode: out.damper_mode,
            sequencer: out.sequencer,
            link_fault,
            step_index,
        }
    }
}

impl Status {
    /// The status of one period. The ride-height estimate is clamped to the
    /// DBC range (+-0.3 m) and a non-finite estimate is sent as 0, so the
    /// status frame is always sent; the controller's `diag` says whether the
    /// estimate is held.
    pub fn from_outputs(out: &Outputs) -> Self {
        Status { ride_height_m: sendable(out.ride_height_m, -RIDE_HEIGHT_LIMIT_M, RIDE_HEIGHT_LIMIT_M), diag: out.diag }
    }
}

impl HeightCtrl {
    /// The ride-height control's pressures of one period, limited to the
    /// DBC range (0 to 120 MPa), a non-finite value sent as 0.
    pub fn from_outputs(out: &Outputs) -> Self {
        HeightCtrl {
            p_load_pa: sendable(out.p_load_pa, 0.0, PRESSURE_LIMIT_PA),
            p_gas2_target_pa: sendable(out.p_gas2_target_pa, 0.0, PRESSURE_LIMIT_PA),
        }
    }
}

impl Motion {
    /// The velocity estimates of one period, limited to the DBC range
    /// (+-10 m/s), a non-finite value sent as 0.
    pub fn from_outputs(out: &Outputs) -> Self {
        Motion {
            strut_vel_m_s: sendable(out.strut_vel_m_s, -VELOCITY_LIMIT_M_S, VELOCITY_LIMIT_M_S),
            body_vel_m_s: sendable(out.body_vel_m_s, -VELOCITY_LIMIT_M_S, VELOCITY_LIMIT_M_S),
        }
    }
}

//! The sending side: one alive counter per message, and the ECU's output
//! frames built from the vehicle step's [`VehicleOutputs`].

use super::messages::{Ctrl, Diag, Kind, Status, Valves, KINDS};
use super::{e2e, encode, encode_output, CanFrame, EncodeError, Message};
use crate::vehicle::{HeightMode, VehicleOutputs};
use crate::{diag, DriveMode, Outputs};

/// Alive counters of every message, so each message's frames count
/// 0, 1, ..., 14, 0, ... independently.
///
/// ```
/// use hp_ctrl::can::{decode, messages::{address, PilTick}, Message, Transmitter};
/// let mut tx = Transmitter::new();
/// for expected in [0, 1, 2] {
///     let frame = tx.frame(&Message::PilTick(PilTick { index: 7 }), address::TESTER).unwrap();
///     assert_eq!(decode(&frame).unwrap().1, expected);
/// }
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Transmitter {
    counters: [u8; KINDS],
}

impl Default for Transmitter {
    fn default() -> Self {
        Self::new()
    }
}

impl Transmitter {
    /// All counters at 0.
    pub const fn new() -> Self {
        Transmitter { counters: [0; KINDS] }
    }

    /// Encodes `msg` from source address `source` with its message's next
    /// counter. The counter advances only if encoding succeeds.
    pub fn frame(&mut self, msg: &Message, source: u8) -> Result<CanFrame, EncodeError> {
        let counter = self.counters.get_mut(msg.kind().index()).ok_or(EncodeError::OutOfRange)?;
        let frame = encode(msg, *counter, source)?;
        *counter = e2e::next_counter(*counter);
        Ok(frame)
    }

    /// [`Transmitter::frame`] for a message the ECU sends (`OutOfRange`
    /// for others): the firmware's path ([`super::encode_output`]).
    pub fn output_frame(&mut self, msg: &Message, source: u8) -> Result<CanFrame, EncodeError> {
        let counter = self.counters.get_mut(msg.kind().index()).ok_or(EncodeError::OutOfRange)?;
        let frame = encode_output(msg, *counter, source)?;
        *counter = e2e::next_counter(*counter);
        Ok(frame)
    }
}

/// The largest ride height `HP_CornerStatus` can carry, m (DBC range).
const RIDE_HEIGHT_LIMIT_M: f64 = 0.3;
/// The largest pressure `HP_CornerCtrl` can carry, Pa (DBC range).
const PRESSURE_LIMIT_PA: f64 = 1.2e8;
/// The largest charge ratio `HP_CornerStatus` can carry (DBC range).
const CHARGE_LIMIT: f64 = 2.0;

/// `x` limited to `lo..=hi`, and 0 if not finite, so an output frame is
/// always sent; the DBC's range is the frame's, not the controller's.
fn sendable(x: f64, lo: f64, hi: f64) -> f64 {
    if x.is_finite() {
        x.max(lo).min(hi)
    } else {
        0.0
    }
}

fn safe(out: &Outputs) -> bool {
    out.diag & diag::SAFE_STATE != 0
}

impl Valves {
    /// Every corner's valves in one period.
    pub fn from_outputs<const N: usize>(out: &VehicleOutputs<N>, link_fault: bool, step_index: u16) -> Self {
        let mut v = Valves {
            step_index,
            height_mode: out.height_mode,
            link_fault,
            // The corners that are not in their safe state agree (same
            // vehicle inputs); all safe is Handling.
            drive_mode: out.corners.iter().find(|c| !safe(c)).map_or(DriveMode::Handling, |c| c.drive_mode),
            ..Valves::default()
        };
        for (((c, v5), v6), s) in out.corners.iter().zip(v.valve5_open.iter_mut()).zip(v.valve6_open.iter_mut()).zip(v.corner_safe.iter_mut()) {
            (*v5, *v6, *s) = (c.valve5_open, c.valve6_open, safe(c));
        }
        v
    }
}

impl Status {
    /// Corner `k`'s status. The ride height is clamped to the DBC range
    /// (+-0.3 m) and a non-finite one sent as 0; the corner's diag (in
    /// `HP_CornerDiag`) says whether it is held.
    pub fn from_outputs<const N: usize>(out: &VehicleOutputs<N>, k: usize) -> Self {
        let (Some(c), Some(g)) = (out.corners.get(k), out.gas.get(k)) else { return Status::default() };
        Status {
            ride_height_m: sendable(c.ride_height_m, -RIDE_HEIGHT_LIMIT_M, RIDE_HEIGHT_LIMIT_M),
            sequencer: c.sequencer,
            spring_mode: c.spring_mode,
            damper_mode: c.damper_mode,
            safe: safe(c),
            gas_settled: g.settled,
            gas_fault: g.fault,
            gas_charge: sendable(f64::from(g.charge_ratio), 0.0, CHARGE_LIMIT),
            gas_loss_confidence: sendable(f64::from(g.confidence), 0.0, 1.0),
        }
    }
}

impl Ctrl {
    /// Corner `k`'s reference pressures, limited to the DBC range (0 to
    /// 120 MPa), a non-finite value sent as 0.
    pub fn from_outputs(out: &Outputs) -> Self {
        Ctrl {
            p_load_pa: sendable(out.p_load_pa, 0.0, PRESSURE_LIMIT_PA),
            p_gas2_target_pa: sendable(out.p_gas2_target_pa, 0.0, PRESSURE_LIMIT_PA),
        }
    }
}

impl Diag {
    /// Corner `k`'s flags.
    pub fn from_outputs(out: &Outputs) -> Self {
        Diag { diag: out.diag }
    }
}

/// The ECU message `kind` for this period, if it has one (an ECU message
/// of a corner it has).
pub fn ecu_message<const N: usize>(kind: Kind, out: &VehicleOutputs<N>) -> Option<Message> {
    let corner = |k: u8| out.corners.get(usize::from(k));
    Some(match kind {
        Kind::CornerStatus(k) => {
            corner(k)?;
            Message::CornerStatus(k, Status::from_outputs(out, usize::from(k)))
        }
        Kind::CornerCtrl(k) => Message::CornerCtrl(k, Ctrl::from_outputs(corner(k)?)),
        Kind::CornerDiag(k) => Message::CornerDiag(k, Diag::from_outputs(corner(k)?)),
        _ => return None,
    })
}

/// The applied height mode as a `u8` (for tools).
pub fn height_mode_value(mode: HeightMode) -> u8 {
    mode as u8
}

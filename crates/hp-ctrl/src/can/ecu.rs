//! The ECU application, independent of any board: frames in, one control
//! period, frames out.
//!
//! The firmware (`crates/hp-fw`) runs this on the microcontroller; the host
//! runs the very same code (the `can_codec` example, the Python bindings)
//! as the reference for processor-in-the-loop comparisons.

use embedded_can::Frame;

use super::messages::{HeightCtrl, Kind, Motion, Status, ValveCmd};
use super::{Accepted, CanFrame, InputDecoder, LinkParams, Message, Transmitter};
use crate::{diag, Inputs, Outputs, Params, State};

/// Control period, s (1 kHz).
pub const PERIOD_S: f64 = 1e-3;
/// Control period, us.
pub const PERIOD_US: u32 = 1000;

/// A CAN link as the application sees it; never blocks.
pub trait Link {
    /// The next received frame, if any.
    fn receive(&mut self) -> Option<CanFrame>;
    /// Queues a frame for sending; false if it had to be dropped.
    fn transmit(&mut self, frame: &CanFrame) -> bool;
}

/// The controller step: the ECU's only call into [`crate::step`].
///
/// Without valid parameters (they failed validation at start-up) the
/// outputs are the safe state: both valves de-energised.
pub fn control_step(params: Option<&Params>, state: &mut State, inputs: &Inputs) -> Outputs {
    match params {
        Some(p) => crate::step(p, state, inputs, PERIOD_S),
        None => Outputs { diag: diag::SAFE_STATE, ..Outputs::default() },
    }
}

/// Everything the ECU application keeps.
pub struct Ecu {
    params: Option<Params>,
    state: State,
    rx: InputDecoder,
    tx: Transmitter,
    step_index: u32,
    /// Frames that could not be queued for sending.
    pub tx_dropped: u32,
}

impl Ecu {
    /// Power-on: the seed unit's calibration; the controller starts in its
    /// safe state and the link supervision with every message stale.
    pub fn new() -> Self {
        Ecu {
            params: Params::seed_unit().ok(),
            state: State::new(),
            rx: InputDecoder::new(LinkParams { period_us: PERIOD_US, ..LinkParams::default() }),
            tx: Transmitter::new(),
            step_index: 0,
            tx_dropped: 0,
        }
    }

    /// True if the parameters validated (otherwise the outputs stay safe).
    pub fn has_params(&self) -> bool {
        self.params.is_some()
    }

    /// The compiled parameters, if they passed validation.
    pub fn params(&self) -> Option<&Params> {
        self.params.as_ref()
    }

    /// Feeds one received frame to the receiver; returns the tick index if
    /// it was a lock-step tick (`HP_PilTick`).
    pub fn receive<F: Frame>(&mut self, frame: &F) -> Option<u16> {
        match self.rx.receive(frame) {
            Ok(Accepted::Tick(index)) => Some(index),
            _ => None,
        }
    }

    /// First part of a period: closes reception, gives the step's inputs.
    pub fn end_period(&mut self) -> Inputs {
        self.rx.end_period()
    }

    /// Second part: the controller step.
    pub fn step(&mut self, inputs: &Inputs) -> Outputs {
        control_step(self.params.as_ref(), &mut self.state, inputs)
    }

    /// Third part: sends the messages due in this period (DBC cycle time
    /// and start delay, with period 0 at power-on), in [`Kind::ECU_TX`]
    /// order: `HP_ValveCmd` and `HP_Status` every period, `HP_HeightCtrl`
    /// and `HP_Motion` every 10th, the diagnostics every 100th.
    pub fn send<L: Link>(&mut self, link: &mut L, inputs: &Inputs, out: &Outputs) {
        for kind in Kind::ECU_TX {
            if kind.def().timing.due(self.step_index) {
                if let Some(msg) = self.message(kind, inputs, out) {
                    self.emit(link, &msg);
                }
            }
        }
        self.step_index = self.step_index.wrapping_add(1);
    }

    /// The ECU's message `kind` for this period.
    fn message(&self, kind: Kind, inputs: &Inputs, out: &Outputs) -> Option<Message> {
        Some(match kind {
            // StepIndex is the period modulo 65536.
            Kind::ValveCmd => Message::ValveCmd(ValveCmd::from_outputs(out, inputs.link_fault, self.step_index as u16)),
            Kind::Status => Message::Status(Status::from_outputs(out)),
            Kind::HeightCtrl => Message::HeightCtrl(HeightCtrl::from_outputs(out)),
            Kind::Motion => Message::Motion(Motion::from_outputs(out)),
            Kind::DiagE2e => Message::DiagE2e(self.rx.diag_e2e()),
            Kind::DiagLink => Message::DiagLink(self.rx.diag_link()),
            _ => return None,
        })
    }

    fn emit<L: Link>(&mut self, link: &mut L, msg: &Message) {
        // Encoding cannot fail for these messages (Status is clamped, the
        // rest are flags and integers in range); a failure is counted.
        let sent = self.tx.frame(msg).map(|f| link.transmit(&f)).unwrap_or(false);
        if !sent {
            self.tx_dropped = self.tx_dropped.saturating_add(1);
        }
    }

    /// One whole control period.
    pub fn period<L: Link>(&mut self, link: &mut L) {
        let inputs = self.end_period();
        let out = self.step(&inputs);
        self.send(link, &inputs, &out);
    }
}

impl Default for Ecu {
    fn default() -> Self {
        Self::new()
    }
}

//! The ECU's receive side: E2E checks with per-message state, the
//! controller's [`Inputs`], and link supervision.
//!
//! Per period the firmware feeds every received frame to
//! [`InputDecoder::receive`], then calls [`InputDecoder::end_period`] once,
//! which returns the [`Inputs`] for the controller step.
//!
//! Rules (see `docs/can.md`):
//! - A frame is used only if it passes every check ([`super::Reject`]) and
//!   its alive counter is exactly one more (mod 15) than the previous
//!   frame's of the same message.
//! - After power-on and after a timeout, the first CRC-valid frame only
//!   re-synchronises the counter and is not used ([`Accepted::Synced`]);
//!   the next frame in sequence is.
//! - Timeout: a supervised message with no used frame for more than its
//!   DBC `E2E_TimeoutMs` is stale: its group's `fresh` bit stays clear and
//!   `link_fault` is set until it is used again. A message that has never
//!   been used is stale too, so the controller starts in its safe state.
//! - Reject window: every reject counts in a window of
//!   [`LinkParams::window_periods`] periods; reaching
//!   [`LinkParams::window_reject_limit`] sets `link_fault` at once, and it
//!   clears at the end of the first whole window below the limit.

use embedded_can::Frame;

use super::e2e::{CounterState, Sequence};
use super::messages::{DiagE2e, DiagLink, Kind};
use super::{check_frame, read_payload, Message, Reject};
use crate::Inputs;

/// Link supervision parameters.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct LinkParams {
    /// Control period, us.
    pub period_us: u32,
    /// Length of the reject window, periods.
    pub window_periods: u16,
    /// Rejects in one window that set `link_fault`.
    pub window_reject_limit: u8,
}

impl Default for LinkParams {
    /// 1 kHz, 10 rejects in 100 ms.
    fn default() -> Self {
        LinkParams { period_us: 1000, window_periods: 100, window_reject_limit: 10 }
    }
}

/// What a frame that passed the checks did.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Accepted {
    /// New values for these input groups.
    Input(u16),
    /// A lock-step tick (`HP_PilTick`) with its index.
    Tick(u16),
    /// Valid, but only re-synchronised the alive counter.
    Synced,
}

/// Receive state of one message.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
struct Slot {
    counter: CounterState,
    /// Time since the end of the period of the last used frame, as of the
    /// end of the previous period, us (saturating).
    age_us: u32,
    /// No used frame for longer than the timeout (or never).
    stale: bool,
}

const NEW_SLOT: Slot = Slot { counter: CounterState::new(), age_us: 0, stale: true };

/// The ECU's receiver: decodes frames into [`Inputs`], counts rejects per
/// reason and supervises timeouts.
///
/// ```
/// use hp_ctrl::can::{messages::Strut, InputDecoder, LinkParams, Message, Transmitter};
/// use hp_ctrl::input_group;
///
/// let mut rx = InputDecoder::new(LinkParams::default());
/// let mut tx = Transmitter::new();
/// let strut = |disp_m| Message::Strut(Strut { disp_m });
/// // The first frame only synchronises the counter.
/// rx.receive(&tx.frame(&strut(0.01)).unwrap()).unwrap();
/// assert_eq!(rx.end_period().fresh, 0);
/// rx.receive(&tx.frame(&strut(0.02)).unwrap()).unwrap();
/// let inputs = rx.end_period();
/// assert_eq!(inputs.fresh, input_group::STRUT);
/// assert!((inputs.strut_disp_m - 0.02).abs() < 1e-9);
/// // Other messages have never arrived: link fault, safe state.
/// assert!(inputs.link_fault);
/// ```
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct InputDecoder {
    params: LinkParams,
    inputs: Inputs,
    fresh: u16,
    slots: [Slot; Kind::ECU_RX.len()],
    rejects: DiagE2e,
    timeouts: u8,
    window_rejects: u8,
    window_age: u16,
    reject_fault: bool,
}

impl InputDecoder {
    /// Power-on state: every message stale, no rejects.
    pub fn new(params: LinkParams) -> Self {
        InputDecoder {
            params,
            inputs: Inputs { link_fault: true, ..Inputs::default() },
            fresh: 0,
            slots: [NEW_SLOT; Kind::ECU_RX.len()],
            rejects: DiagE2e::default(),
            timeouts: 0,
            window_rejects: 0,
            window_age: 0,
            reject_fault: false,
        }
    }

    /// Checks one received frame and, if it is used, stores its values.
    /// A reject is counted under its reason and in the reject window.
    pub fn receive<F: Frame>(&mut self, frame: &F) -> Result<Accepted, Reject> {
        let result = self.check(frame);
        if let Err(reason) = result {
            self.count(reason);
        }
        result
    }

    fn check<F: Frame>(&mut self, frame: &F) -> Result<Accepted, Reject> {
        let (kind, payload, counter) = check_frame(frame)?;
        let slot = kind.rx_index().and_then(|i| self.slots.get_mut(i)).ok_or(Reject::UnknownId)?;
        match slot.counter.check(counter) {
            Sequence::Next => {}
            Sequence::Synced => return Ok(Accepted::Synced),
            Sequence::Repeated => return Err(Reject::Repeated),
            Sequence::Skipped => return Err(Reject::Skipped),
        }
        let msg = read_payload(kind, &payload)?;
        slot.age_us = 0;
        slot.stale = false;
        let group = kind.def().group;
        self.fresh |= group;
        let i = &mut self.inputs;
        match msg {
            Message::PilTick(t) => return Ok(Accepted::Tick(t.index)),
            Message::Pressures(m) => {
                i.p_gas_pa = m.p_gas_pa;
                i.p_gas2_pa = m.p_gas2_pa;
            }
            Message::Strut(m) => i.strut_disp_m = m.disp_m,
            Message::Body(m) => i.body_acc_m_s2 = m.acc_m_s2,
            Message::Vehicle(m) => {
                i.speed_m_s = m.speed_m_s;
                i.brake_pressed = m.brake_pressed;
                i.lat_acc_m_s2 = m.lat_acc_m_s2;
                i.long_acc_m_s2 = m.long_acc_m_s2;
            }
            Message::Steering(m) => {
                i.steer_angle_rad = m.angle_rad;
                i.steer_rate_rad_s = m.rate_rad_s;
            }
            Message::Temperature(m) => i.t_gas_k = m.t_gas_k,
            Message::Driver(m) => {
                i.driver_mode = m.mode;
                i.ride_height_request_m = m.ride_height_request_m;
            }
            // Not in ECU_RX, so rx_index() already refused them.
            Message::ValveCmd(_)
            | Message::Status(_)
            | Message::HeightCtrl(_)
            | Message::Motion(_)
            | Message::DiagE2e(_)
            | Message::DiagLink(_) => return Err(Reject::UnknownId),
        }
        Ok(Accepted::Input(group))
    }

    fn count(&mut self, reason: Reject) {
        let r = &mut self.rejects;
        let counter = match reason {
            Reject::Crc => &mut r.crc,
            Reject::Length => &mut r.length,
            Reject::UnknownId => &mut r.unknown_id,
            Reject::Repeated => &mut r.repeated,
            Reject::Skipped => &mut r.skipped,
            Reject::Range => &mut r.range,
        };
        *counter = counter.saturating_add(1);
        self.window_rejects = self.window_rejects.saturating_add(1);
        if self.window_rejects >= self.params.window_reject_limit {
            self.reject_fault = true;
        }
    }

    /// Closes the period: ages every message, flags timeouts, advances the
    /// reject window, and returns the inputs for the controller step with
    /// this period's `fresh` groups and the `link_fault` verdict.
    pub fn end_period(&mut self) -> Inputs {
        let period_us = self.params.period_us;
        for (slot, kind) in self.slots.iter_mut().zip(Kind::ECU_RX) {
            let timeout_us = u32::from(kind.def().timeout_ms) * 1000;
            if timeout_us == 0 {
                continue;
            }
            // age_us = time from the end of the period of the last used
            // frame to the end of this one.
            if !slot.stale && slot.age_us > timeout_us {
                slot.stale = true;
                slot.counter.reset();
                self.timeouts = self.timeouts.saturating_add(1);
            }
            slot.age_us = slot.age_us.saturating_add(period_us);
        }
        self.window_age = self.window_age.saturating_add(1);
        if self.window_age >= self.params.window_periods {
            if self.window_rejects < self.params.window_reject_limit {
                self.reject_fault = false;
            }
            self.window_rejects = 0;
            self.window_age = 0;
        }
        let stale = self.stale_groups();
        let inputs = Inputs { fresh: self.fresh & !stale, link_fault: self.reject_fault || stale != 0, ..self.inputs };
        self.fresh = 0;
        inputs
    }

    /// Input groups whose message is stale.
    pub fn stale_groups(&self) -> u16 {
        self.slots.iter().zip(Kind::ECU_RX).filter(|(s, _)| s.stale).fold(0, |m, (_, k)| m | k.def().group)
    }

    /// Rejects per reason since power-on (the `HP_DiagE2E` content).
    pub fn diag_e2e(&self) -> DiagE2e {
        self.rejects
    }

    /// Link supervision state (the `HP_DiagLink` content).
    pub fn diag_link(&self) -> DiagLink {
        let stale = self.stale_groups();
        DiagLink {
            timeout_count: self.timeouts,
            stale_groups: (stale & 0x7F) as u8,
            link_fault: self.reject_fault || stale != 0,
            window_rejects: self.window_rejects,
        }
    }
}

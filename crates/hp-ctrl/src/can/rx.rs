//! The ECU's receive side: E2E checks with per-message state, the vehicle
//! step's [`VehicleInputs`], and link supervision.
//!
//! Per period the firmware feeds every received frame to
//! [`InputDecoder::receive`], then calls [`InputDecoder::end_period`] once,
//! which returns the inputs for the vehicle step.
//!
//! Rules (see `docs/can.md`):
//! - A frame is used only if it passes every check ([`super::Reject`]) and
//!   its alive counter is exactly one more (mod 15) than the previous
//!   frame's of the same message. Frames are matched by PGN (any source
//!   address); corner messages of corners the ECU does not have are unknown.
//! - After power-on and after a timeout, the first CRC-valid frame only
//!   re-synchronises the counter and is not used ([`Accepted::Synced`]);
//!   the next frame in sequence is.
//! - Timeout: a supervised message with no used frame for more than its
//!   DBC `E2E_TimeoutMs` is stale: its groups' `fresh` bits stay clear and
//!   the link fault of what it feeds is set until it is used again: a
//!   corner message that corner's, a vehicle message every corner's
//!   (`HP_Inclination` only marks the inclination stale). A message never
//!   used is stale too, so every corner starts in its safe state.
//! - Reject window: every reject counts in a window of
//!   [`LinkParams::window_periods`] periods; reaching
//!   [`LinkParams::window_reject_limit`] sets the vehicle link fault at
//!   once, and it clears at the end of the first whole window below the
//!   limit.

use embedded_can::Frame;

use super::e2e::{CounterState, Sequence};
use super::messages::{DiagE2e, DiagLink, Kind};
use super::{check_frame, read_input_payload, Message, Reject};
use crate::vehicle::{vehicle_group, CornerInputs, VehicleInputs};

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
    /// New values for these vehicle-level groups.
    Vehicle(u16),
    /// New values for these groups of a corner.
    Corner(usize, u16),
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

/// The vehicle messages, in slot order.
const VEHICLE_KINDS: [Kind; 5] = [Kind::PilTick, Kind::Vehicle, Kind::Steering, Kind::Driver, Kind::Inclination];

/// The ECU's receiver for `N` corners.
///
/// ```
/// use hp_ctrl::can::messages::{Motion, address};
/// use hp_ctrl::can::{InputDecoder, LinkParams, Message, Transmitter};
/// use hp_ctrl::input_group;
///
/// let mut rx = InputDecoder::<4>::new(LinkParams::default());
/// let mut tx = Transmitter::new();
/// let motion = |disp| Message::CornerMotion(2, Motion { strut_disp_m: disp, body_acc_m_s2: 0.0, t_gas_k: 300.0 });
/// // The first frame only synchronises the counter.
/// rx.receive(&tx.frame(&motion(0.01), address::SENSORS).unwrap()).unwrap();
/// assert_eq!(rx.end_period().corners[2].fresh, 0);
/// rx.receive(&tx.frame(&motion(0.02), address::SENSORS).unwrap()).unwrap();
/// let inputs = rx.end_period();
/// assert_eq!(inputs.corners[2].fresh, input_group::STRUT | input_group::BODY | input_group::TEMPERATURE);
/// assert!((inputs.corners[2].strut_disp_m - 0.02).abs() < 1e-9);
/// // Other messages have never arrived: link faults, safe states.
/// assert!(inputs.link_fault && inputs.corners[2].link_fault);
/// ```
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct InputDecoder<const N: usize> {
    params: LinkParams,
    inputs: VehicleInputs<N>,
    vehicle_slots: [Slot; 5],
    /// Per corner: pressures, motion.
    corner_slots: [[Slot; 2]; N],
    rejects: DiagE2e,
    timeouts: u8,
    window_rejects: u8,
    window_age: u16,
    reject_fault: bool,
}

impl<const N: usize> InputDecoder<N> {
    /// Power-on state: every message stale, no rejects.
    pub fn new(params: LinkParams) -> Self {
        InputDecoder {
            params,
            inputs: VehicleInputs::default(),
            vehicle_slots: [NEW_SLOT; 5],
            corner_slots: [[NEW_SLOT; 2]; N],
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

    fn slot(&mut self, kind: Kind) -> Option<&mut Slot> {
        match kind {
            Kind::CornerPressures(k) => self.corner_slots.get_mut(usize::from(k)).map(|s| &mut s[0]),
            Kind::CornerMotion(k) => self.corner_slots.get_mut(usize::from(k)).map(|s| &mut s[1]),
            _ => VEHICLE_KINDS.iter().position(|&v| v == kind).and_then(|i| self.vehicle_slots.get_mut(i)),
        }
    }

    fn check<F: Frame>(&mut self, frame: &F) -> Result<Accepted, Reject> {
        let (kind, payload, counter) = check_frame(frame)?;
        let slot = self.slot(kind).ok_or(Reject::UnknownId)?;
        match slot.counter.check(counter) {
            Sequence::Next => {}
            Sequence::Synced => return Ok(Accepted::Synced),
            Sequence::Repeated => return Err(Reject::Repeated),
            Sequence::Skipped => return Err(Reject::Skipped),
        }
        let msg = read_input_payload(kind, &payload)?;
        slot.age_us = 0;
        slot.stale = false;
        let group = kind.def().group;
        let i = &mut self.inputs;
        let v = &mut i.vehicle;
        match msg {
            Message::PilTick(t) => return Ok(Accepted::Tick(t.index)),
            Message::Vehicle(m) => {
                v.speed_m_s = m.speed_m_s;
                v.brake_pressed = m.brake_pressed;
                v.lat_acc_m_s2 = m.lat_acc_m_s2;
                v.long_acc_m_s2 = m.long_acc_m_s2;
            }
            Message::Steering(m) => {
                v.steer_angle_rad = m.angle_rad;
                v.steer_rate_rad_s = m.rate_rad_s;
            }
            Message::Driver(m) => {
                v.driver_mode = m.mode;
                v.height_mode = m.height_mode;
                v.ride_height_request_m = m.ride_height_request_m;
            }
            Message::Inclination(m) => {
                v.pitch_rad = m.pitch_rad;
                v.roll_rad = m.roll_rad;
            }
            Message::CornerPressures(k, m) => {
                let c = corner(&mut i.corners, k)?;
                c.p_gas_pa = m.p_gas_pa;
                c.p_gas2_pa = m.p_gas2_pa;
                c.fresh |= group;
                return Ok(Accepted::Corner(usize::from(k), group));
            }
            Message::CornerMotion(k, m) => {
                let c = corner(&mut i.corners, k)?;
                c.strut_disp_m = m.strut_disp_m;
                c.body_acc_m_s2 = m.body_acc_m_s2;
                c.t_gas_k = m.t_gas_k;
                c.fresh |= group;
                return Ok(Accepted::Corner(usize::from(k), group));
            }
            // The ECU's own messages have no slot: refused above.
            _ => return Err(Reject::UnknownId),
        }
        i.fresh |= group;
        Ok(Accepted::Vehicle(group))
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

    /// Counts a frame rejected before it reached this receiver (the
    /// network layer's unknown identifiers).
    pub fn count_reject(&mut self, reason: Reject) {
        self.count(reason);
    }

    /// Ages one slot by a period; true if it timed out now.
    fn age(slot: &mut Slot, kind: Kind, period_us: u32) -> bool {
        let timeout_us = u32::from(kind.def().timeout_ms) * 1000;
        if timeout_us == 0 {
            return false;
        }
        let timed_out = !slot.stale && slot.age_us > timeout_us;
        if timed_out {
            slot.stale = true;
            slot.counter.reset();
        }
        slot.age_us = slot.age_us.saturating_add(period_us);
        timed_out
    }

    /// Closes the period: ages every message, flags timeouts, advances the
    /// reject window, and returns the inputs for the vehicle step with
    /// this period's fresh groups and link faults.
    pub fn end_period(&mut self) -> VehicleInputs<N> {
        let period_us = self.params.period_us;
        let mut timeouts = 0_u8;
        for (slot, kind) in self.vehicle_slots.iter_mut().zip(VEHICLE_KINDS) {
            timeouts += u8::from(Self::age(slot, kind, period_us));
        }
        for (k, slots) in self.corner_slots.iter_mut().enumerate() {
            let k = k as u8;
            for (slot, kind) in slots.iter_mut().zip([Kind::CornerPressures(k), Kind::CornerMotion(k)]) {
                timeouts += u8::from(Self::age(slot, kind, period_us));
            }
        }
        self.timeouts = self.timeouts.saturating_add(timeouts);
        self.window_age = self.window_age.saturating_add(1);
        if self.window_age >= self.params.window_periods {
            if self.window_rejects < self.params.window_reject_limit {
                self.reject_fault = false;
            }
            self.window_rejects = 0;
            self.window_age = 0;
        }
        let stale_vehicle = self.stale_vehicle();
        // Inclination staleness only disables slope levelling.
        let vehicle_stale = stale_vehicle & 0b0111 != 0;
        let mut inputs = self.inputs;
        inputs.link_fault = self.reject_fault || vehicle_stale;
        inputs.inclination_stale = stale_vehicle & 0b1000 != 0;
        inputs.fresh &= !self.stale_vehicle_groups();
        for (c, slots) in inputs.corners.iter_mut().zip(&self.corner_slots) {
            let [pressures, motion] = slots;
            c.link_fault = pressures.stale || motion.stale;
            if pressures.stale {
                c.fresh &= !crate::input_group::PRESSURES;
            }
            if motion.stale {
                c.fresh &= !(crate::input_group::STRUT | crate::input_group::BODY | crate::input_group::TEMPERATURE);
            }
        }
        self.inputs.fresh = 0;
        for c in &mut self.inputs.corners {
            c.fresh = 0;
        }
        inputs
    }

    /// Stale vehicle messages: bit 0 HP_Vehicle, 1 HP_Steering, 2 HP_Driver, 3 HP_Inclination.
    pub fn stale_vehicle(&self) -> u8 {
        self.vehicle_slots.iter().skip(1).enumerate().filter(|(_, s)| s.stale).fold(0, |m, (n, _)| m | (1 << n))
    }

    fn stale_vehicle_groups(&self) -> u16 {
        let s = self.stale_vehicle();
        let bit = |n: u8, g: u16| if s & (1 << n) != 0 { g } else { 0 };
        bit(0, vehicle_group::VEHICLE) | bit(1, vehicle_group::STEERING) | bit(2, vehicle_group::DRIVER) | bit(3, vehicle_group::INCLINATION)
    }

    /// Stale corner messages: bit `2k` pressures, `2k + 1` motion.
    pub fn stale_corners(&self) -> u16 {
        self.corner_slots.iter().enumerate().fold(0, |m, (k, [p, q])| m | u16::from(p.stale) << (2 * k) | u16::from(q.stale) << (2 * k + 1))
    }

    /// Rejects per reason since power-on (the `HP_DiagE2E` content).
    pub fn diag_e2e(&self) -> DiagE2e {
        self.rejects
    }

    /// Link supervision state (the `HP_DiagLink` content; the vehicle
    /// flags are the caller's).
    pub fn diag_link(&self) -> DiagLink {
        let stale_vehicle = self.stale_vehicle();
        DiagLink {
            timeout_count: self.timeouts,
            window_rejects: self.window_rejects,
            stale_vehicle,
            link_fault: self.reject_fault || stale_vehicle & 0b0111 != 0,
            vehicle_diag: 0,
            stale_corners: self.stale_corners(),
        }
    }

    /// True while too many rejects in the window set the link fault.
    pub fn reject_fault(&self) -> bool {
        self.reject_fault
    }
}

fn corner<const N: usize>(corners: &mut [CornerInputs; N], k: u8) -> Result<&mut CornerInputs, Reject> {
    corners.get_mut(usize::from(k)).ok_or(Reject::UnknownId)
}

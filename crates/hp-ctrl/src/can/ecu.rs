//! The ECU application, independent of any board: frames in, one control
//! period of the vehicle step, frames out, and J1939 network management.
//!
//! The firmware (`crates/hp-fw`) runs this on the microcontroller; the host
//! runs the very same code (the `can_codec` example, the Python bindings)
//! as the reference for processor-in-the-loop comparisons.

use embedded_can::Frame;

use super::j1939::{self, dtc_of, fmi, DtcTable, Handled, Network, SLOTS_PER_CORNER};
use super::messages::{Kind, Valves};
use super::rx::Accepted;
use super::tx::ecu_message;
use super::{CanFrame, InputDecoder, LinkParams, Message, Reject, Transmitter};
use crate::input_group::{BODY, DRIVER, PRESSURES, STEERING, STRUT, TEMPERATURE, VEHICLE};
use crate::vehicle::{self, vehicle_diag, VehicleInputs, VehicleOutputs, VehicleParams, VehicleState};
use crate::diag;

/// Control period, s (1 kHz).
pub const PERIOD_S: f64 = 1e-3;
/// Control period, us.
pub const PERIOD_US: u32 = 1000;
/// Control period, ms.
const PERIOD_MS: u32 = 1;

/// A CAN link as the application sees it; never blocks.
pub trait Link {
    /// The next received frame, if any.
    fn receive(&mut self) -> Option<CanFrame>;
    /// Queues a frame for sending; false if it had to be dropped.
    fn transmit(&mut self, frame: &CanFrame) -> bool;
}

/// Everything the ECU application keeps, for `N` corners with the
/// parameters `params` (in flash on the ECU: [`crate::calibration`]).
pub struct Ecu<'p, const N: usize> {
    params: &'p VehicleParams<N>,
    state: VehicleState<N>,
    rx: InputDecoder<N>,
    tx: Transmitter,
    net: Network,
    dtcs: DtcTable,
    step_index: u32,
    /// Frames that could not be queued for sending.
    pub tx_dropped: u32,
}

impl<'p, const N: usize> Ecu<'p, N> {
    /// Power-on with `params` and the NAME's identity number: every corner
    /// in its safe state, every message stale; the address claim goes out
    /// in the first period.
    ///
    /// ```
    /// use hp_ctrl::can::ecu::Ecu;
    /// let ecu = Ecu::new(&hp_ctrl::calibration::SEED_4, 1);
    /// assert_eq!(ecu.network().address(), 0x2F);
    /// ```
    pub fn new(params: &'p VehicleParams<N>, identity_number: u32) -> Self {
        Ecu {
            params,
            state: VehicleState::new(),
            rx: InputDecoder::new(LinkParams { period_us: PERIOD_US, ..LinkParams::default() }),
            tx: Transmitter::new(),
            net: Network::new(j1939::ecu_name(identity_number), super::messages::address::HPECU),
            dtcs: DtcTable::new(),
            step_index: 0,
            tx_dropped: 0,
        }
    }

    /// The parameters.
    pub fn params(&self) -> &'p VehicleParams<N> {
        self.params
    }

    /// The J1939 network layer (address, claim state).
    pub fn network(&self) -> &Network {
        &self.net
    }

    /// The active trouble codes.
    pub fn dtcs(&self) -> &DtcTable {
        &self.dtcs
    }

    /// Feeds one received frame: J1939 network management first, then the
    /// receiver; returns the tick index if it was a lock-step tick
    /// (`HP_PilTick`).
    pub fn receive<F: Frame>(&mut self, frame: &F) -> Option<u16> {
        match self.net.receive(frame) {
            Handled::Network => None,
            Handled::Ignored => {
                self.rx.count_reject(Reject::UnknownId);
                None
            }
            Handled::Application => match self.rx.receive(frame) {
                Ok(Accepted::Tick(index)) => Some(index),
                _ => None,
            },
        }
    }

    /// First part of a period: closes reception, gives the step's inputs.
    pub fn end_period(&mut self) -> VehicleInputs<N> {
        self.rx.end_period()
    }

    /// Second part: the vehicle step.
    pub fn step(&mut self, inputs: &VehicleInputs<N>) -> VehicleOutputs<N> {
        vehicle::step(self.params, &mut self.state, inputs, PERIOD_S)
    }

    /// The trouble codes of this period's outputs.
    fn update_dtcs(&mut self, out: &VehicleOutputs<N>) {
        let group = |d: u32, g: u16| d & (diag::NOT_FINITE | diag::OUT_OF_RANGE | diag::RATE_LIMIT | diag::STALE) & if d & diag::group(g) != 0 { u32::MAX } else { 0 };
        let mut vehicle_flags = [0_u32; 3];
        for (k, (c, g)) in out.corners.iter().zip(&out.gas).enumerate() {
            let base = k * SLOTS_PER_CORNER;
            for (n, grp) in [PRESSURES, STRUT, BODY, TEMPERATURE].into_iter().enumerate() {
                self.dtcs.set(base + n, dtc_of(group(c.diag, grp), false));
            }
            let loss = 1.0 - g.charge_ratio;
            let severe = g.fault && loss >= 0.1;
            self.dtcs.set(base + 4, g.fault.then_some(if severe { fmi::BELOW_NORMAL_MOST_SEVERE } else { fmi::BELOW_NORMAL_MODERATE }));
            // The safe state from a fault (not the power-on recovery alone).
            let faulted = c.diag & diag::SAFE_STATE != 0 && c.diag & !(diag::SAFE_STATE | diag::RECOVERING) & 0xFF != 0;
            self.dtcs.set(base + 5, faulted.then_some(fmi::CONDITION_EXISTS));
            for (f, grp) in vehicle_flags.iter_mut().zip([VEHICLE, STEERING, DRIVER]) {
                *f |= group(c.diag, grp);
            }
        }
        let vbase = j1939::SLOTS_PER_CORNER * vehicle::MAX_CORNERS;
        for (n, f) in vehicle_flags.into_iter().enumerate() {
            self.dtcs.set(vbase + n, dtc_of(f, true));
        }
        self.dtcs.set(vbase + 3, (out.diag & vehicle_diag::INCLINATION_FAULT != 0).then_some(fmi::NETWORK_DATA_IN_ERROR));
        self.dtcs.set(vbase + 4, self.rx.reject_fault().then_some(fmi::NETWORK_DATA_IN_ERROR));
    }

    /// Third part: the frames of this period, in order: J1939 network
    /// management and DM1, the ECU's messages due by their DBC cycle time
    /// and start delay (period 0 at power-on), and `HP_Valves` last.
    pub fn send<L: Link>(&mut self, link: &mut L, inputs: &VehicleInputs<N>, out: &VehicleOutputs<N>) {
        self.update_dtcs(out);
        let mut dropped = 0;
        self.net.period(PERIOD_MS, &self.dtcs, |f| dropped += u32::from(!link.transmit(&f)));
        self.tx_dropped = self.tx_dropped.saturating_add(dropped);
        if self.net.may_send() {
            let source = self.net.address();
            for kind in Kind::ALL {
                if kind.ecu_sends() && kind != Kind::Valves && kind.def().timing.due(self.step_index) {
                    let msg = match kind {
                        Kind::DiagE2e => Some(Message::DiagE2e(self.rx.diag_e2e())),
                        Kind::DiagLink => {
                            let mut d = self.rx.diag_link();
                            d.vehicle_diag = (out.diag & 0b111) as u8;
                            Some(Message::DiagLink(d))
                        }
                        _ => ecu_message(kind, out),
                    };
                    if let Some(msg) = msg {
                        self.emit(link, &msg, source);
                    }
                }
            }
            // StepIndex is the period modulo 65536.
            let valves = Valves::from_outputs(out, inputs.link_fault, self.step_index as u16);
            self.emit(link, &Message::Valves(valves), source);
        }
        self.step_index = self.step_index.wrapping_add(1);
    }

    fn emit<L: Link>(&mut self, link: &mut L, msg: &Message, source: u8) {
        // Encoding cannot fail for these messages (values are limited to
        // their ranges, the rest are flags and integers in range); a
        // failure is counted.
        let sent = self.tx.output_frame(msg, source).map(|f| link.transmit(&f)).unwrap_or(false);
        if !sent {
            self.tx_dropped = self.tx_dropped.saturating_add(1);
        }
    }

    /// One whole control period.
    pub fn period<L: Link>(&mut self, link: &mut L) -> VehicleOutputs<N> {
        let inputs = self.end_period();
        let out = self.step(&inputs);
        self.send(link, &inputs, &out);
        out
    }
}


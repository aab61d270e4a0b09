//! The J1939 side of the ECU: its NAME and address claim (J1939-81),
//! requests and acknowledgements (J1939-21), DM1 active trouble codes
//! (J1939-73) with the broadcast transport protocol (BAM) when more than
//! one code is active.
//!
//! The protocol state machines and encodings come from the `sae-j1939-rs`
//! crate (MIT/Apache-2.0, `no_std`, no allocation, `rust-version` 1.75):
//! [`AddressClaimer`] (arbitration by NAME, moving to a free address in
//! 128-247 when this ECU loses, Cannot Claim when none is left), [`Name`],
//! [`Dtc`] and [`Lamps`], [`TpCm`] and [`TpDt`], [`Request`] and
//! [`Acknowledgement`]. This module only decides what to send when, and
//! maps the controller's faults to SPN/FMI ([`dtc_of`]).

use embedded_can::{ExtendedId, Frame, Id};
use sae_j1939_rs::address_claim::{AddressClaimer, ClaimAction, ClaimState};
use sae_j1939_rs::diagnostics::{Dtc, Lamp, LampStatus, Lamps};
use sae_j1939_rs::request::Acknowledgement;
use sae_j1939_rs::tp::{TpCm, TpDt};
use sae_j1939_rs::{Address, Name, Pgn};

use super::messages::{address, j1939_id};
use super::CanFrame;

/// PGNs of the standard parameter groups the ECU handles.
pub mod pgn {
    /// Acknowledgement (PDU1).
    pub const ACKNOWLEDGEMENT: u32 = 0xE800;
    /// Request (PDU1).
    pub const REQUEST: u32 = 0xEA00;
    /// Transport protocol, data transfer (PDU1).
    pub const TP_DT: u32 = 0xEB00;
    /// Transport protocol, connection management (PDU1).
    pub const TP_CM: u32 = 0xEC00;
    /// Address Claimed (PDU1, to global).
    pub const ADDRESS_CLAIMED: u32 = 0xEE00;
    /// DM1, active diagnostic trouble codes (PDU2).
    pub const DM1: u32 = 0xFECA;
}

/// Priorities of the standard groups the ECU sends.
const PRIORITY_CLAIM: u8 = 6;
const PRIORITY_ACK: u8 = 6;
const PRIORITY_DM1: u8 = 6;
const PRIORITY_TP: u8 = 7;

/// The ECU's NAME: arbitrary address capable (it moves to a free address
/// in 128-247 when it loses its preferred one), function 47 (the number of
/// its preferred address 0x2F, a suspension system controller in J1939's
/// address table), industry group 0 (global). The manufacturer code is 0:
/// this project has none assigned by SAE; a production ECU carries its own.
///
/// ```
/// use hp_ctrl::can::j1939::ecu_name;
/// let name = ecu_name(1234);
/// assert!(name.arbitrary_address_capable());
/// assert_eq!((name.function(), name.identity_number()), (47, 1234));
/// ```
pub fn ecu_name(identity_number: u32) -> Name {
    Name::new()
        .with_identity_number(identity_number)
        .with_manufacturer_code(0)
        .with_function(47)
        .with_arbitrary_address_capable(true)
}

/// Time after an Address Claimed from a self-configurable address
/// (128-247) before other messages may follow (J1939-81: the contention
/// window), ms.
const CLAIM_WINDOW_MS: u32 = 250;
/// DM1 period, ms (J1939-73: once a second).
pub const DM1_PERIOD_MS: u32 = 1000;
/// Spacing of BAM data packets, ms (J1939-21: 50 to 200).
pub const BAM_PACKET_MS: u32 = 50;
/// Most trouble codes in one DM1.
pub const DM1_MAX_DTCS: usize = 30;
/// Longest DM1 payload: two lamp bytes and the codes.
const DM1_MAX_BYTES: usize = 2 + 4 * DM1_MAX_DTCS;

/// A J1939 identifier's parts.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct J1939Id {
    pub priority: u8,
    /// The PGN; for a PDU1 group (PF < 240) without the destination.
    pub pgn: u32,
    /// The destination of a PDU1 group, [`address::GLOBAL`] for PDU2.
    pub destination: u8,
    pub source: u8,
}

impl J1939Id {
    /// The parts of an extended identifier; `None` for a standard one.
    ///
    /// ```
    /// use hp_ctrl::can::j1939::J1939Id;
    /// let id = J1939Id::of_raw(0x18EA_2FF9);
    /// assert_eq!((id.pgn, id.destination, id.source), (0xEA00, 0x2F, 0xF9));
    /// ```
    pub fn of_raw(raw: u32) -> Self {
        let pf = (raw >> 16) & 0xFF;
        let ps = ((raw >> 8) & 0xFF) as u8;
        let pgn = (raw >> 8) & 0x3_FFFF;
        let (pgn, destination) = if pf < 240 { (pgn & 0x3_FF00, ps) } else { (pgn, address::GLOBAL) };
        J1939Id { priority: ((raw >> 26) & 0x7) as u8, pgn, destination, source: (raw & 0xFF) as u8 }
    }

    /// The parts of a frame's identifier; `None` for a standard one.
    pub fn of<F: Frame>(frame: &F) -> Option<Self> {
        match frame.id() {
            Id::Extended(id) => Some(J1939Id::of_raw(id.as_raw())),
            Id::Standard(_) => None,
        }
    }
}

/// A frame with identifier `raw` (below 2^29) and 8 bytes.
fn frame(raw: u32, data: [u8; 8]) -> Option<CanFrame> {
    ExtendedId::new(raw).map(|id| CanFrame::extended(id, data))
}

/// One possible trouble code: which SPN, and its FMI when active.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Fault {
    pub spn: u32,
    pub fmi: u8,
}

/// First proprietary SPN (J1939-73 leaves 520192-524287 to manufacturers).
pub const SPN_BASE: u32 = 520_192;
/// SPNs per corner.
pub const SPNS_PER_CORNER: u32 = 16;
/// First vehicle-level SPN.
pub const SPN_VEHICLE: u32 = SPN_BASE + SPNS_PER_CORNER * crate::vehicle::MAX_CORNERS as u32;

/// Failure mode identifiers used (J1939-73).
pub mod fmi {
    /// Data valid but below normal operating range, most severe level.
    pub const BELOW_NORMAL_MOST_SEVERE: u8 = 1;
    /// Data erratic, intermittent or incorrect.
    pub const ERRATIC: u8 = 2;
    /// Abnormal update rate (stale).
    pub const ABNORMAL_UPDATE_RATE: u8 = 9;
    /// Data valid but below normal operating range, moderately severe level.
    pub const BELOW_NORMAL_MODERATE: u8 = 18;
    /// Received network data in error.
    pub const NETWORK_DATA_IN_ERROR: u8 = 19;
    /// Condition exists.
    pub const CONDITION_EXISTS: u8 = 31;
}

/// Trouble-code slots: per corner 0 pressures, 1 strut position, 2 body
/// acceleration, 3 gas temperature, 4 gas charge, 5 corner in its safe
/// state; vehicle-level 0 vehicle motion, 1 steering, 2 driver switches,
/// 3 inclination, 4 CAN reject window. (The parameters are compiled in and
/// validated when they are generated, [`crate::calibration`]: no code.)
pub const SLOTS_PER_CORNER: usize = 6;
/// Vehicle-level trouble-code slots.
pub const VEHICLE_SLOTS: usize = 5;
/// All slots.
pub const SLOTS: usize = SLOTS_PER_CORNER * crate::vehicle::MAX_CORNERS + VEHICLE_SLOTS;

/// The SPN of a slot.
pub fn spn_of_slot(slot: usize) -> u32 {
    let corners = SLOTS_PER_CORNER * crate::vehicle::MAX_CORNERS;
    if slot < corners {
        SPN_BASE + SPNS_PER_CORNER * (slot / SLOTS_PER_CORNER) as u32 + (slot % SLOTS_PER_CORNER) as u32
    } else {
        SPN_VEHICLE + (slot - corners) as u32
    }
}

/// The FMI of an input group's fault flags (`hp_ctrl::diag`), or `None`
/// if the group has none: stale alone is an abnormal update rate, anything
/// else erratic data (`network` = the vehicle's signals: network data in
/// error).
pub fn dtc_of(group_flags: u32, network: bool) -> Option<u8> {
    use crate::diag;
    let invalid = group_flags & (diag::NOT_FINITE | diag::OUT_OF_RANGE | diag::RATE_LIMIT) != 0;
    if invalid {
        Some(if network { fmi::NETWORK_DATA_IN_ERROR } else { fmi::ERRATIC })
    } else if group_flags & diag::STALE != 0 {
        Some(fmi::ABNORMAL_UPDATE_RATE)
    } else {
        None
    }
}

/// The active trouble codes with their occurrence counts.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct DtcTable {
    /// The FMI of each active slot, 0 if inactive.
    active: [u8; SLOTS],
    occurrences: [u8; SLOTS],
}

impl DtcTable {
    /// Nothing active.
    pub const fn new() -> Self {
        DtcTable { active: [0; SLOTS], occurrences: [0; SLOTS] }
    }

    /// Sets this period's state of slot `slot`: `Some(fmi)` active. A code
    /// going from inactive to active counts one occurrence (saturating at
    /// 126, J1939-73's largest).
    pub fn set(&mut self, slot: usize, fault: Option<u8>) {
        if let (Some(a), Some(n)) = (self.active.get_mut(slot), self.occurrences.get_mut(slot)) {
            let now = fault.unwrap_or(0);
            if now != 0 && *a != now {
                *n = n.saturating_add(1).min(126);
            }
            *a = now;
        }
    }

    /// The active codes, in slot order.
    pub fn active(&self) -> impl Iterator<Item = Dtc> + '_ {
        self.active.iter().zip(self.occurrences.iter()).enumerate().filter(|(_, (a, _))| **a != 0).map(|(slot, (&f, &n))| Dtc {
            spn: spn_of_slot(slot),
            fmi: f,
            occurrence_count: n,
            conversion_method: false,
        })
    }

    /// Number of active codes.
    pub fn count(&self) -> usize {
        self.active.iter().filter(|a| **a != 0).count()
    }
}

impl Default for DtcTable {
    fn default() -> Self {
        Self::new()
    }
}

/// A BAM transfer in progress.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
struct Bam {
    /// The address it is sent from.
    source: u8,
    len: u16,
    packets: u8,
    next: u8,
    /// Time since the last frame of the transfer, ms.
    since_ms: u32,
}

/// What the ECU's network layer keeps: address claim, pending answers,
/// the DM1 transfer.
#[derive(Debug, Clone)]
pub struct Network {
    claimer: AddressClaimer,
    /// An Address Claimed (or Cannot Claim) is to be sent.
    claim_due: bool,
    /// Time since the last claim was sent, ms.
    claim_age_ms: u32,
    /// A NACK to send: the PGN requested of us that we do not provide.
    nack: Option<u32>,
    /// A DM1 was requested.
    dm1_requested: bool,
    /// Time since the last DM1, ms.
    dm1_age_ms: u32,
    dm1: [u8; DM1_MAX_BYTES],
    bam: Option<Bam>,
    /// Address claims seen from others, and requests answered, for tools.
    pub claims_seen: u16,
}

/// What a received frame was to the network layer.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Handled {
    /// A J1939 network-management or diagnostic frame: consumed.
    Network,
    /// Not for the network layer: the application's.
    Application,
    /// A J1939 frame for another node or not understood: ignored.
    Ignored,
}

impl Network {
    /// Power-on: the claim of `preferred` is due in the first period.
    pub fn new(name: Name, preferred: u8) -> Self {
        Network {
            claimer: AddressClaimer::new(name, Address::new(preferred)),
            claim_due: true,
            claim_age_ms: 0,
            nack: None,
            dm1_requested: false,
            dm1_age_ms: DM1_PERIOD_MS,
            dm1: [0xFF; DM1_MAX_BYTES],
            bam: None,
            claims_seen: 0,
        }
    }

    /// The address the ECU sends from (the null address once it could not
    /// claim one).
    pub fn address(&self) -> u8 {
        self.claimer.address().as_u8()
    }

    /// The claim's state.
    pub fn claim_state(&self) -> ClaimState {
        self.claimer.state()
    }

    /// True when the ECU may send its other messages: it holds an address
    /// (a self-configurable one only after the contention window).
    pub fn may_send(&self) -> bool {
        let a = self.address();
        let claimed = matches!(self.claimer.state(), ClaimState::Claiming | ClaimState::Claimed);
        claimed && !self.claim_due && (!(128..=247).contains(&a) || self.claim_age_ms >= CLAIM_WINDOW_MS)
    }

    /// Takes a received frame if it is J1939 network management or a
    /// request.
    pub fn receive<F: Frame>(&mut self, frame: &F) -> Handled {
        let Some(id) = J1939Id::of(frame) else { return Handled::Application };
        let data = frame.data();
        match id.pgn {
            pgn::ADDRESS_CLAIMED => {
                let Ok(bytes) = <[u8; 8]>::try_from(data) else { return Handled::Ignored };
                self.claims_seen = self.claims_seen.saturating_add(1);
                if let ClaimAction::Announce(_) = self.claimer.on_address_claimed(Address::new(id.source), Name::from_bytes(&bytes)) {
                    self.claim_due = true;
                }
                Handled::Network
            }
            pgn::REQUEST => {
                let me = self.address();
                let to_me = id.destination == me && me != address::NULL;
                if !(to_me || id.destination == address::GLOBAL) {
                    return Handled::Ignored;
                }
                let Some(&[a, b, c]) = data.get(..3).and_then(|d| <&[u8; 3]>::try_from(d).ok()) else { return Handled::Ignored };
                let requested = u32::from_le_bytes([a, b, c, 0]);
                match requested {
                    pgn::ADDRESS_CLAIMED => {
                        // Answered even after giving up (with Cannot Claim).
                        self.claimer.on_request();
                        self.claim_due = true;
                    }
                    pgn::DM1 if self.address() != address::NULL => self.dm1_requested = true,
                    // J1939-21: a request to a specific address for a group
                    // it does not provide is answered with a NACK; a global
                    // one is not answered.
                    _ if to_me => self.nack = Some(requested),
                    _ => {}
                }
                Handled::Network
            }
            pgn::ACKNOWLEDGEMENT | pgn::TP_CM | pgn::TP_DT | pgn::DM1 => Handled::Ignored,
            _ => Handled::Application,
        }
    }

    /// The network frames of one period of `period_ms`, in sending order:
    /// the claim, a NACK, the DM1 (one frame, or the BAM announcement and,
    /// every 50 ms, its next data packet). `dtcs` are this period's active
    /// codes; `send` queues a frame.
    pub fn period(&mut self, period_ms: u32, dtcs: &DtcTable, mut send: impl FnMut(CanFrame)) {
        self.claim_age_ms = self.claim_age_ms.saturating_add(period_ms);
        self.dm1_age_ms = self.dm1_age_ms.saturating_add(period_ms);
        if self.claim_due {
            self.claim_due = false;
            self.claim_age_ms = 0;
            let name = self.claimer.name().to_bytes();
            // `claim()` from Idle, the current claim otherwise.
            let source = if self.claimer.state() == ClaimState::Idle {
                self.claimer.claim().source.as_u8()
            } else {
                self.address()
            };
            if let Some(f) = frame(j1939_id(PRIORITY_CLAIM, pgn::ADDRESS_CLAIMED | u32::from(address::GLOBAL), source), name) {
                send(f);
            }
        }
        if self.claimer.state() == ClaimState::Claiming && self.claim_age_ms >= CLAIM_WINDOW_MS {
            self.claimer.contention_window_elapsed();
        }
        let me = self.address();
        if me == address::NULL {
            self.nack = None;
            self.dm1_requested = false;
            self.bam = None;
            return;
        }
        if self.bam.is_some_and(|b| b.source != me) {
            // The address changed under a transfer: it is abandoned.
            self.bam = None;
        }
        if !self.may_send() {
            // A self-configurable address sends nothing else for 250 ms.
            return;
        }
        if let Some(requested) = self.nack.take() {
            let ack = Acknowledgement { address: Address::new(me), ..Acknowledgement::negative(Pgn::new_masked(requested)) };
            if let Some(f) = frame(j1939_id(PRIORITY_ACK, pgn::ACKNOWLEDGEMENT | u32::from(address::GLOBAL), me), ack.encode()) {
                send(f);
            }
        }
        if let Some(bam) = self.bam.as_mut() {
            bam.since_ms = bam.since_ms.saturating_add(period_ms);
            if bam.since_ms >= BAM_PACKET_MS {
                bam.since_ms = 0;
                let start = usize::from(bam.next - 1) * 7;
                let end = (start + 7).min(usize::from(bam.len));
                let chunk = self.dm1.get(start..end).unwrap_or(&[]);
                let dt = TpDt::new(bam.next, chunk);
                if let Some(f) = frame(j1939_id(PRIORITY_TP, pgn::TP_DT | u32::from(address::GLOBAL), me), dt.encode()) {
                    send(f);
                }
                if bam.next >= bam.packets {
                    self.bam = None;
                } else {
                    bam.next += 1;
                }
            }
            return;
        }
        if self.dm1_age_ms >= DM1_PERIOD_MS || self.dm1_requested {
            self.dm1_age_ms = 0;
            self.dm1_requested = false;
            self.send_dm1(me, dtcs, &mut send);
        }
    }

    fn send_dm1(&mut self, me: u8, dtcs: &DtcTable, send: &mut impl FnMut(CanFrame)) {
        let any = dtcs.count() > 0;
        let on = if any { LampStatus::On } else { LampStatus::Off };
        // Flash status 0b11 is "do not flash" (0b00 would be a slow flash).
        let mut lamps = Lamps::new().with_status(Lamp::AmberWarning, on);
        for lamp in Lamp::ALL {
            lamps = lamps.with_flash_status(lamp, LampStatus::NotAvailable);
        }
        self.dm1 = [0xFF; DM1_MAX_BYTES];
        let [l0, l1] = lamps.encode();
        let mut len = 2;
        if let Some([a, b]) = self.dm1.get_mut(..2).and_then(|s| <&mut [u8; 2]>::try_from(s).ok()) {
            (*a, *b) = (l0, l1);
        }
        for dtc in dtcs.active().take(DM1_MAX_DTCS) {
            if let Some(slot) = self.dm1.get_mut(len..len + 4) {
                slot.copy_from_slice(&dtc.encode());
                len += 4;
            }
        }
        if len <= 6 {
            // No code (J1939-73: SPN 0, FMI 0) or one: a single frame.
            if len == 2 {
                if let Some(s) = self.dm1.get_mut(2..6) {
                    s.copy_from_slice(&[0, 0, 0, 0]);
                }
            }
            let mut data = [0xFF; 8];
            data.copy_from_slice(self.dm1.get(..8).unwrap_or(&[0xFF; 8]));
            if let Some(f) = frame(j1939_id(PRIORITY_DM1, pgn::DM1, me), data) {
                send(f);
            }
        } else if let Ok(cm) = TpCm::bam(len as u16, Pgn::new_masked(pgn::DM1)) {
            if let Some(f) = frame(j1939_id(PRIORITY_TP, pgn::TP_CM | u32::from(address::GLOBAL), me), cm.encode()) {
                send(f);
            }
            let packets = len.div_ceil(7) as u8;
            self.bam = Some(Bam { source: me, len: len as u16, packets, next: 1, since_ms: 0 });
        }
    }
}

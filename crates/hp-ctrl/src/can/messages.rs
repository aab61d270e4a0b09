//! The ECU's own frames of `python/hpctl/data/hpctl.dbc` (the E2E-protected
//! Proprietary B parameter groups): PGNs, priorities, data IDs, timing,
//! signals, and one typed struct per message. The standard J1939 parameter
//! groups (address claim, request, DM1, transport protocol, acknowledgement)
//! are [`super::j1939`]'s.
//!
//! The DBC is the source of truth; this module mirrors it by hand and
//! `tests/test_can_codec.py` checks every number here against the DBC as
//! `cantools` reads it. Per-corner messages exist for corners 0..=7; an
//! ECU for `N` corners uses the first `N`.

use super::signal::{EncodeError, Signal};
use crate::input_group;
use crate::vehicle::{vehicle_group, HeightMode, MAX_CORNERS};
use crate::{DamperMode, DriveMode, DriverMode, SequencerState, SpringMode};

/// A signal with its DBC name and unit.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SignalDef {
    pub name: &'static str,
    pub unit: &'static str,
    pub signal: Signal,
}

/// Source addresses of the DBC's nodes (their identifiers in the DBC).
pub mod address {
    /// The ECU's preferred source address (it may have to claim another).
    pub const HPECU: u8 = 0x2F;
    /// The corner sensor clusters.
    pub const SENSORS: u8 = 0x90;
    /// The vehicle network gateway.
    pub const VEHICLE: u8 = 0x91;
    /// Test bench, service tool, processor-in-the-loop host.
    pub const TESTER: u8 = 0xF9;
    /// J1939's null address (Cannot Claim Address).
    pub const NULL: u8 = 0xFE;
    /// J1939's global (broadcast) destination.
    pub const GLOBAL: u8 = 0xFF;
}

/// A 29-bit J1939 identifier: priority (3 bits), PGN (18 bits; for a PDU1
/// group its low byte is the destination), source address.
///
/// ```
/// use hp_ctrl::can::messages::j1939_id;
/// assert_eq!(j1939_id(6, 0xFECA, 0x2F), 0x18FE_CA2F); // DM1 from 0x2F
/// ```
pub const fn j1939_id(priority: u8, pgn: u32, source: u8) -> u32 {
    ((priority as u32 & 0x7) << 26) | ((pgn & 0x3_FFFF) << 8) | source as u32
}

/// A message as the DBC defines it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MessageDef {
    pub kind: Kind,
    /// Parameter group number (Proprietary B: 0xFF00-0xFFFF).
    pub pgn: u32,
    /// J1939 priority, 0 (highest) to 7.
    pub priority: u8,
    /// The sender's source address in the DBC's identifier.
    pub source: u8,
    /// E2E data ID (DBC attribute `E2E_DataID`).
    pub data_id: u16,
    /// When it is sent (DBC `GenMsgCycleTime`, `GenMsgStartDelayTime`).
    pub timing: Timing,
    /// Receive timeout, ms (DBC `E2E_TimeoutMs`; 0 = not supervised).
    pub timeout_ms: u16,
    /// Input groups the message feeds (corner groups for corner
    /// messages, [`vehicle_group`] for vehicle messages), 0 if none.
    pub group: u16,
    /// The payload bits (little-endian `u64`) of the E2E header and the
    /// signals; every other bit must be zero.
    pub defined_bits: u64,
}

impl MessageDef {
    /// The identifier the DBC gives it (the sender at its DBC address).
    pub const fn id(&self) -> u32 {
        j1939_id(self.priority, self.pgn, self.source)
    }
}

/// When a message is sent.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Timing {
    /// Send period, ms (DBC `GenMsgCycleTime`; 0 = event-driven).
    pub cycle_ms: u16,
    /// First send, ms after start (DBC `GenMsgStartDelayTime`); then every
    /// `cycle_ms`. Spreads the slower frames over the periods.
    pub start_delay_ms: u16,
}

impl Timing {
    const fn every(cycle_ms: u16, start_delay_ms: u16) -> Self {
        Timing { cycle_ms, start_delay_ms }
    }

    /// True if a cyclic message is due in the 1 ms period `index` (from 0).
    ///
    /// ```
    /// use hp_ctrl::can::messages::Kind;
    /// let due: Vec<u32> = (0..300).filter(|&k| Kind::DiagE2e.def().timing.due(k)).collect();
    /// assert_eq!(due, [99, 199, 299]);
    /// ```
    pub fn due(&self, index: u32) -> bool {
        let (cycle, delay) = (u32::from(self.cycle_ms), u32::from(self.start_delay_ms));
        // `%` rather than `is_multiple_of` (Rust 1.87): the firmware builds with
        // 1.85 (docs/firmware.md). `cycle != 0` is checked first.
        cycle != 0 && index >= delay && (index - delay) % cycle == 0
    }
}

/// Bits 0..=11 (CRC byte and counter nibble) of the E2E header.
const HEADER_BITS: u64 = 0x0FFF;

const fn defined_bits(signals: &[SignalDef]) -> u64 {
    let mut bits = HEADER_BITS;
    let mut rest = signals;
    while let [first, tail @ ..] = rest {
        let mask = first.signal.field_mask();
        assert!(bits & mask == 0, "signals overlap");
        bits |= mask;
        rest = tail;
    }
    bits
}

/// Every message of the database; corner messages carry the corner, 0..=7.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Kind {
    PilTick,
    Vehicle,
    Steering,
    Driver,
    Inclination,
    CornerPressures(u8),
    CornerMotion(u8),
    Valves,
    CornerStatus(u8),
    CornerCtrl(u8),
    CornerDiag(u8),
    DiagE2e,
    DiagLink,
}

/// Number of messages of the database.
pub const KINDS: usize = 5 + 2 * MAX_CORNERS + 1 + 3 * MAX_CORNERS + 2;

#[allow(clippy::indexing_slicing)] // Compile-time evaluation: an index out of range fails the build.
const fn all_kinds() -> [Kind; KINDS] {
    let mut all = [Kind::PilTick; KINDS];
    let fixed = [Kind::PilTick, Kind::Vehicle, Kind::Steering, Kind::Driver, Kind::Inclination];
    let mut n = 0;
    while n < fixed.len() {
        all[n] = fixed[n];
        n += 1;
    }
    let mut c = 0;
    while c < MAX_CORNERS {
        all[5 + c] = Kind::CornerPressures(c as u8);
        all[5 + MAX_CORNERS + c] = Kind::CornerMotion(c as u8);
        all[6 + 2 * MAX_CORNERS + c] = Kind::CornerStatus(c as u8);
        all[6 + 3 * MAX_CORNERS + c] = Kind::CornerCtrl(c as u8);
        all[6 + 4 * MAX_CORNERS + c] = Kind::CornerDiag(c as u8);
        c += 1;
    }
    all[5 + 2 * MAX_CORNERS] = Kind::Valves;
    all[KINDS - 2] = Kind::DiagE2e;
    all[KINDS - 1] = Kind::DiagLink;
    all
}

impl Kind {
    /// All kinds in PGN order.
    pub const ALL: [Kind; KINDS] = all_kinds();

    /// Position in [`Kind::ALL`].
    pub fn index(self) -> usize {
        let c = |k: u8| usize::from(k) % MAX_CORNERS;
        match self {
            Kind::PilTick => 0,
            Kind::Vehicle => 1,
            Kind::Steering => 2,
            Kind::Driver => 3,
            Kind::Inclination => 4,
            Kind::CornerPressures(k) => 5 + c(k),
            Kind::CornerMotion(k) => 5 + MAX_CORNERS + c(k),
            Kind::Valves => 5 + 2 * MAX_CORNERS,
            Kind::CornerStatus(k) => 6 + 2 * MAX_CORNERS + c(k),
            Kind::CornerCtrl(k) => 6 + 3 * MAX_CORNERS + c(k),
            Kind::CornerDiag(k) => 6 + 4 * MAX_CORNERS + c(k),
            Kind::DiagE2e => KINDS - 2,
            Kind::DiagLink => KINDS - 1,
        }
    }

    /// The corner of a corner message.
    pub fn corner(self) -> Option<usize> {
        match self {
            Kind::CornerPressures(k) | Kind::CornerMotion(k) | Kind::CornerStatus(k) | Kind::CornerCtrl(k) | Kind::CornerDiag(k) => {
                Some(usize::from(k))
            }
            _ => None,
        }
    }

    /// True for the messages the ECU sends.
    pub fn ecu_sends(self) -> bool {
        matches!(
            self,
            Kind::Valves | Kind::CornerStatus(_) | Kind::CornerCtrl(_) | Kind::CornerDiag(_) | Kind::DiagE2e | Kind::DiagLink
        )
    }

    /// The message with parameter group number `pgn`.
    pub fn from_pgn(pgn: u32) -> Option<Kind> {
        let c = |base: u32| (pgn.wrapping_sub(base) < MAX_CORNERS as u32).then(|| (pgn - base) as u8);
        Some(match pgn {
            0xFF00 => Kind::PilTick,
            0xFF01 => Kind::Vehicle,
            0xFF02 => Kind::Steering,
            0xFF03 => Kind::Driver,
            0xFF04 => Kind::Inclination,
            0xFF80 => Kind::Valves,
            0xFFE0 => Kind::DiagE2e,
            0xFFE1 => Kind::DiagLink,
            _ => {
                if let Some(k) = c(0xFF10) {
                    Kind::CornerPressures(k)
                } else if let Some(k) = c(0xFF20) {
                    Kind::CornerMotion(k)
                } else if let Some(k) = c(0xFF90) {
                    Kind::CornerStatus(k)
                } else if let Some(k) = c(0xFFA0) {
                    Kind::CornerCtrl(k)
                } else if let Some(k) = c(0xFFB0) {
                    Kind::CornerDiag(k)
                } else {
                    return None;
                }
            }
        })
    }

    /// The DBC name. For tools, tests and the figures build: kept out of
    /// [`MessageDef`] so that the firmware, which never names a message,
    /// does not link the strings.
    pub fn name(self) -> &'static str {
        let corner = |table: usize, k: u8| {
            CORNER_NAMES.get(table).and_then(|names| names.get(usize::from(k))).copied().unwrap_or("")
        };
        match self {
            Kind::PilTick => "HP_PilTick",
            Kind::Vehicle => "HP_Vehicle",
            Kind::Steering => "HP_Steering",
            Kind::Driver => "HP_Driver",
            Kind::Inclination => "HP_Inclination",
            Kind::CornerPressures(k) => corner(0, k),
            Kind::CornerMotion(k) => corner(1, k),
            Kind::Valves => "HP_Valves",
            Kind::CornerStatus(k) => corner(2, k),
            Kind::CornerCtrl(k) => corner(3, k),
            Kind::CornerDiag(k) => corner(4, k),
            Kind::DiagE2e => "HP_DiagE2E",
            Kind::DiagLink => "HP_DiagLink",
        }
    }

    /// The message named `name` (DBC spelling).
    pub fn from_name(name: &str) -> Option<Kind> {
        Kind::ALL.iter().copied().find(|k| k.name() == name)
    }

    /// The signals after the E2E header, in DBC order, with their names
    /// and units: for tools and tests (the codec reads and writes each
    /// signal directly, so the firmware does not link this table).
    pub fn signals(self) -> &'static [SignalDef] {
        match self {
            Kind::PilTick => PIL_TICK_SIGNALS,
            Kind::Vehicle => VEHICLE_SIGNALS,
            Kind::Steering => STEERING_SIGNALS,
            Kind::Driver => DRIVER_SIGNALS,
            Kind::Inclination => INCLINATION_SIGNALS,
            Kind::CornerPressures(_) => PRESSURES_SIGNALS,
            Kind::CornerMotion(_) => MOTION_SIGNALS,
            Kind::Valves => VALVES_SIGNALS,
            Kind::CornerStatus(_) => STATUS_SIGNALS,
            Kind::CornerCtrl(_) => CTRL_SIGNALS,
            Kind::CornerDiag(_) => DIAG_SIGNALS,
            Kind::DiagE2e => DIAG_E2E_SIGNALS,
            Kind::DiagLink => DIAG_LINK_SIGNALS,
        }
    }

    /// The signal named `name` (DBC spelling).
    pub fn signal(self, name: &str) -> Option<&'static Signal> {
        self.signals().iter().find(|s| s.name == name).map(|s| &s.signal)
    }

    /// The DBC definition.
    pub fn def(self) -> &'static MessageDef {
        DEFS.get(self.index()).unwrap_or(&PIL_TICK)
    }
}

const fn sig(name: &'static str, unit: &'static str, signal: Signal) -> SignalDef {
    SignalDef { name, unit, signal }
}

// Signals, named after the DBC. Ranges in raw units = DBC [min|max] / factor.
const TICK_INDEX: Signal = Signal::uint(16, 16, 65535);
const VEHICLE_SPEED: Signal = Signal::new(16, 15, false, 0.01, 0.0, 0, 10_000);
const BRAKE_PRESSED: Signal = Signal::flag(31);
const LAT_ACC: Signal = Signal::new(32, 16, true, 0.001, 0.0, -30_000, 30_000);
const LONG_ACC: Signal = Signal::new(48, 16, true, 0.001, 0.0, -30_000, 30_000);
const STEER_ANGLE: Signal = Signal::new(16, 16, true, 0.001, 0.0, -20_000, 20_000);
const STEER_RATE: Signal = Signal::new(32, 16, true, 0.001, 0.0, -30_000, 30_000);
const DRIVER_MODE: Signal = Signal::uint(16, 2, 2);
const HEIGHT_MODE_REQUEST: Signal = Signal::uint(18, 3, 5);
const RIDE_HEIGHT_REQUEST: Signal = Signal::new(32, 16, true, 1e-5, 0.0, -12_500, 12_500);
const BODY_PITCH: Signal = Signal::new(16, 16, true, 1e-4, 0.0, -15_000, 15_000);
const BODY_ROLL: Signal = Signal::new(32, 16, true, 1e-4, 0.0, -15_000, 15_000);
const PRESSURE_SMALL: Signal = Signal::new(16, 24, false, 10.0, 0.0, 0, 12_000_000);
const PRESSURE_LARGE: Signal = Signal::new(40, 24, false, 10.0, 0.0, 0, 12_000_000);
const STRUT_DISP: Signal = Signal::new(16, 16, true, 1e-5, 0.0, -25_000, 25_000);
const BODY_ACC: Signal = Signal::new(32, 16, true, 0.002, 0.0, -30_000, 30_000);
const GAS_TEMP: Signal = Signal::new(48, 16, false, 0.01, 233.15, 0, 24_000);
/// Valve 5 of corner `k` is bit `16 + 2k`, valve 6 bit `17 + 2k`.
const fn valve5(k: u8) -> Signal {
    Signal::flag(16 + 2 * k)
}
const fn valve6(k: u8) -> Signal {
    Signal::flag(17 + 2 * k)
}
/// Corner `k`'s safe state is bit `56 + k`.
const fn corner_safe(k: u8) -> Signal {
    Signal::flag(56 + k)
}
const STEP_INDEX: Signal = Signal::uint(32, 16, 65535);
const DRIVE_MODE: Signal = Signal::flag(48);
const HEIGHT_MODE: Signal = Signal::uint(49, 3, 6);
const LINK_FAULT_CMD: Signal = Signal::flag(52);
const RIDE_HEIGHT: Signal = Signal::new(16, 16, true, 1e-5, 0.0, -30_000, 30_000);
const SEQUENCER: Signal = Signal::uint(32, 3, 4);
const SPRING_MODE: Signal = Signal::flag(35);
const DAMPER_MODE: Signal = Signal::flag(36);
const CORNER_SAFE: Signal = Signal::flag(37);
const GAS_SETTLED: Signal = Signal::flag(38);
const GAS_FAULT: Signal = Signal::flag(39);
const GAS_CHARGE: Signal = Signal::new(40, 16, false, 1e-4, 0.0, 0, 20_000);
const GAS_CONFIDENCE: Signal = Signal::new(56, 7, false, 0.01, 0.0, 0, 100);
const PRESSURE_LOAD: Signal = Signal::new(16, 24, false, 10.0, 0.0, 0, 12_000_000);
const PRESSURE_LARGE_TARGET: Signal = Signal::new(40, 24, false, 10.0, 0.0, 0, 12_000_000);
const DIAG: Signal = Signal::uint(16, 32, 4_294_967_295);
const REJECT_CRC: Signal = Signal::uint(16, 8, 255);
const REJECT_LENGTH: Signal = Signal::uint(24, 8, 255);
const REJECT_UNKNOWN_ID: Signal = Signal::uint(32, 8, 255);
const REJECT_REPEATED: Signal = Signal::uint(40, 8, 255);
const REJECT_SKIPPED: Signal = Signal::uint(48, 8, 255);
const REJECT_RANGE: Signal = Signal::uint(56, 8, 255);
const TIMEOUT_COUNT: Signal = Signal::uint(16, 8, 255);
const WINDOW_REJECTS: Signal = Signal::uint(24, 8, 255);
const STALE_VEHICLE: Signal = Signal::uint(32, 4, 15);
const LINK_FAULT_DIAG: Signal = Signal::flag(36);
const VEHICLE_DIAG: Signal = Signal::uint(37, 3, 7);
const STALE_CORNERS: Signal = Signal::uint(40, 16, 65535);

// The signals of each message, in DBC order.
const PIL_TICK_SIGNALS: &[SignalDef] = &[sig("TickIndex", "", TICK_INDEX)];
const VEHICLE_SIGNALS: &[SignalDef] = &[
    sig("VehicleSpeed", "m/s", VEHICLE_SPEED),
    sig("BrakePressed", "", BRAKE_PRESSED),
    sig("LatAcc", "m/s^2", LAT_ACC),
    sig("LongAcc", "m/s^2", LONG_ACC),
];
const STEERING_SIGNALS: &[SignalDef] = &[sig("SteerAngle", "rad", STEER_ANGLE), sig("SteerRate", "rad/s", STEER_RATE)];
const DRIVER_SIGNALS: &[SignalDef] = &[
    sig("DriverMode", "", DRIVER_MODE),
    sig("HeightMode", "", HEIGHT_MODE_REQUEST),
    sig("RideHeightRequest", "m", RIDE_HEIGHT_REQUEST),
];
const INCLINATION_SIGNALS: &[SignalDef] = &[sig("BodyPitch", "rad", BODY_PITCH), sig("BodyRoll", "rad", BODY_ROLL)];
const PRESSURES_SIGNALS: &[SignalDef] = &[sig("PressureSmall", "Pa", PRESSURE_SMALL), sig("PressureLarge", "Pa", PRESSURE_LARGE)];
const MOTION_SIGNALS: &[SignalDef] = &[sig("StrutDisp", "m", STRUT_DISP), sig("BodyAcc", "m/s^2", BODY_ACC), sig("GasTemp", "K", GAS_TEMP)];
const VALVES_SIGNALS: &[SignalDef] = &[
    sig("Valve5Open_0", "", valve5(0)),
    sig("Valve6Open_0", "", valve6(0)),
    sig("Valve5Open_1", "", valve5(1)),
    sig("Valve6Open_1", "", valve6(1)),
    sig("Valve5Open_2", "", valve5(2)),
    sig("Valve6Open_2", "", valve6(2)),
    sig("Valve5Open_3", "", valve5(3)),
    sig("Valve6Open_3", "", valve6(3)),
    sig("Valve5Open_4", "", valve5(4)),
    sig("Valve6Open_4", "", valve6(4)),
    sig("Valve5Open_5", "", valve5(5)),
    sig("Valve6Open_5", "", valve6(5)),
    sig("Valve5Open_6", "", valve5(6)),
    sig("Valve6Open_6", "", valve6(6)),
    sig("Valve5Open_7", "", valve5(7)),
    sig("Valve6Open_7", "", valve6(7)),
    sig("StepIndex", "", STEP_INDEX),
    sig("DriveMode", "", DRIVE_MODE),
    sig("HeightMode", "", HEIGHT_MODE),
    sig("LinkFault", "", LINK_FAULT_CMD),
    sig("CornerSafe_0", "", corner_safe(0)),
    sig("CornerSafe_1", "", corner_safe(1)),
    sig("CornerSafe_2", "", corner_safe(2)),
    sig("CornerSafe_3", "", corner_safe(3)),
    sig("CornerSafe_4", "", corner_safe(4)),
    sig("CornerSafe_5", "", corner_safe(5)),
    sig("CornerSafe_6", "", corner_safe(6)),
    sig("CornerSafe_7", "", corner_safe(7)),
];
const STATUS_SIGNALS: &[SignalDef] = &[
    sig("RideHeight", "m", RIDE_HEIGHT),
    sig("Sequencer", "", SEQUENCER),
    sig("SpringMode", "", SPRING_MODE),
    sig("DamperMode", "", DAMPER_MODE),
    sig("CornerSafe", "", CORNER_SAFE),
    sig("GasChargeSettled", "", GAS_SETTLED),
    sig("GasChargeFault", "", GAS_FAULT),
    sig("GasCharge", "", GAS_CHARGE),
    sig("GasLossConfidence", "", GAS_CONFIDENCE),
];
const CTRL_SIGNALS: &[SignalDef] = &[sig("PressureLoad", "Pa", PRESSURE_LOAD), sig("PressureLargeTarget", "Pa", PRESSURE_LARGE_TARGET)];
const DIAG_SIGNALS: &[SignalDef] = &[sig("Diag", "", DIAG)];
const DIAG_E2E_SIGNALS: &[SignalDef] = &[
    sig("RejectCrc", "", REJECT_CRC),
    sig("RejectLength", "", REJECT_LENGTH),
    sig("RejectUnknownId", "", REJECT_UNKNOWN_ID),
    sig("RejectRepeated", "", REJECT_REPEATED),
    sig("RejectSkipped", "", REJECT_SKIPPED),
    sig("RejectRange", "", REJECT_RANGE),
];
const DIAG_LINK_SIGNALS: &[SignalDef] = &[
    sig("TimeoutCount", "", TIMEOUT_COUNT),
    sig("WindowRejects", "", WINDOW_REJECTS),
    sig("StaleVehicle", "", STALE_VEHICLE),
    sig("LinkFault", "", LINK_FAULT_DIAG),
    sig("VehicleDiag", "", VEHICLE_DIAG),
    sig("StaleCorners", "", STALE_CORNERS),
];

const CORNER_GROUPS_PRESSURES: u16 = input_group::PRESSURES;
const CORNER_GROUPS_MOTION: u16 = input_group::STRUT | input_group::BODY | input_group::TEMPERATURE;

#[allow(clippy::too_many_arguments)] // One argument per field of the DBC's BO_ line and attributes.
const fn def(
    kind: Kind,
    priority: u8,
    pgn: u32,
    source: u8,
    data_id: u16,
    timing: Timing,
    timeout_ms: u16,
    group: u16,
    signals: &[SignalDef],
) -> MessageDef {
    MessageDef { kind, pgn, priority, source, data_id, timing, timeout_ms, group, defined_bits: defined_bits(signals) }
}

use address::{HPECU, SENSORS, TESTER, VEHICLE as GATEWAY};

pub const PIL_TICK: MessageDef =
    def(Kind::PilTick, 3, 0xFF00, TESTER, 0x0A0F, Timing::every(0, 0), 0, 0, PIL_TICK_SIGNALS);

const CORNER_NAMES: [[&str; MAX_CORNERS]; 5] = [
    [
        "HP_CornerPressures_0",
        "HP_CornerPressures_1",
        "HP_CornerPressures_2",
        "HP_CornerPressures_3",
        "HP_CornerPressures_4",
        "HP_CornerPressures_5",
        "HP_CornerPressures_6",
        "HP_CornerPressures_7",
    ],
    [
        "HP_CornerMotion_0",
        "HP_CornerMotion_1",
        "HP_CornerMotion_2",
        "HP_CornerMotion_3",
        "HP_CornerMotion_4",
        "HP_CornerMotion_5",
        "HP_CornerMotion_6",
        "HP_CornerMotion_7",
    ],
    [
        "HP_CornerStatus_0",
        "HP_CornerStatus_1",
        "HP_CornerStatus_2",
        "HP_CornerStatus_3",
        "HP_CornerStatus_4",
        "HP_CornerStatus_5",
        "HP_CornerStatus_6",
        "HP_CornerStatus_7",
    ],
    [
        "HP_CornerCtrl_0",
        "HP_CornerCtrl_1",
        "HP_CornerCtrl_2",
        "HP_CornerCtrl_3",
        "HP_CornerCtrl_4",
        "HP_CornerCtrl_5",
        "HP_CornerCtrl_6",
        "HP_CornerCtrl_7",
    ],
    [
        "HP_CornerDiag_0",
        "HP_CornerDiag_1",
        "HP_CornerDiag_2",
        "HP_CornerDiag_3",
        "HP_CornerDiag_4",
        "HP_CornerDiag_5",
        "HP_CornerDiag_6",
        "HP_CornerDiag_7",
    ],
];

#[allow(clippy::indexing_slicing)] // Compile-time evaluation: an index out of range fails the build.
const fn all_defs() -> [MessageDef; KINDS] {
    let mut d = [PIL_TICK; KINDS];
    d[1] = def(Kind::Vehicle, 3, 0xFF01, GATEWAY, 0x0A04, Timing::every(10, 0), 50, vehicle_group::VEHICLE, VEHICLE_SIGNALS);
    d[2] = def(Kind::Steering, 3, 0xFF02, GATEWAY, 0x0A05, Timing::every(10, 0), 50, vehicle_group::STEERING, STEERING_SIGNALS);
    d[3] = def(Kind::Driver, 6, 0xFF03, GATEWAY, 0x0A07, Timing::every(100, 0), 500, vehicle_group::DRIVER, DRIVER_SIGNALS);
    d[4] = def(
        Kind::Inclination,
        6,
        0xFF04,
        GATEWAY,
        0x0A08,
        Timing::every(10, 0),
        50,
        vehicle_group::INCLINATION,
        INCLINATION_SIGNALS,
    );
    let mut c = 0;
    while c < MAX_CORNERS {
        let k = c as u8;
        let c32 = c as u32;
        let c16 = c as u16;
        d[5 + c] = def(
            Kind::CornerPressures(k),
            3,
            0xFF10 + c32,
            SENSORS,
            0x0A10 + c16,
            Timing::every(1, 0),
            10,
            CORNER_GROUPS_PRESSURES,
            PRESSURES_SIGNALS,
        );
        d[5 + MAX_CORNERS + c] = def(
            Kind::CornerMotion(k),
            3,
            0xFF20 + c32,
            SENSORS,
            0x0A20 + c16,
            Timing::every(1, 0),
            10,
            CORNER_GROUPS_MOTION,
            MOTION_SIGNALS,
        );
        d[6 + 2 * MAX_CORNERS + c] = def(
            Kind::CornerStatus(k),
            6,
            0xFF90 + c32,
            HPECU,
            0x0B10 + c16,
            Timing::every(10, 1 + c16),
            50,
            0,
            STATUS_SIGNALS,
        );
        d[6 + 3 * MAX_CORNERS + c] = def(
            Kind::CornerCtrl(k),
            6,
            0xFFA0 + c32,
            HPECU,
            0x0B20 + c16,
            Timing::every(100, 20 + c16),
            500,
            0,
            CTRL_SIGNALS,
        );
        d[6 + 4 * MAX_CORNERS + c] = def(
            Kind::CornerDiag(k),
            6,
            0xFFB0 + c32,
            HPECU,
            0x0B30 + c16,
            Timing::every(100, 40 + c16),
            500,
            0,
            DIAG_SIGNALS,
        );
        c += 1;
    }
    d[5 + 2 * MAX_CORNERS] = def(Kind::Valves, 3, 0xFF80, HPECU, 0x0B01, Timing::every(1, 0), 10, 0, VALVES_SIGNALS);
    d[KINDS - 2] = def(Kind::DiagE2e, 6, 0xFFE0, HPECU, 0x0B03, Timing::every(100, 99), 500, 0, DIAG_E2E_SIGNALS);
    d[KINDS - 1] = def(Kind::DiagLink, 6, 0xFFE1, HPECU, 0x0B04, Timing::every(100, 99), 500, 0, DIAG_LINK_SIGNALS);
    d
}

/// Every definition, in the order of [`Kind::ALL`].
static DEFS: [MessageDef; KINDS] = all_defs();

/// `HP_PilTick`: one lock-step control period (emulator only).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct PilTick {
    pub index: u16,
}

/// `HP_Vehicle`.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Vehicle {
    pub speed_m_s: f64,
    pub brake_pressed: bool,
    pub lat_acc_m_s2: f64,
    pub long_acc_m_s2: f64,
}

/// `HP_Steering`.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Steering {
    pub angle_rad: f64,
    pub rate_rad_s: f64,
}

/// `HP_Driver`.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Driver {
    pub mode: DriverMode,
    pub height_mode: HeightMode,
    pub ride_height_request_m: f64,
}

/// `HP_Inclination`.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Inclination {
    pub pitch_rad: f64,
    pub roll_rad: f64,
}

/// `HP_CornerPressures_k`.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Pressures {
    pub p_gas_pa: f64,
    pub p_gas2_pa: f64,
}

/// `HP_CornerMotion_k`.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Motion {
    pub strut_disp_m: f64,
    pub body_acc_m_s2: f64,
    pub t_gas_k: f64,
}

/// `HP_Valves`: every corner's valves in one period (corners beyond the
/// ECU's are sent closed).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Valves {
    pub valve5_open: [bool; MAX_CORNERS],
    pub valve6_open: [bool; MAX_CORNERS],
    /// Control period index modulo 65536.
    pub step_index: u16,
    pub drive_mode: DriveMode,
    pub height_mode: HeightMode,
    pub link_fault: bool,
    pub corner_safe: [bool; MAX_CORNERS],
}

/// `HP_CornerStatus_k`.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Status {
    pub ride_height_m: f64,
    pub sequencer: SequencerState,
    pub spring_mode: SpringMode,
    pub damper_mode: DamperMode,
    pub safe: bool,
    pub gas_settled: bool,
    pub gas_fault: bool,
    /// Charge relative to the nominal.
    pub gas_charge: f64,
    /// Confidence that at least 2 % of the charge is lost, 0..1.
    pub gas_loss_confidence: f64,
}

/// `HP_CornerCtrl_k`: the ride-height control's reference pressures.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Ctrl {
    /// Estimated static load pressure (`Outputs::p_load_pa`).
    pub p_load_pa: f64,
    /// Pressure in L that holds the corner's request (`Outputs::p_gas2_target_pa`).
    pub p_gas2_target_pa: f64,
}

/// `HP_CornerDiag_k`: the corner controller's flags.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct Diag {
    pub diag: u32,
}

/// `HP_DiagE2E`: rejected frames per reason since start, saturating.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct DiagE2e {
    pub crc: u8,
    pub length: u8,
    pub unknown_id: u8,
    pub repeated: u8,
    pub skipped: u8,
    pub range: u8,
}

/// `HP_DiagLink`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct DiagLink {
    /// Timeouts since start, saturating.
    pub timeout_count: u8,
    /// Rejects in the current supervision window, saturating.
    pub window_rejects: u8,
    /// Stale vehicle messages: bit 0 HP_Vehicle, 1 HP_Steering, 2
    /// HP_Driver, 3 HP_Inclination.
    pub stale_vehicle: u8,
    pub link_fault: bool,
    /// Vehicle-level flags (`vehicle_diag` bits 0-2).
    pub vehicle_diag: u8,
    /// Stale corner messages: bit `2k` pressures, `2k + 1` motion.
    pub stale_corners: u16,
}

/// Any message of the database, decoded to physical values; corner
/// messages carry their corner.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Message {
    PilTick(PilTick),
    Vehicle(Vehicle),
    Steering(Steering),
    Driver(Driver),
    Inclination(Inclination),
    CornerPressures(u8, Pressures),
    CornerMotion(u8, Motion),
    Valves(Valves),
    CornerStatus(u8, Status),
    CornerCtrl(u8, Ctrl),
    CornerDiag(u8, Diag),
    DiagE2e(DiagE2e),
    DiagLink(DiagLink),
}

fn flag(s: &Signal, w: u64) -> Option<bool> {
    s.checked_raw_in(w).map(|raw| raw != 0)
}

fn uint(s: &Signal, w: u64) -> Option<u32> {
    s.checked_raw_in(w).and_then(|raw| u32::try_from(raw).ok())
}

fn small(s: &Signal, w: u64) -> Option<u8> {
    s.checked_raw_in(w).and_then(|raw| u8::try_from(raw).ok())
}

fn sequencer(raw: u32) -> Option<SequencerState> {
    Some(match raw {
        0 => SequencerState::Idle,
        1 => SequencerState::Lowering,
        2 => SequencerState::Raising,
        3 => SequencerState::Holding,
        4 => SequencerState::Blocked,
        _ => return None,
    })
}

impl Message {
    /// Which message this is.
    pub fn kind(&self) -> Kind {
        match *self {
            Message::PilTick(_) => Kind::PilTick,
            Message::Vehicle(_) => Kind::Vehicle,
            Message::Steering(_) => Kind::Steering,
            Message::Driver(_) => Kind::Driver,
            Message::Inclination(_) => Kind::Inclination,
            Message::CornerPressures(k, _) => Kind::CornerPressures(k),
            Message::CornerMotion(k, _) => Kind::CornerMotion(k),
            Message::Valves(_) => Kind::Valves,
            Message::CornerStatus(k, _) => Kind::CornerStatus(k),
            Message::CornerCtrl(k, _) => Kind::CornerCtrl(k),
            Message::CornerDiag(k, _) => Kind::CornerDiag(k),
            Message::DiagE2e(_) => Kind::DiagE2e,
            Message::DiagLink(_) => Kind::DiagLink,
        }
    }

    /// The signals as the payload's bits (a little-endian `u64`, header
    /// bits zero). Fails on a NaN, infinite or out-of-range value.
    pub fn signal_bits(&self) -> Result<u64, EncodeError> {
        if self.kind().ecu_sends() {
            self.output_bits()
        } else {
            self.input_bits()
        }
    }

    /// [`Message::signal_bits`] of a message to the ECU; `OutOfRange` for
    /// one the ECU sends. (The halves are separate so that the firmware,
    /// which encodes only its own messages, links only that half.)
    pub fn input_bits(&self) -> Result<u64, EncodeError> {
        Ok(match self {
            Message::PilTick(m) => TICK_INDEX.uint_bits(u32::from(m.index))?,
            Message::Vehicle(m) => {
                VEHICLE_SPEED.bits_of(m.speed_m_s)?
                    | BRAKE_PRESSED.flag_bits(m.brake_pressed)
                    | LAT_ACC.bits_of(m.lat_acc_m_s2)?
                    | LONG_ACC.bits_of(m.long_acc_m_s2)?
            }
            Message::Steering(m) => STEER_ANGLE.bits_of(m.angle_rad)? | STEER_RATE.bits_of(m.rate_rad_s)?,
            Message::Driver(m) => {
                DRIVER_MODE.uint_bits(m.mode as u32)?
                    | HEIGHT_MODE_REQUEST.uint_bits(m.height_mode as u32)?
                    | RIDE_HEIGHT_REQUEST.bits_of(m.ride_height_request_m)?
            }
            Message::Inclination(m) => BODY_PITCH.bits_of(m.pitch_rad)? | BODY_ROLL.bits_of(m.roll_rad)?,
            Message::CornerPressures(_, m) => PRESSURE_SMALL.bits_of(m.p_gas_pa)? | PRESSURE_LARGE.bits_of(m.p_gas2_pa)?,
            Message::CornerMotion(_, m) => STRUT_DISP.bits_of(m.strut_disp_m)? | BODY_ACC.bits_of(m.body_acc_m_s2)? | GAS_TEMP.bits_of(m.t_gas_k)?,
            _ => return Err(EncodeError::OutOfRange),
        })
    }

    /// [`Message::signal_bits`] of a message the ECU sends; `OutOfRange`
    /// for one to the ECU.
    pub fn output_bits(&self) -> Result<u64, EncodeError> {
        Ok(match self {
            Message::Valves(m) => {
                let mut bits = STEP_INDEX.uint_bits(u32::from(m.step_index))?
                    | DRIVE_MODE.uint_bits(m.drive_mode as u32)?
                    | HEIGHT_MODE.uint_bits(m.height_mode as u32)?
                    | LINK_FAULT_CMD.flag_bits(m.link_fault);
                for (k, ((&v5, &v6), &safe)) in m.valve5_open.iter().zip(&m.valve6_open).zip(&m.corner_safe).enumerate() {
                    let k = k as u8;
                    bits |= valve5(k).flag_bits(v5) | valve6(k).flag_bits(v6) | corner_safe(k).flag_bits(safe);
                }
                bits
            }
            Message::CornerStatus(_, m) => {
                RIDE_HEIGHT.bits_of(m.ride_height_m)?
                    | SEQUENCER.uint_bits(m.sequencer as u32)?
                    | SPRING_MODE.uint_bits(m.spring_mode as u32)?
                    | DAMPER_MODE.uint_bits(m.damper_mode as u32)?
                    | CORNER_SAFE.flag_bits(m.safe)
                    | GAS_SETTLED.flag_bits(m.gas_settled)
                    | GAS_FAULT.flag_bits(m.gas_fault)
                    | GAS_CHARGE.bits_of(m.gas_charge)?
                    | GAS_CONFIDENCE.bits_of(m.gas_loss_confidence)?
            }
            Message::CornerCtrl(_, m) => PRESSURE_LOAD.bits_of(m.p_load_pa)? | PRESSURE_LARGE_TARGET.bits_of(m.p_gas2_target_pa)?,
            Message::CornerDiag(_, m) => DIAG.uint_bits(m.diag)?,
            Message::DiagE2e(m) => {
                REJECT_CRC.uint_bits(u32::from(m.crc))?
                    | REJECT_LENGTH.uint_bits(u32::from(m.length))?
                    | REJECT_UNKNOWN_ID.uint_bits(u32::from(m.unknown_id))?
                    | REJECT_REPEATED.uint_bits(u32::from(m.repeated))?
                    | REJECT_SKIPPED.uint_bits(u32::from(m.skipped))?
                    | REJECT_RANGE.uint_bits(u32::from(m.range))?
            }
            Message::DiagLink(m) => {
                TIMEOUT_COUNT.uint_bits(u32::from(m.timeout_count))?
                    | WINDOW_REJECTS.uint_bits(u32::from(m.window_rejects))?
                    | STALE_VEHICLE.uint_bits(u32::from(m.stale_vehicle))?
                    | LINK_FAULT_DIAG.flag_bits(m.link_fault)
                    | VEHICLE_DIAG.uint_bits(u32::from(m.vehicle_diag))?
                    | STALE_CORNERS.uint_bits(u32::from(m.stale_corners))?
            }
            _ => return Err(EncodeError::OutOfRange),
        })
    }

    /// Reads the signals of a `kind` message from `p`; `None` if any signal
    /// is outside its DBC range (the E2E header is not looked at).
    pub fn read(kind: Kind, p: &[u8; 8]) -> Option<Message> {
        if kind.ecu_sends() {
            Message::read_output(kind, p)
        } else {
            Message::read_input(kind, p)
        }
    }

    /// [`Message::read`] of a message to the ECU; `None` for one the ECU
    /// sends (the receiver links only this half).
    pub fn read_input(kind: Kind, p: &[u8; 8]) -> Option<Message> {
        let w = u64::from_le_bytes(*p);
        Some(match kind {
            Kind::PilTick => Message::PilTick(PilTick { index: u16::try_from(uint(&TICK_INDEX, w)?).ok()? }),
            Kind::Vehicle => Message::Vehicle(Vehicle {
                speed_m_s: VEHICLE_SPEED.value_in(w)?,
                brake_pressed: flag(&BRAKE_PRESSED, w)?,
                lat_acc_m_s2: LAT_ACC.value_in(w)?,
                long_acc_m_s2: LONG_ACC.value_in(w)?,
            }),
            Kind::Steering => Message::Steering(Steering { angle_rad: STEER_ANGLE.value_in(w)?, rate_rad_s: STEER_RATE.value_in(w)? }),
            Kind::Driver => Message::Driver(Driver {
                mode: match uint(&DRIVER_MODE, w)? {
                    0 => DriverMode::Auto,
                    1 => DriverMode::Comfort,
                    2 => DriverMode::Sport,
                    _ => return None,
                },
                height_mode: HeightMode::from_u8(small(&HEIGHT_MODE_REQUEST, w)?)?,
                ride_height_request_m: RIDE_HEIGHT_REQUEST.value_in(w)?,
            }),
            Kind::Inclination => Message::Inclination(Inclination { pitch_rad: BODY_PITCH.value_in(w)?, roll_rad: BODY_ROLL.value_in(w)? }),
            Kind::CornerPressures(k) => {
                Message::CornerPressures(k, Pressures { p_gas_pa: PRESSURE_SMALL.value_in(w)?, p_gas2_pa: PRESSURE_LARGE.value_in(w)? })
            }
            Kind::CornerMotion(k) => Message::CornerMotion(
                k,
                Motion { strut_disp_m: STRUT_DISP.value_in(w)?, body_acc_m_s2: BODY_ACC.value_in(w)?, t_gas_k: GAS_TEMP.value_in(w)? },
            ),
            _ => return None,
        })
    }

    /// [`Message::read`] of a message the ECU sends; `None` for one to the
    /// ECU.
    pub fn read_output(kind: Kind, p: &[u8; 8]) -> Option<Message> {
        let w = u64::from_le_bytes(*p);
        Some(match kind {
            Kind::Valves => {
                let mut m = Valves {
                    step_index: u16::try_from(uint(&STEP_INDEX, w)?).ok()?,
                    drive_mode: if flag(&DRIVE_MODE, w)? { DriveMode::Handling } else { DriveMode::Ride },
                    height_mode: HeightMode::from_u8(small(&HEIGHT_MODE, w)?)?,
                    link_fault: flag(&LINK_FAULT_CMD, w)?,
                    ..Valves::default()
                };
                for (k, ((v5, v6), safe)) in m.valve5_open.iter_mut().zip(m.valve6_open.iter_mut()).zip(m.corner_safe.iter_mut()).enumerate() {
                    let k = k as u8;
                    *v5 = flag(&valve5(k), w)?;
                    *v6 = flag(&valve6(k), w)?;
                    *safe = flag(&corner_safe(k), w)?;
                }
                Message::Valves(m)
            }
            Kind::CornerStatus(k) => Message::CornerStatus(
                k,
                Status {
                    ride_height_m: RIDE_HEIGHT.value_in(w)?,
                    sequencer: sequencer(uint(&SEQUENCER, w)?)?,
                    spring_mode: if flag(&SPRING_MODE, w)? { SpringMode::Soft } else { SpringMode::Hard },
                    damper_mode: if flag(&DAMPER_MODE, w)? { DamperMode::Low } else { DamperMode::High },
                    safe: flag(&CORNER_SAFE, w)?,
                    gas_settled: flag(&GAS_SETTLED, w)?,
                    gas_fault: flag(&GAS_FAULT, w)?,
                    gas_charge: GAS_CHARGE.value_in(w)?,
                    gas_loss_confidence: GAS_CONFIDENCE.value_in(w)?,
                },
            ),
            Kind::CornerCtrl(k) => {
                Message::CornerCtrl(k, Ctrl { p_load_pa: PRESSURE_LOAD.value_in(w)?, p_gas2_target_pa: PRESSURE_LARGE_TARGET.value_in(w)? })
            }
            Kind::CornerDiag(k) => Message::CornerDiag(k, Diag { diag: uint(&DIAG, w)? }),
            Kind::DiagE2e => Message::DiagE2e(DiagE2e {
                crc: small(&REJECT_CRC, w)?,
                length: small(&REJECT_LENGTH, w)?,
                unknown_id: small(&REJECT_UNKNOWN_ID, w)?,
                repeated: small(&REJECT_REPEATED, w)?,
                skipped: small(&REJECT_SKIPPED, w)?,
                range: small(&REJECT_RANGE, w)?,
            }),
            Kind::DiagLink => Message::DiagLink(DiagLink {
                timeout_count: small(&TIMEOUT_COUNT, w)?,
                window_rejects: small(&WINDOW_REJECTS, w)?,
                stale_vehicle: small(&STALE_VEHICLE, w)?,
                link_fault: flag(&LINK_FAULT_DIAG, w)?,
                vehicle_diag: small(&VEHICLE_DIAG, w)?,
                stale_corners: u16::try_from(uint(&STALE_CORNERS, w)?).ok()?,
            }),
            _ => return None,
        })
    }
}

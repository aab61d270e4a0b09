//! The frames of `python/hpctl/data/hpctl.dbc`: identifiers, data IDs, timing, signals,
//! and one typed struct per message.
//!
//! The DBC is the source of truth; this module mirrors it by hand and
//! `tests/test_can_codec.py` checks every number here against the DBC as
//! `cantools` reads it.

use super::signal::{EncodeError, Signal};
use crate::input_group;
use crate::{DamperMode, DriveMode, DriverMode, SequencerState, SpringMode};

/// A signal with its DBC name and unit.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SignalDef {
    pub name: &'static str,
    pub unit: &'static str,
    pub signal: Signal,
}

/// A message as the DBC defines it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MessageDef {
    pub kind: Kind,
    pub name: &'static str,
    /// 11-bit CAN identifier.
    pub id: u16,
    /// E2E data ID (DBC attribute `E2E_DataID`).
    pub data_id: u16,
    /// When it is sent (DBC `GenMsgCycleTime`, `GenMsgStartDelayTime`).
    pub timing: Timing,
    /// Receive timeout, ms (DBC `E2E_TimeoutMs`; 0 = not supervised).
    pub timeout_ms: u16,
    /// Input group ([`input_group`]) the message feeds, 0 if none.
    pub group: u16,
    /// The payload bits (little-endian `u64`) of the E2E header and the
    /// signals; every other bit must be zero.
    pub defined_bits: u64,
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
    /// use hp_ctrl::can::messages::DIAG_E2E;
    /// let due: Vec<u32> = (0..300).filter(|&k| DIAG_E2E.timing.due(k)).collect();
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

impl MessageDef {
    #[allow(clippy::too_many_arguments)] // One argument per field of the DBC's BO_ line and attributes.
    const fn new(kind: Kind, name: &'static str, id: u16, data_id: u16, timing: Timing, timeout_ms: u16, group: u16, signals: &[SignalDef]) -> Self {
        let mut defined_bits = HEADER_BITS;
        let mut rest = signals;
        while let [first, tail @ ..] = rest {
            let mask = first.signal.field_mask();
            assert!(defined_bits & mask == 0, "signals overlap");
            defined_bits |= mask;
            rest = tail;
        }
        MessageDef { kind, name, id, data_id, timing, timeout_ms, group, defined_bits }
    }
}

/// Every message of the database.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Kind {
    PilTick,
    Pressures,
    Strut,
    Body,
    Vehicle,
    Steering,
    Temperature,
    Driver,
    ValveCmd,
    Status,
    HeightCtrl,
    Motion,
    DiagE2e,
    DiagLink,
}

impl Kind {
    /// All kinds in identifier order.
    pub const ALL: [Kind; 14] = [
        Kind::PilTick,
        Kind::Pressures,
        Kind::Strut,
        Kind::Body,
        Kind::Vehicle,
        Kind::Steering,
        Kind::Temperature,
        Kind::Driver,
        Kind::ValveCmd,
        Kind::Status,
        Kind::HeightCtrl,
        Kind::Motion,
        Kind::DiagE2e,
        Kind::DiagLink,
    ];

    /// The messages the ECU receives, in the order of [`Kind::rx_index`].
    pub const ECU_RX: [Kind; 8] = [
        Kind::PilTick,
        Kind::Pressures,
        Kind::Strut,
        Kind::Body,
        Kind::Vehicle,
        Kind::Steering,
        Kind::Temperature,
        Kind::Driver,
    ];

    /// The messages the ECU sends, in the order of [`Kind::tx_index`] and
    /// of sending within a period.
    pub const ECU_TX: [Kind; 6] = [Kind::ValveCmd, Kind::Status, Kind::HeightCtrl, Kind::Motion, Kind::DiagE2e, Kind::DiagLink];

    /// Position in [`Kind::ECU_RX`], if the ECU receives this message.
    pub fn rx_index(self) -> Option<usize> {
        Kind::ECU_RX.iter().position(|&k| k == self)
    }

    /// Position in [`Kind::ECU_TX`], if the ECU sends this message.
    pub fn tx_index(self) -> Option<usize> {
        Kind::ECU_TX.iter().position(|&k| k == self)
    }

    /// The message with CAN identifier `id`.
    pub fn from_id(id: u16) -> Option<Kind> {
        Kind::ALL.iter().copied().find(|k| k.def().id == id)
    }

    /// The signals after the E2E header, in DBC order, with their names
    /// and units: for tools and tests (the codec reads and writes each
    /// signal directly, so the firmware does not link this table).
    pub fn signals(self) -> &'static [SignalDef] {
        match self {
            Kind::PilTick => PIL_TICK_SIGNALS,
            Kind::Pressures => PRESSURES_SIGNALS,
            Kind::Strut => STRUT_SIGNALS,
            Kind::Body => BODY_SIGNALS,
            Kind::Vehicle => VEHICLE_SIGNALS,
            Kind::Steering => STEERING_SIGNALS,
            Kind::Temperature => TEMPERATURE_SIGNALS,
            Kind::Driver => DRIVER_SIGNALS,
            Kind::ValveCmd => VALVE_CMD_SIGNALS,
            Kind::Status => STATUS_SIGNALS,
            Kind::HeightCtrl => HEIGHT_CTRL_SIGNALS,
            Kind::Motion => MOTION_SIGNALS,
            Kind::DiagE2e => DIAG_E2E_SIGNALS,
            Kind::DiagLink => DIAG_LINK_SIGNALS,
        }
    }

    /// The signal named `name` (DBC spelling).
    pub fn signal(self, name: &str) -> Option<&'static Signal> {
        self.signals().iter().find(|s| s.name == name).map(|s| &s.signal)
    }

    /// The message named `name` (DBC spelling).
    pub fn from_name(name: &str) -> Option<Kind> {
        Kind::ALL.iter().copied().find(|k| k.def().name == name)
    }

    /// The DBC definition.
    pub fn def(self) -> &'static MessageDef {
        match self {
            Kind::PilTick => &PIL_TICK,
            Kind::Pressures => &PRESSURES,
            Kind::Strut => &STRUT,
            Kind::Body => &BODY,
            Kind::Vehicle => &VEHICLE,
            Kind::Steering => &STEERING,
            Kind::Temperature => &TEMPERATURE,
            Kind::Driver => &DRIVER,
            Kind::ValveCmd => &VALVE_CMD,
            Kind::Status => &STATUS,
            Kind::HeightCtrl => &HEIGHT_CTRL,
            Kind::Motion => &MOTION,
            Kind::DiagE2e => &DIAG_E2E,
            Kind::DiagLink => &DIAG_LINK,
        }
    }
}

const fn sig(name: &'static str, unit: &'static str, signal: Signal) -> SignalDef {
    SignalDef { name, unit, signal }
}

// Signals, named after the DBC. Ranges in raw units = DBC [min|max] / factor.
const TICK_INDEX: Signal = Signal::uint(16, 16, 65535);
const PRESSURE_SMALL: Signal = Signal::new(16, 24, false, 10.0, 0.0, 0, 12_000_000);
const PRESSURE_LARGE: Signal = Signal::new(40, 24, false, 10.0, 0.0, 0, 12_000_000);
const STRUT_DISP: Signal = Signal::new(16, 16, true, 1e-5, 0.0, -25_000, 25_000);
const BODY_ACC: Signal = Signal::new(16, 16, true, 0.002, 0.0, -30_000, 30_000);
const VEHICLE_SPEED: Signal = Signal::new(16, 15, false, 0.01, 0.0, 0, 10_000);
const BRAKE_PRESSED: Signal = Signal::flag(31);
const LAT_ACC: Signal = Signal::new(32, 16, true, 0.001, 0.0, -30_000, 30_000);
const LONG_ACC: Signal = Signal::new(48, 16, true, 0.001, 0.0, -30_000, 30_000);
const STEER_ANGLE: Signal = Signal::new(16, 16, true, 0.001, 0.0, -20_000, 20_000);
const STEER_RATE: Signal = Signal::new(32, 16, true, 0.001, 0.0, -30_000, 30_000);
const GAS_TEMP: Signal = Signal::new(16, 16, false, 0.01, 233.15, 0, 24_000);
const DRIVER_MODE: Signal = Signal::uint(16, 2, 2);
const RIDE_HEIGHT_REQUEST: Signal = Signal::new(32, 16, true, 1e-5, 0.0, -12_500, 12_500);
const VALVE5_OPEN: Signal = Signal::flag(16);
const VALVE6_OPEN: Signal = Signal::flag(17);
const DRIVE_MODE: Signal = Signal::flag(18);
const SPRING_MODE: Signal = Signal::flag(19);
const DAMPER_MODE: Signal = Signal::flag(20);
const SEQUENCER: Signal = Signal::uint(21, 3, 4);
const LINK_FAULT_CMD: Signal = Signal::flag(24);
const STEP_INDEX: Signal = Signal::uint(32, 16, 65535);
const RIDE_HEIGHT: Signal = Signal::new(16, 16, true, 1e-5, 0.0, -30_000, 30_000);
const DIAG: Signal = Signal::uint(32, 32, 4_294_967_295);
const PRESSURE_LOAD: Signal = Signal::new(16, 24, false, 10.0, 0.0, 0, 12_000_000);
const PRESSURE_LARGE_TARGET: Signal = Signal::new(40, 24, false, 10.0, 0.0, 0, 12_000_000);
const STRUT_VEL: Signal = Signal::new(16, 16, true, 0.0005, 0.0, -20_000, 20_000);
const BODY_VEL: Signal = Signal::new(32, 16, true, 0.0005, 0.0, -20_000, 20_000);
const REJECT_CRC: Signal = Signal::uint(16, 8, 255);
const REJECT_LENGTH: Signal = Signal::uint(24, 8, 255);
const REJECT_UNKNOWN_ID: Signal = Signal::uint(32, 8, 255);
const REJECT_REPEATED: Signal = Signal::uint(40, 8, 255);
const REJECT_SKIPPED: Signal = Signal::uint(48, 8, 255);
const REJECT_RANGE: Signal = Signal::uint(56, 8, 255);
const TIMEOUT_COUNT: Signal = Signal::uint(16, 8, 255);
const STALE_GROUPS: Signal = Signal::uint(24, 7, 127);
const LINK_FAULT_DIAG: Signal = Signal::flag(31);
const WINDOW_REJECTS: Signal = Signal::uint(32, 8, 255);

// The signals of each message, in DBC order.
const PIL_TICK_SIGNALS: &[SignalDef] = &[sig("TickIndex", "", TICK_INDEX)];
const PRESSURES_SIGNALS: &[SignalDef] = &[sig("PressureSmall", "Pa", PRESSURE_SMALL), sig("PressureLarge", "Pa", PRESSURE_LARGE)];
const STRUT_SIGNALS: &[SignalDef] = &[sig("StrutDisp", "m", STRUT_DISP)];
const BODY_SIGNALS: &[SignalDef] = &[sig("BodyAcc", "m/s^2", BODY_ACC)];
const VEHICLE_SIGNALS: &[SignalDef] = &[
    sig("VehicleSpeed", "m/s", VEHICLE_SPEED),
    sig("BrakePressed", "", BRAKE_PRESSED),
    sig("LatAcc", "m/s^2", LAT_ACC),
    sig("LongAcc", "m/s^2", LONG_ACC),
];
const STEERING_SIGNALS: &[SignalDef] = &[sig("SteerAngle", "rad", STEER_ANGLE), sig("SteerRate", "rad/s", STEER_RATE)];
const TEMPERATURE_SIGNALS: &[SignalDef] = &[sig("GasTemp", "K", GAS_TEMP)];
const DRIVER_SIGNALS: &[SignalDef] = &[sig("DriverMode", "", DRIVER_MODE), sig("RideHeightRequest", "m", RIDE_HEIGHT_REQUEST)];
const VALVE_CMD_SIGNALS: &[SignalDef] = &[
    sig("Valve5Open", "", VALVE5_OPEN),
    sig("Valve6Open", "", VALVE6_OPEN),
    sig("DriveMode", "", DRIVE_MODE),
    sig("SpringMode", "", SPRING_MODE),
    sig("DamperMode", "", DAMPER_MODE),
    sig("Sequencer", "", SEQUENCER),
    sig("LinkFault", "", LINK_FAULT_CMD),
    sig("StepIndex", "", STEP_INDEX),
];
const STATUS_SIGNALS: &[SignalDef] = &[sig("RideHeight", "m", RIDE_HEIGHT), sig("Diag", "", DIAG)];
const HEIGHT_CTRL_SIGNALS: &[SignalDef] = &[sig("PressureLoad", "Pa", PRESSURE_LOAD), sig("PressureLargeTarget", "Pa", PRESSURE_LARGE_TARGET)];
const MOTION_SIGNALS: &[SignalDef] = &[sig("StrutVel", "m/s", STRUT_VEL), sig("BodyVel", "m/s", BODY_VEL)];
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
    sig("StaleGroups", "", STALE_GROUPS),
    sig("LinkFault", "", LINK_FAULT_DIAG),
    sig("WindowRejects", "", WINDOW_REJECTS),
];

pub const PIL_TICK: MessageDef = MessageDef::new(
    Kind::PilTick,
    "HP_PilTick",
    0x050,
    0x0A0F,
    Timing::every(0, 0),
    0,
    0,
    PIL_TICK_SIGNALS,
);
pub const PRESSURES: MessageDef = MessageDef::new(
    Kind::Pressures,
    "HP_Pressures",
    0x100,
    0x0A01,
    Timing::every(1, 0),
    10,
    input_group::PRESSURES,
    PRESSURES_SIGNALS,
);
pub const STRUT: MessageDef = MessageDef::new(
    Kind::Strut,
    "HP_Strut",
    0x101,
    0x0A02,
    Timing::every(1, 0),
    10,
    input_group::STRUT,
    STRUT_SIGNALS,
);
pub const BODY: MessageDef = MessageDef::new(
    Kind::Body,
    "HP_Body",
    0x102,
    0x0A03,
    Timing::every(1, 0),
    10,
    input_group::BODY,
    BODY_SIGNALS,
);
pub const VEHICLE: MessageDef = MessageDef::new(
    Kind::Vehicle,
    "HP_Vehicle",
    0x110,
    0x0A04,
    Timing::every(10, 0),
    50,
    input_group::VEHICLE,
    VEHICLE_SIGNALS,
);
pub const STEERING: MessageDef = MessageDef::new(
    Kind::Steering,
    "HP_Steering",
    0x111,
    0x0A05,
    Timing::every(10, 0),
    50,
    input_group::STEERING,
    STEERING_SIGNALS,
);
pub const TEMPERATURE: MessageDef = MessageDef::new(
    Kind::Temperature,
    "HP_Temperature",
    0x120,
    0x0A06,
    Timing::every(100, 0),
    500,
    input_group::TEMPERATURE,
    TEMPERATURE_SIGNALS,
);
pub const DRIVER: MessageDef = MessageDef::new(
    Kind::Driver,
    "HP_Driver",
    0x130,
    0x0A07,
    Timing::every(100, 0),
    500,
    input_group::DRIVER,
    DRIVER_SIGNALS,
);
pub const VALVE_CMD: MessageDef = MessageDef::new(
    Kind::ValveCmd,
    "HP_ValveCmd",
    0x200,
    0x0B01,
    Timing::every(1, 0),
    10,
    0,
    VALVE_CMD_SIGNALS,
);
pub const STATUS: MessageDef = MessageDef::new(
    Kind::Status,
    "HP_Status",
    0x210,
    0x0B02,
    Timing::every(1, 0),
    10,
    0,
    STATUS_SIGNALS,
);
pub const HEIGHT_CTRL: MessageDef = MessageDef::new(
    Kind::HeightCtrl,
    "HP_HeightCtrl",
    0x211,
    0x0B05,
    Timing::every(10, 3),
    50,
    0,
    HEIGHT_CTRL_SIGNALS,
);
pub const MOTION: MessageDef = MessageDef::new(
    Kind::Motion,
    "HP_Motion",
    0x212,
    0x0B06,
    Timing::every(10, 6),
    50,
    0,
    MOTION_SIGNALS,
);
pub const DIAG_E2E: MessageDef = MessageDef::new(
    Kind::DiagE2e,
    "HP_DiagE2E",
    0x220,
    0x0B03,
    Timing::every(100, 99),
    500,
    0,
    DIAG_E2E_SIGNALS,
);
pub const DIAG_LINK: MessageDef = MessageDef::new(
    Kind::DiagLink,
    "HP_DiagLink",
    0x221,
    0x0B04,
    Timing::every(100, 99),
    500,
    0,
    DIAG_LINK_SIGNALS,
);

/// `HP_PilTick`: one lock-step control period (emulator only).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct PilTick {
    pub index: u16,
}

/// `HP_Pressures`.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Pressures {
    pub p_gas_pa: f64,
    pub p_gas2_pa: f64,
}

/// `HP_Strut`.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Strut {
    pub disp_m: f64,
}

/// `HP_Body`.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Body {
    pub acc_m_s2: f64,
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

/// `HP_Temperature`.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Temperature {
    pub t_gas_k: f64,
}

/// `HP_Driver`.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Driver {
    pub mode: DriverMode,
    pub ride_height_request_m: f64,
}

/// `HP_ValveCmd`.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct ValveCmd {
    pub valve5_open: bool,
    pub valve6_open: bool,
    pub drive_mode: DriveMode,
    pub spring_mode: SpringMode,
    pub damper_mode: DamperMode,
    pub sequencer: SequencerState,
    pub link_fault: bool,
    /// Control period index modulo 65536.
    pub step_index: u16,
}

/// `HP_Status`.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Status {
    pub ride_height_m: f64,
    pub diag: u32,
}

/// `HP_HeightCtrl`: the ride-height control's reference pressures.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct HeightCtrl {
    /// Estimated static load pressure (`Outputs::p_load_pa`).
    pub p_load_pa: f64,
    /// Pressure in L that holds the requested height
    /// (`Outputs::p_gas2_target_pa`).
    pub p_gas2_target_pa: f64,
}

/// `HP_Motion`: the velocity estimates of the skyhook law.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Motion {
    /// Strut compression rate, positive = compressing.
    pub strut_vel_m_s: f64,
    /// Body vertical velocity, positive = up.
    pub body_vel_m_s: f64,
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
    /// Input groups currently timed out (or never received).
    pub stale_groups: u8,
    pub link_fault: bool,
    /// Rejects in the current supervision window, saturating.
    pub window_rejects: u8,
}

/// Any message of the database, decoded to physical values.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Message {
    PilTick(PilTick),
    Pressures(Pressures),
    Strut(Strut),
    Body(Body),
    Vehicle(Vehicle),
    Steering(Steering),
    Temperature(Temperature),
    Driver(Driver),
    ValveCmd(ValveCmd),
    Status(Status),
    HeightCtrl(HeightCtrl),
    Motion(Motion),
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

impl Message {
    /// Which message this is.
    pub fn kind(&self) -> Kind {
        match self {
            Message::PilTick(_) => Kind::PilTick,
            Message::Pressures(_) => Kind::Pressures,
            Message::Strut(_) => Kind::Strut,
            Message::Body(_) => Kind::Body,
            Message::Vehicle(_) => Kind::Vehicle,
            Message::Steering(_) => Kind::Steering,
            Message::Temperature(_) => Kind::Temperature,
            Message::Driver(_) => Kind::Driver,
            Message::ValveCmd(_) => Kind::ValveCmd,
            Message::Status(_) => Kind::Status,
            Message::HeightCtrl(_) => Kind::HeightCtrl,
            Message::Motion(_) => Kind::Motion,
            Message::DiagE2e(_) => Kind::DiagE2e,
            Message::DiagLink(_) => Kind::DiagLink,
        }
    }

    /// Writes the signals into bytes 2..=7 of `p` (the E2E header, bytes
    /// 0 and 1, is not touched). Fails on a NaN, infinite or out-of-range
    /// value.
    pub fn write(&self, p: &mut [u8; 8]) -> Result<(), EncodeError> {
        let header = u64::from_le_bytes(*p) & 0xFFFF;
        *p = (header | self.signal_bits()?).to_le_bytes();
        Ok(())
    }

    /// The signals as the payload's bits (a little-endian `u64`, header
    /// bits zero).
    pub fn signal_bits(&self) -> Result<u64, EncodeError> {
        Ok(match self {
            Message::PilTick(m) => TICK_INDEX.uint_bits(u32::from(m.index))?,
            Message::Pressures(m) => PRESSURE_SMALL.bits_of(m.p_gas_pa)? | PRESSURE_LARGE.bits_of(m.p_gas2_pa)?,
            Message::Strut(m) => STRUT_DISP.bits_of(m.disp_m)?,
            Message::Body(m) => BODY_ACC.bits_of(m.acc_m_s2)?,
            Message::Vehicle(m) => {
                VEHICLE_SPEED.bits_of(m.speed_m_s)?
                    | BRAKE_PRESSED.flag_bits(m.brake_pressed)
                    | LAT_ACC.bits_of(m.lat_acc_m_s2)?
                    | LONG_ACC.bits_of(m.long_acc_m_s2)?
            }
            Message::Steering(m) => STEER_ANGLE.bits_of(m.angle_rad)? | STEER_RATE.bits_of(m.rate_rad_s)?,
            Message::Temperature(m) => GAS_TEMP.bits_of(m.t_gas_k)?,
            Message::Driver(m) => DRIVER_MODE.uint_bits(m.mode as u32)? | RIDE_HEIGHT_REQUEST.bits_of(m.ride_height_request_m)?,
            Message::ValveCmd(m) => {
                VALVE5_OPEN.flag_bits(m.valve5_open)
                    | VALVE6_OPEN.flag_bits(m.valve6_open)
                    | DRIVE_MODE.uint_bits(m.drive_mode as u32)?
                    | SPRING_MODE.uint_bits(m.spring_mode as u32)?
                    | DAMPER_MODE.uint_bits(m.damper_mode as u32)?
                    | SEQUENCER.uint_bits(m.sequencer as u32)?
                    | LINK_FAULT_CMD.flag_bits(m.link_fault)
                    | STEP_INDEX.uint_bits(u32::from(m.step_index))?
            }
            Message::Status(m) => RIDE_HEIGHT.bits_of(m.ride_height_m)? | DIAG.uint_bits(m.diag)?,
            Message::HeightCtrl(m) => PRESSURE_LOAD.bits_of(m.p_load_pa)? | PRESSURE_LARGE_TARGET.bits_of(m.p_gas2_target_pa)?,
            Message::Motion(m) => STRUT_VEL.bits_of(m.strut_vel_m_s)? | BODY_VEL.bits_of(m.body_vel_m_s)?,
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
                    | STALE_GROUPS.uint_bits(u32::from(m.stale_groups))?
                    | LINK_FAULT_DIAG.flag_bits(m.link_fault)
                    | WINDOW_REJECTS.uint_bits(u32::from(m.window_rejects))?
            }
        })
    }

    /// Reads the signals of a `kind` message from `p`; `None` if any signal
    /// is outside its DBC range (the E2E header is not looked at).
    pub fn read(kind: Kind, p: &[u8; 8]) -> Option<Message> {
        let w = u64::from_le_bytes(*p);
        Some(match kind {
            Kind::PilTick => Message::PilTick(PilTick { index: u16::try_from(uint(&TICK_INDEX, w)?).ok()? }),
            Kind::Pressures => Message::Pressures(Pressures {
                p_gas_pa: PRESSURE_SMALL.value_in(w)?,
                p_gas2_pa: PRESSURE_LARGE.value_in(w)?,
            }),
            Kind::Strut => Message::Strut(Strut { disp_m: STRUT_DISP.value_in(w)? }),
            Kind::Body => Message::Body(Body { acc_m_s2: BODY_ACC.value_in(w)? }),
            Kind::Vehicle => Message::Vehicle(Vehicle {
                speed_m_s: VEHICLE_SPEED.value_in(w)?,
                brake_pressed: flag(&BRAKE_PRESSED, w)?,
                lat_acc_m_s2: LAT_ACC.value_in(w)?,
                long_acc_m_s2: LONG_ACC.value_in(w)?,
            }),
            Kind::Steering => Message::Steering(Steering {
                angle_rad: STEER_ANGLE.value_in(w)?,
                rate_rad_s: STEER_RATE.value_in(w)?,
            }),
            Kind::Temperature => Message::Temperature(Temperature { t_gas_k: GAS_TEMP.value_in(w)? }),
            Kind::Driver => Message::Driver(Driver {
                mode: match uint(&DRIVER_MODE, w)? {
                    0 => DriverMode::Auto,
                    1 => DriverMode::Comfort,
                    2 => DriverMode::Sport,
                    _ => return None,
                },
                ride_height_request_m: RIDE_HEIGHT_REQUEST.value_in(w)?,
            }),
            Kind::ValveCmd => Message::ValveCmd(ValveCmd {
                valve5_open: flag(&VALVE5_OPEN, w)?,
                valve6_open: flag(&VALVE6_OPEN, w)?,
                drive_mode: if flag(&DRIVE_MODE, w)? { DriveMode::Handling } else { DriveMode::Ride },
                spring_mode: if flag(&SPRING_MODE, w)? { SpringMode::Soft } else { SpringMode::Hard },
                damper_mode: if flag(&DAMPER_MODE, w)? { DamperMode::Low } else { DamperMode::High },
                sequencer: match uint(&SEQUENCER, w)? {
                    0 => SequencerState::Idle,
                    1 => SequencerState::Lowering,
                    2 => SequencerState::Raising,
                    3 => SequencerState::Holding,
                    4 => SequencerState::Blocked,
                    _ => return None,
                },
                link_fault: flag(&LINK_FAULT_CMD, w)?,
                step_index: u16::try_from(uint(&STEP_INDEX, w)?).ok()?,
            }),
            Kind::Status => Message::Status(Status { ride_height_m: RIDE_HEIGHT.value_in(w)?, diag: uint(&DIAG, w)? }),
            Kind::HeightCtrl => Message::HeightCtrl(HeightCtrl {
                p_load_pa: PRESSURE_LOAD.value_in(w)?,
                p_gas2_target_pa: PRESSURE_LARGE_TARGET.value_in(w)?,
            }),
            Kind::Motion => Message::Motion(Motion { strut_vel_m_s: STRUT_VEL.value_in(w)?, body_vel_m_s: BODY_VEL.value_in(w)? }),
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
                stale_groups: small(&STALE_GROUPS, w)?,
                link_fault: flag(&LINK_FAULT_DIAG, w)?,
                window_rejects: small(&WINDOW_REJECTS, w)?,
            }),
        })
    }
}

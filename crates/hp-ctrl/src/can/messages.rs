//! The frames of `can/hpctl.dbc`: identifiers, data IDs, timing, signals,
//! and one typed struct per message.
//!
//! The DBC is the source of truth; this module mirrors it by hand and
//! `tests/test_can_dbc.py` checks every number here against the DBC as
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
    /// Send period, ms (DBC `GenMsgCycleTime`; 0 = event-driven).
    pub cycle_ms: u16,
    /// Receive timeout, ms (DBC `E2E_TimeoutMs`; 0 = not supervised).
    pub timeout_ms: u16,
    /// Input group ([`input_group`]) the message feeds, 0 if none.
    pub group: u16,
    /// The signals after the E2E header, in DBC order.
    pub signals: &'static [SignalDef],
}

impl MessageDef {
    /// The signal named `name` (DBC spelling).
    pub fn signal(&self, name: &str) -> Option<&'static Signal> {
        self.signals.iter().find(|s| s.name == name).map(|s| &s.signal)
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
    DiagE2e,
    DiagLink,
}

impl Kind {
    /// All kinds in identifier order.
    pub const ALL: [Kind; 12] = [
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

    /// The messages the ECU sends, in the order of [`Kind::tx_index`].
    pub const ECU_TX: [Kind; 4] = [Kind::ValveCmd, Kind::Status, Kind::DiagE2e, Kind::DiagLink];

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

pub const PIL_TICK: MessageDef = MessageDef {
    kind: Kind::PilTick,
    name: "HP_PilTick",
    id: 0x050,
    data_id: 0x0A0F,
    cycle_ms: 0,
    timeout_ms: 0,
    group: 0,
    signals: &[sig("TickIndex", "", TICK_INDEX)],
};
pub const PRESSURES: MessageDef = MessageDef {
    kind: Kind::Pressures,
    name: "HP_Pressures",
    id: 0x100,
    data_id: 0x0A01,
    cycle_ms: 1,
    timeout_ms: 10,
    group: input_group::PRESSURES,
    signals: &[sig("PressureSmall", "Pa", PRESSURE_SMALL), sig("PressureLarge", "Pa", PRESSURE_LARGE)],
};
pub const STRUT: MessageDef = MessageDef {
    kind: Kind::Strut,
    name: "HP_Strut",
    id: 0x101,
    data_id: 0x0A02,
    cycle_ms: 1,
    timeout_ms: 10,
    group: input_group::STRUT,
    signals: &[sig("StrutDisp", "m", STRUT_DISP)],
};
pub const BODY: MessageDef = MessageDef {
    kind: Kind::Body,
    name: "HP_Body",
    id: 0x102,
    data_id: 0x0A03,
    cycle_ms: 1,
    timeout_ms: 10,
    group: input_group::BODY,
    signals: &[sig("BodyAcc", "m/s^2", BODY_ACC)],
};
pub const VEHICLE: MessageDef = MessageDef {
    kind: Kind::Vehicle,
    name: "HP_Vehicle",
    id: 0x110,
    data_id: 0x0A04,
    cycle_ms: 10,
    timeout_ms: 50,
    group: input_group::VEHICLE,
    signals: &[
        sig("VehicleSpeed", "m/s", VEHICLE_SPEED),
        sig("BrakePressed", "", BRAKE_PRESSED),
        sig("LatAcc", "m/s^2", LAT_ACC),
        sig("LongAcc", "m/s^2", LONG_ACC),
    ],
};
pub const STEERING: MessageDef = MessageDef {
    kind: Kind::Steering,
    name: "HP_Steering",
    id: 0x111,
    data_id: 0x0A05,
    cycle_ms: 10,
    timeout_ms: 50,
    group: input_group::STEERING,
    signals: &[sig("SteerAngle", "rad", STEER_ANGLE), sig("SteerRate", "rad/s", STEER_RATE)],
};
pub const TEMPERATURE: MessageDef = MessageDef {
    kind: Kind::Temperature,
    name: "HP_Temperature",
    id: 0x120,
    data_id: 0x0A06,
    cycle_ms: 100,
    timeout_ms: 500,
    group: input_group::TEMPERATURE,
    signals: &[sig("GasTemp", "K", GAS_TEMP)],
};
pub const DRIVER: MessageDef = MessageDef {
    kind: Kind::Driver,
    name: "HP_Driver",
    id: 0x130,
    data_id: 0x0A07,
    cycle_ms: 100,
    timeout_ms: 500,
    group: input_group::DRIVER,
    signals: &[sig("DriverMode", "", DRIVER_MODE), sig("RideHeightRequest", "m", RIDE_HEIGHT_REQUEST)],
};
pub const VALVE_CMD: MessageDef = MessageDef {
    kind: Kind::ValveCmd,
    name: "HP_ValveCmd",
    id: 0x200,
    data_id: 0x0B01,
    cycle_ms: 1,
    timeout_ms: 10,
    group: 0,
    signals: &[
        sig("Valve5Open", "", VALVE5_OPEN),
        sig("Valve6Open", "", VALVE6_OPEN),
        sig("DriveMode", "", DRIVE_MODE),
        sig("SpringMode", "", SPRING_MODE),
        sig("DamperMode", "", DAMPER_MODE),
        sig("Sequencer", "", SEQUENCER),
        sig("LinkFault", "", LINK_FAULT_CMD),
        sig("StepIndex", "", STEP_INDEX),
    ],
};
pub const STATUS: MessageDef = MessageDef {
    kind: Kind::Status,
    name: "HP_Status",
    id: 0x210,
    data_id: 0x0B02,
    cycle_ms: 1,
    timeout_ms: 10,
    group: 0,
    signals: &[sig("RideHeight", "m", RIDE_HEIGHT), sig("Diag", "", DIAG)],
};
pub const DIAG_E2E: MessageDef = MessageDef {
    kind: Kind::DiagE2e,
    name: "HP_DiagE2E",
    id: 0x220,
    data_id: 0x0B03,
    cycle_ms: 100,
    timeout_ms: 500,
    group: 0,
    signals: &[
        sig("RejectCrc", "", REJECT_CRC),
        sig("RejectLength", "", REJECT_LENGTH),
        sig("RejectUnknownId", "", REJECT_UNKNOWN_ID),
        sig("RejectRepeated", "", REJECT_REPEATED),
        sig("RejectSkipped", "", REJECT_SKIPPED),
        sig("RejectRange", "", REJECT_RANGE),
    ],
};
pub const DIAG_LINK: MessageDef = MessageDef {
    kind: Kind::DiagLink,
    name: "HP_DiagLink",
    id: 0x221,
    data_id: 0x0B04,
    cycle_ms: 100,
    timeout_ms: 500,
    group: 0,
    signals: &[
        sig("TimeoutCount", "", TIMEOUT_COUNT),
        sig("StaleGroups", "", STALE_GROUPS),
        sig("LinkFault", "", LINK_FAULT_DIAG),
        sig("WindowRejects", "", WINDOW_REJECTS),
    ],
};

/// `HP_PilTick`: one lock-step control period (emulator only).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct PilTick {
    pub index: u16,
}

/// `HP_Pressures`.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Pressures {
    pub p_small_pa: f64,
    pub p_large_pa: f64,
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
    DiagE2e(DiagE2e),
    DiagLink(DiagLink),
}

fn flag(s: &Signal, p: &[u8; 8]) -> Option<bool> {
    s.checked_raw(p).map(|raw| raw != 0)
}

fn uint(s: &Signal, p: &[u8; 8]) -> Option<u32> {
    s.checked_raw(p).and_then(|raw| u32::try_from(raw).ok())
}

fn small(s: &Signal, p: &[u8; 8]) -> Option<u8> {
    s.checked_raw(p).and_then(|raw| u8::try_from(raw).ok())
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
            Message::DiagE2e(_) => Kind::DiagE2e,
            Message::DiagLink(_) => Kind::DiagLink,
        }
    }

    /// Writes the signals into bytes 2..=7 of `p` (the E2E header is not
    /// touched). Fails on a NaN, infinite or out-of-range value.
    pub fn write(&self, p: &mut [u8; 8]) -> Result<(), EncodeError> {
        match self {
            Message::PilTick(m) => TICK_INDEX.put_uint(p, u32::from(m.index)),
            Message::Pressures(m) => {
                PRESSURE_SMALL.put(p, m.p_small_pa)?;
                PRESSURE_LARGE.put(p, m.p_large_pa)
            }
            Message::Strut(m) => STRUT_DISP.put(p, m.disp_m),
            Message::Body(m) => BODY_ACC.put(p, m.acc_m_s2),
            Message::Vehicle(m) => {
                VEHICLE_SPEED.put(p, m.speed_m_s)?;
                BRAKE_PRESSED.put_flag(p, m.brake_pressed);
                LAT_ACC.put(p, m.lat_acc_m_s2)?;
                LONG_ACC.put(p, m.long_acc_m_s2)
            }
            Message::Steering(m) => {
                STEER_ANGLE.put(p, m.angle_rad)?;
                STEER_RATE.put(p, m.rate_rad_s)
            }
            Message::Temperature(m) => GAS_TEMP.put(p, m.t_gas_k),
            Message::Driver(m) => {
                DRIVER_MODE.put_uint(p, m.mode as u32)?;
                RIDE_HEIGHT_REQUEST.put(p, m.ride_height_request_m)
            }
            Message::ValveCmd(m) => {
                VALVE5_OPEN.put_flag(p, m.valve5_open);
                VALVE6_OPEN.put_flag(p, m.valve6_open);
                DRIVE_MODE.put_uint(p, m.drive_mode as u32)?;
                SPRING_MODE.put_uint(p, m.spring_mode as u32)?;
                DAMPER_MODE.put_uint(p, m.damper_mode as u32)?;
                SEQUENCER.put_uint(p, m.sequencer as u32)?;
                LINK_FAULT_CMD.put_flag(p, m.link_fault);
                STEP_INDEX.put_uint(p, u32::from(m.step_index))
            }
            Message::Status(m) => {
                RIDE_HEIGHT.put(p, m.ride_height_m)?;
                DIAG.put_uint(p, m.diag)
            }
            Message::DiagE2e(m) => {
                REJECT_CRC.put_uint(p, u32::from(m.crc))?;
                REJECT_LENGTH.put_uint(p, u32::from(m.length))?;
                REJECT_UNKNOWN_ID.put_uint(p, u32::from(m.unknown_id))?;
                REJECT_REPEATED.put_uint(p, u32::from(m.repeated))?;
                REJECT_SKIPPED.put_uint(p, u32::from(m.skipped))?;
                REJECT_RANGE.put_uint(p, u32::from(m.range))
            }
            Message::DiagLink(m) => {
                TIMEOUT_COUNT.put_uint(p, u32::from(m.timeout_count))?;
                STALE_GROUPS.put_uint(p, u32::from(m.stale_groups))?;
                LINK_FAULT_DIAG.put_flag(p, m.link_fault);
                WINDOW_REJECTS.put_uint(p, u32::from(m.window_rejects))
            }
        }
    }

    /// Reads the signals of a `kind` message from `p`; `None` if any signal
    /// is outside its DBC range (the E2E header is not looked at).
    pub fn read(kind: Kind, p: &[u8; 8]) -> Option<Message> {
        Some(match kind {
            Kind::PilTick => Message::PilTick(PilTick { index: u16::try_from(uint(&TICK_INDEX, p)?).ok()? }),
            Kind::Pressures => Message::Pressures(Pressures {
                p_small_pa: PRESSURE_SMALL.get(p)?,
                p_large_pa: PRESSURE_LARGE.get(p)?,
            }),
            Kind::Strut => Message::Strut(Strut { disp_m: STRUT_DISP.get(p)? }),
            Kind::Body => Message::Body(Body { acc_m_s2: BODY_ACC.get(p)? }),
            Kind::Vehicle => Message::Vehicle(Vehicle {
                speed_m_s: VEHICLE_SPEED.get(p)?,
                brake_pressed: flag(&BRAKE_PRESSED, p)?,
                lat_acc_m_s2: LAT_ACC.get(p)?,
                long_acc_m_s2: LONG_ACC.get(p)?,
            }),
            Kind::Steering => Message::Steering(Steering {
                angle_rad: STEER_ANGLE.get(p)?,
                rate_rad_s: STEER_RATE.get(p)?,
            }),
            Kind::Temperature => Message::Temperature(Temperature { t_gas_k: GAS_TEMP.get(p)? }),
            Kind::Driver => Message::Driver(Driver {
                mode: match uint(&DRIVER_MODE, p)? {
                    0 => DriverMode::Auto,
                    1 => DriverMode::Comfort,
                    2 => DriverMode::Sport,
                    _ => return None,
                },
                ride_height_request_m: RIDE_HEIGHT_REQUEST.get(p)?,
            }),
            Kind::ValveCmd => Message::ValveCmd(ValveCmd {
                valve5_open: flag(&VALVE5_OPEN, p)?,
                valve6_open: flag(&VALVE6_OPEN, p)?,
                drive_mode: if flag(&DRIVE_MODE, p)? { DriveMode::Handling } else { DriveMode::Ride },
                spring_mode: if flag(&SPRING_MODE, p)? { SpringMode::Soft } else { SpringMode::Hard },
                damper_mode: if flag(&DAMPER_MODE, p)? { DamperMode::Low } else { DamperMode::High },
                sequencer: match uint(&SEQUENCER, p)? {
                    0 => SequencerState::Idle,
                    1 => SequencerState::Lowering,
                    2 => SequencerState::Raising,
                    3 => SequencerState::Holding,
                    4 => SequencerState::Blocked,
                    _ => return None,
                },
                link_fault: flag(&LINK_FAULT_CMD, p)?,
                step_index: u16::try_from(uint(&STEP_INDEX, p)?).ok()?,
            }),
            Kind::Status => Message::Status(Status { ride_height_m: RIDE_HEIGHT.get(p)?, diag: uint(&DIAG, p)? }),
            Kind::DiagE2e => Message::DiagE2e(DiagE2e {
                crc: small(&REJECT_CRC, p)?,
                length: small(&REJECT_LENGTH, p)?,
                unknown_id: small(&REJECT_UNKNOWN_ID, p)?,
                repeated: small(&REJECT_REPEATED, p)?,
                skipped: small(&REJECT_SKIPPED, p)?,
                range: small(&REJECT_RANGE, p)?,
            }),
            Kind::DiagLink => Message::DiagLink(DiagLink {
                timeout_count: small(&TIMEOUT_COUNT, p)?,
                stale_groups: small(&STALE_GROUPS, p)?,
                link_fault: flag(&LINK_FAULT_DIAG, p)?,
                window_rejects: small(&WINDOW_REJECTS, p)?,
            }),
        })
    }
}

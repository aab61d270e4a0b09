//! The CAN codec as a line-oriented filter, so tools in other languages
//! (the Python tests) can drive exactly the code the ECU runs.
//!
//! One command per line on stdin, one answer line per command on stdout:
//!
//! - `table`: the message and signal definitions, one `msg NAME ID
//!   DATA_ID CYCLE DELAY TIMEOUT GROUP PGN PRIORITY SOURCE` or `sig ...` line
//!   each, then `end`.
//! - `encode NAME COUNTER SIGNAL=VALUE...`: every signal of message NAME
//!   (DBC names) -> `frame ID HEX` (the frame as the codec writes it), or
//!   `error REASON`.
//! - `decode ID HEX`: stateless decode -> `message NAME COUNTER
//!   SIGNAL=VALUE...`, or `reject REASON`.
//! - `rx ID HEX`: the ECU receiver (4 corners) -> `vehicle GROUPS`,
//!   `corner K GROUPS`, `synced`, `tick INDEX` or `reject REASON`.
//! - `period`: close the receiver's period -> `inputs FIELD=VALUE...`
//!   (vehicle fields, then `cK.FIELD=VALUE` per corner).
//! - `diag`: the receiver's reject counters and link state.
//! - `config`: the seed unit's static operating point (what the ECU's
//!   parameters assume) -> `config static_pressure_pa=.. static_temperature_k=..`.
//! - `ecu ID HEX`: the ECU application (`hp_ctrl::can::ecu::Ecu<4>`, the code
//!   the firmware runs) receives a frame -> `tick INDEX` or `ok`.
//! - `ecu_period`: the ECU closes one control period -> `frames ID#HEX...`,
//!   the frames it sends (the host reference for processor-in-the-loop).
//!
//! Run: `cargo run -p hp-ctrl --example can_codec`.

use std::io::{self, BufRead, Write};

use embedded_can::{ExtendedId, Frame, Id, StandardId};
use hp_ctrl::can::ecu::{Ecu, Link};
use hp_ctrl::can::{self, Accepted, CanFrame, InputDecoder, Kind, LinkParams, Reject};

fn parse_hex(s: &str) -> Option<Vec<u8>> {
    if s.len() % 2 != 0 {
        return None;
    }
    (0..s.len()).step_by(2).map(|i| u8::from_str_radix(s.get(i..i + 2)?, 16).ok()).collect()
}

fn hex(bytes: &[u8]) -> String {
    bytes.iter().map(|b| format!("{b:02X}")).collect()
}

/// An identifier above 0x7FF is extended (J1939), else standard.
fn parse_frame(id: &str, data: &str) -> Result<CanFrame, String> {
    let raw = u32::from_str_radix(id, 16).map_err(|e| format!("bad id: {e}"))?;
    let id: Id = if raw > 0x7FF {
        ExtendedId::new(raw).ok_or("id out of range")?.into()
    } else {
        StandardId::new(raw as u16).ok_or("id out of range")?.into()
    };
    let data = parse_hex(data).ok_or("bad hex")?;
    CanFrame::new(id, &data).ok_or_else(|| "more than 8 bytes".into())
}

fn reason(r: Reject) -> &'static str {
    match r {
        Reject::UnknownId => "unknown_id",
        Reject::Length => "length",
        Reject::Crc => "crc",
        Reject::Repeated => "repeated",
        Reject::Skipped => "skipped",
        Reject::Range => "range",
    }
}

fn table() -> String {
    let mut out = String::new();
    for kind in Kind::ALL {
        let d = kind.def();
        let t = d.timing;
        out += &format!(
            "msg {} {:#x} {:#x} {} {} {} {} {:#x} {} {:#x}\n",
            d.kind.name(),
            d.id(),
            d.data_id,
            t.cycle_ms,
            t.start_delay_ms,
            d.timeout_ms,
            d.group,
            d.pgn,
            d.priority,
            d.source
        );
        for s in kind.signals() {
            let g = &s.signal;
            out += &format!(
                "sig {} {} {} {} {} {:?} {:?} {} {} {}\n",
                d.kind.name(),
                s.name,
                g.start_bit,
                g.bit_len,
                u8::from(g.signed),
                g.factor,
                g.offset,
                g.raw_min,
                g.raw_max,
                if s.unit.is_empty() { "-" } else { s.unit }
            );
        }
    }
    out + "end"
}

/// Parses NAME=VALUE for every signal of the message into a payload, reads
/// it as the typed message, and encodes that with the codec (from the
/// sender's DBC source address).
fn encode(args: &[&str]) -> Result<String, String> {
    let [name, counter, assignments @ ..] = args else {
        return Err("usage: encode NAME COUNTER SIGNAL=VALUE...".into());
    };
    let kind = Kind::from_name(name).ok_or("unknown message")?;
    let counter: u8 = counter.parse().map_err(|_| "bad counter")?;
    let def = kind.def();
    let mut payload = [0u8; 8];
    let mut seen = 0;
    for a in assignments {
        let (sig, value) = a.split_once('=').ok_or("expected SIGNAL=VALUE")?;
        let value: f64 = value.parse().map_err(|_| "bad value")?;
        let s = kind.signal(sig).ok_or_else(|| format!("unknown signal {sig}"))?;
        s.put(&mut payload, value).map_err(|_| "out_of_range")?;
        seen += 1;
    }
    if seen != kind.signals().len() {
        return Err("every signal needs a value".into());
    }
    let msg = can::read_payload(kind, &payload).map_err(|r| reason(r).to_string())?;
    let frame = can::encode(&msg, counter, def.source).map_err(|_| "out_of_range")?;
    Ok(format!("frame {:X} {}", frame_id(&frame), hex(frame.data())))
}

fn decode(frame: &CanFrame) -> String {
    match can::decode(frame) {
        Err(r) => format!("reject {}", reason(r)),
        Ok((msg, counter)) => {
            // Re-encode the typed message and read each signal by name.
            let Ok(again) = can::encode(&msg, counter, 0) else {
                return "error re-encode".into();
            };
            let def = msg.kind().def();
            let values: Vec<String> = msg
                .kind()
                .signals()
                .iter()
                .map(|s| format!("{}={:?}", s.name, s.signal.get(again.payload()).unwrap_or(f64::NAN)))
                .collect();
            format!("message {} {} {}", def.kind.name(), counter, values.join(" "))
        }
    }
}

fn inputs_line<const N: usize>(i: &hp_ctrl::vehicle::VehicleInputs<N>) -> String {
    let v = &i.vehicle;
    let mut s = format!(
        "inputs speed_m_s={:?} lat_acc_m_s2={:?} long_acc_m_s2={:?} steer_angle_rad={:?} steer_rate_rad_s={:?} brake_pressed={} \
         driver_mode={} height_mode={} ride_height_request_m={:?} pitch_rad={:?} roll_rad={:?} fresh={} link_fault={} inclination_stale={}",
        v.speed_m_s,
        v.lat_acc_m_s2,
        v.long_acc_m_s2,
        v.steer_angle_rad,
        v.steer_rate_rad_s,
        u8::from(v.brake_pressed),
        v.driver_mode as u8,
        v.height_mode as u8,
        v.ride_height_request_m,
        v.pitch_rad,
        v.roll_rad,
        i.fresh,
        u8::from(i.link_fault),
        u8::from(i.inclination_stale)
    );
    for (k, c) in i.corners.iter().enumerate() {
        s += &format!(
            " c{k}.p_gas_pa={:?} c{k}.p_gas2_pa={:?} c{k}.strut_disp_m={:?} c{k}.body_acc_m_s2={:?} c{k}.t_gas_k={:?} c{k}.fresh={} c{k}.link_fault={}",
            c.p_gas_pa,
            c.p_gas2_pa,
            c.strut_disp_m,
            c.body_acc_m_s2,
            c.t_gas_k,
            c.fresh,
            u8::from(c.link_fault)
        );
    }
    s
}

/// Collects what the ECU sends.
#[derive(Default)]
struct Collect(Vec<CanFrame>);

impl Link for Collect {
    fn receive(&mut self) -> Option<CanFrame> {
        None
    }
    fn transmit(&mut self, frame: &CanFrame) -> bool {
        self.0.push(*frame);
        true
    }
}

fn frame_id(f: &CanFrame) -> u32 {
    match f.id() {
        Id::Standard(id) => u32::from(id.as_raw()),
        Id::Extended(id) => id.as_raw(),
    }
}

fn main() -> io::Result<()> {
    let mut rx = InputDecoder::<4>::new(LinkParams::default());
    let mut ecu = Ecu::new(&hp_ctrl::calibration::SEED_4, 1);
    let stdout = io::stdout();
    let mut out = stdout.lock();
    for line in io::stdin().lock().lines() {
        let line = line?;
        let words: Vec<&str> = line.split_whitespace().collect();
        let answer = match words.as_slice() {
            [] => continue,
            ["table"] => table(),
            ["encode", args @ ..] => encode(args).unwrap_or_else(|e| format!("error {e}")),
            ["decode", id, data] => parse_frame(id, data).map(|f| decode(&f)).unwrap_or_else(|e| format!("error {e}")),
            ["decode", id] => parse_frame(id, "").map(|f| decode(&f)).unwrap_or_else(|e| format!("error {e}")),
            ["rx", id, data @ ..] => match parse_frame(id, data.first().copied().unwrap_or("")) {
                Err(e) => format!("error {e}"),
                Ok(f) => match rx.receive(&f) {
                    Ok(Accepted::Vehicle(groups)) => format!("vehicle {groups}"),
                    Ok(Accepted::Corner(k, groups)) => format!("corner {k} {groups}"),
                    Ok(Accepted::Tick(index)) => format!("tick {index}"),
                    Ok(Accepted::Synced) => "synced".into(),
                    Err(r) => format!("reject {}", reason(r)),
                },
            },
            ["period"] => inputs_line(&rx.end_period()),
            ["config"] => {
                let unit = hp_ctrl::Config::seed_unit().unit;
                format!("config static_pressure_pa={:?} static_temperature_k={:?}", unit.static_pressure_pa, unit.static_temperature_k)
            }
            ["ecu", id, data @ ..] => match parse_frame(id, data.first().copied().unwrap_or("")) {
                Err(e) => format!("error {e}"),
                Ok(f) => ecu.receive(&f).map_or_else(|| "ok".to_string(), |i| format!("tick {i}")),
            },
            ["ecu_period"] => {
                let mut sent = Collect::default();
                ecu.period(&mut sent);
                let frames: Vec<String> = sent.0.iter().map(|f| format!("{:X}#{}", frame_id(f), hex(f.data()))).collect();
                format!("frames {}", frames.join(" "))
            }
            ["diag"] => {
                let e = rx.diag_e2e();
                let l = rx.diag_link();
                format!(
                    "diag crc={} length={} unknown_id={} repeated={} skipped={} range={} timeouts={} stale_vehicle={} stale_corners={} link_fault={} window={}",
                    e.crc,
                    e.length,
                    e.unknown_id,
                    e.repeated,
                    e.skipped,
                    e.range,
                    l.timeout_count,
                    l.stale_vehicle,
                    l.stale_corners,
                    u8::from(l.link_fault),
                    l.window_rejects
                )
            }
            _ => "error unknown command".into(),
        };
        writeln!(out, "{answer}")?;
        out.flush()?;
    }
    Ok(())
}

//! Codec tests against independent references: a bit-at-a-time CRC, the
//! AUTOSAR profile-11 examples, and properties of arbitrary input.

extern crate std;

use std::vec::Vec;
use std::vec;

use embedded_can::{ExtendedId, Frame, StandardId};
use proptest::prelude::*;

use super::messages::*;
use super::*;
use crate::{input_group, DamperMode, DriveMode, DriverMode, SequencerState, SpringMode};

/// Textbook MSB-first CRC-8, one bit at a time, init 0, no final XOR.
fn reference_crc8(bytes: &[u8]) -> u8 {
    let mut crc = 0u8;
    for &b in bytes {
        crc ^= b;
        for _ in 0..8 {
            crc = if crc & 0x80 != 0 { (crc << 1) ^ 0x1D } else { crc << 1 };
        }
    }
    crc
}

/// Profile-11 CRC from its definition: data ID low, high, bytes 1..=7.
fn reference_p11(data_id: u16, payload: &[u8; 8]) -> u8 {
    let mut bytes = vec![(data_id & 0xFF) as u8, (data_id >> 8) as u8];
    bytes.extend_from_slice(&payload[1..]);
    reference_crc8(&bytes)
}

fn frame(id: u16, payload: [u8; 8]) -> CanFrame {
    CanFrame::standard(StandardId::new(id).unwrap(), payload)
}

#[test]
fn autosar_profile_11_examples() {
    // AUTOSAR E2E protocol specification, profile 11 examples (DataIDMode
    // BOTH, data ID 0x123, 8-byte zero payload).
    let mut p = [0u8; 8];
    e2e::protect(&mut p, 0x123, 0);
    assert_eq!(p, [0xCC, 0, 0, 0, 0, 0, 0, 0]);
    e2e::protect(&mut p, 0x123, 1);
    assert_eq!(p, [0x91, 0x01, 0, 0, 0, 0, 0, 0]);
    // The catalogue parameters: CRC-8/GSM-A is what profile 11 computes,
    // CRC-8/SAE-J1850 (init 0xFF, xorout 0xFF) is not.
    assert_eq!(reference_crc8(b"123456789"), 0x37);
    assert_ne!(e2e::crc8_update(0xFF, &[0x23, 0x01, 0, 0, 0, 0, 0, 0, 0]) ^ 0xFF, 0xCC);
}

#[test]
fn counter_sequence_and_wrap() {
    let mut c = 0;
    for _ in 0..15 {
        c = e2e::next_counter(c);
    }
    assert_eq!(c, 0, "15 steps of a mod-15 counter return to the start");
    assert_eq!(e2e::next_counter(14), 0);
}

/// A value inside the range of `s`, at raw position `t` in [0, 1].
fn in_range(s: &signal::Signal, t: f64) -> f64 {
    let raw = s.raw_min as f64 + t * (s.raw_max - s.raw_min) as f64;
    raw * s.factor + s.offset
}

#[test]
fn every_signal_round_trips_at_its_range_edges() {
    for kind in Kind::ALL {
        for sd in kind.signals() {
            let s = &sd.signal;
            for t in [0.0, 1.0, 0.5] {
                let x = in_range(s, t);
                let mut p = [0u8; 8];
                s.put(&mut p, x).unwrap();
                let back = s.get(&p).unwrap();
                assert!((back - x).abs() <= s.factor * 0.5 + 1e-9 * x.abs(), "{} {x} {back}", sd.name);
            }
            // One LSB past each edge is refused.
            let lo = s.raw_min as f64 * s.factor + s.offset - s.factor;
            let hi = s.raw_max as f64 * s.factor + s.offset + s.factor;
            assert!(s.to_raw(lo).is_err() && s.to_raw(hi).is_err(), "{}", sd.name);
        }
    }
}

#[test]
fn reserved_and_unused_bits_are_rejected() {
    let msg = Message::Strut(Strut { disp_m: 0.01 });
    let good = encode(&msg, 0).unwrap();
    for (byte, bit) in [(1usize, 4u8), (1, 7), (4, 0), (7, 7)] {
        let mut p = *good.payload();
        p[byte] |= 1 << bit;
        p[0] = reference_p11(STRUT.data_id, &p);
        assert_eq!(decode(&frame(STRUT.id, p)), Err(Reject::Range), "byte {byte} bit {bit}");
    }
}

#[test]
fn invalid_enumerations_and_counter_15_are_rejected() {
    let mut p = [0u8; 8];
    p[2] = 3; // DriverMode 3
    p[0] = reference_p11(DRIVER.data_id, &p);
    assert_eq!(decode(&frame(DRIVER.id, p)), Err(Reject::Range));
    let mut p = [0u8; 8];
    p[1] = 0x0F;
    p[0] = reference_p11(STRUT.data_id, &p);
    assert_eq!(decode(&frame(STRUT.id, p)), Err(Reject::Range));
    let mut p = [0u8; 8];
    p[2] = 5 << 5; // Sequencer 5
    p[0] = reference_p11(VALVE_CMD.data_id, &p);
    assert_eq!(decode(&frame(VALVE_CMD.id, p)), Err(Reject::Range));
}

#[test]
fn frame_format_errors() {
    let good = encode(&Message::Body(Body { acc_m_s2: 1.0 }), 0).unwrap();
    let short = CanFrame::new(StandardId::new(BODY.id).unwrap(), &good.payload()[..7]).unwrap();
    assert_eq!(decode(&short), Err(Reject::Length));
    let remote = CanFrame::new_remote(StandardId::new(BODY.id).unwrap(), 8).unwrap();
    assert_eq!(decode(&remote), Err(Reject::Length));
    let extended = CanFrame::new(ExtendedId::new(u32::from(BODY.id)).unwrap(), good.payload()).unwrap();
    assert_eq!(decode(&extended), Err(Reject::UnknownId));
    assert_eq!(decode(&frame(0x7FF, *good.payload())), Err(Reject::UnknownId));
    // Same payload under another message's identifier: the data ID differs.
    assert_eq!(decode(&frame(STRUT.id, *good.payload())), Err(Reject::Crc));
}

#[test]
fn typed_fields_land_in_the_named_signals() {
    let msgs = [
        Message::Pressures(Pressures { p_gas_pa: 1.234e7, p_gas2_pa: 9.87e6 }),
        Message::Vehicle(Vehicle { speed_m_s: 12.34, brake_pressed: true, lat_acc_m_s2: -2.5, long_acc_m_s2: 3.25 }),
        Message::Steering(Steering { angle_rad: -1.5, rate_rad_s: 2.75 }),
        Message::Driver(Driver { mode: DriverMode::Sport, ride_height_request_m: -0.05 }),
        Message::ValveCmd(ValveCmd {
            valve5_open: true,
            valve6_open: false,
            drive_mode: DriveMode::Handling,
            spring_mode: SpringMode::Hard,
            damper_mode: DamperMode::Low,
            sequencer: SequencerState::Holding,
            link_fault: true,
            step_index: 54321,
        }),
        Message::Status(Status { ride_height_m: -0.1234, diag: 0xDEAD_BEEF }),
        Message::HeightCtrl(HeightCtrl { p_load_pa: 14_810_000.0, p_gas2_target_pa: 16_330_010.0 }),
        Message::Motion(Motion { strut_vel_m_s: -0.7315, body_vel_m_s: 0.0425 }),
    ];
    let expected: [&[(&str, f64)]; 8] = [
        &[("PressureSmall", 1.234e7), ("PressureLarge", 9.87e6)],
        &[("VehicleSpeed", 12.34), ("BrakePressed", 1.0), ("LatAcc", -2.5), ("LongAcc", 3.25)],
        &[("SteerAngle", -1.5), ("SteerRate", 2.75)],
        &[("DriverMode", 2.0), ("RideHeightRequest", -0.05)],
        &[
            ("Valve5Open", 1.0),
            ("Valve6Open", 0.0),
            ("DriveMode", 1.0),
            ("SpringMode", 0.0),
            ("DamperMode", 1.0),
            ("Sequencer", 3.0),
            ("LinkFault", 1.0),
            ("StepIndex", 54321.0),
        ],
        &[("RideHeight", -0.1234), ("Diag", 3735928559.0)],
        &[("PressureLoad", 14_810_000.0), ("PressureLargeTarget", 16_330_010.0)],
        &[("StrutVel", -0.7315), ("BodyVel", 0.0425)],
    ];
    for (msg, signals) in msgs.iter().zip(expected) {
        let f = encode(msg, 0).unwrap();
        for (name, value) in signals {
            let s = msg.kind().signal(name).unwrap();
            let got = s.get(f.payload()).unwrap();
            assert!((got - value).abs() <= s.factor * 0.5 + 1e-12, "{name}: {got} vs {value}");
        }
    }
}

fn all_inputs_frames(tx: &mut Transmitter) -> Vec<CanFrame> {
    let msgs = [
        Message::Pressures(Pressures { p_gas_pa: 8e6, p_gas2_pa: 7e6 }),
        Message::Strut(Strut { disp_m: 0.01 }),
        Message::Body(Body { acc_m_s2: -0.5 }),
        Message::Vehicle(Vehicle { speed_m_s: 10.0, brake_pressed: true, lat_acc_m_s2: 0.5, long_acc_m_s2: -1.0 }),
        Message::Steering(Steering { angle_rad: 0.1, rate_rad_s: -0.2 }),
        Message::Temperature(Temperature { t_gas_k: 300.0 }),
        Message::Driver(Driver { mode: DriverMode::Comfort, ride_height_request_m: 0.02 }),
    ];
    msgs.iter().map(|m| tx.frame(m).unwrap()).collect()
}

#[test]
fn decoder_fills_every_input_and_marks_every_group() {
    let mut rx = InputDecoder::new(LinkParams::default());
    let mut tx = Transmitter::new();
    for f in all_inputs_frames(&mut tx) {
        assert_eq!(rx.receive(&f), Ok(Accepted::Synced));
    }
    let first = rx.end_period();
    assert_eq!(first.fresh, 0);
    assert!(first.link_fault);
    for f in all_inputs_frames(&mut tx) {
        assert!(matches!(rx.receive(&f), Ok(Accepted::Input(_))));
    }
    let i = rx.end_period();
    assert_eq!(i.fresh, input_group::ALL);
    assert!(!i.link_fault);
    assert!((i.p_gas_pa - 8e6).abs() < 5.0 && (i.p_gas2_pa - 7e6).abs() < 5.0);
    assert!((i.strut_disp_m - 0.01).abs() < 5e-6);
    assert!((i.body_acc_m_s2 + 0.5).abs() < 1e-3);
    assert!((i.speed_m_s - 10.0).abs() < 5e-3 && i.brake_pressed);
    assert!((i.lat_acc_m_s2 - 0.5).abs() < 5e-4 && (i.long_acc_m_s2 + 1.0).abs() < 5e-4);
    assert!((i.steer_angle_rad - 0.1).abs() < 5e-4 && (i.steer_rate_rad_s + 0.2).abs() < 5e-4);
    assert!((i.t_gas_k - 300.0).abs() < 5e-3);
    assert_eq!(i.driver_mode, DriverMode::Comfort);
    assert!((i.ride_height_request_m - 0.02).abs() < 5e-6);
    // Next period without frames: nothing fresh, values held, no fault yet.
    let held = rx.end_period();
    assert_eq!(held.fresh, 0);
    assert!(!held.link_fault);
    assert_eq!(held.p_gas_pa, i.p_gas_pa);
}

#[test]
fn repeated_and_skipped_counters_are_rejected_then_resync() {
    let mut rx = InputDecoder::new(LinkParams::default());
    let strut = |c: u8| encode(&Message::Strut(Strut { disp_m: 0.0 }), c).unwrap();
    assert_eq!(rx.receive(&strut(5)), Ok(Accepted::Synced));
    assert_eq!(rx.receive(&strut(6)), Ok(Accepted::Input(input_group::STRUT)));
    assert_eq!(rx.receive(&strut(6)), Err(Reject::Repeated));
    assert_eq!(rx.receive(&strut(8)), Err(Reject::Skipped));
    assert_eq!(rx.receive(&strut(9)), Ok(Accepted::Input(input_group::STRUT)));
    assert_eq!(rx.receive(&strut(14)), Err(Reject::Skipped));
    assert_eq!(rx.receive(&strut(0)), Ok(Accepted::Input(input_group::STRUT)));
    let d = rx.diag_e2e();
    assert_eq!((d.repeated, d.skipped, d.crc, d.range), (1, 2, 0, 0));
}

#[test]
fn timeout_sets_link_fault_and_needs_resync() {
    let mut rx = InputDecoder::new(LinkParams::default());
    let mut tx = Transmitter::new();
    for _ in 0..2 {
        for f in all_inputs_frames(&mut tx) {
            rx.receive(&f).unwrap();
        }
    }
    assert!(!rx.end_period().link_fault);
    // Keep everything but the strut message alive for 10 ms: still fine.
    let others = |tx: &mut Transmitter| {
        all_inputs_frames(tx).into_iter().filter(|f| f.id() != StandardId::new(STRUT.id).unwrap().into()).collect::<Vec<_>>()
    };
    for period in 1..=11 {
        for f in others(&mut tx) {
            rx.receive(&f).unwrap();
        }
        let i = rx.end_period();
        // The strut message was last used in period 0; stale after > 10 ms.
        assert_eq!(i.link_fault, period > 10, "period {period}");
        assert_eq!(i.fresh & input_group::STRUT, 0);
    }
    assert_eq!(rx.diag_link().timeout_count, 1);
    assert_eq!(rx.diag_link().stale_groups, input_group::STRUT as u8);
    // Recovery: one synchronising frame, then one in sequence.
    let strut = |tx: &mut Transmitter| tx.frame(&Message::Strut(Strut { disp_m: 0.0 })).unwrap();
    assert_eq!(rx.receive(&strut(&mut tx)), Ok(Accepted::Synced));
    assert!(rx.end_period().link_fault);
    assert_eq!(rx.receive(&strut(&mut tx)), Ok(Accepted::Input(input_group::STRUT)));
    for f in others(&mut tx) {
        rx.receive(&f).unwrap();
    }
    let i = rx.end_period();
    assert!(!i.link_fault);
    assert_eq!(i.fresh, input_group::ALL);
}

#[test]
fn reject_window_sets_and_clears_link_fault() {
    let params = LinkParams { period_us: 1000, window_periods: 10, window_reject_limit: 3 };
    let mut rx = InputDecoder::new(params);
    let mut tx = Transmitter::new();
    let feed = |rx: &mut InputDecoder, tx: &mut Transmitter| {
        for f in all_inputs_frames(tx) {
            rx.receive(&f).unwrap();
        }
    };
    feed(&mut rx, &mut tx);
    feed(&mut rx, &mut tx);
    assert!(!rx.end_period().link_fault); // window period 1
    let garbage = frame(PRESSURES.id, [0x00, 0x00, 1, 2, 3, 4, 5, 6]);
    for _ in 0..3 {
        assert_eq!(rx.receive(&garbage), Err(Reject::Crc));
    }
    feed(&mut rx, &mut tx);
    assert!(rx.end_period().link_fault, "limit reached: fault at once"); // period 2
    for period in 3..=20 {
        feed(&mut rx, &mut tx);
        let fault = rx.end_period().link_fault;
        // Window 1 (periods 1..=10) ends at the limit: fault held; window 2
        // (11..=20) is clean: cleared at its end.
        assert_eq!(fault, period < 20, "period {period}");
    }
    assert_eq!(rx.diag_e2e().crc, 3);
}

#[test]
fn ecu_outputs_are_unknown_to_the_ecu_receiver() {
    let mut rx = InputDecoder::new(LinkParams::default());
    let f = encode(&Message::Status(Status { ride_height_m: 0.0, diag: 0 }), 0).unwrap();
    assert_eq!(rx.receive(&f), Err(Reject::UnknownId));
    assert_eq!(rx.diag_e2e().unknown_id, 1);
}

#[test]
fn status_clamps_and_zeroes_bad_ride_height() {
    let out = |h| crate::Outputs { ride_height_m: h, ..Default::default() };
    assert_eq!(Status::from_outputs(&out(f64::NAN)).ride_height_m, 0.0);
    assert_eq!(Status::from_outputs(&out(1.0)).ride_height_m, 0.3);
    assert_eq!(Status::from_outputs(&out(-1.0)).ride_height_m, -0.3);
    for h in [f64::NAN, 1.0, -1.0, 0.1] {
        assert!(encode(&Message::Status(Status::from_outputs(&out(h))), 0).is_ok());
    }
}

#[test]
fn height_ctrl_and_motion_limit_and_zero_bad_values() {
    let out = |p: f64, v: f64| crate::Outputs {
        p_load_pa: p,
        p_gas2_target_pa: -p,
        strut_vel_m_s: v,
        body_vel_m_s: -v,
        ..Default::default()
    };
    for (p, v, expect) in [
        (f64::NAN, f64::NAN, (0.0, 0.0, 0.0, 0.0)),
        (f64::INFINITY, f64::NEG_INFINITY, (0.0, 0.0, 0.0, 0.0)),
        (2e8, 12.0, (1.2e8, 0.0, 10.0, -10.0)),
        (1.5e7, -0.25, (1.5e7, 0.0, -0.25, 0.25)),
    ] {
        let h = HeightCtrl::from_outputs(&out(p, v));
        let m = Motion::from_outputs(&out(p, v));
        assert_eq!((h.p_load_pa, h.p_gas2_target_pa, m.strut_vel_m_s, m.body_vel_m_s), expect, "{p} {v}");
        assert!(encode(&Message::HeightCtrl(h), 0).is_ok() && encode(&Message::Motion(m), 0).is_ok());
    }
}

fn known_id() -> impl Strategy<Value = u16> {
    prop::sample::select(Kind::ALL.iter().map(|k| k.def().id).collect::<Vec<_>>())
}

/// Every scaled signal (factor or offset not the identity): (name, signal).
fn scaled_signals() -> Vec<(&'static str, signal::Signal)> {
    Kind::ALL
        .iter()
        .flat_map(|k| k.signals().iter())
        .filter(|sd| sd.signal.factor != 1.0 || sd.signal.offset != 0.0)
        .map(|sd| (sd.name, sd.signal))
        .collect()
}

proptest! {
    /// Decoding is the DBC's formula `raw * factor + offset` in f64, bit
    /// for bit, for any raw value in range.
    #[test]
    fn decoded_value_is_the_dbc_formula(index in 0usize..64, t in 0.0f64..=1.0) {
        let all = scaled_signals();
        let (name, s) = all[index % all.len()];
        let raw = s.raw_min + ((s.raw_max - s.raw_min) as f64 * t).round() as i64;
        let mut p = [0u8; 8];
        s.put_raw(&mut p, raw);
        let formula = raw as f64 * s.factor + s.offset;
        prop_assert_eq!(s.get(&p).map(f64::to_bits), Some(formula.to_bits()), "{} raw {}", name, raw);
    }

    /// Encoding gives the nearest raw value: a value `frac` LSB from raw
    /// value `raw` (|frac| < 0.5, away from the tie by far more than the
    /// quotient's rounding error) encodes to `raw`, at the range edges too.
    #[test]
    fn encoded_raw_is_the_nearest(index in 0usize..64, t in 0.0f64..=1.0, frac in -0.499_999f64..0.499_999) {
        let all = scaled_signals();
        let (name, s) = all[index % all.len()];
        let raw = s.raw_min + ((s.raw_max - s.raw_min) as f64 * t).round() as i64;
        let x = (raw as f64 + frac) * s.factor + s.offset;
        prop_assert_eq!(s.to_raw(x), Ok(raw), "{} x {}", name, x);
    }

    #[test]
    fn table_crc_matches_bitwise_reference(data_id: u16, payload: [u8; 8]) {
        prop_assert_eq!(e2e::crc(data_id, &payload), reference_p11(data_id, &payload));
    }

    /// Arbitrary identifiers, lengths and bytes: never a panic, and nothing
    /// with a wrong CRC is ever accepted.
    #[test]
    fn arbitrary_frames_never_panic_nor_pass_a_wrong_crc(
        id in prop_oneof![known_id(), 0u16..0x800],
        data in prop::collection::vec(any::<u8>(), 0..=8),
        extended: bool,
    ) {
        let f = if extended {
            CanFrame::new(ExtendedId::new(u32::from(id)).unwrap(), &data).unwrap()
        } else {
            CanFrame::new(StandardId::new(id).unwrap(), &data).unwrap()
        };
        let mut rx = InputDecoder::new(LinkParams::default());
        let before = rx.end_period();
        let result = decode(&f);
        let rx_result = rx.receive(&f);
        if let Ok((msg, _)) = result {
            let payload: [u8; 8] = data.as_slice().try_into().unwrap();
            prop_assert!(!extended);
            prop_assert_eq!(payload[0], reference_p11(msg.kind().def().data_id, &payload));
        }
        // A lone frame is at most a synchronisation: nothing changes.
        prop_assert!(matches!(rx_result, Ok(Accepted::Synced) | Err(_)));
        prop_assert_eq!(rx.end_period(), before);
    }

    /// Random payloads under a known identifier with a correct CRC: either
    /// rejected as out of range, or every signal decodes inside its range
    /// and re-encodes to the same bytes.
    #[test]
    fn valid_crc_random_payloads_decode_in_range_or_are_rejected(id in known_id(), mut payload: [u8; 8]) {
        let kind = Kind::from_id(id).unwrap();
        payload[0] = reference_p11(kind.def().data_id, &payload);
        match decode(&frame(id, payload)) {
            Ok((msg, counter)) => {
                prop_assert_eq!(counter, payload[1] & 0x0F);
                let again = encode(&msg, counter).unwrap();
                prop_assert_eq!(again.payload(), &payload);
            }
            Err(reason) => prop_assert_eq!(reason, Reject::Range),
        }
    }

    /// A single corrupted bit in a valid frame is always caught by the CRC
    /// (CRC-8 detects every 1-bit error).
    #[test]
    fn one_bit_flip_is_rejected(t in 0.0f64..=1.0, counter in 0u8..15, bit in 0usize..64) {
        let msg = Message::Pressures(Pressures {
            p_gas_pa: in_range(Kind::Pressures.signal("PressureSmall").unwrap(), t),
            p_gas2_pa: in_range(Kind::Pressures.signal("PressureLarge").unwrap(), 1.0 - t),
        });
        let good = encode(&msg, counter).unwrap();
        let mut p = *good.payload();
        p[bit / 8] ^= 1 << (bit % 8);
        prop_assert_eq!(decode(&frame(PRESSURES.id, p)), Err(Reject::Crc));
    }

    /// Fixed-point round trip within half an LSB for every signal of every
    /// message, anywhere in range.
    #[test]
    fn physical_round_trip_within_half_lsb(kind_index in 0usize..Kind::ALL.len(), ts in prop::array::uniform8(0.0f64..=1.0), counter in 0u8..15) {
        let kind = Kind::ALL[kind_index];
        let def = kind.def();
        let mut p = [0u8; 8];
        for (sd, t) in kind.signals().iter().zip(ts) {
            sd.signal.put(&mut p, in_range(&sd.signal, t)).unwrap();
        }
        e2e::protect(&mut p, def.data_id, counter);
        let (msg, c) = decode(&frame(def.id, p)).unwrap();
        prop_assert_eq!(c, counter);
        let back = encode(&msg, counter).unwrap();
        for (sd, t) in kind.signals().iter().zip(ts) {
            let x = in_range(&sd.signal, t);
            let y = sd.signal.get(back.payload()).unwrap();
            prop_assert!((x - y).abs() <= sd.signal.factor * 0.5 * (1.0 + 1e-9), "{} {} {}", sd.name, x, y);
        }
    }
}

/// Collects what the ECU sends.
#[derive(Default)]
struct Sent(Vec<CanFrame>);

impl ecu::Link for Sent {
    fn receive(&mut self) -> Option<CanFrame> {
        None
    }
    fn transmit(&mut self, frame: &CanFrame) -> bool {
        self.0.push(*frame);
        true
    }
}

fn decoded(frames: &[CanFrame]) -> Vec<Message> {
    frames.iter().map(|f| decode(f).unwrap().0).collect()
}

#[test]
fn ecu_without_inputs_sends_safe_valve_commands_and_periodic_diagnostics() {
    let mut ecu = ecu::Ecu::new();
    assert!(ecu.has_params());
    for period in 0..200u16 {
        let mut sent = Sent::default();
        ecu.period(&mut sent);
        let msgs = decoded(&sent.0);
        let Message::ValveCmd(cmd) = msgs[0] else { panic!("{msgs:?}") };
        assert!(cmd.link_fault && !cmd.valve5_open && !cmd.valve6_open);
        assert_eq!(cmd.step_index, period);
        let Message::Status(status) = msgs[1] else { panic!("{msgs:?}") };
        assert_ne!(status.diag & crate::diag::SAFE_STATE, 0);
        // The DBC's schedule (cycle time, start delay): the height control
        // in periods 3, 13, ..., the motion in 6, 16, ..., diagnostics in
        // 99 and 199.
        let mut expect = vec![Kind::ValveCmd, Kind::Status];
        if period % 10 == 3 {
            expect.push(Kind::HeightCtrl);
        }
        if period % 10 == 6 {
            expect.push(Kind::Motion);
        }
        if period % 100 == 99 {
            expect.extend([Kind::DiagE2e, Kind::DiagLink]);
        }
        assert_eq!(msgs.iter().map(Message::kind).collect::<Vec<_>>(), expect, "period {period}");
        if let Some(Message::DiagLink(link)) = msgs.last() {
            assert!(link.link_fault);
            assert_eq!(link.stale_groups, input_group::ALL as u8);
        }
    }
}

#[test]
fn ecu_with_good_inputs_leaves_the_safe_state() {
    let mut ecu = ecu::Ecu::new();
    let mut tx = Transmitter::new();
    let cfg = crate::Config::seed_unit();
    let msgs = [
        Message::Pressures(Pressures { p_gas_pa: cfg.unit.static_pressure_pa, p_gas2_pa: cfg.unit.static_pressure_pa }),
        Message::Strut(Strut { disp_m: 0.0 }),
        Message::Body(Body { acc_m_s2: 0.0 }),
        Message::Vehicle(Vehicle { speed_m_s: 10.0, brake_pressed: false, lat_acc_m_s2: 0.0, long_acc_m_s2: 0.0 }),
        Message::Steering(Steering { angle_rad: 0.0, rate_rad_s: 0.0 }),
        Message::Temperature(Temperature { t_gas_k: cfg.unit.static_temperature_k }),
        Message::Driver(Driver { mode: DriverMode::Auto, ride_height_request_m: 0.0 }),
    ];
    let mut last = Vec::new();
    for _ in 0..1000 {
        for m in &msgs {
            ecu.receive(&tx.frame(m).unwrap());
        }
        let mut sent = Sent::default();
        ecu.period(&mut sent);
        last = decoded(&sent.0);
    }
    let Message::ValveCmd(cmd) = last[0] else { panic!() };
    assert!(!cmd.link_fault);
    let Message::Status(status) = last[1] else { panic!() };
    assert_eq!(status.diag & crate::diag::SAFE_STATE, 0, "diag {:#x}", status.diag);
}

#[test]
fn ecu_without_parameters_stays_safe() {
    let mut state = crate::State::new();
    let inputs = crate::Inputs { fresh: input_group::ALL, ..Default::default() };
    let out = ecu::control_step(None, &mut state, &inputs);
    assert!(!out.valve5_open && !out.valve6_open);
    assert_eq!(out.diag, crate::diag::SAFE_STATE);
}

#[test]
fn documented_frame_vectors() {
    // docs/can.md; bytes computed with cantools and crccheck's CRC-8/GSM-A
    // (python/hpctl/pil.py), independently of this codec.
    let p = encode(&Message::Pressures(Pressures { p_gas_pa: 14_811_300.0, p_gas2_pa: 12_000_000.0 }), 0).unwrap();
    assert_eq!(p.payload(), &[0xF5, 0x00, 0xAA, 0x99, 0x16, 0x80, 0x4F, 0x12]);
    let cmd = ValveCmd {
        valve5_open: true,
        valve6_open: true,
        drive_mode: DriveMode::Ride,
        spring_mode: SpringMode::Soft,
        damper_mode: DamperMode::Low,
        sequencer: SequencerState::Idle,
        link_fault: false,
        step_index: 1234,
    };
    let v = encode(&Message::ValveCmd(cmd), 5).unwrap();
    assert_eq!(v.payload(), &[0x03, 0x05, 0x1B, 0x00, 0xD2, 0x04, 0x00, 0x00]);
    let h = encode(&Message::HeightCtrl(HeightCtrl { p_load_pa: 14_811_300.0, p_gas2_target_pa: 15_790_390.0 }), 3).unwrap();
    assert_eq!(h.payload(), &[0xEF, 0x03, 0xAA, 0x99, 0x16, 0x1F, 0x18, 0x18]);
    let m = encode(&Message::Motion(Motion { strut_vel_m_s: -0.7315, body_vel_m_s: 0.0425 }), 0).unwrap();
    assert_eq!(m.payload(), &[0x2E, 0x00, 0x49, 0xFA, 0x55, 0x00, 0x00, 0x00]);
    assert_eq!(e2e::crc(PIL_TICK.data_id, &[0; 8]), 0x55);
    assert_eq!(e2e::crc(STRUT.data_id, &[0; 8]), 0xB6);
}

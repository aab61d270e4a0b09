//! Codec, receiver, J1939 network layer and ECU tests.
extern crate std;
use std::{vec, vec::Vec};
use super::ecu::{Ecu, Link};
use super::j1939::{self, pgn, J1939Id};
use super::messages::{address, j1939_id, Driver, Inclination, Motion, PilTick, Pressures, Steering, Vehicle};
use super::*;
use crate::vehicle::HeightMode;
use crate::DriverMode;
use embedded_can::{ExtendedId, Frame};
use sae_j1939_rs::diagnostics::{self, Lamp, LampStatus};
use sae_j1939_rs::Name;

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

fn raw_id(f: &CanFrame) -> u32 {
    match f.id() {
        embedded_can::Id::Extended(id) => id.as_raw(),
        embedded_can::Id::Standard(id) => u32::from(id.as_raw()),
    }
}

fn ext(raw: u32, data: &[u8]) -> CanFrame {
    CanFrame::new(ExtendedId::new(raw).unwrap(), data).unwrap()
}

#[test]
fn every_message_round_trips_from_any_source_address() {
    for kind in Kind::ALL {
        let mut payload = [0u8; 8];
        for s in kind.signals() {
            let g = &s.signal;
            g.put_raw(&mut payload, (g.raw_min + g.raw_max) / 2);
        }
        let msg = read_payload(kind, &payload).unwrap();
        for source in [0x00, 0x2F, 0x80, 0xF9] {
            let f = encode(&msg, 7, source).unwrap();
            assert!(f.is_extended());
            let id = J1939Id::of_raw(raw_id(&f));
            assert_eq!((id.pgn, id.source, id.priority), (kind.def().pgn, source, kind.def().priority));
            assert_eq!(decode(&f).unwrap(), (msg, 7), "{}", kind.name());
        }
    }
}

#[test]
fn definitions_are_consistent() {
    for (i, kind) in Kind::ALL.into_iter().enumerate() {
        let d = kind.def();
        assert_eq!(kind.index(), i);
        assert_eq!(d.kind, kind);
        assert_eq!(Kind::from_pgn(d.pgn), Some(kind));
        assert_eq!(Kind::from_name(kind.name()), Some(kind));
        assert!((0xFF00..=0xFFFF).contains(&d.pgn), "{}: Proprietary B", kind.name());
    }
}

#[test]
fn standard_ids_and_foreign_pgns_are_unknown() {
    let f = CanFrame::standard(embedded_can::StandardId::new(0x100).unwrap(), [0; 8]);
    assert_eq!(decode(&f), Err(Reject::UnknownId));
    assert_eq!(decode(&ext(j1939_id(6, 0xFEF1, 0x00), &[0; 8])), Err(Reject::UnknownId));
}

/// The frames a good 4-corner vehicle sends in one period.
fn good_frames(tx: &mut Transmitter, k: u32, height: HeightMode) -> Vec<CanFrame> {
    let cfg = crate::Config::seed_unit();
    let p = cfg.unit.static_pressure_pa;
    let mut msgs = vec![];
    for c in 0..4 {
        msgs.push(Message::CornerPressures(c, Pressures { p_gas_pa: p, p_gas2_pa: p }));
        msgs.push(Message::CornerMotion(c, Motion { strut_disp_m: 0.0, body_acc_m_s2: 0.0, t_gas_k: cfg.unit.static_temperature_k }));
    }
    if k % 10 == 0 {
        msgs.push(Message::Vehicle(Vehicle { speed_m_s: 0.0, ..Default::default() }));
        msgs.push(Message::Steering(Steering::default()));
        msgs.push(Message::Inclination(Inclination::default()));
    }
    if k % 100 == 0 {
        msgs.push(Message::Driver(Driver { mode: DriverMode::Auto, height_mode: height, ride_height_request_m: 0.0 }));
    }
    msgs.iter().map(|m| tx.frame(m, m.kind().def().source).unwrap()).collect()
}

#[test]
fn ecu_claims_its_address_first_and_sends_valves_last() {
    let mut ecu = Ecu::new(&crate::calibration::SEED_4, 1);
    let mut out = Collect::default();
    ecu.period(&mut out);
    let ids: Vec<J1939Id> = out.0.iter().map(|f| J1939Id::of_raw(raw_id(f))).collect();
    assert_eq!((ids[0].pgn, ids[0].source, ids[0].destination), (pgn::ADDRESS_CLAIMED, address::HPECU, address::GLOBAL));
    assert_eq!(out.0[0].data(), &j1939::ecu_name(1).to_bytes());
    // Every sensor missing: many codes, so the DM1 goes out by BAM.
    assert_eq!((ids[1].pgn, out.0[1].data()[0]), (pgn::TP_CM, 0x20));
    assert_eq!(&out.0[1].data()[5..], &[0xCA, 0xFE, 0x00]);
    assert_eq!(ids.last().unwrap().pgn, Kind::Valves.def().pgn);
    // Without inputs every corner is safe and the valves are closed.
    let (Message::Valves(v), _) = decode(out.0.last().unwrap()).unwrap() else { panic!() };
    assert!(v.link_fault && v.corner_safe[..4].iter().all(|&s| s));
    assert!(!v.valve5_open.iter().chain(&v.valve6_open).any(|&o| o));
}

#[test]
fn a_lower_name_takes_the_address_and_the_ecu_moves_to_a_free_one() {
    let mut ecu = Ecu::new(&crate::calibration::SEED_4, 1);
    ecu.period(&mut Collect::default());
    // A NAME lower than ours (not arbitrary address capable) claims 0x2F.
    let rival = Name::new().with_identity_number(7).with_manufacturer_code(5);
    ecu.receive(&ext(j1939_id(6, pgn::ADDRESS_CLAIMED | 0xFF, address::HPECU), &rival.to_bytes()));
    let mut out = Collect::default();
    ecu.period(&mut out);
    let first = J1939Id::of_raw(raw_id(&out.0[0]));
    assert_eq!((first.pgn, first.source), (pgn::ADDRESS_CLAIMED, 128));
    // From a self-configurable address: nothing else for 250 ms.
    assert_eq!(out.0.len(), 1);
    for _ in 0..249 {
        let mut out = Collect::default();
        ecu.period(&mut out);
        assert!(out.0.is_empty());
    }
    let mut out = Collect::default();
    ecu.period(&mut out);
    assert!(out.0.iter().all(|f| J1939Id::of_raw(raw_id(f)).source == 128) && !out.0.is_empty());
}

#[test]
fn a_higher_name_is_answered_by_defending_the_address() {
    let mut ecu = Ecu::new(&crate::calibration::SEED_4, 1);
    ecu.period(&mut Collect::default());
    let rival = Name::new().with_identity_number(7).with_manufacturer_code(2000).with_arbitrary_address_capable(true).with_industry_group(7);
    ecu.receive(&ext(j1939_id(6, pgn::ADDRESS_CLAIMED | 0xFF, 0x2F), &rival.to_bytes()));
    let mut out = Collect::default();
    ecu.period(&mut out);
    let first = J1939Id::of_raw(raw_id(&out.0[0]));
    assert_eq!((first.pgn, first.source), (pgn::ADDRESS_CLAIMED, 0x2F));
    assert_eq!(ecu.network().address(), 0x2F);
}

#[test]
fn requests_are_answered_and_unknown_ones_nacked() {
    let mut ecu = Ecu::new(&crate::calibration::SEED_4, 1);
    let mut tx = Transmitter::new();
    // Good inputs until no trouble code is left and the BAM is over.
    for k in 0..2500 {
        for f in good_frames(&mut tx, k, HeightMode::Normal) {
            ecu.receive(&f);
        }
        ecu.period(&mut Collect::default());
    }
    assert_eq!(ecu.dtcs().count(), 0);
    let request = |dest: u8, pgn: u32| ext(j1939_id(6, pgn::REQUEST | u32::from(dest), address::TESTER), &pgn.to_le_bytes()[..3]);
    for (frame, expect) in [
        (request(0x2F, pgn::ADDRESS_CLAIMED), Some(pgn::ADDRESS_CLAIMED)),
        (request(0xFF, pgn::DM1), Some(pgn::DM1)),
        (request(0x2F, 0xFEF1), Some(pgn::ACKNOWLEDGEMENT)),
        (request(0xFF, 0xFEF1), None),
        (request(0x30, pgn::DM1), None),
    ] {
        // Far from the DM1's own period.
        for k in 0..10 {
            for f in good_frames(&mut tx, k, HeightMode::Normal) {
                ecu.receive(&f);
            }
            ecu.period(&mut Collect::default());
        }
        ecu.receive(&frame);
        for f in good_frames(&mut tx, 1, HeightMode::Normal) {
            ecu.receive(&f);
        }
        let mut out = Collect::default();
        ecu.period(&mut out);
        let network: Vec<u32> =
            out.0.iter().map(|f| J1939Id::of_raw(raw_id(f)).pgn).filter(|&p| p < 0xFF00).collect();
        assert_eq!(network.first().copied(), expect, "{:X}", raw_id(&frame));
        if expect == Some(pgn::ACKNOWLEDGEMENT) {
            let ack = sae_j1939_rs::request::Acknowledgement::decode(&out.0[0].data().try_into().unwrap());
            assert_eq!((ack.pgn.as_u32(), ack.address.as_u8(), ack.control.is_positive()), (0xFEF1, 0x2F, false));
        }
    }
}

#[test]
fn a_failed_corner_sensor_is_one_dtc_and_one_corner_in_its_safe_state() {
    let mut ecu = Ecu::new(&crate::calibration::SEED_4, 1);
    let mut tx = Transmitter::new();
    let mut last = None;
    let mut dm1 = vec![];
    for k in 0..3000 {
        for f in good_frames(&mut tx, k, HeightMode::Normal) {
            // Corner 1's pressures from period 2000 on: stale.
            if k >= 2000 && J1939Id::of_raw(raw_id(&f)).pgn == Kind::CornerPressures(1).def().pgn {
                continue;
            }
            ecu.receive(&f);
        }
        let mut out = Collect::default();
        last = Some(ecu.period(&mut out));
        if k > 2100 {
            dm1.extend(out.0.into_iter().filter(|f| J1939Id::of_raw(raw_id(f)).pgn == pgn::DM1));
        }
    }
    let out = last.unwrap();
    let safe: Vec<bool> = out.corners.iter().map(|c| c.diag & crate::diag::SAFE_STATE != 0).collect();
    assert_eq!(safe, [false, true, false, false]);
    // Two codes: corner 1's pressures stale (FMI 9) and corner 1 in its safe state (FMI 31): a BAM, not a single DM1.
    let codes: Vec<(u32, u8)> = ecu.dtcs().active().map(|d| (d.spn, d.fmi)).collect();
    assert_eq!(codes, [(j1939::SPN_BASE + 16, 9), (j1939::SPN_BASE + 16 + 5, 31)]);
    assert!(dm1.is_empty(), "two codes go by BAM");
}

#[test]
fn one_code_is_a_single_frame_dm1_with_the_amber_lamp() {
    let mut table = j1939::DtcTable::new();
    table.set(3, Some(2));
    let mut net = j1939::Network::new(j1939::ecu_name(1), 0x2F);
    let mut sent = vec![];
    net.period(1, &table, |f| sent.push(f));
    let dm1 = sent.iter().find(|f| J1939Id::of_raw(raw_id(f)).pgn == pgn::DM1).unwrap();
    let m = diagnostics::Message::parse(dm1.data()).unwrap();
    assert_eq!(m.lamps().status(Lamp::AmberWarning), LampStatus::On);
    let codes: Vec<_> = m.dtcs().filter(|d| !d.is_no_fault()).map(|d| (d.spn, d.fmi, d.occurrence_count)).collect();
    assert_eq!(codes, [(j1939::SPN_BASE + 3, 2, 1)]);
}

#[test]
fn tick_closes_a_period_in_lock_step() {
    let mut ecu = Ecu::new(&crate::calibration::SEED_4, 1);
    let mut tx = Transmitter::new();
    let tick = |tx: &mut Transmitter, i| tx.frame(&Message::PilTick(PilTick { index: i }), address::TESTER).unwrap();
    assert_eq!(ecu.receive(&tick(&mut tx, 0)), None); // synchronises
    assert_eq!(ecu.receive(&tick(&mut tx, 1)), Some(1));
}

//! The controller in closed loop with the plant model (hp-core's SDOF rig):
//! pump-free lowering on a rough road, checked against the plant's own gas
//! state, and a manoeuvre switching the modes.
#![allow(clippy::unwrap_used, clippy::indexing_slicing, clippy::panic)]

use hp_core::gas::EquationOfState;
use hp_core::motion::Motion;
use hp_core::presets;
use hp_core::rig::{Rig, RigKind};
use hp_core::unit::{Unit, Valves};
use hp_vehicle::closed_loop::{run, Sensors, VehicleSignals};
use hp_ctrl::{DriveMode, Params, SequencerState, State};

const DT_S: f64 = 1.0e-3;

/// A rough road as a base motion: 40 sines from 0.3 to 15 Hz with a flat
/// velocity spectrum (like ISO 8608 at constant speed), 0.15 m/s rms, with
/// fixed pseudo-random phases, faded in over 2 s.
fn rough_road(duration_s: f64) -> (Vec<f64>, Vec<f64>) {
    let n = (duration_s / DT_S) as usize + 1;
    let count = 40;
    let velocity_rms_m_s = 0.15;
    let v_amplitude = velocity_rms_m_s * (2.0 / count as f64).sqrt();
    let mut phase = 0.0_f64;
    let sines: Vec<(f64, f64, f64)> = (0..count)
        .map(|k| {
            let f_hz = 0.3 * (15.0_f64 / 0.3).powf(k as f64 / (count - 1) as f64);
            phase = (phase + 0.618_033_988_75).fract();
            (v_amplitude / (2.0 * std::f64::consts::PI * f_hz), f_hz, 2.0 * std::f64::consts::PI * phase)
        })
        .collect();
    let time_s: Vec<f64> = (0..n).map(|k| k as f64 * DT_S).collect();
    let disp_m = time_s
        .iter()
        .map(|&t| {
            let fade = 0.5 * (1.0 - (std::f64::consts::PI * (t / 2.0).min(1.0)).cos());
            let z: f64 = sines
                .iter()
                .map(|&(a, f, p)| a * ((2.0 * std::f64::consts::PI * f * t + p).sin() - p.sin()))
                .sum();
            fade * z
        })
        .collect();
    (time_s, disp_m)
}

#[test]
fn lowering_by_30_mm_on_a_rough_road_holds_what_the_gas_says() {
    let unit = Unit::new(presets::seed_unit()).unwrap();
    let (time_s, disp_m) = rough_road(40.0);
    let kind = RigKind::Sdof {
        sprung_mass_kg: presets::SEED_SPRUNG_MASS_KG,
        base: Motion::Sampled { time_s: &time_s, disp_m: &disp_m },
    };
    let rig = Rig::new(&unit, kind, presets::SEED_STATIC_TEMPERATURE_K, Valves::default()).unwrap();
    let params = Params::seed_unit().unwrap();
    let margin_pa = params.config().ride_height.valve6_margin_pa;
    let mut state = State::new();
    let request_s = 8.0;
    let vehicle = |_: usize, t_s: f64| VehicleSignals {
        speed_m_s: 10.0,
        ride_height_request_m: if t_s >= request_s { -0.03 } else { 0.0 },
        ..VehicleSignals::default()
    };
    let (mut last_sample, mut last_out) = (None, None);
    let mut moved = false;
    let mut openings = 0;
    let mut was_open = false;
    run(&rig, &params, &Sensors::default(), &mut state, time_s.len() - 1, DT_S, DT_S, vehicle, |p| {
        // THE rule of pump-free sequencing, on the pressures the controller saw.
        let (i, o) = (p.inputs, p.outputs);
        match o.sequencer {
            SequencerState::Lowering if o.valve6_open => assert!(i.p_gas_pa - i.p_gas2_pa > margin_pa),
            SequencerState::Raising => panic!("raising while lowering to a fixed request: {o:?}"),
            SequencerState::Lowering => moved = true,
            _ => {}
        }
        openings += usize::from(o.valve6_open && !was_open && o.sequencer == SequencerState::Lowering);
        was_open = o.valve6_open;
        // Within the stroke (+-0.125 m of the static position) all along.
        assert!(p.sample.disp_m.abs() < 0.125, "strut at {} m", p.sample.disp_m);
        last_sample = Some(*p.sample);
        last_out = Some(*o);
        true
    })
    .unwrap();
    let (sample, out) = (last_sample.unwrap(), last_out.unwrap());
    assert!(moved && openings > 0);
    assert_eq!(out.sequencer, SequencerState::Holding, "{out:?}");
    // The height at rest that the oil in L holds, from the plant's gas
    // volume and temperature and the true static load pressure (the EOS,
    // not the controller's table or load estimate): within the sequencer's
    // 3 mm restart band plus 1 mm of estimation error.
    let u = unit.params();
    let (_, gas_mass_kg) = unit.gas_masses_kg();
    let rest_m3 = gas_mass_kg / u.gas.density_kg_m3(u.static_pressure_pa, sample.unit.t_gas2_k).unwrap();
    let held_m = (sample.v_gas2_m3 - rest_m3) / u.piston_area_m2;
    assert!((held_m + 0.03).abs() < 0.004, "held {held_m} m, estimate {} m", out.ride_height_m);
}

#[test]
fn a_lane_change_enters_handling_at_once_and_ride_returns_after_the_hold() {
    let unit = Unit::new(presets::seed_unit()).unwrap();
    let (time_s, disp_m) = rough_road(12.0);
    let kind = RigKind::Sdof {
        sprung_mass_kg: presets::SEED_SPRUNG_MASS_KG,
        base: Motion::Sampled { time_s: &time_s, disp_m: &disp_m },
    };
    let rig = Rig::new(&unit, kind, presets::SEED_STATIC_TEMPERATURE_K, Valves::default()).unwrap();
    let params = Params::seed_unit().unwrap();
    let hold_s = params.config().mode.handling_hold_s;
    // Lateral acceleration of a 3.5 m lane change in 2.5 s (peak 3.5 m/s^2).
    let (start_s, duration_s) = (5.0, 2.5);
    let lat = |t_s: f64| {
        let u = (t_s - start_s) / duration_s;
        if (0.0..=1.0).contains(&u) {
            2.0 * std::f64::consts::PI * 3.5 / (duration_s * duration_s) * (2.0 * std::f64::consts::PI * u).sin()
        } else {
            0.0
        }
    };
    let enter = params.config().mode.lat_acc_enter_m_s2;
    let vehicle = |_: usize, t_s: f64| VehicleSignals { speed_m_s: 15.0, lat_acc_m_s2: lat(t_s), ..VehicleSignals::default() };
    let mut modes = Vec::new();
    run(&rig, &params, &Sensors::default(), &mut State::new(), time_s.len() - 1, DT_S, DT_S, vehicle, |p| {
        modes.push((p.index as f64 * DT_S, p.inputs.lat_acc_m_s2, p.outputs.drive_mode, p.outputs.valve6_open));
        true
    })
    .unwrap();
    // Ride before the manoeuvre, Handling (valve 6 closed) in the period the
    // lateral acceleration passes the threshold, Ride again only after the
    // last period above the exit threshold plus the hold.
    let first_over = modes.iter().find(|m| m.1.abs() > enter).unwrap();
    assert_eq!(first_over.2, DriveMode::Handling);
    assert!(!first_over.3);
    let before = modes.iter().filter(|m| m.0 > 3.0 && m.0 < start_s);
    assert!(before.clone().all(|m| m.2 == DriveMode::Ride), "not in Ride before the manoeuvre");
    let exit = params.config().mode.lat_acc_exit_m_s2;
    let last_trigger_s = modes.iter().filter(|m| m.1.abs() >= exit).map(|m| m.0).fold(0.0, f64::max);
    let back_s = modes.iter().find(|m| m.0 > first_over.0 && m.2 == DriveMode::Ride).unwrap().0;
    assert!(back_s >= last_trigger_s + hold_s - 1e-9, "Ride at {back_s} s, last trigger {last_trigger_s} s");
    assert!(back_s < last_trigger_s + hold_s + 0.01, "Ride at {back_s} s, last trigger {last_trigger_s} s");
}


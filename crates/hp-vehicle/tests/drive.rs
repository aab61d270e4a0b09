//! The vehicle with one controller per wheel: every wheel goes to Ride on a
//! calm road, all enter Handling in the same period on a lane change, the
//! passive suspension keeps its valves, and the controllers see their own
//! wheel.
#![allow(clippy::unwrap_used, clippy::indexing_slicing, clippy::panic)]

use hp_core::unit::Valves;
use hp_ctrl::{DriveMode, Params, State};
use hp_vehicle::closed_loop::Sensors;
use hp_vehicle::drive::{run, Driver, Suspension};
use hp_vehicle::presets;
use hp_vehicle::track::Road;
use hp_vehicle::vehicle::{Vehicle, MAX_CORNERS};

const DT_S: f64 = 1e-3;

/// A lane change's steering: one sine period of the steering-wheel angle.
fn steering(t_s: f64, start_s: f64, duration_s: f64, amplitude_rad: f64) -> (f64, f64) {
    let u = (t_s - start_s) / duration_s;
    if (0.0..=1.0).contains(&u) {
        let w = 2.0 * std::f64::consts::PI / duration_s;
        (amplitude_rad * (w * (t_s - start_s)).sin(), amplitude_rad * w * (w * (t_s - start_s)).cos())
    } else {
        (0.0, 0.0)
    }
}

#[test]
fn every_wheel_rides_soft_on_a_calm_road_and_firms_up_together_in_a_lane_change() {
    for p in [presets::armoured_4x4(), presets::armoured_8x8()] {
        let params = Params::new(presets::controller_config(&p)).unwrap();
        let suspension = Suspension::SemiActive(&params);
        let v = Vehicle::new(p, 293.15, suspension.initial_valves()).unwrap();
        let n = v.corner_count();
        let mut states = [State::new(); MAX_CORNERS];
        let (start, duration) = (6.0, 3.0);
        let mut periods = Vec::new();
        run(&v, &Road::FLAT, suspension, &Sensors::default(), &mut states, 10_000, DT_S, DT_S, |_, t| {
            let (steer, rate) = steering(t, start, duration, 2.0);
            Driver { speed_m_s: 12.0, steer_angle_rad: steer, steer_rate_rad_s: rate, ..Driver::default() }
        }, |q| {
            let modes: Vec<DriveMode> = q.outputs[..n].iter().map(|o| o.drive_mode).collect();
            periods.push((q.index as f64 * DT_S, modes, q.valves[..n].to_vec(), q.sample.lat_acc_m_s2));
            // Each controller sees its own unit.
            for k in 0..n {
                assert_eq!(q.inputs[k].p_gas2_pa, q.sample.corners[k].forces.unit.p_gas2_pa);
                assert_eq!(q.inputs[k].strut_disp_m, q.sample.corners[k].forces.strut.disp_m);
            }
            true
        })
        .unwrap();
        // Before the manoeuvre, past the power-on recovery and the hold: Ride,
        // valve 6 open (soft) on every wheel.
        let calm = periods.iter().find(|x| x.0 >= 5.0).unwrap();
        assert!(calm.1.iter().all(|m| *m == DriveMode::Ride), "{:?}", calm.1);
        assert!(calm.2.iter().all(|v| v.valve6_open));
        // In the lane change all wheels enter Handling in the same period.
        let first = periods.iter().find(|x| x.0 > start && x.1.contains(&DriveMode::Handling)).unwrap();
        assert!(first.1.iter().all(|m| *m == DriveMode::Handling), "{:?}", first.1);
        assert!(first.2.iter().all(|v| !v.valve6_open && !v.valve5_open));
        assert!(first.0 < start + 0.5, "Handling only at {} s", first.0);
        let peak = periods.iter().map(|x| x.3.abs()).fold(0.0, f64::max);
        assert!(peak > 1.5, "lateral acceleration {peak} m/s^2");
    }
}

#[test]
fn a_passive_suspension_keeps_its_valves() {
    let p = presets::armoured_4x4();
    let setting = Valves::from_modes(false, true);
    let suspension = Suspension::Passive(setting);
    let v = Vehicle::new(p, 293.15, suspension.initial_valves()).unwrap();
    let mut states = [State::new(); MAX_CORNERS];
    let mut count = 0;
    run(&v, &Road::FLAT, suspension, &Sensors::default(), &mut states, 500, DT_S, DT_S, |_, _| Driver { speed_m_s: 5.0, ..Driver::default() }, |q| {
        assert!(q.valves[..4].iter().all(|x| *x == setting));
        count += 1;
        true
    })
    .unwrap();
    assert_eq!(count, 500);
    assert_eq!(states, [State::new(); MAX_CORNERS], "the controllers did not run");
}

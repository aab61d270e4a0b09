//! The quarter car against what it was not written from: the undamped
//! two-mass eigenfrequencies of its linearised springs, static equilibrium,
//! and the tyre leaving the road over a pothole.
#![allow(clippy::unwrap_used, clippy::indexing_slicing)]

mod common;

use hp_core::motion::Motion;
use hp_core::unit::{Unit, Valves, STANDARD_GRAVITY_M_S2};
use hp_vehicle::presets;
use hp_vehicle::quarter_car::{QuarterCar, QuarterCarParams, QuarterCarSample};
use hp_vehicle::tyre::Tyre;

fn simulate(car: &QuarterCar<'_>, duration_s: f64, dt_s: f64) -> Vec<QuarterCarSample> {
    let mut x = car.initial_state().unwrap();
    let mut out = Vec::new();
    let n = (duration_s / dt_s) as usize;
    for k in 0..n {
        let t = k as f64 * dt_s;
        let (rate, s) = car.rate_and_sample(t, &x).unwrap();
        out.push(s);
        x = car.advance(t, t + dt_s, &x, &rate, dt_s).unwrap();
    }
    out
}

#[test]
fn at_rest_on_a_level_road_nothing_moves() {
    let unit = Unit::new(hp_core::presets::seed_unit()).unwrap();
    for valves in [Valves::from_modes(true, true), Valves::from_modes(false, false)] {
        let car = QuarterCar::new(&unit, presets::quarter_car(), Motion::Hold { disp_m: 0.0 }, 293.15, valves).unwrap();
        let samples = simulate(&car, 2.0, 1e-3);
        let last = samples.last().unwrap();
        assert!(last.body_disp_m.abs() < 1e-9 && last.wheel_disp_m.abs() < 1e-9, "{last:?}");
        // The tyre carries both masses.
        let weight = (3000.0 + 400.0) * STANDARD_GRAVITY_M_S2;
        assert!((last.corner.tyre_force_n - weight).abs() < 1e-6 * weight);
    }
}

#[test]
fn the_two_modes_are_the_linearised_eigenfrequencies() {
    // With isothermal gas (so the static rate is the dynamic one), almost
    // no damping and a stiff-ish tyre, a 1 mm road step rings at the two
    // undamped eigenfrequencies of m_s, m_u on k_s, k_t.
    let unit = Unit::new(common::spring_only_unit()).unwrap();
    let tyre = Tyre { stiffness_n_per_m: 1.2e6, damping_n_s_per_m: 0.0 };
    let params = QuarterCarParams { sprung_mass_kg: 3000.0, unsprung_mass_kg: 400.0, tyre };
    let valves = Valves::from_modes(true, true);
    let road = Motion::Step { height_m: 0.001, start_s: 0.1, rise_s: 0.005 };
    let car = QuarterCar::new(&unit, params, road, 293.15, valves).unwrap();
    let k_s = common::static_rate_n_per_m(&unit, car.static_disp_m(), 293.15, valves);
    let (m_s, m_u, k_t) = (3000.0, 400.0, tyre.stiffness_n_per_m);
    // det([k_s - w^2 m_s, -k_s], [-k_s, k_s + k_t - w^2 m_u]) = 0.
    let a = m_s * m_u;
    let b = -(m_s * (k_s + k_t) + m_u * k_s);
    let c = k_s * k_t;
    let disc = (b * b - 4.0 * a * c).sqrt();
    let f = |w2: f64| w2.sqrt() / (2.0 * std::f64::consts::PI);
    let (f_body, f_hop) = (f((-b - disc) / (2.0 * a)), f((-b + disc) / (2.0 * a)));
    let dt = 5e-4;
    let samples = simulate(&car, 40.0, dt);
    // Every 4th sample (500 Hz) is plenty for modes below 15 Hz.
    let body: Vec<f64> = samples.iter().step_by(4).map(|s| s.body_disp_m).collect();
    let wheel: Vec<f64> = samples.iter().step_by(4).map(|s| s.wheel_disp_m).collect();
    let fb = common::peak_frequency_hz(&body, 4.0 * dt, 0.5, 3.0);
    let fw = common::peak_frequency_hz(&wheel, 4.0 * dt, 5.0, 15.0);
    assert!((fb / f_body - 1.0).abs() < 0.005, "body {fb} Hz, linear {f_body} Hz");
    assert!((fw / f_hop - 1.0).abs() < 0.005, "wheel hop {fw} Hz, linear {f_hop} Hz");
}

#[test]
fn the_tyre_leaves_the_road_over_a_pothole_and_never_pulls() {
    // A 10 cm drop of the road within 10 ms (a pothole's edge at speed):
    // the wheel cannot follow, the tyre force is zero while it is in the
    // air, never negative, and the car lands and settles.
    let unit = Unit::new(hp_core::presets::seed_unit()).unwrap();
    let road = Motion::Step { height_m: -0.1, start_s: 0.5, rise_s: 0.01 };
    let car = QuarterCar::new(&unit, presets::quarter_car(), road, 293.15, Valves::from_modes(true, true)).unwrap();
    let samples = simulate(&car, 4.0, 5e-4);
    let airborne: Vec<&QuarterCarSample> = samples.iter().filter(|s| s.corner.tyre_deflection_m <= 0.0).collect();
    assert!(!airborne.is_empty(), "the wheel never left the road");
    assert!(airborne.iter().all(|s| s.corner.tyre_force_n == 0.0));
    assert!(samples.iter().all(|s| s.corner.tyre_force_n >= 0.0));
    // In the air only the strut and gravity act on the wheel.
    for s in &airborne {
        let expected = -s.corner.unit.force_true_n / 400.0 - STANDARD_GRAVITY_M_S2;
        assert!((s.wheel_acc_m_s2 - expected).abs() < 1e-9 * expected.abs().max(1.0));
    }
    let last = samples.last().unwrap();
    assert!((last.body_disp_m + 0.1).abs() < 0.005 && (last.wheel_disp_m + 0.1).abs() < 0.005, "{last:?}");
}

//! Bad input gives an error, never a panic: arbitrary parameters, states
//! driven out of range, absurd step sizes, broken sample arrays.
#![allow(clippy::unwrap_used, clippy::indexing_slicing, clippy::panic)]
mod common;
use hp_core::error::Error;
use hp_core::gas::{EquationOfState, Gas};
use hp_core::motion::Motion;
use hp_core::presets::seed_unit;
use hp_core::rig::{run, Rig, RigKind};
use hp_core::unit::{Unit, Valves};
use proptest::prelude::*;

fn any_f64() -> impl Strategy<Value = f64> {
    prop_oneof![
        Just(f64::NAN),
        Just(f64::INFINITY),
        Just(f64::NEG_INFINITY),
        Just(0.0),
        Just(-0.0),
        Just(f64::MIN_POSITIVE),
        Just(f64::MAX),
        -1e12..1e12f64,
        any::<f64>(),
    ]
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(2000))]

    #[test]
    fn unit_construction_never_panics(area in any_f64(), vs in any_f64(), p in any_f64(), t in any_f64(), tau in any_f64()) {
        let mut params = seed_unit();
        params.piston_area_m2 = area;
        params.small_acc_volume_m3 = vs;
        params.static_pressure_pa = p;
        params.static_temperature_k = t;
        params.heat = match hp_core::thermal::HeatTransfer::from_tau_s(tau) { Ok(h) => h, Err(_) => params.heat };
        if let Ok(unit) = Unit::new(params) {
            prop_assert!(unit.gas_masses_kg().0 > 0.0);
        }
    }

    #[test]
    fn density_solve_never_panics(p in any_f64(), t in any_f64()) {
        for gas in Gas::ALL {
            if let Ok(rho) = gas.density_kg_m3(p, t) {
                prop_assert!(rho.is_finite() && rho > 0.0);
            }
        }
    }

    #[test]
    fn rigs_never_panic_on_wild_excitation(amp in any_f64(), f in any_f64(), dt in any_f64(), mass in any_f64()) {
        let unit = Unit::new(seed_unit()).unwrap();
        let base = Motion::Sine { amplitude_m: amp, frequency_hz: f, offset_m: 0.0 };
        for kind in [RigKind::Sdof { sprung_mass_kg: mass, base }, RigKind::Characterisation { strut: base }] {
            if let Ok(rig) = Rig::new(&unit, kind, 293.15, Valves::default()) {
                let mut n = 0;
                let result = run(&rig, (0..20).map(|i| i as f64 * 0.05), dt, |_, _| Valves::default(), |_, s| {
                    n += 1;
                    s.unit.force_true_n.is_finite()
                });
                // Either it ran, or it reported why.
                if result.is_ok() { prop_assert!(n >= 1); }
            }
        }
    }
}

#[test]
fn errors_name_parameter_value_and_range() {
    let mut params = seed_unit();
    params.small_acc_volume_m3 = -1e-3;
    let e = Unit::new(params).unwrap_err();
    assert_eq!(e, Error::OutOfRange { name: "small_acc_volume_m3", value: -1e-3, min: 1e-6, max: 1.0 });
    let text = format!("{e}");
    assert_eq!(text, "small_acc_volume_m3 = -0.001 is outside the valid range [1e-6, 1]");
}

#[test]
fn driving_the_hard_spring_to_zero_volume_is_a_state_error() {
    let unit = Unit::new(seed_unit()).unwrap();
    // 200 mm compression in 0.1 s with only 0.3 L of gas: beyond the stroke and the gas.
    let kind = RigKind::Characterisation { strut: Motion::Step { height_m: 0.2, start_s: 0.0, rise_s: 0.1 } };
    let rig = Rig::new(&unit, kind, 293.15, Valves::from_modes(true, true)).unwrap();
    let r = run(&rig, (0..100).map(|i| i as f64 * 0.01), 1e-4, |_, _| Valves::from_modes(true, true), |_, _| true);
    assert!(matches!(r, Err(Error::StateOutOfRange { .. })), "{r:?}");
}

#[test]
fn too_large_step_is_reported_not_exploded() {
    let unit = Unit::new(seed_unit()).unwrap();
    let kind = RigKind::Sdof { sprung_mass_kg: 3000.0, base: Motion::Step { height_m: 0.043, start_s: 0.1, rise_s: 0.05 } };
    let rig = Rig::new(&unit, kind, 293.15, Valves::default()).unwrap();
    // 0.5 s steps: far beyond RK4's stability for the valve-6 orifice.
    let r = run(&rig, (0..=40).map(|i| i as f64 * 0.5), 0.5, |_, _| Valves::default(), |_, s| s.unit.force_true_n.is_finite());
    assert!(r.is_err(), "{r:?}");
}

#[test]
fn sampled_motion_rejects_broken_arrays() {
    let t = [0.0, 0.1, 0.1, 0.3];
    let x = [0.0, 0.01, 0.02, 0.0];
    assert!(Motion::Sampled { time_s: &t, disp_m: &x }.validate().is_err());
    assert!(Motion::Sampled { time_s: &[0.0, 0.1], disp_m: &[0.0] }.validate().is_err());
    assert!(Motion::Sampled { time_s: &[], disp_m: &[] }.validate().is_err());
    assert!(Motion::Sampled { time_s: &[0.0, f64::NAN], disp_m: &[0.0, 0.0] }.validate().is_err());
    assert!(Motion::Sampled { time_s: &[0.0, 1.0], disp_m: &[0.0, f64::INFINITY] }.validate().is_err());
}

#[test]
fn sampled_motion_interpolates_smoothly_and_exactly_at_samples() {
    let t: Vec<f64> = (0..50).map(|i| (i as f64 * 0.021).powf(1.1)).collect();
    let x: Vec<f64> = t.iter().map(|&ti| (3.0 * ti).sin() * 0.05).collect();
    let m = Motion::Sampled { time_s: &t, disp_m: &x };
    m.validate().unwrap();
    for (ti, xi) in t.iter().zip(&x) {
        assert!((m.at(*ti).0 - xi).abs() < 1e-15);
    }
    // The velocity at the first and last samples is the curve's, not the
    // zero of the hold outside: an integrator's first stage sits exactly there.
    assert!((m.at(t[0]).1 - 0.15).abs() < 0.02);
    assert!((m.at(t[49]).1 - 0.15 * (3.0 * t[49]).cos()).abs() < 0.02);
    assert_eq!(m.at(t[49] + 1.0), (x[49], 0.0));
    // Between samples it is close to the smooth function and its derivative.
    for k in 1..400 {
        let tt = k as f64 * 0.002;
        if tt >= t[48] {
            break;
        }
        let (xx, vv) = m.at(tt);
        assert!((xx - (3.0 * tt).sin() * 0.05).abs() < 2e-5);
        assert!((vv - 0.15 * (3.0 * tt).cos()).abs() < 2e-3);
    }
}

#[test]
fn sampled_motion_with_velocities_passes_through_both() {
    let t: Vec<f64> = (0..40).map(|i| i as f64 * 0.05).collect();
    let x: Vec<f64> = t.iter().map(|&ti| (3.0 * ti).sin() * 0.05).collect();
    let v: Vec<f64> = t.iter().map(|&ti| (3.0 * ti).cos() * 0.15).collect();
    let m = Motion::SampledVelocity { time_s: &t, disp_m: &x, vel_m_s: &v };
    m.validate().unwrap();
    for ((ti, xi), vi) in t.iter().zip(&x).zip(&v) {
        let (xx, vv) = m.at(*ti);
        assert!((xx - xi).abs() < 1e-15 && (vv - vi).abs() < 1e-12);
    }
    // Exact tangents make the curve fourth-order accurate between samples:
    // far closer than the three-point tangents at this coarse spacing.
    let coarse = Motion::Sampled { time_s: &t, disp_m: &x };
    let (mut e_exact, mut e_three) = (0.0_f64, 0.0_f64);
    for k in 1..380 {
        let tt = k as f64 * 0.005;
        e_exact = e_exact.max((m.at(tt).1 - 0.15 * (3.0 * tt).cos()).abs());
        e_three = e_three.max((coarse.at(tt).1 - 0.15 * (3.0 * tt).cos()).abs());
    }
    assert!(e_exact < 0.05 * e_three, "{e_exact} vs {e_three}");
    assert!(Motion::SampledVelocity { time_s: &t, disp_m: &x, vel_m_s: &v[..3] }.validate().is_err());
}

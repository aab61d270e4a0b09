//! The seed's single-degree-of-freedom step test (43 mm base step, 3000 kg)
//! and the linearised natural frequency against CoolProp's speed of sound.
#![allow(clippy::unwrap_used, clippy::indexing_slicing, clippy::panic)]
mod common;
use common::{fixture, run_uniform, unit_with};
use hp_core::damper::{Damper, DamperCurve};
use hp_core::motion::Motion;
use hp_core::presets::SEED_SPRUNG_MASS_KG;
use hp_core::rig::{RigKind, RigSample};
use hp_core::thermal::HeatTransfer;
use hp_core::unit::{Unit, Valves};

const STEP_M: f64 = 0.043;
const START_S: f64 = 0.5;
const RISE_S: f64 = 0.05;

fn step_response(unit: &Unit, valves: Valves, height_m: f64, duration_s: f64) -> Vec<RigSample> {
    step_response_dt(unit, valves, height_m, duration_s, 1e-3)
}

fn step_response_dt(unit: &Unit, valves: Valves, height_m: f64, duration_s: f64, dt_s: f64) -> Vec<RigSample> {
    let kind = RigKind::Sdof {
        sprung_mass_kg: SEED_SPRUNG_MASS_KG,
        base: Motion::Step { height_m, start_s: START_S, rise_s: RISE_S },
    };
    run_uniform(unit, kind, valves, duration_s, 1e-3, dt_s)
}

/// Times at which the body crosses its final level after the step.
fn crossings(samples: &[RigSample], level: f64) -> Vec<f64> {
    samples
        .windows(2)
        .filter(|w| w[0].time_s > START_S + RISE_S)
        .filter_map(|w| {
            let (a, b) = (w[0].body_disp_m - level, w[1].body_disp_m - level);
            (a * b < 0.0).then(|| w[0].time_s + (w[1].time_s - w[0].time_s) * a / (a - b))
        })
        .collect()
}

/// Frequency from the period between the first and third crossings, Hz.
fn crossing_frequency_hz(samples: &[RigSample], level: f64) -> f64 {
    let c = crossings(samples, level);
    assert!(c.len() >= 3, "not oscillating: {c:?}");
    1.0 / (c[2] - c[0])
}

#[test]
fn damper_off_is_under_damped_at_the_seeds_frequencies() {
    let unit = Unit::new(hp_core::presets::seed_unit()).unwrap();
    let hard = step_response(&unit, Valves::from_modes(true, false), STEP_M, 5.0);
    let soft = step_response(&unit, Valves::from_modes(false, false), STEP_M, 6.0);
    for s in [&hard, &soft] {
        // At least two overshoots beyond 5 % of the step: under-damped.
        let overshoots = crossings(s, STEP_M).len();
        assert!(overshoots >= 4, "{overshoots} crossings");
        let peak = s.iter().map(|x| x.body_disp_m).fold(f64::MIN, f64::max);
        assert!(peak > STEP_M * 1.2, "peak {peak}");
    }
    let f_hard = crossing_frequency_hz(&hard, STEP_M);
    let f_soft = crossing_frequency_hz(&soft, STEP_M);
    // The seed: about 1.5 Hz hard, about 1 Hz soft. This unit: 1.65 / 0.88 Hz
    // (see presets: the volume ratio fixes f_hard / f_soft near 1.83).
    assert!((1.35..1.8).contains(&f_hard), "hard {f_hard} Hz");
    assert!((0.8..1.1).contains(&f_soft), "soft {f_soft} Hz");
    assert!((1.6..2.0).contains(&(f_hard / f_soft)));
}

#[test]
fn damper_on_settles_within_one_cycle() {
    let unit = Unit::new(hp_core::presets::seed_unit()).unwrap();
    for (hard, f_off) in [(true, 1.65), (false, 0.88)] {
        let s = step_response(&unit, Valves::from_modes(hard, true), STEP_M, 5.0);
        let one_cycle_after_step = START_S + RISE_S + 1.0 / f_off;
        for x in s.iter().filter(|x| x.time_s > one_cycle_after_step) {
            assert!((x.body_disp_m - STEP_M).abs() < 0.05 * STEP_M, "hard={hard} t={} z={}", x.time_s, x.body_disp_m);
        }
        // It did move: the body reached at least 90 % of the step.
        assert!(s.iter().any(|x| x.body_disp_m > 0.9 * STEP_M));
    }
}

#[test]
fn small_step_frequency_matches_linearised_gas_spring_from_coolprop() {
    // Linearised adiabatic gas spring: k = A^2 rho c^2 / V with the speed of
    // sound c from CoolProp, f = sqrt(k / m) / (2 pi). Adiabatic gas and an
    // almost undamped strut isolate the spring.
    let light = DamperCurve { bleed_pa_s_per_m3: 2e7, orifice_pa_s2_per_m6: 0.0, blowoff_pa: 1e9, blowoff_slope_pa_s_per_m3: 2e7, blowoff_knee: 0.0, blowoff2_pa: 0.0, blowoff2_slope_pa_s_per_m3: 0.0, bleed_parallel_m3_per_s_pa: 0.0 };
    let unit = unit_with(|p| {
        p.heat = HeatTransfer::Adiabatic;
        p.damper = Damper { on_compression: light, on_rebound: light, off_compression: light, off_rebound: light };
        // So that L follows S without lag (a stiffer orifice: smaller steps).
        p.valve6.flow_area_m2 *= 10.0;
    });
    let p = *unit.params();
    let reference = fixture("n2_static.csv")[0].clone();
    assert!((reference["p_pa"] / p.static_pressure_pa - 1.0).abs() < 1e-9);
    let rho_c2 = reference["rho_kg_m3"] * reference["speed_of_sound_m_s"].powi(2);
    for (hard, volume) in [(true, p.small_acc_volume_m3), (false, p.small_acc_volume_m3 + p.large_acc_volume_m3)] {
        let k = p.piston_area_m2 * p.piston_area_m2 * rho_c2 / volume;
        let f_ref = (k / SEED_SPRUNG_MASS_KG).sqrt() / (2.0 * std::f64::consts::PI);
        let s = step_response_dt(&unit, Valves::from_modes(hard, false), 1e-3, 4.0, 1e-4);
        let f = crossing_frequency_hz(&s, 1e-3);
        // Within the equation of state's error in rho c^2 near 15 MPa (~1 %).
        assert!((f / f_ref - 1.0).abs() < 0.01, "hard={hard}: {f} Hz vs {f_ref} Hz");
    }
}

#[test]
fn mismatched_charge_shifts_ride_height_not_the_body() {
    // 10 % over-charged: the unit sits extended (negative compression) under the load.
    let unit = unit_with(|p| p.static_pressure_pa *= 1.1);
    let s = step_response(&unit, Valves::from_modes(true, true), 0.0, 1.0);
    assert!(s.iter().all(|x| x.body_disp_m.abs() < 1e-9));
    assert!(s[0].disp_m < -0.005);
    let load = SEED_SPRUNG_MASS_KG * hp_core::unit::STANDARD_GRAVITY_M_S2;
    assert!((s[0].unit.force_true_n / load - 1.0).abs() < 1e-9);
}

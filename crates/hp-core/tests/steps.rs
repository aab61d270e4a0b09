//! The step count between two instants (`hp_core::ode::steps`, used by
//! every fixed-step integration between output samples or control
//! periods): a period of exactly the largest step is one step, however the
//! instants were rounded. Before, `(k + 1) dt - k dt` (a few ulps above `dt`
//! for most `k`) was split into two half steps.
#![allow(clippy::unwrap_used, clippy::indexing_slicing, clippy::panic)]

use hp_core::motion::Motion;
use hp_core::ode::steps;
use hp_core::presets;
use hp_core::rig::{Rig, RigKind};
use hp_core::unit::{Unit, Valves};

#[test]
fn a_period_of_exactly_the_step_is_one_step() {
    for dt in [5e-4, 1e-3, 4e-3, 1e-2, 1.0 / 3000.0] {
        // Instants as the drive loops make them (k dt) and as the bindings'
        // plants do (a running sum).
        let mut sum = 0.0;
        for k in 0..200_000u32 {
            let t = f64::from(k) * dt;
            let (n, h) = steps(t, f64::from(k + 1) * dt, dt).unwrap();
            assert_eq!(n, 1, "dt {dt}, period {k}");
            // The step is the period, whose rounding grows with t.
            assert!((h - dt).abs() <= 1e-10 * dt.max(t), "dt {dt}, period {k}: {h}");
            let (n, _) = steps(sum, sum + dt, dt).unwrap();
            assert_eq!(n, 1, "dt {dt}, summed instant {sum}");
            sum += dt;
        }
    }
}

#[test]
fn longer_periods_take_equal_steps_no_longer_than_the_largest() {
    for (span, max_dt, expected) in [(4e-3, 1e-3, 4), (1e-2, 1e-3, 10), (1.000_001e-3, 1e-3, 2), (0.999e-3, 1e-3, 1), (2.5e-3, 1e-3, 3), (1e-6, 1e-3, 1)] {
        for t in [0.0, 0.37, 1234.5] {
            let (n, h) = steps(t, t + span, max_dt).unwrap();
            assert_eq!(n, expected, "{span} in steps of {max_dt} from {t}");
            assert!(h <= max_dt * (1.0 + 1e-9), "{h}");
        }
    }
    assert!(steps(1.0, 1.0, 1e-3).is_err());
    assert!(steps(1.0, 0.5, 1e-3).is_err());
    assert!(steps(0.0, 1e5, 1e-3).is_err()); // 1e8 steps
    assert!(steps(0.0, 1.0, 0.0).is_err());
}

#[test]
fn the_rig_advances_a_period_of_the_step_in_one_rk4_step() {
    let unit = Unit::new(presets::seed_unit()).unwrap();
    let kind = RigKind::Sdof { sprung_mass_kg: presets::SEED_SPRUNG_MASS_KG, base: Motion::Sine { amplitude_m: 0.02, frequency_hz: 2.0, offset_m: 0.0 } };
    let rig = Rig::new(&unit, kind, 293.15, Valves::from_modes(false, true)).unwrap();
    let dt = 1e-3;
    let mut state = rig.initial_state().unwrap();
    for k in 1..300u32 {
        let t = f64::from(k) * dt;
        let end = f64::from(k + 1) * dt;
        let (rate, _) = rig.rate_and_sample(t, &state).unwrap();
        let advanced = rig.advance(t, end, &state, &rate, dt).unwrap();
        // One step of the period's length, bit for bit.
        assert_eq!(advanced, rig.step(t, &state, end - t).unwrap(), "period {k}");
        state = advanced;
    }
}

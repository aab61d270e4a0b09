//! A valve switch placed between two outputs (`switch_lead`, a logged
//! valve state taken midway) against the same switch at an output placed
//! there: the samples the two runs share must agree, for the fixed-step
//! and the adaptive runner, switching valve 6 both ways and valve 5, and
//! differ clearly from switching at the output that shows the new valves.
//! A bad lead is refused.
#![allow(clippy::unwrap_used, clippy::indexing_slicing, clippy::panic)]
use hp_core::motion::Motion;
use hp_core::presets;
use hp_core::rig::{run_adaptive, run_with_lead, Adaptive, Rig, RigKind, RigSample, SampleDetail, Steps};
use hp_core::unit::{Unit, Valves};

const DT: f64 = 0.005;
const N: usize = 400;

/// Valves of the coarse grid's output `i` (0.005 s apart): the spring
/// switches soft at output 100, hard at 200; the damper off at 300.
fn coarse(i: usize) -> Valves {
    Valves::from_modes(!(100..200).contains(&i), i < 300)
}

/// The same switches on a grid twice as fine, each at the output placed
/// `lead` of the coarse interval earlier (lead 0.5: the midpoint).
fn fine(j: usize) -> Valves {
    coarse(j.div_ceil(2))
}

fn rig(unit: &Unit) -> Rig<'_> {
    let kind = RigKind::Characterisation { strut: Motion::Sine { amplitude_m: 0.04, frequency_hz: 1.0, offset_m: 0.0 } };
    Rig::new(unit, kind, 293.15, coarse(0)).unwrap()
}

fn grid(n: usize, dt: f64) -> Vec<f64> {
    (0..=n).map(|i| i as f64 * dt).collect()
}

fn fixed(unit: &Unit, times: &[f64], lead: f64, valves: fn(usize) -> Valves) -> Vec<RigSample> {
    let mut out = Vec::new();
    run_with_lead(&rig(unit), times.iter().copied(), 1e-4, lead, |i, _| valves(i), |_, s| {
        out.push(*s);
        true
    })
    .unwrap();
    out
}

fn adaptive(unit: &Unit, times: &[f64], lead: f64, valves: fn(usize) -> Valves) -> Vec<RigSample> {
    let mut out = Vec::new();
    let settings = Adaptive { rtol: 1e-10, switch_lead: lead, ..Adaptive::default() };
    run_adaptive(&rig(unit), times, settings, SampleDetail::Full, Steps::Controlled, |i, _| valves(i), |_, s| {
        out.push(*s);
        true
    })
    .unwrap();
    out
}

/// Largest difference of the two gas pressures and the force over the
/// coarse outputs (every second fine one), relative to their scales.
fn largest(coarse: &[RigSample], fine: &[RigSample]) -> f64 {
    coarse
        .iter()
        .zip(fine.iter().step_by(2))
        .map(|(a, b)| {
            assert!((a.time_s - b.time_s).abs() < 1e-12);
            assert_eq!(a.valves, b.valves, "the sample shows the valves of its interval");
            let p = (a.unit.p_gas_true_pa - b.unit.p_gas_true_pa).abs().max((a.unit.p_gas2_true_pa - b.unit.p_gas2_true_pa).abs());
            (p / 1e6).max((a.unit.force_true_n - b.unit.force_true_n).abs() / 1e3)
        })
        .fold(0.0, f64::max)
}

#[test]
fn a_switch_midway_is_a_switch_at_an_output_placed_there() {
    let unit = Unit::new(presets::seed_unit()).unwrap();
    let (c, f) = (grid(N, DT), grid(2 * N, DT / 2.0));
    for (name, run) in [("fixed", fixed as fn(&Unit, &[f64], f64, fn(usize) -> Valves) -> Vec<RigSample>), ("adaptive", adaptive)] {
        let reference = run(&unit, &f, 0.0, fine);
        let midway = largest(&run(&unit, &c, 0.5, coarse), &reference);
        let at_output = largest(&run(&unit, &c, 0.0, coarse), &reference);
        // Both runners take the same steps in both runs (measured: 2e-13
        // fixed, 0 adaptive). Switching at the output instead, 2.5 ms
        // late, is off by 0.42 (MPa or kN).
        assert!(midway < 1e-9, "{name}: midway {midway:e} (MPa, kN)");
        assert!(at_output > 1e3 * midway && at_output > 1e-2, "{name}: at the output {at_output:e} against midway {midway:e}");
    }
}

#[test]
fn a_lead_of_zero_is_the_plain_run() {
    let unit = Unit::new(presets::seed_unit()).unwrap();
    let c = grid(N, DT);
    let mut plain = Vec::new();
    hp_core::rig::run(&rig(&unit), c.iter().copied(), 1e-4, |i, _| coarse(i), |_, s| {
        plain.push(*s);
        true
    })
    .unwrap();
    let led = fixed(&unit, &c, 0.0, coarse);
    assert!(plain.iter().zip(&led).all(|(a, b)| a.unit.p_gas_true_pa.to_bits() == b.unit.p_gas_true_pa.to_bits()));
}

#[test]
fn a_bad_lead_is_refused() {
    let unit = Unit::new(presets::seed_unit()).unwrap();
    let c = grid(10, DT);
    for lead in [-0.1, 1.0, 1.5, f64::NAN, f64::INFINITY] {
        let err = run_with_lead(&rig(&unit), c.iter().copied(), 1e-4, lead, |i, _| coarse(i), |_, _| true).unwrap_err();
        assert!(format!("{err}").contains("switch_lead"), "{err}");
        // The range the message gives is inclusive and excludes 1.
        assert!(format!("{err}").contains("[0, 0.9999999999999999]"), "{err}");
        let settings = Adaptive { switch_lead: lead, ..Adaptive::default() };
        let err = run_adaptive(&rig(&unit), &c, settings, SampleDetail::Full, Steps::Controlled, |i, _| coarse(i), |_, _| true).unwrap_err();
        assert!(format!("{err}").contains("switch_lead"), "{err}");
    }
    // The range's upper end itself is valid.
    assert!(run_with_lead(&rig(&unit), c.iter().copied(), 1e-4, hp_core::rig::MAX_SWITCH_LEAD, |i, _| coarse(i), |_, _| true).is_ok());
}

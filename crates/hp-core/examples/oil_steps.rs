//! What the oil spring costs the adaptive integrator: the seed unit on the
//! characterisation rig, a 60 mm, 0.5 Hz sine for 200 s (outputs at
//! 10 Hz, rtol 1e-7), without oil compliance and with it at several bulk
//! moduli (1 L of oil): accepted and rejected steps, the steps ROS34PW2
//! took, the switches to it and back, the median step, and the largest
//! force error against the same run at rtol 1e-11 (BENCHMARKS.md, stop 77).
//!
//!     cargo run --release -p hp-core --example oil_steps
use hp_core::adaptive::Stats;
use hp_core::motion::Motion;
use hp_core::presets::seed_unit;
use hp_core::rig::{run_adaptive, Adaptive, Rig, RigKind, SampleDetail, Steps};
use hp_core::unit::{OilCompliance, Unit, Valves};

const DURATION_S: f64 = 200.0;

fn run(bulk_pa: Option<f64>, rtol: f64) -> Result<(Vec<f64>, Stats, Vec<f64>), hp_core::Error> {
    let mut p = seed_unit();
    p.effects.oil_compliance = bulk_pa.map(|b| OilCompliance { bulk_modulus_pa: b, oil_volume_m3: 1e-3 });
    let unit = Unit::new(p)?;
    let valves = Valves::from_modes(true, true);
    let kind = RigKind::Characterisation { strut: Motion::Sine { amplitude_m: 0.06, frequency_hz: 0.5, offset_m: 0.0 } };
    let rig = Rig::new(&unit, kind, 293.15, valves)?;
    let times: Vec<f64> = (0..=2000).map(|i| f64::from(i) * DURATION_S / 2000.0).collect();
    let (mut force, mut ends) = (Vec::new(), Vec::new());
    let mut record = |t: f64| ends.push(t);
    let settings = Adaptive { rtol, ..Adaptive::default() };
    let stats = run_adaptive(&rig, &times, settings, SampleDetail::Full, Steps::Record(&mut record), |_, _| valves, |_, s| {
        force.push(s.unit.force_n);
        true
    })?;
    let mut steps: Vec<f64> = ends.iter().zip(ends.iter().skip(1)).map(|(a, b)| b - a).collect();
    steps.sort_by(f64::total_cmp);
    Ok((force, stats, steps))
}

fn main() -> Result<(), hp_core::Error> {
    println!("oil          accepted  rejected  ros34pw2  switches  median_step_ms  max_force_error_n");
    for bulk in [None, Some(3e8), Some(1e9), Some(3e9)] {
        let (force, stats, steps) = run(bulk, 1e-7)?;
        let (reference, _, _) = run(bulk, 1e-11)?;
        let error = force.iter().zip(&reference).map(|(a, b)| (a - b).abs()).fold(0.0, f64::max);
        let median_ms = steps.get(steps.len() / 2).map_or(f64::NAN, |h| h * 1e3);
        let label = bulk.map_or("rigid".to_string(), |b| format!("{:.1} GPa", b / 1e9));
        println!("{label:<11} {:>9} {:>9} {:>9} {:>9} {median_ms:>15.2} {error:>18.3}",
                 stats.accepted, stats.rejected, stats.rosenbrock, stats.switches);
    }
    Ok(())
}

//! Speed of the vehicle models (benchmarks, not tests). The real-time
//! factor of a run is its simulated time divided by the measured time;
//! `baseline/exp` is measured in the same run so ratios survive a slower
//! machine.
//!
//!     cargo bench -p hp-vehicle --bench vehicle
#![allow(clippy::unwrap_used, clippy::expect_used, clippy::indexing_slicing)]
use criterion::{criterion_group, criterion_main, Criterion, Throughput};
use hp_core::motion::Motion;
use hp_core::rig::{run as rig_run, Rig, RigKind};
use hp_core::unit::{Unit, Valves};
use hp_ctrl::{Params, State};
use hp_vehicle::closed_loop::Sensors;
use hp_vehicle::drive::{run, Driver, Suspension};
use hp_vehicle::presets;
use hp_vehicle::track::{Road, Track};
use hp_vehicle::vehicle::{Vehicle, VehicleParams, MAX_CORNERS};
use std::hint::black_box;

/// A rough two-track road (sum of sines, class D-like amplitudes), 2 cm grid.
fn rough(length_m: f64) -> (Vec<f64>, Vec<f64>) {
    let n = (length_m / 0.02) as usize + 1;
    let track = |phase: f64| -> Vec<f64> {
        (0..n)
            .map(|k| {
                let x = k as f64 * 0.02;
                let fade = (x / 20.0).min(1.0);
                fade * (0.02 * (0.5 * x + phase).sin() + 0.008 * (2.1 * x + 2.0 * phase).sin() + 0.003 * (7.3 * x + phase).sin())
            })
            .collect()
    };
    (track(0.0), track(1.3))
}

fn baseline(c: &mut Criterion) {
    c.bench_function("baseline/exp", |b| b.iter(|| libm::exp(black_box(-0.41))));
    // One unit on hp-core's SDOF rig for the same 10 s (what the vehicle
    // does per wheel): the vehicle's cost in units of it.
    let unit = Unit::new(hp_core::presets::seed_unit()).unwrap();
    let kind = RigKind::Sdof { sprung_mass_kg: 3000.0, base: Motion::Sine { amplitude_m: 0.02, frequency_hz: 1.0, offset_m: 0.0 } };
    let rig = Rig::new(&unit, kind, 293.15, Valves::from_modes(false, true)).unwrap();
    let mut g = c.benchmark_group("sdof_10s_at_1khz");
    g.sample_size(20);
    g.bench_function("run", |b| {
        b.iter(|| {
            let mut last = 0.0;
            rig_run(&rig, (0..=10_000).map(|i| f64::from(i) * 1e-3), 1e-3, |_, _| Valves::from_modes(false, true), |_, s| {
                last = s.body_disp_m;
                true
            })
            .unwrap();
            black_box(last)
        })
    });
    g.finish();
}

const SECONDS: usize = 10;
const DT_S: f64 = 1e-3;

fn drive(c: &mut Criterion, name: &str, params: VehicleParams) {
    let (left, right) = rough(SECONDS as f64 * 12.0 + 20.0);
    let road = Road { left: Track { start_m: -10.0, dx_m: 0.02, height_m: &left }, right: Track { start_m: -10.0, dx_m: 0.02, height_m: &right } };
    let ctrl = Params::new(presets::controller_config(&params)).unwrap();
    let mut g = c.benchmark_group(format!("{name}_10s_at_1khz"));
    g.sample_size(10);
    g.throughput(Throughput::Elements((SECONDS * 1000) as u64));
    for (label, suspension) in [("passive", Suspension::Passive(Valves::from_modes(false, true))), ("semi_active", Suspension::SemiActive(&ctrl))] {
        let vehicle = Vehicle::new(params, 293.15, suspension.initial_valves()).unwrap();
        g.bench_function(label, |b| {
            b.iter(|| {
                let mut states = [State::new(); MAX_CORNERS];
                let mut last = 0.0;
                run(&vehicle, &road, suspension, &Sensors::default(), &mut states, SECONDS * 1000, DT_S, DT_S, |_, _| Driver { speed_m_s: 12.0, ..Driver::default() }, |p| {
                    last = p.sample.body.heave_m;
                    true
                })
                .unwrap();
                black_box(last)
            })
        });
    }
    g.finish();
}

fn vehicles(c: &mut Criterion) {
    drive(c, "vehicle_8x8", presets::armoured_8x8());
    drive(c, "vehicle_4x4", presets::armoured_4x4());
}

criterion_group!(benches, baseline, vehicles);
criterion_main!(benches);

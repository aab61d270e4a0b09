//! Speed benchmarks of the physics core (not tests: nothing here can fail
//! because a machine is slow). `scripts/bench_report.py` turns criterion's
//! results into BENCHMARKS.md, as absolute numbers and as ratios against the
//! `baseline` group measured in the same run.
//!
//!     cargo bench -p hp-core --bench physics
#![allow(clippy::unwrap_used, clippy::expect_used)]
use criterion::{criterion_group, criterion_main, BatchSize, Criterion, Throughput};
use hp_core::gas::{EquationOfState, Gas};
use hp_core::motion::Motion;
use hp_core::presets::{seed_unit, SEED_SPRUNG_MASS_KG};
use hp_core::rig::{run, Rig, RigKind};
use hp_core::unit::{Unit, Valves};
use std::hint::black_box;

fn baseline(c: &mut Criterion) {
    // One libm exp: the unit of cost that a BWR evaluation is built around.
    c.bench_function("baseline/exp", |b| b.iter(|| libm::exp(black_box(-0.41))));
}

fn eos(c: &mut Criterion) {
    let mut g = c.benchmark_group("eos_props");
    for gas in Gas::ALL {
        g.bench_function(gas.name(), |b| b.iter(|| gas.props(black_box(166.96), black_box(293.15))));
    }
    g.finish();
    let mut g = c.benchmark_group("eos_density_solve");
    g.bench_function("bwr-textbook", |b| b.iter(|| Gas::BwrTextbook.density_kg_m3(black_box(14.8e6), black_box(293.15))));
    g.finish();
}

fn sdof_rig(unit: &Unit) -> Rig<'_> {
    let kind = RigKind::Sdof {
        sprung_mass_kg: SEED_SPRUNG_MASS_KG,
        base: Motion::Step { height_m: 0.043, start_s: 0.5, rise_s: 0.05 },
    };
    Rig::new(unit, kind, 293.15, Valves::from_modes(false, true)).unwrap()
}

fn sdof(c: &mut Criterion) {
    let unit = Unit::new(seed_unit()).unwrap();
    let rig = sdof_rig(&unit);
    let state = rig.initial_state().unwrap();
    c.bench_function("sdof/rk4_step_1ms", |b| b.iter(|| rig.step(black_box(0.6), black_box(&state), 1e-3).unwrap()));

    // Ten simulated seconds at 1 kHz with every sample observed: the
    // real-time factor is 10 s divided by this time.
    let mut g = c.benchmark_group("sdof_10s_at_1khz");
    g.sample_size(20);
    g.throughput(Throughput::Elements(10_000));
    g.bench_function("run", |b| {
        b.iter_batched(
            || (),
            |_| {
                let mut last = 0.0;
                run(&rig, (0..=10_000).map(|i| f64::from(i) * 1e-3), 1e-3, |_, _| Valves::from_modes(false, true), |_, s| {
                    last = s.body_disp_m;
                    true
                })
                .unwrap();
                last
            },
            BatchSize::SmallInput,
        )
    });
    g.finish();
}

criterion_group!(benches, baseline, eos, sdof);
criterion_main!(benches);

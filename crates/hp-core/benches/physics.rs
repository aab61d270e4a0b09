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
use hp_core::rig::{run, run_adaptive, Adaptive, Rig, RigKind, SampleDetail, Steps};
use hp_core::unit::{Unit, Valves};
use std::hint::black_box;

fn baseline(c: &mut Criterion) {
    // One libm exp: the unit of cost the equations of state are built
    // around (BWR has one, the reference model five).
    c.bench_function("baseline/exp", |b| b.iter(|| libm::exp(black_box(-0.41))));
}

fn eos(c: &mut Criterion) {
    let mut g = c.benchmark_group("eos_props");
    for gas in Gas::ALL {
        g.bench_function(gas.name(), |b| b.iter(|| gas.props(black_box(166.96), black_box(293.15))));
    }
    g.finish();
    let mut g = c.benchmark_group("eos_pressure_and_slope");
    g.bench_function("span", |b| b.iter(|| Gas::Span.pressure_and_slope(black_box(166.96), black_box(293.15))));
    g.finish();
    let mut g = c.benchmark_group("eos_density_solve");
    for gas in [Gas::Span, Gas::BwrTextbook] {
        g.bench_function(gas.name(), |b| b.iter(|| gas.density_kg_m3(black_box(14.8e6), black_box(293.15))));
    }
    g.finish();
}

fn sdof_rig(unit: &Unit, valves: Valves) -> Rig<'_> {
    let kind = RigKind::Sdof {
        sprung_mass_kg: SEED_SPRUNG_MASS_KG,
        base: Motion::Step { height_m: 0.043, start_s: 0.5, rise_s: 0.05 },
    };
    Rig::new(unit, kind, 293.15, valves).unwrap()
}

fn sdof(c: &mut Criterion) {
    let unit = Unit::new(seed_unit()).unwrap();
    // The soft spring with the damper on: valve 6 open, its orifice the
    // stiffest dynamics of the unit.
    let soft_on = Valves::from_modes(false, true);
    let rig = sdof_rig(&unit, soft_on);
    let state = rig.initial_state().unwrap();
    c.bench_function("sdof/rk4_step_1ms", |b| b.iter(|| rig.step(black_box(0.6), black_box(&state), 1e-3).unwrap()));

    // Ten simulated seconds at 1 kHz with every sample observed in full
    // (all the unit's outputs): the real-time factor is 10 s divided by
    // this time. Fixed RK4 steps of 1 ms, and the adaptive integrator at
    // its default tolerance (samples from its dense output).
    let times: Vec<f64> = (0..=10_000).map(|i| f64::from(i) * 1e-3).collect();
    let mut g = c.benchmark_group("sdof_10s_at_1khz");
    g.sample_size(20);
    g.throughput(Throughput::Elements(10_000));
    g.bench_function("rk4_1ms", |b| {
        b.iter_batched(
            || (),
            |_| {
                let mut last = 0.0;
                run(&rig, times.iter().copied(), 1e-3, |_, _| soft_on, |_, s| {
                    last = s.unit.force_n;
                    true
                })
                .unwrap();
                last
            },
            BatchSize::SmallInput,
        )
    });
    for (name, detail) in [("adaptive", SampleDetail::Full), ("adaptive_states_only", SampleDetail::States)] {
        g.bench_function(name, |b| {
            b.iter(|| {
                let mut last = 0.0;
                run_adaptive(&rig, &times, Adaptive::default(), detail, Steps::Controlled, |_, _| soft_on, |_, s| {
                    last = s.body_disp_m + s.unit.force_n;
                    true
                })
                .unwrap();
                last
            })
        });
    }
    g.finish();

    // The seed's slow-steps characterisation with valve 6 open, 20 minutes
    // (5 steps of 20 mm up and down, 2 s ramps, 118 s dwells), sampled at
    // 10 Hz in full.
    let kind = RigKind::Characterisation { strut: Motion::Steps { increment_m: 0.02, count: 5, ramp_s: 2.0, dwell_s: 118.0 } };
    let rig = Rig::new(&unit, kind, 293.15, soft_on).unwrap();
    let times: Vec<f64> = (0..=12_000).map(|i| f64::from(i) * 0.1).collect();
    let mut g = c.benchmark_group("slow_steps_20min_valve6_open");
    g.sample_size(10);
    g.bench_function("adaptive", |b| {
        b.iter(|| {
            let mut last = 0.0;
            run_adaptive(&rig, &times, Adaptive::default(), SampleDetail::Full, Steps::Controlled, |_, _| soft_on, |_, s| {
                last = s.unit.force_n;
                true
            })
            .unwrap();
            last
        })
    });
    g.finish();
}

fn power_law(c: &mut Criterion) {
    // The effects' power laws (wall conductance, oil cooling, leakage) at
    // every stage of every step: `unit::power` (exp of n ln x) against the
    // libm crate's fdlibm pow it replaced (stop 60), at a wall-conductance
    // factor's typical base and a fitted exponent.
    let mut g = c.benchmark_group("power_law");
    g.bench_function("libm_pow", |b| b.iter(|| libm::pow(black_box(0.97), black_box(0.9066))));
    g.bench_function("unit_power", |b| b.iter(|| hp_core::unit::power(black_box(0.97), black_box(0.9066))));
    g.finish();
}

criterion_group!(benches, baseline, eos, sdof, power_law);
criterion_main!(benches);

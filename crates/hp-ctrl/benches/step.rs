//! Nanoseconds per controller step on the host, against a trivial baseline
//! (copying the period's inputs) measured in the same run.
//!
//! The inputs replay 1000 periods of a vehicle in Ride on a rough road with
//! a lowering request in progress, so every block (monitor, estimators,
//! mode, skyhook, sequencer with table look-ups) does its full work.
//!
//!     cargo bench -p hp-ctrl --bench step
#![allow(clippy::unwrap_used, clippy::indexing_slicing)]

use std::hint::black_box;

use criterion::{criterion_group, criterion_main, Criterion};
use hp_ctrl::{input_group, step, Inputs, Params, State};

const DT_S: f64 = 1.0e-3;

fn road(params: &Params) -> Vec<Inputs> {
    let unit = &params.config().unit;
    (0..1000)
        .map(|k| {
            let t = k as f64 * DT_S;
            let w = 2.0 * std::f64::consts::PI;
            Inputs {
                p_gas_pa: unit.static_pressure_pa * (1.0 + 0.1 * (1.5 * w * t).sin()),
                p_gas2_pa: unit.static_pressure_pa * (1.0 + 0.05 * (1.5 * w * t + 0.3).sin()),
                strut_disp_m: 0.02 * (1.5 * w * t).sin(),
                body_acc_m_s2: 0.5 * (1.1 * w * t).cos(),
                speed_m_s: 15.0,
                lat_acc_m_s2: 0.3 * (0.2 * w * t).sin(),
                long_acc_m_s2: 0.1,
                steer_angle_rad: 0.05,
                steer_rate_rad_s: 0.1,
                t_gas_k: unit.static_temperature_k + 10.0,
                ride_height_request_m: -0.03,
                fresh: input_group::ALL,
                ..Inputs::default()
            }
        })
        .collect()
}

fn bench_step(c: &mut Criterion) {
    let params = Params::seed_unit().unwrap();
    let periods = road(&params);
    // Past recovery, the hold and the load estimate's settling (0.5 + 5 s),
    // so the normal path runs, sequencing included.
    let mut warm = State::new();
    for _ in 0..7 {
        for inputs in &periods {
            step(&params, &mut warm, inputs, DT_S);
        }
    }
    let mut group = c.benchmark_group("controller");
    group.bench_function("baseline: copy Inputs", |b| {
        let mut k = 0;
        b.iter(|| {
            k = (k + 1) % periods.len();
            black_box(*black_box(&periods[k]))
        })
    });
    group.bench_function("step", |b| {
        let mut state = warm;
        let mut k = 0;
        b.iter(|| {
            k = (k + 1) % periods.len();
            step(black_box(&params), &mut state, black_box(&periods[k]), black_box(DT_S))
        })
    });
    group.finish();
}

criterion_group!(benches, bench_step);
criterion_main!(benches);

//! Shared test support: reading the CoolProp fixtures, building units and
//! running rigs into vectors.
#![allow(dead_code, clippy::unwrap_used, clippy::expect_used, clippy::indexing_slicing, clippy::panic)]

use hp_core::gas::{EquationOfState, Gas};
use hp_core::motion::Motion;
use hp_core::rig::{run, Rig, RigKind, RigSample};
use hp_core::unit::{Unit, UnitParams, Valves};
use std::collections::HashMap;

/// Rows of a CoolProp fixture (comment lines start with '#').
pub fn fixture(name: &str) -> Vec<HashMap<String, f64>> {
    let path = format!("{}/tests/data/{name}", env!("CARGO_MANIFEST_DIR"));
    let text = std::fs::read_to_string(&path).expect(&path);
    let mut lines = text.lines().filter(|l| !l.starts_with('#'));
    let header: Vec<String> = lines.next().unwrap().split(',').map(str::to_owned).collect();
    lines
        .map(|l| header.iter().cloned().zip(l.split(',').map(|v| v.parse::<f64>().unwrap())).collect())
        .collect()
}

/// Relative error statistics of one model against the reference grid.
#[derive(Debug, Clone, Copy)]
pub struct ErrorStats {
    pub max: f64,
    pub rms: f64,
    /// (p_pa, t_k) where the max occurs.
    pub at: (f64, f64),
}

/// Relative errors of `quantity(model props)` against the fixture column
/// `column`, over rows with p <= p_max_pa.
pub fn errors(gas: Gas, column: &str, p_max_pa: f64, quantity: impl Fn(&hp_core::gas::GasProps) -> f64) -> ErrorStats {
    let mut max: f64 = 0.0;
    let mut sum2 = 0.0;
    let mut n = 0.0;
    let mut at = (0.0, 0.0);
    for row in fixture("n2_grid.csv") {
        if row["p_pa"] > p_max_pa {
            continue;
        }
        let props = gas.props(row["rho_kg_m3"], row["t_k"]);
        let e = (quantity(&props) / row[column] - 1.0).abs();
        if e > max {
            max = e;
            at = (row["p_pa"], row["t_k"]);
        }
        sum2 += e * e;
        n += 1.0;
    }
    ErrorStats { max, rms: (sum2 / n).sqrt(), at }
}

/// Runs a rig over uniformly spaced output times and collects the samples.
pub fn run_uniform(unit: &Unit, kind: RigKind<'_>, valves: Valves, duration_s: f64, out_dt_s: f64, dt_s: f64) -> Vec<RigSample> {
    let rig = Rig::new(unit, kind, unit.params().static_temperature_k, valves).unwrap();
    let n = (duration_s / out_dt_s).round() as usize;
    let mut out = Vec::with_capacity(n + 1);
    run(&rig, (0..=n).map(|i| i as f64 * out_dt_s), dt_s, |_, _| valves, |_, s| {
        out.push(*s);
        true
    })
    .unwrap();
    out
}

/// A sine on the characterisation rig.
pub fn sine(amplitude_m: f64, frequency_hz: f64) -> RigKind<'static> {
    RigKind::Characterisation { strut: Motion::Sine { amplitude_m, frequency_hz, offset_m: 0.0 } }
}

/// The seed's unit with modifications.
pub fn unit_with(f: impl FnOnce(&mut UnitParams)) -> Unit {
    let mut p = hp_core::presets::seed_unit();
    f(&mut p);
    Unit::new(p).unwrap()
}

/// Loop integral of `y dx` over samples (trapezoid), e.g. the work
/// `integral F dx` over whole cycles.
pub fn loop_integral(xs: impl Iterator<Item = (f64, f64)>) -> f64 {
    let pts: Vec<(f64, f64)> = xs.collect();
    pts.windows(2).map(|w| 0.5 * (w[0].1 + w[1].1) * (w[1].0 - w[0].0)).sum()
}

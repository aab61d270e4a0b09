//! Prints the accuracy table of the equations of state against CoolProp's
//! reference nitrogen (the golden fixture written by
//! tests/reference/make_n2_reference.py: a dense grid over 2-110 MPa and
//! 233-473 K, and states beyond it), as Markdown for docs/accuracy.md.
//!
//!     cargo run --release -p hp-core --example eos_accuracy
#![allow(clippy::unwrap_used, clippy::expect_used, clippy::indexing_slicing)]
#[path = "../tests/common/mod.rs"]
mod common;
use common::fixture;
use hp_core::gas::{EquationOfState, Gas, GasProps};
use std::collections::HashMap;

type Row = HashMap<String, f64>;

/// Largest and RMS relative error of `model(row)` against `row[column]`
/// over `rows`, with the (p, T) of the largest.
fn stats(rows: &[&Row], column: &str, model: impl Fn(&Row) -> Option<f64>) -> (f64, (f64, f64), f64, usize) {
    let (mut max, mut at, mut sum2, mut n, mut failed) = (0.0_f64, (0.0, 0.0), 0.0, 0.0, 0);
    for r in rows {
        let Some(v) = model(r) else {
            failed += 1;
            continue;
        };
        let e = (v / r[column] - 1.0).abs();
        if e > max {
            max = e;
            at = (r["p_pa"], r["t_k"]);
        }
        sum2 += e * e;
        n += 1.0;
    }
    (max, at, (sum2 / n).sqrt(), failed)
}

fn pct(x: f64) -> String {
    if x >= 1e-4 {
        format!("{:.2} %", 100.0 * x)
    } else {
        format!("{:.0e}", x)
    }
}

fn main() {
    let all = fixture("n2_span_golden.csv");
    let envelope: Vec<&Row> = all.iter().filter(|r| r["region"] == 0.0).collect();
    let low: Vec<&Row> = envelope.iter().copied().filter(|r| r["p_pa"] <= 30.1e6).collect();
    let beyond: Vec<&Row> = all.iter().filter(|r| r["region"] == 1.0).collect();
    println!("{} states on the envelope grid (2-110 MPa x 233-473 K), {} beyond it.\n", envelope.len(), beyond.len());
    println!("| model | quantity | range | max error | at (MPa, K) | RMS error |");
    println!("|---|---|---|---|---|---|");
    type Quantity = (&'static str, &'static str, fn(&GasProps) -> f64);
    let quantities: [Quantity; 4] = [
        ("p", "p_pa", |p| p.p_pa),
        ("(dp/dT)_rho", "dp_dt_pa_per_k", |p| p.dp_dt_pa_per_k),
        ("(dp/drho)_T", "dp_drho_pa_m3_per_kg", |p| p.dp_drho_pa_m3_per_kg),
        ("c_v", "cv_j_per_kg_k", |p| p.cv_j_per_kg_k),
    ];
    for gas in Gas::ALL {
        let ranges: Vec<(&str, &[&Row])> = if gas == Gas::Span {
            vec![("2-110 MPa", &envelope), ("beyond", &beyond)]
        } else {
            vec![("2-30 MPa", &low), ("2-110 MPa", &envelope)]
        };
        for (label, column, f) in quantities {
            for (range, rows) in &ranges {
                let (max, at, rms, _) = stats(rows, column, |r| Some(f(&gas.props(r["rho_kg_m3"], r["t_k"]))));
                println!("| {} | {label} | {range} | {} | {:.3}, {:.0} | {} |", gas.name(), pct(max), at.0 / 1e6, at.1, pct(rms));
            }
        }
        for (range, rows) in &ranges {
            let (max, at, rms, failed) = stats(rows, "rho_kg_m3", |r| gas.density_kg_m3(r["p_pa"], r["t_k"]).ok());
            let note = if failed > 0 { format!(" ({failed} not solved)") } else { String::new() };
            println!("| {} | density from (p, T) | {range} | {}{note} | {:.3}, {:.0} | {} |", gas.name(), pct(max), at.0 / 1e6, at.1, pct(rms));
        }
    }
}

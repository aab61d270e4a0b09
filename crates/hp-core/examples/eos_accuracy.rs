//! Prints the accuracy table of the equations of state against CoolProp's
//! reference nitrogen (the fixture written by
//! tests/reference/make_n2_reference.py), as Markdown for docs/accuracy.md.
//!
//!     cargo run -p hp-core --example eos_accuracy
#![allow(clippy::unwrap_used, clippy::expect_used, clippy::indexing_slicing)]
#[path = "../tests/common/mod.rs"]
mod common;
use common::errors;
use hp_core::gas::Gas;

fn main() {
    println!("| model | quantity | range | max error | at (MPa, K) | RMS error |");
    println!("|---|---|---|---|---|---|");
    for gas in Gas::ALL {
        type Quantity = (&'static str, &'static str, fn(&hp_core::gas::GasProps) -> f64);
        let quantities: [Quantity; 3] = [
            ("p", "p_pa", |p| p.p_pa),
            ("(dp/dT)_rho", "dp_dt_pa_per_k", |p| p.dp_dt_pa_per_k),
            ("c_v", "cv_j_per_kg_k", |p| p.cv_j_per_kg_k),
        ];
        for (label, column, f) in quantities {
            for (range, p_max) in [("2-30 MPa", 30.1e6), ("2-110 MPa", 111e6)] {
                let e = errors(gas, column, p_max, f);
                println!(
                    "| {} | {label} | {range} | {:.2} % | {:.0}, {:.0} | {:.2} % |",
                    gas.name(),
                    100.0 * e.max,
                    e.at.0 / 1e6,
                    e.at.1,
                    100.0 * e.rms
                );
            }
        }
    }
}

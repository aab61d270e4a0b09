//! Prints `crates/hp-ctrl/src/calibration/tables.rs`, the built-in
//! calibrations compiled on the host (see `hp_ctrl::calibration`):
//!
//! ```text
//! cargo run -p hp-ctrl --no-default-features --example write_calibration \
//!     > crates/hp-ctrl/src/calibration/tables.rs
//! ```

use std::process::ExitCode;

fn main() -> ExitCode {
    let mut text = String::new();
    if hp_ctrl::calibration::write_tables(&mut text).is_err() {
        eprintln!("write_calibration: a calibration does not validate, has a non-finite value, or the corners differ");
        return ExitCode::FAILURE;
    }
    print!("{text}");
    ExitCode::SUCCESS
}

//! Prints the model description of one FMU: `hp-fmu-describe hpctl_unit`.
//! `scripts/build-fmu.sh` calls it when packing the FMUs.

use std::process::ExitCode;

fn main() -> ExitCode {
    let id = std::env::args().nth(1).unwrap_or_default();
    match hp_fmu::model_info(&id) {
        Some(info) => {
            print!("{}", hp_fmu::description::model_description(info, env!("CARGO_PKG_VERSION")));
            ExitCode::SUCCESS
        }
        None => {
            eprintln!("usage: hp-fmu-describe hpctl_unit|hpctl_controller (got {id:?})");
            ExitCode::from(2)
        }
    }
}

//! `hpctl._core`: the Rust core as seen from Python. Thin by design: it
//! converts arguments, releases the GIL, calls hp-core / hp-ctrl and
//! converts results; all physics and control logic live in those crates.

use pyo3::prelude::*;

mod args;
mod can;
mod ctrl;
mod e2e_counter;
mod errors;
mod exec;
mod leak;
mod params;
mod plant;
mod sim;
mod vehicle;

#[pymodule]
fn _core(m: &Bound<'_, PyModule>) -> PyResult<()> {
    errors::register(m)?;
    sim::register(m)?;
    ctrl::register(m)?;
    can::register(m)?;
    leak::register(m)?;
    vehicle::register(m)?;
    m.add_class::<plant::Plant>()?;
    m.add_class::<e2e_counter::CanCounter>()?;
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    Ok(())
}

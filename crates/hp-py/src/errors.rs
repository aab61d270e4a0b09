//! One Rust error enum, one Python exception hierarchy.
//!
//! `hp_core::Error` maps variant by variant onto subclasses of `HpctlError`,
//! which derives from `ValueError`, so `except ValueError` catches every bad
//! input. A panic (a bug) is caught at the boundary and raised as
//! `InternalError` instead of crossing into Python.

use pyo3::exceptions::{PyRuntimeError, PyValueError};
use pyo3::prelude::*;
use std::panic::{catch_unwind, AssertUnwindSafe};

pyo3::create_exception!(_core, HpctlError, PyValueError, "Base of hpctl's input errors (a ValueError).");
pyo3::create_exception!(_core, ParameterError, HpctlError, "A parameter is missing, unknown, or outside its valid range.");
pyo3::create_exception!(_core, ConvergenceError, HpctlError, "An iterative solve did not converge for the given input.");
pyo3::create_exception!(_core, SimulationError, HpctlError, "The simulated state left the model's valid range (step too large or excitation too violent).");
pyo3::create_exception!(_core, InternalError, PyRuntimeError, "A bug in hpctl's Rust core: please report it.");

/// The Python exception for a core error, with the core's message (which
/// names the parameter, its value and the valid range). A parameter error
/// also carries them as attributes (`parameter`, `value`, `expected`), like
/// the ones `hpctl.errors` raises.
pub fn to_py(e: hp_core::Error) -> PyErr {
    let message = e.to_string();
    match e {
        hp_core::Error::OutOfRange { name, value, min, max } => {
            let value = move |py: Python<'_>| pyo3::types::PyFloat::new(py, value).into_any().unbind();
            with_fields(ParameterError::new_err(message), name, value, &format!("a finite number within [{min:e}, {max:e}]"))
        }
        hp_core::Error::NoConvergence { .. } => ConvergenceError::new_err(message),
        hp_core::Error::StateOutOfRange { .. } => SimulationError::new_err(message),
    }
}

/// Sets the `parameter`, `value` and `expected` attributes of an error.
fn with_fields(err: PyErr, name: &str, value: impl FnOnce(Python<'_>) -> Py<PyAny>, expected: &str) -> PyErr {
    Python::attach(|py| {
        let v = err.value(py);
        // Attributes on a fresh exception instance cannot fail; if they
        // did, the message still says everything.
        let _ = v.setattr("parameter", name);
        let _ = v.setattr("value", value(py));
        let _ = v.setattr("expected", expected);
    });
    err
}

/// An error about an input the binding itself checks (missing or unknown
/// key, wrong type).
pub fn parameter(message: impl Into<String>) -> PyErr {
    ParameterError::new_err(message.into())
}

/// A bad argument: `name = value: expected ...`, with the attributes
/// `parameter`, `value` and `expected` (the message says the same).
pub fn bad_argument(name: &str, value: &Bound<'_, PyAny>, expected: &str) -> PyErr {
    let repr = value.repr().map(|r| r.to_string()).unwrap_or_else(|_| "?".to_owned());
    // One line, at most about 80 characters, whatever the repr.
    let mut shown = repr.split_whitespace().collect::<Vec<_>>().join(" ");
    if shown.chars().count() > 80 {
        shown = shown.chars().take(77).collect::<String>() + "...";
    }
    let err = ParameterError::new_err(format!("{name} = {shown}: expected {expected}"));
    with_fields(err, name, |_| value.clone().unbind(), expected)
}

/// Runs `f`, turning a panic into `InternalError`.
pub fn guard<T>(f: impl FnOnce() -> PyResult<T>) -> PyResult<T> {
    match catch_unwind(AssertUnwindSafe(f)) {
        Ok(result) => result,
        Err(payload) => {
            let what = payload
                .downcast_ref::<&str>()
                .map(|s| (*s).to_owned())
                .or_else(|| payload.downcast_ref::<String>().cloned())
                .unwrap_or_else(|| "unknown panic".to_owned());
            Err(InternalError::new_err(format!("internal error in hpctl's Rust core: {what}")))
        }
    }
}

/// Registers the exception classes on the module.
pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    let py = m.py();
    m.add("HpctlError", py.get_type::<HpctlError>())?;
    m.add("ParameterError", py.get_type::<ParameterError>())?;
    m.add("ConvergenceError", py.get_type::<ConvergenceError>())?;
    m.add("SimulationError", py.get_type::<SimulationError>())?;
    m.add("InternalError", py.get_type::<InternalError>())?;
    Ok(())
}

//! The one error type of the physics core.
//!
//! Every fallible operation returns [`Error`]; nothing in this crate panics.
//! The bindings map each variant to one Python exception class, so every
//! variant carries what a user needs to fix the input: the parameter, the
//! value it had and the range it must lie in.

use core::fmt;

/// Why a physics computation could not be done.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Error {
    /// A parameter or input lies outside the range the model is valid for
    /// (this includes NaN and infinities where they are not allowed).
    OutOfRange {
        /// Name of the parameter, with its SI unit suffix.
        name: &'static str,
        /// The value that was given.
        value: f64,
        /// Smallest valid value (inclusive).
        min: f64,
        /// Largest valid value (inclusive).
        max: f64,
    },
    /// An iterative solve (e.g. density from pressure and temperature)
    /// did not converge within its iteration budget.
    NoConvergence {
        /// What was being solved.
        what: &'static str,
        /// The input it was solved for (e.g. the pressure in Pa).
        target: f64,
    },
    /// The state left the physically meaningful region during integration
    /// (e.g. a gas volume reached zero): the step size is too large or the
    /// excitation drives the unit beyond what the model describes.
    StateOutOfRange {
        /// Name of the state variable, with its SI unit suffix.
        name: &'static str,
        /// The value it reached.
        value: f64,
        /// Smallest valid value.
        min: f64,
        /// Largest valid value.
        max: f64,
        /// Simulated time at which it happened, in seconds.
        time_s: f64,
    },
}

/// Shorthand for results of this crate.
pub type Result<T> = core::result::Result<T, Error>;

/// A number as people read it: plain in [1e-3, 1e6), scientific otherwise.
struct Num(f64);

impl fmt::Display for Num {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let a = libm::fabs(self.0);
        if a == 0.0 || (1e-3..1e6).contains(&a) || !a.is_finite() {
            write!(f, "{}", self.0)
        } else {
            write!(f, "{:e}", self.0)
        }
    }
}

impl fmt::Display for Error {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match *self {
            Error::OutOfRange { name, value, min, max } => write!(
                f,
                "{name} = {} is outside the valid range [{}, {}]",
                Num(value),
                Num(min),
                Num(max)
            ),
            Error::NoConvergence { what, target } => {
                write!(f, "{what} did not converge for target {}", Num(target))
            }
            Error::StateOutOfRange { name, value, min, max, time_s } => write!(
                f,
                "state {name} = {} left the valid range [{}, {}] at t = {} s \
                 (a fixed step too long for the model's fastest dynamics, or \
                 parameters or an excitation that take the unit out of the \
                 model's range, such as a leak that emptied the gas)",
                Num(value),
                Num(min),
                Num(max),
                Num(time_s)
            ),
        }
    }
}

/// Checks that `value` is finite and within `[min, max]`.
///
/// ```
/// use hp_core::error::check_range;
/// assert!(check_range("mass_kg", 3000.0, 1e-3, 1e6).is_ok());
/// assert!(check_range("mass_kg", f64::NAN, 1e-3, 1e6).is_err());
/// ```
pub fn check_range(name: &'static str, value: f64, min: f64, max: f64) -> Result<f64> {
    // `!(a <= b)` also rejects NaN.
    if value.is_finite() && value >= min && value <= max {
        Ok(value)
    } else {
        Err(Error::OutOfRange { name, value, min, max })
    }
}

//! The E2E alive-counter sequence of one message's receiver
//! (`hp_ctrl::can::e2e::CounterState`) from Python: what `hpctl can
//! decode` applies to a log, so a log is judged by the ECU's own rule.

use crate::errors::{guard, parameter};
use hp_ctrl::can::e2e::{CounterState, Sequence, COUNTER_MAX};
use pyo3::prelude::*;

/// One message's counter check: `check(counter)` returns "next",
/// "repeated", "skipped" or "synced" (no reference yet: power-on).
#[pyclass(module = "hpctl._core")]
pub struct CanCounter {
    state: CounterState,
}

#[pymethods]
impl CanCounter {
    #[new]
    fn new() -> Self {
        CanCounter { state: CounterState::new() }
    }

    /// Checks the counter of a CRC-valid frame (0..=14) and updates the reference.
    fn check(&mut self, counter: i64) -> PyResult<&'static str> {
        guard(|| {
            let c = u8::try_from(counter)
                .ok()
                .filter(|&c| c <= COUNTER_MAX)
                .ok_or_else(|| parameter(format!("counter = {counter} must be within [0, {COUNTER_MAX}]")))?;
            Ok(match self.state.check(c) {
                Sequence::Next => "next",
                Sequence::Repeated => "repeated",
                Sequence::Skipped => "skipped",
                Sequence::Synced => "synced",
            })
        })
    }

    /// Forgets the reference (the next valid frame re-synchronises).
    fn reset(&mut self) {
        self.state.reset();
    }
}

//! Running core work from Python: with the GIL released, with progress
//! and Ctrl-C, or many cases in parallel on a rayon pool.

use crate::errors::{parameter, to_py};
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyList};

/// Runs `work` with the GIL released. `work` gets a tick function to call
/// with its progress (`done` out of `total`); about ten times a second the
/// tick takes the GIL back to check for Ctrl-C and to call `progress(done,
/// total)`, and returns `false` when the work should stop. An interrupt or
/// an exception in the callback is then returned instead of the result.
pub fn detached_with_progress<T: Send>(
    py: Python<'_>,
    total: usize,
    progress: Option<Py<PyAny>>,
    work: impl FnOnce(&mut dyn FnMut(usize) -> bool) -> T + Send,
) -> PyResult<T> {
    let mut interrupt: Option<PyErr> = None;
    let result = py.detach(|| {
        let mut last = std::time::Instant::now();
        let mut tick = |done: usize| -> bool {
            if last.elapsed().as_millis() < 100 {
                return true;
            }
            last = std::time::Instant::now();
            Python::attach(|py| {
                let reported = py.check_signals().and_then(|()| match &progress {
                    Some(cb) => cb.call1(py, (done, total)).map(|_| ()),
                    None => Ok(()),
                });
                match reported {
                    Ok(()) => true,
                    Err(e) => {
                        interrupt = Some(e);
                        false
                    }
                }
            })
        };
        work(&mut tick)
    });
    match interrupt {
        Some(e) => Err(e),
        None => Ok(result),
    }
}

/// Runs every case on a pool of `threads` threads (all cores when None)
/// with the GIL released, then converts each result with `to_dict`. A
/// failed case yields its exception in the returned list, in its place, so
/// one bad case does not lose the others.
pub fn run_parallel<'py, C: Sync, R: Send>(
    py: Python<'py>,
    cases: &[C],
    threads: Option<usize>,
    run: impl Fn(&C) -> Result<R, hp_core::Error> + Sync,
    to_dict: impl Fn(&C, R) -> PyResult<Bound<'py, PyDict>>,
) -> PyResult<Bound<'py, PyList>> {
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads.unwrap_or(0))
        .build()
        .map_err(|e| parameter(format!("threads = {threads:?}: {e}")))?;
    let results: Vec<Result<R, hp_core::Error>> = py.detach(|| {
        use rayon::prelude::*;
        pool.install(|| cases.par_iter().map(&run).collect())
    });
    let out = PyList::empty(py);
    for (case, result) in cases.iter().zip(results) {
        match result {
            Ok(r) => out.append(to_dict(case, r)?)?,
            Err(e) => out.append(to_py(e).into_value(py))?,
        }
    }
    Ok(out)
}

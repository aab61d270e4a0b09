//! Running core work from Python: with the GIL released, with progress
//! and Ctrl-C, or many cases in parallel on a rayon pool.

use crate::errors::{bad_argument, parameter, to_py};
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyList};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc::{self, RecvTimeoutError};
use std::time::Duration;

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

/// Most threads a pool may have, as a multiple of the cores: more only
/// adds switching (the work is CPU-bound), and an absurd count (a typo,
/// 100000) must not start thousands of threads.
pub const MAX_THREADS_PER_CORE: usize = 4;

/// The number of cores (1 if the system cannot tell).
pub fn cores() -> usize {
    std::thread::available_parallelism().map(std::num::NonZeroUsize::get).unwrap_or(1)
}

/// The `threads` argument of the parallel runners: None or 0 = all cores,
/// else 1 to [`MAX_THREADS_PER_CORE`] x the cores. Anything else (negative,
/// too many, not an integer) is a `ParameterError` naming it.
pub fn threads_arg(threads: Option<&Bound<'_, PyAny>>) -> PyResult<Option<usize>> {
    let Some(obj) = threads.filter(|t| !t.is_none()) else { return Ok(None) };
    let max = MAX_THREADS_PER_CORE * cores();
    let expected = format!("an integer from 0 (all {} cores) to {max} ({MAX_THREADS_PER_CORE} x the cores)", cores());
    if obj.is_instance_of::<pyo3::types::PyBool>() {
        return Err(bad_argument("threads", obj, &expected));
    }
    match obj.extract::<i64>() {
        Ok(0) => Ok(None),
        Ok(n) if n > 0 && (n as u64) <= max as u64 => Ok(Some(n as usize)),
        _ => Err(bad_argument("threads", obj, &expected)),
    }
}

/// Runs every case on a pool of `threads` threads (all cores when None)
/// with the GIL released, then converts each result with `to_dict`. A
/// failed case yields its exception in the returned list, in its place, so
/// one bad case does not lose the others.
///
/// Ctrl-C: the calling thread wakes every 100 ms to let Python check its
/// signals; on an interrupt the cases not yet started are skipped, the
/// ones running finish, and the interrupt is raised (within about one
/// case's run time, not after the whole batch).
pub fn run_parallel<'py, C: Sync, R: Send>(
    py: Python<'py>,
    cases: &[C],
    threads: Option<usize>,
    run: impl Fn(&C) -> Result<R, hp_core::Error> + Sync,
    to_dict: impl Fn(&C, R) -> PyResult<Bound<'py, PyDict>>,
) -> PyResult<Bound<'py, PyList>> {
    let max = MAX_THREADS_PER_CORE * cores();
    if let Some(n) = threads.filter(|&n| n > max) {
        return Err(parameter(format!("threads = {n}: expected at most {max} ({MAX_THREADS_PER_CORE} x the {} cores)", cores())));
    }
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads.unwrap_or(0))
        .build()
        .map_err(|e| parameter(format!("threads = {threads:?}: {e}")))?;
    let cancel = AtomicBool::new(false);
    let mut interrupt: Option<PyErr> = None;
    let results: Vec<Option<Result<R, hp_core::Error>>> = py.detach(|| {
        std::thread::scope(|scope| {
            let (done_tx, done_rx) = mpsc::channel::<()>();
            let worker = scope.spawn(|| {
                use rayon::prelude::*;
                let out = pool.install(|| {
                    cases.par_iter().map(|c| if cancel.load(Ordering::Relaxed) { None } else { Some(run(c)) }).collect()
                });
                drop(done_tx);
                out
            });
            // Disconnected (the worker dropped its end) = done.
            while let Err(RecvTimeoutError::Timeout) = done_rx.recv_timeout(Duration::from_millis(100)) {
                if interrupt.is_none() {
                    if let Err(e) = Python::attach(|py| py.check_signals()) {
                        interrupt = Some(e);
                        cancel.store(true, Ordering::Relaxed);
                    }
                }
            }
            // A panic in a case is re-raised here, for `guard` to report.
            worker.join().unwrap_or_else(|payload| std::panic::resume_unwind(payload))
        })
    });
    if let Some(e) = interrupt {
        return Err(e);
    }
    let out = PyList::empty(py);
    for (case, result) in cases.iter().zip(results) {
        match result {
            Some(Ok(r)) => out.append(to_dict(case, r)?)?,
            Some(Err(e)) => out.append(to_py(e).into_value(py))?,
            // Only skipped on an interrupt, which returned above.
            None => out.append(parameter("case skipped").into_value(py))?,
        }
    }
    Ok(out)
}

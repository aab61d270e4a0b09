"""One BLAS thread while hpctl fits.

A fit's own linear algebra is small (SciPy's trust region: an SVD of a
Jacobian of tens of thousands of rows by tens of columns per iteration)
while the model's runs fill every core in Rust. OpenBLAS's threads wait
for their next task spinning, taking the cores from those runs: the
bundled campaign's flexible diagnosis (scripts/bench_diagnose.py, 2 cores)
spent 17 % of its CPU time in OpenBLAS's thread server and waits, and took
292.5 s with OpenBLAS's two threads, 194.0 s with one (BENCHMARKS.md, stop
39). One thread also makes a fit's rounding the same on every machine, and
with it the optimiser's path: a flexible fit's valleys are ill-conditioned
enough that the thread count moved the candidates' BIC changes (that
diagnosis: heat build-up's -4,889 with two threads, -14,880 with one; the
same verdict, 1.0587 and 1.0594 x the noise).

The limit is the process's (threadpoolctl changes the libraries' own
setting), and set from the main thread only: OpenBLAS (0.3.30 and 0.3.31,
threadpoolctl 3.8) keeps its thread count as the main thread set it, and a
limit set from another thread is not applied (measured: the main thread and
the setting thread itself both still read two). :func:`hpctl.identify.
diagnose.diagnose` holds it in its caller's thread for its whole run, its
worker threads' fits inside; the caller's setting is back when it returns.
"""

from __future__ import annotations

import threading
from collections.abc import Iterator
from contextlib import contextmanager

from threadpoolctl import threadpool_limits


@contextmanager
def one_blas_thread() -> Iterator[None]:
    """While in it, BLAS runs on one thread (from the main thread; in
    another thread it changes nothing, see the module's description)."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    # threadpoolctl's limits nest: an inner one gives back the outer's.
    with threadpool_limits(limits=1, user_api="blas"):
        yield

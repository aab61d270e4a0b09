"""Worker processes of hpctl's own, for Python work that holds the GIL.

A diagnosis runs its candidates' fits in threads: the model's runs release
the GIL (Rust), SciPy's SVD does. The flexible model's static damper fit
does not: SciPy's trust region on a few thousand samples is mostly Python.
Beside the candidates' threads it took 38 s instead of 9, and every thread
waited for it (:func:`hpctl.identify.damper_start.prefetch_static`). In a
process of its own it takes a core's time and nothing else.

Why not :class:`concurrent.futures.ProcessPoolExecutor`: its workers
(``spawn`` or ``forkserver``; ``fork`` copies a process whose other threads
hold locks) import the caller's main module again. A script that calls the
diagnosis without an ``if __name__ == "__main__"`` guard then ran its
whole self again in every worker (measured: the bundled campaign's
diagnosis three times at once, 221 s instead of 81), writing whatever
that script writes. These workers run :func:`_main` (``python -P -c``):
they import hpctl and what the tasks name, never the caller's script.

A task is a picklable function and its arguments (pickles between this
process and its own children only). A worker that fails (it cannot start,
cannot import hpctl, dies) fails its task with :class:`WorkerError`; the
caller then computes it itself. Workers ignore Ctrl-C (the caller's
process decides) and end when their input closes: when the pool shuts
down, or the caller's process ends however it ends.
"""

from __future__ import annotations

import importlib
import os
import pickle
import queue
import signal
import subprocess
import sys
import threading
from collections.abc import Callable, Sequence
from concurrent.futures import Executor, Future
from pathlib import Path
from typing import IO, Any, ParamSpec, TypeVar

from hpctl.identify import STATIC_STARTS

P = ParamSpec("P")
T = TypeVar("T")


class WorkerError(RuntimeError):
    """A worker process failed (not the task's own exception)."""


class WorkerPool(Executor):
    """``workers`` processes, each started when a task first needs it; with
    ``preload`` (modules, by name) started at once, each importing them as
    it starts: the imports then run beside the caller's own work (a
    diagnosis reading its records) instead of in front of the first tasks
    (a worker's start with SciPy and matplotlib is about a second).
    ``later``'s modules a worker imports once it has run a task and no
    task is waiting or running in any worker: what later tasks need (the
    report's figures) without delaying the first ones (the static damper
    fits, two cores' hyperthreads sharing one physical core: an import
    beside the last start made it 1.4 s instead of 1.2); a task that comes
    meanwhile waits for the import."""

    def __init__(self, workers: int, preload: Sequence[str] = (), later: Sequence[str] = ()) -> None:
        if workers < 1:
            raise ValueError(f"workers must be at least 1, got {workers}")
        self._preload = tuple(preload)
        self._later = pickle.dumps((_import_all, (tuple(later),), {}), protocol=pickle.HIGHEST_PROTOCOL) if later else None
        self._tasks: queue.SimpleQueue[tuple[Future[Any], bytes] | None] = queue.SimpleQueue()
        self._lock = threading.Lock()
        self._closed = False
        self._children: set[subprocess.Popen[bytes]] = set()
        self._running = 0  # tasks running in the workers (under _lock)
        self._threads = [threading.Thread(target=self._serve, name=f"hpctl-worker-{i}", daemon=True) for i in range(workers)]
        for t in self._threads:
            t.start()

    def submit(self, fn: Callable[P, T], /, *args: P.args, **kwargs: P.kwargs) -> Future[T]:
        with self._lock:
            if self._closed:
                raise RuntimeError("cannot submit to a WorkerPool that was shut down")
            future: Future[T] = Future()
            self._tasks.put((future, pickle.dumps((fn, args, kwargs), protocol=pickle.HIGHEST_PROTOCOL)))
            return future

    def shutdown(self, wait: bool = True, *, cancel_futures: bool = False) -> None:
        with self._lock:
            if not self._closed:
                self._closed = True
                if cancel_futures:
                    while True:
                        try:
                            item = self._tasks.get_nowait()
                        except queue.Empty:
                            break
                        if item is not None:
                            item[0].cancel()
                    # The tasks running are not waited for either: their
                    # threads see the end of the output and finish.
                    for child in self._children:
                        child.kill()
                for _ in self._threads:
                    self._tasks.put(None)
        if wait:
            for t in self._threads:
                t.join()

    def _serve(self) -> None:
        child: subprocess.Popen[bytes] | None = None
        # The child that has imported ``later``'s modules (or was asked to).
        later_in: subprocess.Popen[bytes] | None = None
        try:
            if self._preload:
                try:
                    child = self._spawn()
                except OSError:
                    child = None  # started again for the first task, which fails if it cannot
            ran = False
            while True:
                owed = self._later is not None and ran and child is not None and later_in is not child
                if owed and self._later is not None and child is not None and self._idle():
                    later_in = child
                    try:
                        _ask(child, self._later)
                    except (OSError, EOFError, pickle.UnpicklingError, ValueError):
                        pass  # the next task finds the child gone and starts another
                    continue
                try:
                    # Owing the import, the pool is looked at again shortly.
                    item = self._tasks.get(timeout=0.1 if owed else None)
                except queue.Empty:
                    continue
                if item is None:
                    break
                future, payload = item
                if not future.set_running_or_notify_cancel():
                    continue
                ran = True
                with self._lock:
                    self._running += 1
                try:
                    if child is None or child.poll() is not None:
                        self._forget(child)
                        child = self._spawn()
                    ok, value = _ask(child, payload)
                except (OSError, EOFError, pickle.UnpicklingError, ValueError) as e:
                    future.set_exception(WorkerError(f"worker process failed: {e!r}"))
                    self._forget(child)
                    child = None
                    continue
                finally:
                    with self._lock:
                        self._running -= 1
                if ok:
                    future.set_result(value)
                else:
                    future.set_exception(value)
        finally:
            self._forget(child)

    def _idle(self) -> bool:
        """No task waiting, none running in any worker."""
        with self._lock:
            return self._running == 0 and self._tasks.empty()

    def _spawn(self) -> subprocess.Popen[bytes]:
        child = _start(self._preload)
        with self._lock:
            self._children.add(child)
        return child

    def _forget(self, child: subprocess.Popen[bytes] | None) -> None:
        if child is not None:
            with self._lock:
                self._children.discard(child)
        _stop(child)


def static_pool(workers: int | None = None, later: Sequence[str] = ()) -> WorkerPool:
    """A pool of ``workers`` processes (default: one per start of the
    static damper fit, :data:`hpctl.identify.STATIC_STARTS`, at most one
    per core) for :func:`hpctl.identify.damper_start.prefetch_static`,
    started at once with what a static fit's start needs imported
    (:mod:`hpctl.identify.damper_static`); ``later``'s modules (the
    report's figures, :func:`hpctl.report.calibration.record_plots`, where
    the caller draws them there too) each worker imports once it has run a
    task and none is waiting, not before the static fits (measured,
    ``hpctl fit --flexible`` on the bundled campaign: the static fits
    waited for workers that imported hpctl's identification and the
    figures first, 1.3 s of CPU each while the CPU was busiest). A worker
    that cannot start fails its tasks, and the fits that asked for them
    are computed in the caller's process, as without it.

    Here, beside the pool, so that a caller can start it before importing
    SciPy and hpctl's identification (the command line's flexible fit: the
    workers' imports, 0.45 s of CPU each, then run while the caller's own
    leave a core idle; stop 63)."""
    n = min(len(STATIC_STARTS), os.cpu_count() or 1) if workers is None else workers
    return WorkerPool(n, preload=("hpctl.identify.damper_static",), later=later)


#: The worker's program: hpctl from where this process has it, appended to
#: the child's path (after its own site-packages, so that it changes
#: nothing another module is found by), and ``-P`` keeps the working
#: directory off it (a ``numpy.py`` there is not imported).
_BOOT = "import sys; sys.path.append({root!r}); from hpctl.identify.workers import _main; _main({preload!r})"


def _start(preload: Sequence[str] = ()) -> subprocess.Popen[bytes]:
    root = str(Path(__file__).resolve().parents[2])
    # BLAS on one thread from the start (the worker also limits it).
    env = {**os.environ, "OPENBLAS_NUM_THREADS": "1", "OMP_NUM_THREADS": "1"}
    boot = _BOOT.format(root=root, preload=tuple(preload))
    return subprocess.Popen([sys.executable, "-P", "-c", boot], stdin=subprocess.PIPE, stdout=subprocess.PIPE, env=env)


def _ask(child: subprocess.Popen[bytes], payload: bytes) -> tuple[bool, Any]:
    """Sends a pickled task to ``child`` and reads its answer."""
    if child.stdin is None or child.stdout is None:
        raise OSError("the worker has no pipes")
    child.stdin.write(len(payload).to_bytes(8, "little") + payload)
    child.stdin.flush()
    answer: tuple[bool, Any] = pickle.loads(_read(child.stdout))
    return answer


def _import_all(names: Sequence[str]) -> None:
    """A worker's task: imports ``names`` (:class:`WorkerPool`'s ``later``);
    one that fails is left to the tasks that need it, as a preload."""
    for name in names:
        try:
            importlib.import_module(name)
        except Exception as e:
            print(f"hpctl worker: importing {name} failed: {e!r}", file=sys.stderr)


def _stop(child: subprocess.Popen[bytes] | None) -> None:
    if child is None:
        return
    try:
        if child.stdin is not None:
            child.stdin.close()
        child.wait(timeout=5)
    except (OSError, subprocess.TimeoutExpired):
        child.kill()
        child.wait()


def _read(stream: IO[bytes]) -> bytes:
    head = stream.read(8)
    if len(head) < 8:
        raise EOFError("the worker closed its output")
    n = int.from_bytes(head, "little")
    body = stream.read(n)
    if len(body) < n:
        raise EOFError("the worker closed its output mid-answer")
    return body


def _main(preload: Sequence[str] = ()) -> None:
    """The worker: ``preload``'s modules imported, then tasks from stdin,
    answers to stdout, until stdin closes."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    # The protocol keeps the real stdout; anything a task prints goes to stderr.
    out = os.fdopen(os.dup(sys.stdout.fileno()), "wb")
    os.dup2(sys.stderr.fileno(), sys.stdout.fileno())
    from threadpoolctl import threadpool_limits

    for name in preload:
        # A module that fails to import fails the tasks that need it, as without preloading.
        try:
            importlib.import_module(name)
        except Exception as e:
            print(f"hpctl worker: preloading {name} failed: {e!r}", file=sys.stderr)
    # As the diagnosis's own process (hpctl.identify.blas): the same rounding.
    threadpool_limits(1)
    src = sys.stdin.buffer
    while True:
        try:
            task = _read(src)
        except EOFError:
            return
        try:
            fn, args, kwargs = pickle.loads(task)
            answer = (True, fn(*args, **kwargs))
        except Exception as e:  # the task's own failure goes back to its caller
            answer = (False, e)
        try:
            data = pickle.dumps(answer, protocol=pickle.HIGHEST_PROTOCOL)
        except Exception as e:  # an unpicklable result or exception
            data = pickle.dumps((False, WorkerError(f"the task's answer could not be sent back: {e!r}")))
        try:
            out.write(len(data).to_bytes(8, "little") + data)
            out.flush()
        except OSError:  # the pool is gone (shut down without waiting, or its process ended)
            return

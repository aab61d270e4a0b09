"""hpctl's own worker processes (hpctl.identify.workers): results and a
task's own exceptions come back, a worker that dies fails only its task,
shutting down cancels what has not started, and a script that uses them
without a ``__main__`` guard is not run again by them."""

from __future__ import annotations

import math
import operator
import os
import subprocess
import sys
import time
from pathlib import Path

import pytest

from hpctl.identify.workers import WorkerError, WorkerPool


def test_results_come_back_from_other_processes_and_a_tasks_exception_is_raised_here() -> None:
    # The tasks are the standard library's: the workers do not have the tests' directory.
    pool = WorkerPool(2)
    try:
        assert [f.result(timeout=60) for f in [pool.submit(operator.mul, float(i), 2.0) for i in range(6)]] == [0.0, 2.0, 4.0, 6.0, 8.0, 10.0]
        pids = {f.result(timeout=60) for f in [pool.submit(os.getpid) for _ in range(6)]}
        assert os.getpid() not in pids and 1 <= len(pids) <= 2
        with pytest.raises(ValueError, match="math domain error"):
            pool.submit(math.sqrt, -1.0).result(timeout=60)
        # The worker that raised it serves on.
        assert pool.submit(operator.mul, 1.5, 2.0).result(timeout=60) == 3.0
    finally:
        pool.shutdown()


def test_a_worker_that_dies_fails_its_task_only_and_is_started_again() -> None:
    pool = WorkerPool(1)
    try:
        first = pool.submit(os.getpid).result(timeout=60)
        with pytest.raises(WorkerError, match="worker process failed"):
            pool.submit(os._exit, 3).result(timeout=60)
        assert pool.submit(operator.mul, 2.0, 2.0).result(timeout=60) == 4.0
        assert pool.submit(os.getpid).result(timeout=60) != first
    finally:
        pool.shutdown()


def test_shutting_down_with_cancel_drops_what_has_not_started_and_refuses_more() -> None:
    pool = WorkerPool(1)
    running = pool.submit(time.sleep, 30.0)
    waiting = [pool.submit(time.sleep, 0.0) for _ in range(3)]
    deadline = time.monotonic() + 60
    while not running.running() and time.monotonic() < deadline:
        time.sleep(0.01)
    t0 = time.monotonic()
    pool.shutdown(wait=True, cancel_futures=True)
    assert time.monotonic() - t0 < 20  # the running task's worker is stopped, not waited out
    assert all(f.cancelled() for f in waiting)
    with pytest.raises(WorkerError):
        running.result(timeout=0)
    with pytest.raises(RuntimeError, match="shut down"):
        pool.submit(time.sleep, 0.0)


def test_a_worker_that_cannot_start_fails_its_task(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(sys, "executable", "/nonexistent/python")
    pool = WorkerPool(1)
    try:
        with pytest.raises(WorkerError):
            pool.submit(os.getpid).result(timeout=60)
    finally:
        pool.shutdown()


def test_an_unguarded_script_is_not_run_again_by_the_workers_nor_its_directorys_modules(tmp_path: Path) -> None:
    # multiprocessing's spawn and forkserver workers import the caller's
    # main module: this script would append a line per worker. And a
    # module of the working directory's name a worker imports is not the
    # one there (a worker started with the directory on its path would
    # import this threadpoolctl.py, which logs itself).
    log = tmp_path / "ran.txt"
    (tmp_path / "threadpoolctl.py").write_text(f"with open({str(log)!r}, 'a') as f:\n    f.write('shadow\\n')\n")
    (tmp_path / "scripts").mkdir()
    script = tmp_path / "scripts" / "unguarded.py"
    script.write_text(
        "import os\n"
        f"with open({str(log)!r}, 'a') as f:\n"
        "    f.write(f'{os.getpid()}\\n')\n"
        "from hpctl.identify.workers import WorkerPool\n"
        "pool = WorkerPool(2)\n"
        "print(sum(f.result(timeout=60) for f in [pool.submit(abs, -i) for i in range(4)]))\n"
        "pool.shutdown()\n"
    )
    done = subprocess.run([sys.executable, str(script)], capture_output=True, text=True, timeout=120, check=False, cwd=tmp_path)
    assert done.returncode == 0, done.stderr
    assert done.stdout.strip() == "6"
    assert len(log.read_text().splitlines()) == 1


def test_preloaded_workers_start_at_once_with_their_modules_imported() -> None:
    # Started with the pool (before any task) and with the modules named
    # imported: a task that only asks finds them (it imports nothing itself).
    asks = "sorted(m for m in ('colorsys', 'wave') if m in __import__('sys').modules)"
    pool = WorkerPool(2, preload=("colorsys", "wave"))
    try:
        deadline = time.monotonic() + 60
        while len(pool._children) < 2 and time.monotonic() < deadline:
            time.sleep(0.01)
        assert len(pool._children) == 2  # no task submitted yet
        assert pool.submit(eval, asks).result(timeout=60) == ["colorsys", "wave"]
    finally:
        pool.shutdown()
    lazy = WorkerPool(1)
    try:
        time.sleep(0.2)
        assert not lazy._children
        assert lazy.submit(eval, asks).result(timeout=60) == []
    finally:
        lazy.shutdown()


def test_a_module_that_fails_to_preload_fails_only_the_tasks_that_need_it() -> None:
    pool = WorkerPool(1, preload=("hpctl_no_such_module",))
    try:
        assert pool.submit(operator.mul, 2.0, 3.0).result(timeout=60) == 6.0
    finally:
        pool.shutdown()


#: A task that reads the worker's own modules (``eval`` pickles by name).
IMPORTED = "'colorsys' in __import__('sys').modules"


def test_a_later_module_is_imported_once_a_worker_is_idle_after_its_first_task() -> None:
    # Not before the first task (which must not wait for it), and then
    # without any task asking for it.
    pool = WorkerPool(1, preload=("json",), later=("colorsys",))
    try:
        assert pool.submit(eval, IMPORTED).result(timeout=60) is False
        deadline = time.monotonic() + 60
        while not pool.submit(eval, IMPORTED).result(timeout=60):
            assert time.monotonic() < deadline, "the later module was never imported"
            time.sleep(0.05)
    finally:
        pool.shutdown()


def test_a_later_module_that_cannot_be_imported_leaves_the_worker_serving() -> None:
    pool = WorkerPool(1, later=("hpctl_no_such_module",))
    try:
        first = pool.submit(os.getpid).result(timeout=60)
        time.sleep(0.5)  # idle: the import is tried (and fails) here
        assert [pool.submit(operator.mul, 2.0, 3.0).result(timeout=60) for _ in range(3)] == [6.0] * 3
        assert pool.submit(os.getpid).result(timeout=60) == first  # the same worker, not a new one
    finally:
        pool.shutdown()


def test_a_static_fits_worker_starts_without_reading_records() -> None:
    # The static fit's code alone (hpctl.identify.damper_static), not the
    # records' signal processing behind hpctl.identify.damper_start
    # (SciPy's signal filters): the static fits wait for the workers'
    # start while the CPU is busiest.
    from hpctl.identify.workers import static_pool

    pool = static_pool(1)
    try:
        loaded = pool.submit(eval, "sorted(m for m in ('scipy.signal', 'hpctl.identify.dataset', 'hpctl.identify.damper_static', "
                                   "'matplotlib') if m in __import__('sys').modules)").result(timeout=60)
    finally:
        pool.shutdown()
    assert loaded == ["hpctl.identify.damper_static"]

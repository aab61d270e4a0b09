"""A fit runs its linear algebra on one BLAS thread (hpctl.identify.blas):
the model's runs have the cores, and the optimiser's rounding is the same
on every machine. The caller's own setting is back once the last running
fit ends, whichever thread started it."""

from __future__ import annotations

import threading

import pytest
from threadpoolctl import threadpool_info, threadpool_limits

import hpctl
from hpctl.identify import fit as fit_module
from hpctl.identify import virtual_rig
from hpctl.identify.blas import one_blas_thread
from hpctl.identify.dataset import prepare


def _blas_threads() -> set[int]:
    return {i["num_threads"] for i in threadpool_info() if i["user_api"] == "blas"}


@pytest.fixture
def two_blas_threads():  # type: ignore[no-untyped-def]
    import scipy.linalg  # noqa: F401  (SciPy's own OpenBLAS loaded too)

    with threadpool_limits(limits=2, user_api="blas"):
        assert _blas_threads() == {2}  # the machine's libraries obey a limit at all
        yield


def test_a_fit_solves_on_one_blas_thread_and_gives_back_the_callers(two_blas_threads: None, monkeypatch: pytest.MonkeyPatch) -> None:
    seen: list[set[int]] = []
    solve = fit_module.least_squares

    def watched(*args, **kwargs):  # type: ignore[no-untyped-def]
        seen.append(_blas_threads())
        return solve(*args, **kwargs)

    monkeypatch.setattr(fit_module, "least_squares", watched)
    test = next(t for t in virtual_rig.sweep_tests() if getattr(t.motion, "frequency_hz", 0.0) == 1.0)
    datasets = prepare(virtual_rig.make_records(hpctl.Unit.seed(), tests=[test], seed=3))
    r = fit_module.fit(datasets, ("heat_transfer",), input_noise=False)
    assert r.success and seen and all(s == {1} for s in seen)
    assert _blas_threads() == {2}


def test_worker_threads_fit_inside_the_main_threads_limit(two_blas_threads: None) -> None:
    """As in a diagnosis: the caller's thread holds the limit, the worker
    threads' fits run inside it; a worker's own entry and exit change
    nothing (OpenBLAS takes no limit from a thread other than the main)."""
    seen: dict[str, set[int]] = {}

    def worker(key: str) -> None:
        with one_blas_thread():
            seen[key + " inside"] = _blas_threads()
        seen[key + " after"] = _blas_threads()

    def run(key: str) -> None:
        t = threading.Thread(target=worker, args=(key,))
        t.start()
        t.join(30)

    with one_blas_thread():
        run("held")
        seen["main, after the worker"] = _blas_threads()
    run("not held")
    assert seen == {"held inside": {1}, "held after": {1}, "main, after the worker": {1}, "not held inside": {2}, "not held after": {2}}
    assert _blas_threads() == {2}


def test_a_diagnosis_holds_one_thread_and_gives_the_setting_back(two_blas_threads: None, monkeypatch: pytest.MonkeyPatch) -> None:
    from hpctl.identify import diagnose as dg

    seen: list[set[int]] = []

    def watched(*args, **kwargs):  # type: ignore[no-untyped-def]
        seen.append(_blas_threads())
        raise RuntimeError("stop here")

    monkeypatch.setattr(dg, "_diagnose", watched)
    with pytest.raises(RuntimeError, match="stop here"):
        dg.diagnose([], ())
    assert seen == [{1}] and _blas_threads() == {2}


def test_an_error_inside_gives_the_setting_back(two_blas_threads: None) -> None:
    with pytest.raises(RuntimeError, match="inside"):
        with one_blas_thread():
            assert _blas_threads() == {1}
            raise RuntimeError("inside")
    assert _blas_threads() == {2}

"""The drawn inputs' drives kept (hpctl.identify.dataset._drawn_drive): the
seeded draws of an input's noise are prepared once for the same record,
instants and input, and what is kept is what preparing them again gives."""

from __future__ import annotations

import numpy as np
import pytest

import hpctl
from hpctl.identify import dataset as ds
from hpctl.identify import virtual_rig
from hpctl.identify.dataset import carried_drives, carried_records, prepare, with_input_noise, with_input_noise_and_clock


@pytest.fixture
def datasets() -> list[ds.Dataset]:
    tests = [t for t in virtual_rig.program_tests("full") if t.name in ("sine_0.1hz", "sdof_step")]
    assert len(tests) == 2
    records = virtual_rig.make_records(hpctl.Unit.seed(), tests=tests, seed=5)
    return prepare(records)


def _motion(d: ds.Dataset) -> tuple[np.ndarray, np.ndarray]:  # type: ignore[type-arg]
    m = d.rig.base if isinstance(d.rig, ds.SdofRig) else d.rig.strut
    return np.asarray(m.disp_m), np.asarray(m.vel_m_s)


def test_a_drawn_drive_is_prepared_once_and_is_what_preparing_it_again_gives(
        datasets: list[ds.Dataset], monkeypatch: pytest.MonkeyPatch) -> None:
    calls: list[int] = []
    drive = ds._drive

    def counted(*a: object) -> object:
        calls.append(1)
        return drive(*a)  # type: ignore[arg-type]

    monkeypatch.setattr(ds, "_drive", counted)
    monkeypatch.setattr(ds, "_drawn", type(ds._drawn)())
    monkeypatch.setattr(ds, "_drawn_bytes", [0])
    first = [with_input_noise(d, np.random.default_rng(12)) for d in datasets]
    assert len(calls) == len(datasets)
    # The same draws on copies of the datasets (other weights, the same
    # record and instants): no preparation, the same drives.
    copies = [ds.replace(d, weight_sigma={}) for d in datasets]
    again = [with_input_noise(d, np.random.default_rng(12)) for d in copies]
    assert len(calls) == len(datasets)
    assert all(a.rig is b.rig for a, b in zip(first, again)) and all(a.weight_sigma == {} for a in again)
    # What is kept is what the preparation gives, to the last bit.
    for d, a in zip(datasets, first):
        x = ds.input_disp_m(d.record) + np.random.default_rng(12).normal(0.0, d.input_noise_m, len(d.times_s))
        fresh = drive(d.record, d.times_s, x)[0]
        m = fresh.base if isinstance(fresh, ds.SdofRig) else fresh.strut
        got = _motion(a)
        assert np.array_equal(got[0], np.asarray(m.disp_m)) and np.array_equal(got[1], np.asarray(m.vel_m_s))
    # Another draw is prepared anew.
    other = with_input_noise(datasets[0], np.random.default_rng(13))
    assert len(calls) == len(datasets) + 1 and other.rig is not first[0].rig
    # The carried draws (with the clock's shifts) likewise: once, then kept.
    carried = carried_records(datasets)
    assert carried == [0, 1]  # both records carry their input's noise
    n = len(calls)
    drives = carried_drives(datasets, carried)
    made = len(calls) - n
    assert made == len(carried) * ds.CARRIED_DRAWS
    again_drives = carried_drives(copies, carried)
    assert len(calls) == n + made
    for a, b in zip(drives, again_drives):
        assert [x.rig for x in a[1:]] == [x.rig for x in b[1:]]
        assert all(np.array_equal(x.clock_shift_s, y.clock_shift_s) for x, y in zip(a[1:], b[1:]))


def test_kept_drives_are_held_to_their_bytes(datasets: list[ds.Dataset], monkeypatch: pytest.MonkeyPatch) -> None:
    # Each entry counts three arrays of the input's length; past the limit
    # the least recently used go (one always stays).
    monkeypatch.setattr(ds, "_drawn", type(ds._drawn)())
    monkeypatch.setattr(ds, "_drawn_bytes", [0])
    d = datasets[0]
    one = 3 * 8 * len(d.times_s)
    monkeypatch.setattr(ds, "DRAWN_DRIVES_KEPT_BYTES", 2 * one)
    rigs = [with_input_noise_and_clock(d, np.random.default_rng(seed)).rig for seed in range(4)]
    assert len(ds._drawn) == 2 and ds._drawn_bytes[0] == 2 * one
    # The two most recent are kept (the same objects back), the first two
    # prepared anew.
    assert with_input_noise_and_clock(d, np.random.default_rng(3)).rig is rigs[3]
    assert with_input_noise_and_clock(d, np.random.default_rng(0)).rig is not rigs[0]
    monkeypatch.setattr(ds, "DRAWN_DRIVES_KEPT_BYTES", 0)
    with_input_noise_and_clock(d, np.random.default_rng(9))
    assert len(ds._drawn) == 1


def test_a_fits_input_noise_draws_are_prepared_beside_it_and_the_fit_is_the_same(
        datasets: list[ds.Dataset], monkeypatch: pytest.MonkeyPatch) -> None:
    # fit() prepares its input-noise draws' drives in a thread of its own
    # (fit._prepare_input_draws) while it fits; the draws then asked for
    # are all kept (none prepared in the fit's own thread), nothing is left
    # preparing after it, and the result is the one without that thread,
    # to the last bit.
    import threading

    from hpctl.identify import fit as fit_module

    def fitted() -> fit_module.FitResult:
        # Every drive kept before dropped: each fit prepares its own.
        monkeypatch.setattr(ds, "_drawn", type(ds._drawn)())
        monkeypatch.setattr(ds, "_drawn_bytes", [0])
        return fit_module.fit(datasets, ("heat_transfer", "real_gas"), max_nfev=4)

    where: list[str] = []
    drive = ds._drive

    def counted(*a: object) -> object:
        where.append(threading.current_thread().name)
        return drive(*a)  # type: ignore[arg-type]

    monkeypatch.setattr(ds, "_drive", counted)
    beside = fitted()
    assert len(where) == fit_module.INPUT_NOISE_DRAWS * len(datasets) and set(where) == {"hpctl-input-draws"}, set(where)
    assert not fit_module._preparing and not [t for t in threading.enumerate() if t.name == "hpctl-input-draws"]
    monkeypatch.setattr(fit_module, "_prepare_input_draws", lambda _datasets: None)
    where.clear()
    alone = fitted()
    assert len(where) == fit_module.INPUT_NOISE_DRAWS * len(datasets) and set(where) == {threading.current_thread().name}
    assert beside.values == alone.values and beside.stderr == alone.stderr and beside.rss == alone.rss
    assert np.array_equal(beside.covariance, alone.covariance)

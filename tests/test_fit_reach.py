"""Which records a parameter can change (:func:`hpctl.identify.fit.reach`):
the finite-difference Jacobian runs a column's perturbation only on those,
so a record said to be out of a parameter's reach must come out of the
model bit for bit the same when that parameter moves, and a fit must give
the same result as with every column run on every record."""

from __future__ import annotations

import numpy as np
import pytest

from hpctl.identify import fit as fit_module
from hpctl.identify import virtual_rig
from hpctl.identify.dataset import Dataset, prepare
from hpctl.identify.fit import fit, model_for, reach, simulate_all, values_from_x
from hpctl.model.effects import DAMPER_SHAPE, VALVE6_SHAPE

#: Every effect the unit simulates (the others act on its outputs and
#: reach every record), so that every kind of parameter is perturbed.
EFFECTS = ("heat_transfer", "real_gas", "friction", "oil_compliance", "heat_buildup", "leakage", "valve_lag")


@pytest.fixture(scope="module")
def datasets() -> list[Dataset]:
    # One record of each kind of valve use, short: valve 5 open and the
    # hard spring (a sine), valve 5 closed (fast sine; the SDOF step),
    # valve 6 switched with valve 5 open.
    extra = virtual_rig.effect_tests()
    sine = virtual_rig.sweep_tests(cycles=1.0, per_cycle=100)[3]
    tests = [sine, extra["fast"], extra["switching"], extra["sdof"]]
    unit = virtual_rig.truth_unit((), {})
    return prepare(virtual_rig.make_records(unit, tests=tests, seed=5))


def test_each_record_kind_is_present(datasets: list[Dataset]) -> None:
    # The fixture must hold what the reach test relies on: records out of
    # the reach of each branch and of valve 6, and records inside it.
    on = [bool(d.damper_on.any()) for d in datasets]
    valve6 = [bool((~np.asarray(d.spring_hard, bool)).any()) for d in datasets]
    assert any(on) and not all(on) and any(valve6) and not all(valve6)


def test_a_parameter_changes_nothing_where_it_is_said_not_to_reach(datasets: list[Dataset]) -> None:
    model = model_for(datasets, EFFECTS, flexible=True)
    params = model.params
    reaches = reach(params, datasets)
    sparse = [i for i, r in enumerate(reaches) if len(r) < len(datasets)]
    # Every damper branch's shape and valve 6's orifice are sparse here.
    assert {params[i].name for i in sparse} == {p.name for ps in DAMPER_SHAPE.values() for p in ps} | {p.name for p in VALVE6_SHAPE}
    x0 = np.array([p.to_x(p.initial) for p in params])
    base = simulate_all(model, datasets, [values_from_x(params, x0)])[0]
    moved_sets = []
    for i in sparse:
        # A large move (a tenth of the fit range), not a finite difference's.
        lo, hi = params[i].x_bounds()
        x = x0.copy()
        x[i] = x[i] + 0.1 * (hi - lo) if x[i] + 0.1 * (hi - lo) <= hi else x[i] - 0.1 * (hi - lo)
        moved_sets.append(values_from_x(params, x))
    moved = simulate_all(model, datasets, moved_sets)
    changed_inside = 0
    for i, runs in zip(sparse, moved):
        for j, (d, run, ref) in enumerate(zip(datasets, runs, base)):
            assert not isinstance(run, Exception) and not isinstance(ref, Exception)
            same = all(np.array_equal(run[c], ref[c]) for c in ref)
            if j not in reaches[i]:
                assert same, f"{params[i].name} changed {d.name}, which it is said not to reach"
            else:
                changed_inside += not same
    # The moves are large enough to show: most land inside their reach.
    assert changed_inside >= len(sparse) // 2


def test_runs_of_chosen_records_are_the_full_runs(datasets: list[Dataset]) -> None:
    model = model_for(datasets, ("heat_transfer", "real_gas"), flexible=True)
    values = {p.name: p.initial for p in model.params}
    full = simulate_all(model, datasets, [values, values])
    some = simulate_all(model, datasets, [values, values], which=[(2, 0), ()])
    assert len(some[0]) == 2 and some[1] == []
    for j, run in zip((2, 0), some[0]):
        ref = full[0][j]
        assert not isinstance(run, Exception) and not isinstance(ref, Exception)
        assert all(np.array_equal(run[c], ref[c]) for c in ref)


def test_a_fit_is_the_same_as_with_every_column_run_on_every_record(datasets: list[Dataset], monkeypatch: pytest.MonkeyPatch) -> None:
    # Bit for bit: the skipped runs' columns are exact zeros either way.
    # A few evaluations: the Jacobians of the steps and the errors' at the end.
    effects = ("heat_transfer", "real_gas")
    sparse = fit(datasets, effects, flexible=True, max_nfev=4, input_noise=False)
    monkeypatch.setattr(fit_module, "reach", lambda params, ds: [tuple(range(len(ds)))] * len(params))
    dense = fit(datasets, effects, flexible=True, max_nfev=4, input_noise=False)
    assert np.all(np.isfinite(list(sparse.stderr.values())))
    assert sparse.values == dense.values and sparse.stderr == dense.stderr and sparse.rss == dense.rss

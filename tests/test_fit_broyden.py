"""Broyden's Jacobian updates for screening fits (``fit(jacobian="broyden")``,
:class:`hpctl.identify.fit._Secant`): the same optimum as finite
differences, honest errors, fewer runs of the model.

Virtual-rig records drawn anew on each run (the seed printed on failure,
HPCTL_TEST_SEED replays it)."""

from __future__ import annotations

import os
import secrets
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from tests.test_calibrate_cli import leaky_rig  # noqa: F401  (the leaky rig's records, one definition)

import hpctl
from hpctl.data.records import read_record
from hpctl.errors import ParameterError
from hpctl.identify import fit as fit_module
from hpctl.identify import virtual_rig
from hpctl.identify.dataset import prepare
from hpctl.identify.diagnose import screening_ftol
from hpctl.identify.fit import _Secant, fit
from hpctl.model.unit import Friction

MODEL = ("heat_transfer", "real_gas", "friction")


@pytest.fixture
def seed() -> int:
    return int(os.environ.get("HPCTL_TEST_SEED", secrets.randbelow(2**31)))


def test_an_update_maps_the_step_to_the_change_and_keeps_the_rest() -> None:
    # Broyden's conditions, on a nonlinear function: the new Jacobian maps
    # the step taken to the residuals' change exactly, and agrees with the
    # old one on every direction across the step; the prior rows (linear in
    # x, the last two here) are exact and stay as they were.
    rng = np.random.default_rng(7)

    def f(x: np.ndarray) -> np.ndarray:
        return np.concatenate([np.sin(np.arange(1, 7) * x[0]) + x[1] ** 2 - np.arange(6) * x[2], x[:2] / 0.5])

    x0 = np.array([0.1, 0.2, 0.3])
    j0 = rng.normal(size=(8, 3))
    j0[6:] = np.array([[2.0, 0, 0], [0, 2.0, 0]])
    s = _Secant(n_prior=2)
    s.fresh(x0, f(x0), j0)
    s.MIN_RATIO = -np.inf  # this test is about the update, not when to make one
    x1 = x0 + np.array([0.01, -0.02, 0.005])
    j1 = s.update(x1, f(x1))
    assert j1 is not None and not s.exact_at(x1)
    dx = x1 - x0
    np.testing.assert_allclose(j1[:6] @ dx, (f(x1) - f(x0))[:6], rtol=1e-12, atol=1e-14)
    across = np.cross(dx, [1.0, 0.0, 0.0])
    np.testing.assert_allclose(j1 @ across, j0 @ across, rtol=1e-12, atol=1e-14)
    np.testing.assert_array_equal(j1[6:], j0[6:])


def test_a_jacobian_handed_out_never_changes_after() -> None:
    # The secant hands its Jacobians out without copying them (the
    # optimiser keeps one as its current Jacobian, and fit the last as the
    # errors' Jacobian): an update makes a new array, so nothing handed
    # out changes when the secant moves on.
    x0 = np.zeros(2)
    j0 = np.eye(2)
    s = _Secant(n_prior=0)
    s.MIN_RATIO = -np.inf
    out0 = s.fresh(x0, np.array([1.0, 1.0]), j0)
    kept0 = out0.copy()
    out1 = s.update(np.array([-0.5, -0.5]), np.array([0.6, 0.4]))
    assert out1 is not None and out1 is not out0
    kept1 = out1.copy()
    out2 = s.update(np.array([-0.7, -0.6]), np.array([0.3, 0.35]))
    assert out2 is not None and out2 is not out1
    np.testing.assert_array_equal(out0, kept0)
    np.testing.assert_array_equal(out1, kept1)
    assert not np.array_equal(out2, out1)  # it did move on


def test_finite_differences_are_due_where_the_jacobian_predicted_badly() -> None:
    x0 = np.zeros(2)
    f0 = np.array([1.0, 1.0])
    s = _Secant(n_prior=0)
    s.fresh(x0, f0, np.eye(2))
    # The Jacobian predicted the step to remove the residual; it removed a
    # quarter of the cost: below MIN_RATIO of the prediction.
    assert s.update(np.array([-1.0, -1.0]), np.array([0.866, 0.866])) is None
    assert s.exact_at(x0)  # nothing was changed
    # No step, or a run that failed somewhere: finite differences too.
    assert s.update(x0, f0) is None
    assert s.update(np.array([-0.5, -0.5]), np.array([np.nan, 0.5])) is None
    # As predicted: updated.
    assert s.update(np.array([-0.5, -0.5]), np.array([0.5, 0.5])) is not None


def test_a_hybrid_takes_finite_differences_after_a_step_that_halved_the_cost() -> None:
    # jacobian="hybrid": far from the optimum (a step cut the cost by more
    # than FAR_SHARE of it) finite differences, as predicted or not; near
    # it Broyden's updates, as "broyden" does everywhere.
    x0 = np.zeros(2)
    f0 = np.array([1.0, 1.0])
    far = np.array([-0.8, -0.8])  # exactly as the Jacobian predicted: the cost from 1.0 to 0.04
    near = np.array([-0.2, -0.2])  # the cost from 1.0 to 0.64
    for share, after_far in ((None, True), (_Secant.FAR_SHARE, False)):
        s = _Secant(n_prior=0, far_share=share)
        s.fresh(x0, f0, np.eye(2))
        assert (s.update(far, f0 + far) is not None) == after_far
        s.fresh(x0, f0, np.eye(2))
        assert s.update(near, f0 + near) is not None


@pytest.mark.parametrize("jacobian", ["", "broyden ", "secant", "FINITE_DIFFERENCE"])
def test_a_fit_refuses_an_unknown_jacobian(jacobian: str) -> None:
    records = virtual_rig.make_records(hpctl.Unit.seed(), tests=[virtual_rig.effect_tests()["sdof"]], seed=1)
    with pytest.raises(ParameterError, match="jacobian") as e:
        fit(prepare(records), ("heat_transfer", "real_gas"), jacobian=jacobian)
    assert isinstance(e.value, ValueError) and "broyden" in str(e.value)


def test_broyden_reaches_the_finite_difference_optimum_in_fewer_runs(seed: int, monkeypatch: pytest.MonkeyPatch) -> None:
    # Friction, a gas time constant and the damper on the virtual rig's
    # sweep. From the library's start at full precision: the same optimum
    # (to well within its standard errors, the cost to the screening's BIC
    # resolution) and the same errors (finite differences at the optimum
    # either way). As a screening fit (from the model without friction, the
    # screening's tolerance, no errors): the same optimum in fewer runs of
    # the model (seeds 1-12 on 2026-11-28: 222 runs of the sweep against
    # 402 in all, about half on every seed; from the library's start 399
    # against 550).
    _same_optimum_in_fewer_runs(seed, monkeypatch)


@pytest.mark.parametrize("seed", [1666552740, 1808844868])
def test_a_broyden_fit_is_confirmed_wherever_it_stopped(seed: int, monkeypatch: pytest.MonkeyPatch) -> None:
    # Draws on which a Broyden fit stopped short of the optimum: on 1666552740
    # with an update at its end (3.1 above the optimum's residual sum of
    # squares); on 1808844868 with finite differences at its end, computed
    # after the optimiser had decided to stop on a step an update made, in
    # a trust region the updates had shrunk (0.15 above, a quarter of an
    # error off). Each convergence is now confirmed by a restart there.
    _same_optimum_in_fewer_runs(seed, monkeypatch)


def _same_optimum_in_fewer_runs(seed: int, monkeypatch: pytest.MonkeyPatch) -> None:
    rng = np.random.default_rng(seed)
    truth = {"tau_s": float(rng.uniform(1.0, 5.0)), "friction_coulomb_n": float(rng.uniform(200.0, 1200.0))}
    unit = hpctl.Unit.seed().replace(tau_s=truth["tau_s"]).with_effects(friction=Friction(truth["friction_coulomb_n"], 300.0, 2e-3))
    datasets = prepare(virtual_rig.make_records(unit, "sweep", seed=seed % 1000))
    runs: list[Any] = []
    real = fit_module.run_many

    def counted(cases: Sequence[Any], *a: Any, **k: Any) -> Any:
        runs.extend(cases)
        return real(cases, *a, **k)

    monkeypatch.setattr(fit_module, "run_many", counted)
    fd = fit(datasets, MODEL, input_noise=False)
    br = fit(datasets, MODEL, input_noise=False, jacobian="broyden")
    context = f"seed={seed} truth={truth} fd={fd.values} ({fd.message}) broyden={br.values} ({br.message})"
    assert fd.success and br.success, context
    assert abs(br.bic - fd.bic) < 1.0, context
    for name, v in fd.values.items():
        assert abs(br.values[name] - v) < 0.2 * fd.stderr[name], (name, context)
        assert br.stderr[name] == pytest.approx(fd.stderr[name], rel=0.05), (name, context)

    base = fit(datasets, MODEL[:2], input_noise=False)
    ftol = screening_ftol(base.n)
    counts = {}
    screened = {}
    for jacobian in ("finite_difference", "broyden"):
        runs.clear()
        screened[jacobian] = fit(datasets, MODEL, initial=base.values, input_noise=False, ftol=ftol, errors=False, jacobian=jacobian)
        counts[jacobian] = len(runs)
    context = f"seed={seed} truth={truth} runs={counts}"
    assert abs(screened["broyden"].bic - screened["finite_difference"].bic) < 1.0, context
    assert counts["broyden"] < counts["finite_difference"], context


def test_a_screening_starts_from_the_jacobian_of_the_model_it_extends(seed: int, monkeypatch: pytest.MonkeyPatch) -> None:
    # A Broyden screening of friction on the model without it (what
    # diagnose._try fits), given that model (``extends``): its first
    # Jacobian takes the shared parameters' columns from that model's and
    # runs only friction's, and it ends at the same optimum (the
    # screening's BIC resolution) in fewer runs. A "hybrid" fit ignores it:
    # the same runs, the same end, bit for bit.
    rng = np.random.default_rng(seed)
    truth = {"tau_s": float(rng.uniform(1.0, 5.0)), "friction_coulomb_n": float(rng.uniform(200.0, 1200.0))}
    unit = hpctl.Unit.seed().replace(tau_s=truth["tau_s"]).with_effects(friction=Friction(truth["friction_coulomb_n"], 300.0, 2e-3))
    base = fit(prepare(virtual_rig.make_records(unit, "sweep", seed=seed % 1000)), MODEL[:2], input_noise=False)
    assert base.jacobian is not None and base.jacobian.shape == (base.n, len(base.model.params))
    runs: list[Any] = []
    real = fit_module.run_many

    def counted(cases: Sequence[Any], *a: Any, **k: Any) -> Any:
        runs.append(len(cases))
        return real(cases, *a, **k)

    monkeypatch.setattr(fit_module, "run_many", counted)
    ftol = screening_ftol(base.n)
    ends = {}
    batches = {}
    for jacobian, extends in (("broyden", None), ("broyden", base), ("hybrid", None), ("hybrid", base)):
        runs.clear()
        ends[jacobian, extends is not None] = fit(base.datasets, MODEL, initial=base.values, input_noise=False, ftol=ftol, errors=False,
                                                  jacobian=jacobian, extends=extends)
        batches[jacobian, extends is not None] = list(runs)
    context = f"seed={seed} truth={truth} batches of runs={batches}"
    plain, seeded = ends["broyden", False], ends["broyden", True]
    assert abs(seeded.bic - plain.bic) < 1.0, context
    assert sum(batches["broyden", True]) < sum(batches["broyden", False]), context
    # The start's Jacobian: friction's columns alone (each a run of the
    # records it reaches), where the plain one runs every column.
    n_records = len(base.datasets)
    new = len(seeded.model.params) - len(base.model.params)
    assert batches["broyden", True][1] <= new * n_records < batches["broyden", False][1], context
    assert batches["hybrid", True] == batches["hybrid", False], context
    assert ends["hybrid", True].values == ends["hybrid", False].values, context


@pytest.mark.parametrize("extends", [{"tau_s": 2.0}, "seed", 1.0])
def test_a_fit_refuses_an_extends_that_is_no_fit(extends: Any) -> None:
    records = virtual_rig.make_records(hpctl.Unit.seed(), tests=[virtual_rig.effect_tests()["sdof"]], seed=1)
    with pytest.raises(ParameterError, match="extends") as e:
        fit(prepare(records), ("heat_transfer", "real_gas"), jacobian="broyden", extends=extends)
    assert isinstance(e.value, ValueError) and "FitResult" in str(e.value)


def test_a_jacobian_is_taken_only_for_the_residuals_it_was_computed_on() -> None:
    # Another list of the same records, a fold, a fit without errors: no
    # columns taken (the residuals' rows would not be the same).
    from hpctl.identify.fit import _seed_columns

    datasets = prepare(virtual_rig.make_records(hpctl.Unit.seed(), tests=[virtual_rig.effect_tests()["sdof"]], seed=1))
    base = fit(datasets, MODEL[:2], input_noise=False, place_switches=False)
    params = fit_module.model_for(base.datasets, MODEL).params
    taken = _seed_columns(params, base.datasets, None, base)
    assert taken is not None and taken[1] is base.jacobian
    shared, _ = taken
    assert {params[i].name for i in shared} == {p.name for p in base.model.params}
    assert all(params[i].name == base.model.params[k].name for i, k in shared.items())
    again = prepare(virtual_rig.make_records(hpctl.Unit.seed(), tests=[virtual_rig.effect_tests()["sdof"]], seed=1))
    assert _seed_columns(params, again, None, base) is None
    assert _seed_columns(params, base.datasets, 0, base) is None
    bare = fit(datasets, MODEL[:2], input_noise=False, errors=False)
    assert bare.jacobian is None and _seed_columns(params, bare.datasets, None, bare) is None


def test_errors_left_out_and_added_at_the_optimum_are_the_fits_own() -> None:
    # A screening fit is fitted without errors; the candidates weighed for
    # acceptance get them from finite differences at their optimum
    # (diagnose._with_errors): the same as a fit with errors there.
    from hpctl.identify.diagnose import Candidate, _with_errors

    unit = hpctl.Unit.seed().replace(tau_s=2.0).with_effects(friction=Friction(600.0, 300.0, 2e-3))
    datasets = prepare(virtual_rig.make_records(unit, "sweep", seed=3))
    bare = fit(datasets, MODEL, input_noise=False, jacobian="broyden", errors=False)
    full = fit(datasets, MODEL, input_noise=False, jacobian="broyden")
    assert bare.stderr == {} and bare.values == full.values and bare.rss == full.rss
    c = Candidate(("friction",), 2, bare, 100.0, 0.5)
    _with_errors(datasets, c)
    assert c.result.values == bare.values and set(c.result.stderr) == set(full.stderr)
    for name, e in full.stderr.items():
        assert c.result.stderr[name] == pytest.approx(e, rel=1e-6), name


def test_the_flexible_models_screening_fits_use_broyden_on_long_records_only() -> None:
    # The fixed-shape models' screening fits always; the flexible model's
    # where a run of the records outweighs the optimiser's work (the
    # foreign heat build-up case's 39,612 residuals: Broyden; its leak
    # case's 12,252: finite differences; docs/foreign-rig.md, stop 38).
    from hpctl.identify.diagnose import BROYDEN_FLEXIBLE_MIN_RESIDUALS, screening_jacobian

    assert 12_252 < BROYDEN_FLEXIBLE_MIN_RESIDUALS <= 39_612
    assert screening_jacobian(False, 100) == "broyden"
    assert screening_jacobian(True, 12_252) == "finite_difference"
    assert screening_jacobian(True, 39_612) == "broyden"
    assert screening_jacobian(True, BROYDEN_FLEXIBLE_MIN_RESIDUALS) == "broyden"
    # The accepted model's fit, which starts at a finite-difference
    # screening optimum, on the flexible model's long records only.
    from hpctl.identify.diagnose import accepted_jacobian

    assert accepted_jacobian(False, 10**6) == accepted_jacobian(True, 12_252) == "finite_difference"
    assert accepted_jacobian(True, 39_612) == accepted_jacobian(True, BROYDEN_FLEXIBLE_MIN_RESIDUALS) == "broyden"


def test_a_flexible_candidate_screened_by_broyden_is_weighed_on_its_finite_difference_fit(
    request: pytest.FixtureRequest, monkeypatch: pytest.MonkeyPatch, tmp_path: Path
) -> None:
    # Broyden's flexible screening only ranks: on the bundled 75-minute heat
    # run it ended at another optimum and the accepted model's fit started
    # there stayed at 1.86 x the noise (stop 38). A candidate weighed for
    # acceptance is screened again, with finite differences while far from
    # the optimum (where the path chooses it), so what is weighed gains
    # what screening with them throughout does, and the accepted model's
    # fit (Broyden's from there, on long records) ends at its optimum. The
    # leak records are short: the threshold moved to make them "long".
    import hpctl.identify.diagnose as dg

    leaky: Path = request.getfixturevalue("leaky_rig")
    records = [read_record(p) for p in sorted(leaky.glob("*.csv"))]
    monkeypatch.setattr(dg, "BROYDEN_FLEXIBLE_MIN_RESIDUALS", 10**12)
    few = ("leakage", "sensor_offset")  # one other candidate is enough, and cheaper
    fd = dg.diagnose(records, ("heat_transfer", "real_gas"), candidates=few, max_rounds=1, flexible=True)
    monkeypatch.setattr(dg, "BROYDEN_FLEXIBLE_MIN_RESIDUALS", 0)
    real_fit = dg.fit
    accepted_calls: list[dict[str, Any]] = []

    def recorded(datasets: Any, effects: Any, **kw: Any) -> Any:
        if kw.get("max_nfev") == dg.ACCEPTED_MAX_NFEV and kw.get("input_noise", True):  # not the screening again (RESCREEN)
            accepted_calls.append(dict(kw, n_params=len(kw["initial"])))
        return real_fit(datasets, effects, **kw)

    monkeypatch.setattr(dg, "fit", recorded)
    br = dg.diagnose(records, ("heat_transfer", "real_gas"), candidates=few, max_rounds=1, flexible=True)
    assert fd.found == br.found == ["leakage"]
    assert all(c.screened_by == "finite_difference" and c.broyden_delta_bic is None for c in fd.rounds[0].candidates)
    leak = next(c for c in br.rounds[0].candidates if c.effect == "leakage")
    fd_leak = next(c for c in fd.rounds[0].candidates if c.effect == "leakage")
    assert leak.screened_by == "hybrid" and leak.broyden_delta_bic is not None
    # Its Broyden screening ended once it had explained half the excess
    # (dg.enough_explained): what it would have gained after is the second
    # screening's to say.
    assert leak.ended_at_share and not leak.stopped_at_null
    # Its screening again (finite differences while far, Broyden's
    # updates near the optimum) gains what the finite differences' did,
    # to the screening's resolution (its result is the accepted fit's by
    # now).
    assert leak.delta_bic == pytest.approx(fd_leak.delta_bic, abs=1.0)
    # The accepted model's fit, started there, updates its Jacobian too
    # (dg.accepted_jacobian) and ends at the same optimum to well within
    # its errors (finite differences at the optimum either way); its
    # tolerance is the tenth of an error (dg.accepted_ftol).
    assert [c["jacobian"] for c in accepted_calls] == ["broyden"], accepted_calls
    assert accepted_calls[0]["ftol"] == dg.accepted_ftol(fd.final.n, len(fd.final.model.params))
    assert br.final.success and fd.final.success
    for name, v in fd.final.values.items():
        assert abs(br.final.values[name] - v) < 0.2 * fd.final.stderr[name], (name, br.final.values[name], v, fd.final.stderr[name])
        assert br.final.stderr[name] == pytest.approx(fd.final.stderr[name], rel=0.05), name
    # The others kept Broyden's screening, and the JSON says which is which.
    others = [c for c in br.rounds[0].candidates if c.broyden_delta_bic is None]
    assert others and all(c.screened_by == "broyden" for c in others)
    rows = {r["effect"]: r for r in dg.summary(br)["candidates_last_round"]}
    assert rows["leakage"]["screened_by"] == "hybrid" and rows["leakage"]["broyden_delta_bic"] == leak.broyden_delta_bic
    assert rows["leakage"]["ended_at_share"] is True and not any(r["ended_at_share"] for e, r in rows.items() if e != "leakage")
    # And the report's table of candidates.
    from hpctl.data.output import OutputDir
    from hpctl.report.calibration import diagnosis_report

    with OutputDir(tmp_path, "diagnose") as out:
        report = diagnosis_report(br, out)
    text = (tmp_path / report.name).read_text(encoding="utf-8")
    assert f"finite differences far, Broyden near (Broyden: {leak.broyden_delta_bic:.1f}, *ended at 50%*)" in text and "| Broyden |" in text


@pytest.mark.parametrize("first_gain", [0.0, 1.0])
def test_a_confirmation_ends_where_its_first_step_gains_less_than_ftol(first_gain: float, monkeypatch: pytest.MonkeyPatch) -> None:
    # A Broyden fit's convergence is confirmed by restarts on finite
    # differences. Where a restart's first step (the one that Jacobian
    # took) gains less than ftol of the cost, a finite-difference fit
    # would have ended there: confirmed, however much the restart's later
    # updates gained (the bundled heat run's accepted fit crawled on, 4.5e-4
    # a restart on a cost of 24,812, to its evaluation limit). Where it
    # gains more, the restarts go on (to the budget here: each "gains" 1).
    from hpctl.identify.trust_region import Solution

    unit = hpctl.Unit.seed().replace(tau_s=2.0).with_effects(friction=Friction(600.0, 300.0, 2e-3))
    datasets = prepare(virtual_rig.make_records(unit, "sweep", seed=3))
    solves: list[float] = []

    def crawling(fun: Any, x0: np.ndarray, jac: Any, lo: Any, hi: Any, **kw: Any) -> Solution:
        solves.append(kw["ftol"])
        k = len(x0)
        return Solution(x=x0.copy(), cost=1000.0 - len(solves), jac=np.zeros((1, k)), grad=np.zeros(k), active_mask=np.zeros(k, dtype=int),
                        nfev=1, njev=1, status=2, first_reduction=first_gain)

    monkeypatch.setattr(fit_module, "least_squares", crawling)
    fit(datasets, MODEL, input_noise=False, errors=False, jacobian="broyden", max_nfev=12, ftol=1e-6)
    # ftol * cost = 1e-3: a first step of 0 confirms at the first restart.
    assert len(solves) == (2 if first_gain == 0.0 else 12)

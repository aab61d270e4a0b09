"""Each logged valve switch placed within its sample interval
(hpctl.identify.switching): the outputs inserted for it, the parabola that
places it, and the places found on records whose switches were made at
known places between their samples."""

from __future__ import annotations

import json
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from hpctl.identify import virtual_rig
from hpctl.identify.dataset import prepare
from hpctl.identify.fit import _place_step, fit, model_for, simulate_all, values_from_x
from hpctl.identify.switching import EDGE, PROBE_LEADS, best_lead, extrapolated_leads, switch_samples, timeline


@pytest.fixture(scope="module")
def switching_dataset() -> object:
    unit = virtual_rig.truth_unit((), {})
    test = virtual_rig.effect_tests()["switching"]
    return prepare([virtual_rig.record_test(unit, test, virtual_rig.Noise(), np.random.default_rng(4))])[0]


def test_the_switches_are_the_samples_where_a_flag_changes(switching_dataset: object) -> None:
    d = switching_dataset
    ks = switch_samples(d)  # type: ignore[arg-type]
    hard = np.asarray(d.spring_hard)  # type: ignore[attr-defined]
    assert ks.size == 7  # 10 s switched every 1.3 s
    assert np.all(hard[ks] != hard[ks - 1])
    assert np.count_nonzero(hard[1:] != hard[:-1]) == ks.size


def test_the_timeline_inserts_an_output_at_each_placed_switch(switching_dataset: object) -> None:
    d = switching_dataset
    ks = switch_samples(d)  # type: ignore[arg-type]
    leads = np.linspace(0.0, 0.9, ks.size)  # the first at its sample: nothing inserted
    placed = timeline(d, leads)  # type: ignore[arg-type]
    assert placed is not None
    times, hard, on, keep = placed
    t = d.times_s  # type: ignore[attr-defined]
    np.testing.assert_array_equal(times[keep], t)
    assert np.count_nonzero(~keep) == ks.size - 1
    extra = times[~keep]
    np.testing.assert_allclose(extra, t[ks[1:]] - leads[1:] * (t[ks[1:]] - t[ks[1:] - 1]), rtol=0, atol=1e-12)
    assert np.all(np.diff(times) > 0)
    # Each inserted output has the new valve state: the switch is there.
    np.testing.assert_array_equal(hard[~keep], np.asarray(d.spring_hard)[ks[1:]])  # type: ignore[attr-defined]
    np.testing.assert_array_equal(hard[keep], np.asarray(d.spring_hard))  # type: ignore[attr-defined]
    assert on.shape == times.shape
    assert timeline(d) is None  # type: ignore[arg-type]  # no places of its own: midway, as the core does it
    with pytest.raises(ValueError, match="switch leads"):
        timeline(d, np.zeros(3))  # type: ignore[arg-type]


def test_midway_by_an_inserted_output_is_the_cores_midway(switching_dataset: object) -> None:
    # The same run to the bit: the core's own midway switch and one placed
    # at the half by an inserted output.
    d = switching_dataset
    model = model_for([d], ("heat_transfer", "real_gas"))  # type: ignore[list-item]
    v = values_from_x(model.params, [p.to_x(p.initial) for p in model.params])
    a = simulate_all(model, [d], [v])[0][0]  # type: ignore[list-item]
    b = simulate_all(model, [replace(d, switch_leads=np.full(7, 0.5))], [v])[0][0]  # type: ignore[type-var]
    assert not isinstance(a, Exception) and not isinstance(b, Exception)
    for c in ("p_gas_pa", "p_gas2_pa", "force_n"):
        np.testing.assert_array_equal(a[c], b[c])


def test_the_parabola_finds_the_vertex_and_keeps_to_the_probes() -> None:
    for truth in (0.2, 0.5, 0.77):
        costs = [3.0 * (x - truth) ** 2 + 1.0 for x in PROBE_LEADS]
        assert best_lead(costs) == pytest.approx(truth, abs=1e-12)
    assert best_lead([(x - 2.0) ** 2 for x in PROBE_LEADS]) == PROBE_LEADS[-1]  # beyond the span: its end
    assert best_lead([2.0, 1.0, 2.0 + 1e-9]) == pytest.approx(0.5, abs=1e-6)
    assert best_lead([-1.0, 0.0, -2.0]) == PROBE_LEADS[2]  # opens downward: the cheapest probe
    assert best_lead([np.inf, 1.0, 2.0]) == PROBE_LEADS[1]  # a failed probe: the cheapest of the others
    assert best_lead([np.inf, np.inf, np.inf]) == 0.5


@pytest.mark.parametrize("true_lead", [0.15, 0.85])
def test_the_fit_places_switches_made_between_samples(monkeypatch: pytest.MonkeyPatch, true_lead: float) -> None:
    # The virtual rig switches valve 6 at ``true_lead`` of the interval
    # before the sample that logs it (not midway, where the fit puts a
    # logged switch by default): the fit finds each switch's place within
    # 0.15 of an interval, and the residual falls towards the noise.
    monkeypatch.setattr(virtual_rig, "LOGGED_SWITCH_LEAD", true_lead)
    unit = virtual_rig.truth_unit((), {})
    rec = virtual_rig.record_test(unit, virtual_rig.effect_tests()["switching"], virtual_rig.Noise(), np.random.default_rng(7))
    datasets = prepare([rec])
    model = ("heat_transfer", "real_gas")
    midway = fit(datasets, model, input_noise=False, place_switches=False)
    placed = fit(datasets, model, input_noise=False)
    leads = placed.datasets[0].switch_leads
    context = f"true {true_lead}: places {np.round(leads, 3)}, RMS/noise {midway.rms_ratio:.3f} -> {placed.rms_ratio:.3f}"
    print(context)
    assert leads.size == 7
    # A place off by more than 0.15 is one the data cannot tell (a valve
    # closing with next to no flow through it): its segment fits no worse
    # than with the true place (chi-square, one degree: 4 is 2 sigma).
    d = placed.datasets[0]
    at_truth = simulate_all(placed.model, [replace(d, switch_leads=np.full(7, true_lead))], [placed.values])[0][0]
    assert not isinstance(at_truth, Exception)
    ks = switch_samples(d)
    for s, (k, nxt) in enumerate(zip(ks, [*ks[1:], len(d.times_s)])):
        if abs(leads[s] - true_lead) <= 0.15:
            continue
        seg = slice(int(k), int(nxt))
        cost = {name: sum(float(np.sum(((sim[c][seg] - y[seg]) / d.weight_sigma[c][seg]) ** 2)) for c, y in d.targets.items())
                for name, sim in (("found", placed.sims[0]), ("true", at_truth))}  # type: ignore[index]
        assert cost["found"] <= cost["true"] + 4.0, (context, s, cost)
    assert np.count_nonzero(np.abs(leads - true_lead) <= 0.15) >= 5, context
    assert placed.rms_ratio < midway.rms_ratio and placed.rms_ratio < 1.1, context
    assert "placed within its sample interval" in placed.message


def test_hpctl_fit_reports_where_it_placed_each_switch(tmp_path: Path) -> None:
    # The places are part of the result: in fit.md (a table) and in --json
    # (per record: the first sample with the new state, the place, the
    # switch's time), each switch inside its interval.
    from click.testing import CliRunner

    from hpctl.cli import main
    from hpctl.data.records import write_record

    monkey_lead = 0.3
    unit = virtual_rig.truth_unit((), {})
    old = virtual_rig.LOGGED_SWITCH_LEAD
    virtual_rig.LOGGED_SWITCH_LEAD = monkey_lead
    try:
        rec = virtual_rig.record_test(unit, virtual_rig.effect_tests()["switching"], virtual_rig.Noise(), np.random.default_rng(2))
    finally:
        virtual_rig.LOGGED_SWITCH_LEAD = old
    csv, toml = write_record(rec, tmp_path / "rec" / "valve_switching")
    r = CliRunner().invoke(main, ["fit", str(toml), "--model", "seed", "--out", str(tmp_path / "out"), "--json", "--quiet"])
    assert r.exit_code == 0, r.stderr
    s = json.loads(r.stdout)
    rows = s["switch_places"]["valve_switching"]
    assert len(rows) == 7
    for row in rows:
        assert row["sample_s"] - 0.005 - 1e-12 <= row["switched_at_s"] <= row["sample_s"]
        assert abs(row["place"] - monkey_lead) <= 0.15, rows
        assert row["switched_at_s"] == pytest.approx(row["sample_s"] - row["place"] * 0.005, abs=1e-12)
    md = (tmp_path / "out" / "fit.md").read_text()
    section = md.split("## Valve switches")[1].split("## Plots")[0]
    assert section.count("| valve_switching |") == 7, section
    # Places at their joint optimum with the parameters: no warning of them.
    assert not [w for w in s["warnings"] if "places" in w["message"]], s["warnings"]


def test_places_left_short_of_their_joint_optimum_are_a_warning(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    # A fit whose joint steps of the places and the parameters ran out while
    # one more would still move a place (here: none allowed, and the step
    # from the optimum made 0.4 of an interval for two of the seven
    # switches) says so in the output and the JSON, with the records, and
    # exits 0 only without --strict.
    from click.testing import CliRunner

    from hpctl.cli import main
    from hpctl.data.records import write_record
    from hpctl.identify import fit as fit_module

    rec = virtual_rig.record_test(virtual_rig.truth_unit((), {}), virtual_rig.effect_tests()["switching"], virtual_rig.Noise(),
                                  np.random.default_rng(2))
    csv, toml = write_record(rec, tmp_path / "rec" / "valve_switching")
    step = np.zeros(7)
    step[[2, 5]] = [0.4, -0.25]
    monkeypatch.setattr(fit_module, "JOINT_PLACE_STEPS", 0)
    monkeypatch.setattr(fit_module, "_place_step", lambda *args: step)
    args = ["fit", str(toml), "--model", "seed", "--json", "--quiet"]
    r = CliRunner().invoke(main, [*args, "--out", str(tmp_path / "out")])
    assert r.exit_code == 0, r.stderr
    warned = [w for w in json.loads(r.stdout)["warnings"] if "places" in w["message"]]
    assert len(warned) == 1, warned
    w = warned[0]
    assert w["code"] == "not_converged"
    assert w["details"] == {"place_step_max": 0.4, "moved": 2, "switches": 7, "records": ["valve_switching"]}
    assert "2 of 7" in w["message"] and "0.40" in w["message"], w["message"]
    strict = CliRunner().invoke(main, [*args, "--out", str(tmp_path / "strict"), "--strict"])
    assert strict.exit_code == 3 and "places" in strict.stderr, strict.stderr


def test_the_places_uncertainty_goes_into_the_parameters_errors() -> None:
    # The places as nuisance columns of the covariance, each with the prior
    # of a uniform place in its interval: the parameters' errors are the
    # corresponding block of the sandwich over parameters and places (here
    # white residuals: the independent case), and never smaller than with
    # the places held, where the places and the parameters are correlated.
    from hpctl.identify.fit import PLACE_PRIOR_SD, _covariance, standard_errors
    from hpctl.model.effects import Param

    rng = np.random.default_rng(8)
    n, k, m = 600, 3, 4
    params = [Param(f"p{i}", -1.0, 1.0, 0.0, 0.0, (-1.0, 1.0)) for i in range(k)]
    j = rng.normal(size=(n, k))
    nuisance = 0.6 * j[:, [0, 0, 1, 2]] + rng.normal(size=(n, m))
    r = rng.normal(size=n)
    held = standard_errors(params, _covariance(params, np.zeros(k), j, np.zeros((0, k)), r, np.ones(n), [n], None))
    cov = _covariance(params, np.zeros(k), j, np.zeros((0, k)), r, np.ones(n), [n], None, nuisance)
    free = standard_errors(params, cov)
    a = np.hstack([j, nuisance])
    prior = np.hstack([np.zeros((m, k)), np.eye(m) / PLACE_PRIOR_SD])
    s2 = float(r @ r) / (n - k - m)
    bread = np.linalg.inv(a.T @ a + prior.T @ prior)
    block = (bread @ (s2 * a.T @ a + prior.T @ prior) @ bread)[:k, :k]
    np.testing.assert_allclose([free[p.name] for p in params], np.sqrt(np.diag(block)), rtol=1e-10)
    np.testing.assert_allclose(cov, block, rtol=1e-10, atol=1e-14)  # the correlations too
    assert all(free[p.name] > held[p.name] for p in params), (held, free)


def test_passes_that_converge_steadily_are_extrapolated_to_their_end(switching_dataset: object) -> None:
    # Aitken's extrapolation of a linearly converging sequence: moves
    # shrinking by rho = 0.75 each pass end at settled + move rho / (1 - rho)
    # (a geometric series), held within the interval's edges.
    d = switching_dataset
    n = switch_samples(d).size  # type: ignore[arg-type]
    first = np.linspace(0.2, 0.6, n)
    previous = np.linspace(0.08, 0.0, n)  # one switch that does not move
    move = 0.75 * previous
    placed, settled = [replace(d, switch_leads=first)], [replace(d, switch_leads=first + move)]  # type: ignore[type-var]
    out, got_move, jumped = extrapolated_leads(placed, settled, previous)
    np.testing.assert_allclose(got_move, move, rtol=1e-12)
    assert jumped
    np.testing.assert_allclose(out[0].switch_leads, np.clip(first + move + move * 3.0, EDGE, 1.0 - EDGE), rtol=1e-12)
    assert out[0].switch_leads[-1] == pytest.approx(0.6)
    far = [replace(d, switch_leads=np.full(n, 0.95))]  # type: ignore[type-var]
    out, _, jumped = extrapolated_leads([replace(d, switch_leads=np.full(n, 0.9))], far, np.full(n, 0.06))  # type: ignore[type-var]
    assert jumped and np.all(out[0].switch_leads == 1.0 - EDGE)
    # No history, a move that turned, one that did not shrink enough to
    # trust (rho 0.9 or more), or none: the places as the pass left them.
    for prev in (None, -previous, move / 0.95, np.zeros(n)):
        out, _, jumped = extrapolated_leads(placed, settled, prev)
        assert not jumped and out[0] is settled[0]
    # Records without switches pass through.
    bare = replace(d, switch_leads=np.zeros(0))  # type: ignore[type-var]
    out, got_move, jumped = extrapolated_leads([bare, *placed], [bare, *settled], previous)
    assert jumped and out[0] is bare and got_move.shape == (n,)


def test_the_joint_step_of_places_and_parameters_goes_along_their_valley() -> None:
    # A linear model whose parameter and two places trade (columns 0.95
    # alike): with the parameter held, each place's best lies short of the
    # joint optimum, and alternating the two crawls. The joint step reaches
    # the optimum in one, and a place the optimum puts past its interval's
    # edge goes to the edge, the rest solved again with it there.
    rng = np.random.default_rng(5)
    n = 200
    u = rng.normal(size=n)
    v = rng.normal(size=n)
    w = rng.normal(size=n)
    theta_col = u
    places = np.column_stack([0.95 * u + 0.31 * v, 0.9 * u + 0.43 * w])
    truth_theta, truth_places = 0.3, np.array([0.8, 0.6])
    y = theta_col * truth_theta + places @ truth_places
    leads = np.array([0.5, 0.5])
    # The fit at the start: the parameter at its optimum with the places held.
    theta = float(theta_col @ (y - places @ leads) / (theta_col @ theta_col))
    r = theta_col * theta + places @ leads - y
    x, lo, hi = np.array([theta]), np.array([-10.0]), np.array([10.0])
    step = _place_step(x, lo, hi, theta_col[:, None], np.zeros((0, 1)), r, np.zeros(0), places, leads)
    assert step == pytest.approx(truth_places - leads, abs=1e-9)
    # A truth past the edge: the place pinned at 0.99, the other the best with it there.
    y = theta_col * truth_theta + places @ np.array([1.4, 0.6])
    theta = float(theta_col @ (y - places @ leads) / (theta_col @ theta_col))
    r = theta_col * theta + places @ leads - y
    step = _place_step(np.array([theta]), lo, hi, theta_col[:, None], np.zeros((0, 1)), r, np.zeros(0), places, leads)
    assert leads[0] + step[0] == pytest.approx(0.99)
    a = np.column_stack([theta_col, places[:, 1]])
    best = np.linalg.lstsq(a, y - places[:, 0] * 0.99, rcond=None)[0]
    assert leads[1] + step[1] == pytest.approx(best[1], abs=1e-9)

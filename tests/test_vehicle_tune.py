"""Tuning the controller: locally and on a two-worker Dask cluster started
and stopped by process id on 127.0.0.1 (this test must run in CI: if Dask
is missing it fails at the import, it does not skip)."""

from __future__ import annotations

import json
from pathlib import Path

import dask.distributed  # noqa: F401  (fails, not skips, without the cluster extra)
import numpy as np
import pytest
from click.testing import CliRunner

from hpctl.cli import main
from hpctl.control.controller import Controller
from hpctl.vehicle import route, tuning
from hpctl.vehicle.cluster import LocalCluster
from hpctl.vehicle.model import preset


@pytest.fixture(scope="module")
def problem() -> tuning.Problem:
    routes = (route.mixed(scale=0.05, seed=3),)
    return tuning.Problem(("4x4",), routes, references=tuning.references(("4x4",), routes, threads=2))


def test_parameters_map_to_valid_configurations(problem: tuning.Problem) -> None:
    base = preset("4x4").controller_config()
    x = tuning.values(base, problem.params)
    assert tuning.apply(base, problem.params, x) == base
    lows = [np.log10(p.low) if p.log else p.low for p in problem.params]
    highs = [np.log10(p.high) if p.log else p.high for p in problem.params]
    for corner in (lows, highs):
        c = tuning.apply(base, problem.params, corner)
        Controller(c)  # the controller accepts every corner of the search box
        assert c["mode"]["lat_acc_exit_m_s2"] < c["mode"]["lat_acc_enter_m_s2"]


def test_the_default_scores_near_the_passive_references(problem: tuning.Problem) -> None:
    s = tuning.score(problem, tuning.values(preset("4x4").controller_config(), problem.params))
    assert s.failures == 0
    # Roll like hard/high (within 10 %), comfort no better than soft/low.
    assert 0.9 < s.roll_ratio < 1.1 and s.comfort_ratio >= 0.95
    assert s.j == pytest.approx(s.comfort_ratio + s.roll_ratio + tuning.END_STOP_J * s.end_stop_hits)


def test_tuning_on_a_local_two_worker_cluster(problem: tuning.Problem, tmp_path: Path) -> None:
    with LocalCluster(workers=2, log_dir=tmp_path) as cluster:
        assert len(cluster.pids) == 3
        ex = tuning.DaskExecutor(cluster.address)
        try:
            assert ex.workers == 2
            # Both workers take candidates (the scores carry the worker's pid).
            base = tuning.values(preset("4x4").controller_config(), problem.params)
            scores = ex.map(tuning._Score(problem), [base] * 4)
            assert len({s.pid for s in scores}) == 2
            assert len({s.j for s in scores}) == 1  # deterministic wherever it runs
            result = tuning.tune(problem, ex, popsize=1, maxiter=1, seed=2)
        finally:
            ex.close()
        # The command line on the same cluster.
        out = tmp_path / "tune"
        res = CliRunner().invoke(main, ["tune", "--seeds", "3", "--scale", "0.05", "--popsize", "1", "--maxiter", "1",
                                        "--cluster", cluster.address, "--out", str(out), "--quiet"])
        assert res.exit_code == 0, res.output
    # The processes are gone.
    assert cluster.processes == []
    # Never worse than the default (it stays in the population), a valid configuration.
    assert result.best.j <= result.default.j + 1e-12
    assert result.evaluations >= 12 and result.generations == 1
    Controller(result.config)
    summary = json.loads((out / "tuning.json").read_text())
    assert summary["executor"].startswith("dask tcp://127.0.0.1:")
    assert summary["best"]["j"] <= summary["default"]["j"] + 1e-12
    Controller(json.loads((out / "tuned.json").read_text())["config"])

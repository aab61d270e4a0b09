"""Benchmark: scaling of the controller tuning from one to two workers.

One generation's worth of candidates (the same batch each time) is scored
on a local Dask cluster of 1 and of 2 single-threaded workers (processes
started and stopped by id on 127.0.0.1), and with 1 and 2 local threads.
Prints the times and the speed-ups; a ratio, not a pass/fail.

    python scripts/bench_tune.py [--candidates 48] [--repeats 3] [--discard 1] [--scale 0.2] [--json out.json]

48 candidates by default: with the faster vehicle plant 8 or 16 took 1-4 s,
shorter than the run-to-run noise lets a ratio mean something
(BENCHMARKS.md, 2026-11-26).

Every worker is warmed before any timing (``Client.run`` scores one
candidate on each: imports, the gas table, the route and the driver's
signals it caches). Warming with a map of as many candidates as workers,
as this script did before 2026-11-26, let Dask put both on one worker, so
a "two worker" time could include the other worker's cold start. The one-
and two-worker clusters then run alternately, ``--repeats`` times, so that
a change of the shared machine's speed during the run falls on both; the
ratio is reported per repeat, by the median times and by the least times.
The first ``--discard`` repeats run the same way but are reported apart
and left out of the ratios: in each of three runs on 2026-11-26 the first
repeat's two-way runs (Dask and threads alike) were 10-30 % slower than
the later ones, while the one-way runs were not (a second vCPU that had
been idle; a tuning study keeps both busy for its whole run).
"""

from __future__ import annotations

import argparse
import json
import statistics
import time
from collections.abc import Callable
from typing import Any

import numpy as np

from hpctl.vehicle import route, tuning
from hpctl.vehicle.cluster import LocalCluster


def _timed(run: Callable[[], list[Any]], workers: int) -> float:
    t = time.perf_counter()
    scores = run()
    elapsed = time.perf_counter() - t
    used = {s.pid for s in scores}
    if len(used) != workers:
        print(f"warning: {workers} workers asked for, candidates ran in {len(used)} processes")
    return elapsed


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--candidates", type=int, default=48)
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--discard", type=int, default=1)
    ap.add_argument("--scale", type=float, default=0.2)
    ap.add_argument("--json", default=None)
    a = ap.parse_args()
    routes = (route.mixed(scale=a.scale, seed=1),)
    problem = tuning.Problem(("4x4",), routes, references=tuning.references(("4x4",), routes, threads=2))
    rng = np.random.default_rng(0)
    bounds = [((np.log10(p.low), np.log10(p.high)) if p.log else (p.low, p.high)) for p in problem.params]
    batch = [[float(rng.uniform(lo, hi)) for lo, hi in bounds] for _ in range(a.candidates)]
    fn = tuning._Score(problem)
    times: dict[str, list[float]] = {"dask_1": [], "dask_2": [], "threads_1": [], "threads_2": []}
    discarded: dict[str, list[float]] = {k: [] for k in times}
    with LocalCluster(workers=1) as one, LocalCluster(workers=2) as two:
        dask = {1: tuning.DaskExecutor(one.address), 2: tuning.DaskExecutor(two.address)}
        for n, ex in dask.items():
            warm = ex.client.run(fn, batch[0])
            assert len(warm) == n, f"{len(warm)} workers warmed, {n} expected"
        threads = {1: tuning.LocalExecutor(1), 2: tuning.LocalExecutor(2)}
        threads[2].map(fn, batch[:2])  # this process's caches (shared by its threads)
        for r in range(a.discard + a.repeats):
            into = discarded if r < a.discard else times
            for n in (1, 2):
                into[f"dask_{n}"].append(_timed(lambda: dask[n].map(fn, batch), n))
            for n in (1, 2):
                into[f"threads_{n}"].append(_timed(lambda: threads[n].map(fn, batch), 1))
        for ex in dask.values():
            ex.close()
        for t in threads.values():
            t.close()

    def ratios(kind: str) -> dict[str, Any]:
        one_s, two_s = times[f"{kind}_1"], times[f"{kind}_2"]
        return {
            "per_repeat": [x / y for x, y in zip(one_s, two_s)],
            "by_median": statistics.median(one_s) / statistics.median(two_s),
            "by_least": min(one_s) / min(two_s),
        }

    out = {
        "candidates": a.candidates,
        "repeats": a.repeats,
        "route_scale": a.scale,
        "times_s": times,
        "discarded_times_s": discarded,
        "speedup_dask_1_to_2": ratios("dask"),
        "speedup_threads_1_to_2": ratios("threads"),
    }
    print(json.dumps(out, indent=2))
    if a.json:
        with open(a.json, "w") as f:
            json.dump(out, f, indent=2)


if __name__ == "__main__":
    main()

"""Benchmark: scaling of the controller tuning from one to two workers.

One generation's worth of candidates (the same batch each time) is scored
on a local Dask cluster of 1 and of 2 single-threaded workers (processes
started and stopped by id on 127.0.0.1), and with 1 and 2 local threads.
Prints the times and the speed-ups; a ratio, not a pass/fail.

    python scripts/bench_tune.py [--candidates 48] [--scale 0.2] [--json out.json]

48 candidates by default: with the faster vehicle plant 8 or 16 took 1-4 s,
shorter than the run-to-run noise lets a ratio mean something
(BENCHMARKS.md, 2026-11-26).
"""

from __future__ import annotations

import argparse
import json
import time

import numpy as np

from hpctl.vehicle import route, tuning
from hpctl.vehicle.cluster import LocalCluster


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--candidates", type=int, default=48)
    ap.add_argument("--scale", type=float, default=0.2)
    ap.add_argument("--json", default=None)
    a = ap.parse_args()
    routes = (route.mixed(scale=a.scale, seed=1),)
    problem = tuning.Problem(("4x4",), routes, references=tuning.references(("4x4",), routes, threads=2))
    rng = np.random.default_rng(0)
    bounds = [((np.log10(p.low), np.log10(p.high)) if p.log else (p.low, p.high)) for p in problem.params]
    batch = [[float(rng.uniform(lo, hi)) for lo, hi in bounds] for _ in range(a.candidates)]
    fn = tuning._Score(problem)
    times: dict[str, float] = {}
    for workers in (1, 2):
        with LocalCluster(workers=workers) as cluster:
            ex = tuning.DaskExecutor(cluster.address)
            ex.map(fn, batch[:workers])  # warm up: imports and route caches on every worker
            t = time.perf_counter()
            ex.map(fn, batch)
            times[f"dask_{workers}"] = time.perf_counter() - t
            ex.close()
    for threads in (1, 2):
        ex2 = tuning.LocalExecutor(threads)
        ex2.map(fn, batch[:threads])
        t = time.perf_counter()
        ex2.map(fn, batch)
        times[f"threads_{threads}"] = time.perf_counter() - t
        ex2.close()
    out = {
        "candidates": a.candidates,
        "route_scale": a.scale,
        "times_s": times,
        "speedup_dask_1_to_2": times["dask_1"] / times["dask_2"],
        "speedup_threads_1_to_2": times["threads_1"] / times["threads_2"],
    }
    print(json.dumps(out, indent=2))
    if a.json:
        with open(a.json, "w") as f:
            json.dump(out, f, indent=2)


if __name__ == "__main__":
    main()

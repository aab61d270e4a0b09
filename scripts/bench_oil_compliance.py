"""Benchmark of the oil-compliance effect's cost (issue 12 item 4, the
first of "what remains" in BENCHMARKS.md): the steps and wall time of one
run of every record of the bundled campaign (``scripts/bench_diagnose.py``
makes and caches it) at the declared model ``seed`` with and without
``oil_compliance``, one evaluation of all the records together (in
parallel, as a fit evaluates them), and the time of ``hpctl fit CAMPAIGN
--model seed,oil_compliance`` with where it ended.

With ``--baseline DIR`` (a folder holding another build of the ``hpctl``
package, e.g. ``pip install --no-deps --target DIR`` of a wheel built from
main) every measurement runs for both builds in the same run, each in its
own process, alternating (baseline, this build, baseline, ...) so that
the machine's load falls on both alike; the report gives the ratios, and
the largest difference between the two builds' outputs (force, S
pressure) against the records' noise.

    python scripts/bench_oil_compliance.py [--baseline DIR] [--repeats 3] [--fit-repeats 1] [--heat-run] [--json FILE]

``--heat-run`` measures the bundled 75-minute heat run's record too (its
runs, steps and the builds' difference; the fit stays the campaign's).

A benchmark, not a test: it prints numbers and never fails because the
machine is slow.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "scripts"))
sys.path.insert(0, str(ROOT))

#: The oil bulk moduli measured: the fit's start (the registry's initial
#: value) and the stiffest the fit may try (its upper bound).
MODULI_PA = (1e9, 3e9)


def measure(campaign: Path, repeats: int, out_npz: Path) -> dict[str, Any]:
    """In this process: per record and model, the steps and the best of
    ``repeats`` wall times of one run; the outputs saved to ``out_npz``."""
    import numpy as np

    import hpctl
    from hpctl.data.records import read_record
    from hpctl.identify.dataset import prepare
    from hpctl.identify.fit import Model, simulate_all
    from hpctl.model.effects import LIBRARY, parse_model

    recs = [read_record(p) for p in sorted(campaign.glob("*.csv"))]
    datasets = prepare(recs)
    rows: dict[str, Any] = {}
    arrays: dict[str, Any] = {}
    for spec, moduli in (("seed", (None,)), ("seed,oil_compliance", MODULI_PA)):
        effects = parse_model(spec)
        model = Model(tuple(e for e in LIBRARY if e in effects), True)
        for modulus in moduli:
            values = {p.name: p.initial for p in model.params}
            label = spec if modulus is None else f"{spec} B={modulus:.0e}"
            if modulus is not None:
                values["oil_bulk_modulus_pa"] = modulus
            for d in datasets:
                best = float("inf")
                sim: Any = None
                for _ in range(repeats):
                    t0 = time.perf_counter()
                    sim = simulate_all(model, [d], [values], record_steps=True)[0][0]
                    best = min(best, time.perf_counter() - t0)
                if isinstance(sim, Exception):
                    rows[f"{label}|{d.name}"] = {"error": str(sim)}
                    continue
                rows[f"{label}|{d.name}"] = {"steps": int(len(sim["step_end_s"])), "samples": int(len(d.times_s)), "run_s": best}
                for c in ("force_n", "p_gas_pa"):
                    arrays[f"{label}|{d.name}|{c}"] = np.asarray(sim[c])
                    arrays[f"noise|{d.name}|{c}"] = np.asarray(d.sigma.get(c, np.nan))
    # One evaluation of all records together, as a fit's residual or
    # Jacobian column costs, at the fit's start (the registry's values).
    evaluation: dict[str, float] = {}
    for modulus in MODULI_PA:
        model = Model(tuple(e for e in LIBRARY if e in parse_model("seed,oil_compliance")), True)
        values = {p.name: p.initial for p in model.params} | {"oil_bulk_modulus_pa": modulus}
        best = float("inf")
        for _ in range(repeats):
            t0 = time.perf_counter()
            simulate_all(model, datasets, [values])
            best = min(best, time.perf_counter() - t0)
        evaluation[f"{modulus:.0e}"] = best
    np.savez(out_npz, **arrays)
    return {"hpctl": str(Path(hpctl.__file__).parent), "rows": rows, "evaluation_s": evaluation}


def fit_counted(campaign: Path, out: Path) -> dict[str, Any]:
    """In this process: ``hpctl fit CAMPAIGN --model seed,oil_compliance``
    with the runs of the records counted (each case one record's run)."""
    import contextlib
    import io

    import hpctl.identify.fit as ft
    from hpctl.cli import main

    counts = {"evaluations": 0, "record_runs": 0}
    original = ft.run_many

    def counted(cases: Any, *args: Any, **kwargs: Any) -> Any:
        counts["evaluations"] += 1
        counts["record_runs"] += len(cases)
        return original(cases, *args, **kwargs)

    ft.run_many = counted
    stdout = io.StringIO()
    t0 = time.perf_counter()
    with contextlib.redirect_stdout(stdout), contextlib.suppress(SystemExit):
        main(["fit", str(campaign), "--model", "seed,oil_compliance", "--json", "-q", "--force", "--out", str(out)], standalone_mode=False)
    fit = json.loads(stdout.getvalue())
    return {"in_process_s": time.perf_counter() - t0, **counts, "params": fit.get("params"), "rms_ratio": fit.get("rms_ratio"),
            "converged": fit.get("converged")}


def uptime() -> str:
    try:
        return " ".join(Path("/proc/loadavg").read_text().split()[:3])
    except OSError:
        return "?"


def env_for(build: Path | None) -> dict[str, str]:
    env = dict(os.environ)
    if build is not None:
        env["PYTHONPATH"] = os.pathsep.join([str(build)] + ([env["PYTHONPATH"]] if env.get("PYTHONPATH") else []))
    return env


def run_measure(build: Path | None, campaign: Path, repeats: int, npz: Path) -> dict[str, Any]:
    cmd = [sys.executable, str(Path(__file__).resolve()), "--measure", str(campaign), "--repeats", str(repeats), "--npz", str(npz)]
    out = subprocess.run(cmd, env=env_for(build), check=True, capture_output=True, text=True).stdout
    result: dict[str, Any] = json.loads(out.splitlines()[-1])
    return result


def time_fit(build: Path | None, campaign: Path, out: Path) -> dict[str, Any]:
    """``hpctl fit`` in a fresh process (its start-up included), with the
    records' runs counted."""
    cmd = [sys.executable, str(Path(__file__).resolve()), "--fit-counted", str(campaign), "--npz", str(out)]
    load = uptime()
    t0 = time.perf_counter()
    proc = subprocess.run(cmd, env=env_for(build), capture_output=True, text=True)
    took = time.perf_counter() - t0
    row: dict[str, Any] = {"seconds": took, "load": f"{load} -> {uptime()}", "exit": proc.returncode}
    try:
        row.update(json.loads(proc.stdout.splitlines()[-1]))
    except (json.JSONDecodeError, IndexError):
        row["stderr"] = proc.stderr[-2000:]
    return row


def report(builds: dict[str, Path | None], folder: Path, repeats: int, tmp: Path) -> dict[str, dict[str, Any]]:
    """Measures the records of ``folder`` for every build and prints their
    steps, times and the builds' difference against the noise."""
    import numpy as np

    tmp.mkdir(parents=True, exist_ok=True)
    runs: dict[str, dict[str, Any]] = {}
    for name, build in builds.items():
        load = uptime()
        runs[name] = run_measure(build, folder, repeats, tmp / f"{name}.npz")
        print(f"measured {name} ({runs[name]['hpctl']}), load {load} -> {uptime()}", flush=True)
    labels = sorted({k.split("|")[0] for k in runs["this"]["rows"]})
    records_ = sorted({k.split("|")[1] for k in runs["this"]["rows"]})
    print(f"\n{'model':28} {'record':20} {'samples':>7} " + " ".join(f"{n + ' steps':>14} {n + ' ms':>10}" for n in builds)
          + ("  steps ratio  time ratio" if len(builds) == 2 else ""))
    for lab in labels:
        for r in records_:
            cells = [runs[n]["rows"].get(f"{lab}|{r}", {}) for n in builds]
            if any("error" in c for c in cells):
                print(f"{lab:28} {r:20} " + " | ".join(c.get("error", "ok") for c in cells))
                continue
            line = f"{lab:28} {r:20} {cells[0]['samples']:7d} " + " ".join(f"{c['steps']:14d} {c['run_s'] * 1e3:10.1f}" for c in cells)
            if len(cells) == 2:
                line += f"  {cells[0]['steps'] / cells[1]['steps']:11.2f} {cells[0]['run_s'] / cells[1]['run_s']:11.2f}"
            print(line)
    print("\none evaluation of all records together (best of --repeats), s: " + "; ".join(
        f"B={m}: " + ", ".join(f"{n} {runs[n]['evaluation_s'][m]:.2f}" for n in builds)
        + (f" (ratio {runs['baseline']['evaluation_s'][m] / runs['this']['evaluation_s'][m]:.2f})" if len(builds) == 2 else "")
        for m in runs["this"]["evaluation_s"]))
    if len(builds) == 2:
        a0, a1 = np.load(tmp / "baseline.npz"), np.load(tmp / "this.npz")
        print("\nlargest difference between the builds' outputs, over the record's noise in that channel:")
        for k in sorted(a1.files):
            if k.startswith("noise") or k not in a0.files:
                continue
            _, rec, ch = k.split("|")
            noise = float(a1[f"noise|{rec}|{ch}"])
            d = float(np.max(np.abs(a0[k] - a1[k])))
            print(f"  {k:60} {d:10.3g} ({d / noise:.2g} x noise)")
    return runs


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--baseline", type=Path, default=None, help="a folder with another build of the hpctl package, measured alongside")
    ap.add_argument("--repeats", type=int, default=3, help="runs of each record; the best time is kept")
    ap.add_argument("--fit-repeats", type=int, default=1, help="timed fits per build (0: none)")
    ap.add_argument("--heat-run", action="store_true", help="the bundled heat run's record measured too")
    ap.add_argument("--json", type=Path, default=None)
    ap.add_argument("--measure", type=Path, default=None, help=argparse.SUPPRESS)
    ap.add_argument("--npz", type=Path, default=None, help=argparse.SUPPRESS)
    ap.add_argument("--fit-counted", type=Path, default=None, help=argparse.SUPPRESS)
    a = ap.parse_args()
    if a.measure is not None:
        print(json.dumps(measure(a.measure, a.repeats, a.npz)))
        return 0
    if a.fit_counted is not None:
        print(json.dumps(fit_counted(a.fit_counted, a.npz)))
        return 0

    from bench_diagnose import CAMPAIGN_EFFECT, CAMPAIGN_SEED, CAMPAIGN_TESTS, HEAT_EFFECT, HEAT_SEED, HEAT_TESTS, records

    print("python " + " ".join([str(Path(sys.argv[0]))] + sys.argv[1:]))
    print(f"{time.strftime('%Y-%m-%d %H:%M UTC', time.gmtime())}, {os.cpu_count()} cores, load {uptime()}")
    campaign = records("campaign", CAMPAIGN_EFFECT, CAMPAIGN_SEED, CAMPAIGN_TESTS)
    sets = {"campaign": campaign}
    if a.heat_run:
        sets["heat run"] = records("heat-run", HEAT_EFFECT, HEAT_SEED, HEAT_TESTS)
    builds: dict[str, Path | None] = {"this": None}
    if a.baseline is not None:
        builds = {"baseline": a.baseline.resolve(), "this": None}
    tmp = Path(tempfile.mkdtemp(prefix="bench-oil-"))
    measured: dict[str, dict[str, dict[str, Any]]] = {}
    for set_name, folder in sets.items():
        print(f"\n== {set_name}")
        measured[set_name] = report(builds, folder, a.repeats, tmp / set_name.replace(" ", "-"))
    fits: dict[str, list[dict[str, Any]]] = {n: [] for n in builds}
    for i in range(a.fit_repeats):
        for name, build in builds.items():
            row = time_fit(build, campaign, tmp / f"fit-{name}-{i}")
            fits[name].append(row)
            print(f"hpctl fit CAMPAIGN --model seed,oil_compliance ({name}): {row['seconds']:.1f} s, load {row['load']}, exit {row['exit']}"
                  + (f", {row['evaluations']} evaluations of the records ({row['record_runs']} record runs), "
                     f"{row['seconds'] / row['record_runs'] * 1e3:.0f} ms a record run, "
                     f"rms/noise {row['rms_ratio']:.4g}, ended at {row.get('params')}" if row.get("rms_ratio") is not None else "")
                  + (f"\n{row['stderr']}" if "stderr" in row else ""), flush=True)
    if a.json is not None:
        a.json.parent.mkdir(parents=True, exist_ok=True)
        a.json.write_text(json.dumps({"runs": measured, "fits": fits, "campaign": str(campaign)}, indent=1, default=str) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())

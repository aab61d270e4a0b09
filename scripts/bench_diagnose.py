"""Benchmark of issue 12's item 4: how long hpctl takes to diagnose and fit
rig data it did not write.

A bundled campaign made by the foreign rig (``tests/foreign_rig``, which
shares no code with hp-core) from the fixed spec below (effect, seed and
tests are committed here, so the data are deterministic):

- ``campaign``: five records, 25.1 minutes of rig data: a slow sine
  (0.01 Hz, 300 s), slow steps (496 s), the seed's SDOF step with the damper
  off and on (5 s each) and a heat build-up piece (0.5 Hz, damper on,
  700 s); one undeclared effect (seal friction, drawn by the seed);
- ``heat run``: one 75-minute record (0.5 Hz, damper on, 4,500 s at 10 Hz)
  with heat build-up.

Twenty-five minutes at the rig's rates is about 5 MB of CSV, too large to
commit: the records are generated once (the foreign rig is slow; the time
is printed) and cached under ``out/bench-diagnose/`` (git-ignored), keyed
by the foreign rig's code version, so that a change of the rig makes new
data.

Timed, each in a fresh process (``hpctl ... --json -q``), one at a time:

1. ``hpctl diagnose CAMPAIGN --model seed --json`` (target <= 60 s);
2. ``hpctl diagnose HEATRUN --model seed --json`` (target <= 120 s);
3. ``hpctl fit CAMPAIGN --model seed --json`` (one fit, target <= 10 s);

plus, in this process: the diagnosis again with a per-phase breakdown
(simulation of the records, the Jacobian's runs, the screening fits of the
candidates, cross-validation, the final fits with input noise) from
counters wrapped around hpctl's functions, against a baseline measured in
the same run (one simulation of every campaign record at the declared
model: the times read as "so many model runs"); the first round with the
candidates fitted one at a time and in the thread pool (the pool's gain,
same run); and how far the records' drives could be decimated (the
criterion is in :data:`DECIMATION_TOL`). The load average (``uptime``) is
printed with every time: the machine is shared.

Every timed row is also given as a multiple of a machine baseline measured
in the same run, before and after the rows (:func:`machine_baseline`): the
bundled campaign's five records run once at the flexible model's start,
and a QR of a Jacobian the size of the campaign's (57,255 x 35), the two
kinds of work a fit is made of. The targets are seconds on the issue's
machine; the ratios say what a time on another machine would be there
(stop 68: the targets were met on one 2-core Xeon and missed on an AMD
EPYC by 10 %).

    python scripts/bench_diagnose.py [--only decimation,campaign,heat,fit,breakdown,parallel] [--timeout-s 1800] [--json out/bench-diagnose/result.json]
    python scripts/bench_diagnose.py --flexible [--only campaign,fit,breakdown] [--screening-jacobian broyden]
    python scripts/bench_diagnose.py --only steps

``--flexible`` times the flexible model instead (``hpctl diagnose/fit
--flexible``: the damper characteristic, the friction's shape, the static
state and charge identified), the model that reaches the noise on foreign
data where ``--model seed``'s assumed damper leaves tens of times it; the
targets are the same. ``--screening-jacobian`` (breakdown only) replaces
the diagnosis's choice of Jacobian for its screening fits, to measure the
other one.

This is a benchmark, not a test: it prints numbers and never fails because
the machine is slow.
"""

from __future__ import annotations

import argparse
import contextlib
import json
import os
import subprocess
import sys
import threading
import time
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from tests.foreign_rig import Test, generate  # noqa: E402
from tests.foreign_rig.motion import Sine, Step, Steps  # noqa: E402
from tests.foreign_rig.records import code_version  # noqa: E402

CACHE = ROOT / "out" / "bench-diagnose"

#: The campaign: (effect, seed, tests). Changing any of it makes new data.
CAMPAIGN_EFFECT, CAMPAIGN_SEED = "friction", 20261123
CAMPAIGN_TESTS = (
    Test("sine_0.01hz", Sine(0.06, 0.01), 300.0, 600),
    Test("slow_steps", Steps(0.02, 4, 2.0, 60.0), 496.0, 2480, excitation="steps"),
    Test("sdof_step_hard_off", Step(0.043, 0.5, 0.05), 5.0, 1000, sdof=True, damper_on=False, excitation="step"),
    Test("sdof_step_hard_on", Step(0.043, 0.5, 0.05), 5.0, 1000, sdof=True, damper_on=True, excitation="step"),
    Test("heat_piece", Sine(0.06, 0.5), 700.0, 14000, damper_on=True),
)
HEAT_EFFECT, HEAT_SEED = "heat_buildup", 20261123
HEAT_TESTS = (Test("heat_run_75min", Sine(0.06, 0.5), 4500.0, 45000, damper_on=True),)

TARGETS_S = {"campaign": 60.0, "heat": 120.0, "fit": 10.0}


def uptime() -> str:
    try:
        return " ".join(Path("/proc/loadavg").read_text().split()[:3])
    except OSError:
        return "?"


def records(name: str, effect: str, seed: int, tests: tuple[Test, ...]) -> Path:
    """The records' folder, generated (and timed) if not cached yet."""
    folder = CACHE / code_version() / name
    if (folder / "truth.json").exists():
        return folder
    load = uptime()
    start = time.perf_counter()
    generate(effect, seed, out=folder, tests=tests)
    took = time.perf_counter() - start
    seconds = sum(t.duration_s for t in tests)
    print(f"generated {name}: {len(tests)} records, {seconds / 60:.1f} min of rig data, by the foreign rig in {took:.1f} s "
          f"({seconds / took:.1f} x real time; load {load})", flush=True)
    return folder


def timed(cmd: list[str], label: str, timeout_s: float) -> dict[str, Any]:
    load = uptime()
    start = time.perf_counter()
    # The progress lines are kept with the time each came (stderr is a
    # pipe: one line per step): they say how far a run that does not
    # finish got, and how long each round took.
    log = CACHE / "runs" / f"{label}.stderr"
    log.parent.mkdir(parents=True, exist_ok=True)
    out_path = log.with_suffix(".stdout")
    with open(log, "w") as err_file, open(out_path, "w") as out_file:
        proc = subprocess.Popen(cmd, stdout=out_file, stderr=subprocess.PIPE, text=True)
        err_lines: list[str] = []

        def pump() -> None:
            assert proc.stderr is not None
            for line in proc.stderr:
                err_lines.append(line)
                err_file.write(f"{time.perf_counter() - start:8.1f} s  {line}")
                err_file.flush()

        reader = threading.Thread(target=pump, daemon=True)
        reader.start()
        try:
            proc.wait(timeout=timeout_s)
        except subprocess.TimeoutExpired:
            proc.kill()
            proc.wait()
            took = time.perf_counter() - start
            last = log.read_text().strip().splitlines()[-1:] or ["(no progress line)"]
            print(f"{label:9} did not finish in {took:.0f} s (load {load} -> {uptime()}); last progress line: {last[0]}", flush=True)
            return {"label": label, "command": " ".join(cmd), "wall_s": None, "timeout_s": timeout_s, "load_before": load,
                    "load_after": uptime(), "last_progress": last[0]}
        reader.join()
    took = time.perf_counter() - start
    p = subprocess.CompletedProcess(cmd, proc.returncode, out_path.read_text(), "".join(err_lines))
    row: dict[str, Any] = {"label": label, "command": " ".join(cmd), "wall_s": round(took, 2), "load_before": load, "load_after": uptime(),
                           "exit": p.returncode}
    if p.returncode not in (0, 3):
        row["error"] = (p.stderr or p.stdout)[-500:]
    else:
        try:
            doc = json.loads(p.stdout)
            if "verdict" in doc:
                row["verdict"], row["found"] = doc["verdict"], doc.get("found")
            for k in ("error_before", "error_after"):
                if k in doc:
                    row[k.replace("error_", "rms_ratio_")] = doc[k]["rms_ratio"]
            if "rms_ratio" in doc:
                row["rms_ratio"] = doc["rms_ratio"]
        except json.JSONDecodeError:
            row["error"] = "no JSON on stdout"
    target = TARGETS_S.get(label.removesuffix("-flexible"))
    verdict = "" if target is None else (f"  target {target:.0f} s: met" if took <= target else f"  target {target:.0f} s: MISSED by {took / target:.1f} x")
    print(f"{label:9} {took:8.1f} s  (load {load} -> {row['load_after']}, exit {p.returncode}){verdict}", flush=True)
    return row


class Phases:
    """Wall time and calls per phase, from wrappers around hpctl's functions
    (the innermost phase gets the time: a fit inside cross-validation is
    cross-validation's). The candidates' fits run in threads: a phase's
    time is summed over them (thread-seconds), so the phases can add up to
    more than the wall time."""

    def __init__(self) -> None:
        self._local = threading.local()
        self.lock = threading.Lock()
        self.time_s: dict[str, float] = {}
        self.calls: dict[str, int] = {}
        self.runs: dict[str, int] = {}

    @property
    def stack(self) -> list[str]:
        """This thread's phases (the candidates' fits run in threads)."""
        if not hasattr(self._local, "stack"):
            self._local.stack = []
        stack: list[str] = self._local.stack
        return stack

    def wrap(self, module: Any, name: str, phase: Callable[[tuple[Any, ...], dict[str, Any]], str]) -> Callable[[], None]:
        original = getattr(module, name)

        def wrapper(*args: Any, **kwargs: Any) -> Any:
            ph = phase(args, kwargs)
            self.stack.append(ph)
            start = time.perf_counter()
            try:
                return original(*args, **kwargs)
            finally:
                took = time.perf_counter() - start
                self.stack.pop()
                with self.lock:
                    self.time_s[ph] = self.time_s.get(ph, 0.0) + took
                    self.calls[ph] = self.calls.get(ph, 0) + 1
                    if self.stack:  # the outer phase's time excludes this one
                        outer = self.stack[-1]
                        self.time_s[outer] = self.time_s.get(outer, 0.0) - took

        setattr(module, name, wrapper)
        return lambda: setattr(module, name, original)


@contextlib.contextmanager
def phase_counters() -> Iterator[Phases]:
    from hpctl.identify import diagnose as dg
    from hpctl.identify import fit as ft

    ph = Phases()
    restore = []

    def fit_phase(args: tuple[Any, ...], kwargs: dict[str, Any]) -> str:
        if kwargs.get("fold") is not None:  # a fold's fit (in its own thread)
            return "cross-validation"
        return "fit (with input noise)" if kwargs.get("input_noise", True) else "candidates (screening fits)"

    def sim_phase(args: tuple[Any, ...], kwargs: dict[str, Any]) -> str:
        datasets, value_sets = args[1], args[2]
        steps = kwargs.get("steps")
        kind = "simulate: Jacobian columns" if steps is not None else "simulate: residuals"
        if len(datasets) > 5 * 3 and len(value_sets) == 1:
            kind = "simulate: input-noise draws"
        with ph.lock:
            ph.runs[kind] = ph.runs.get(kind, 0) + len(datasets) * len(value_sets)
        return kind

    restore.append(ph.wrap(dg, "cross_validation", lambda a, k: "cross-validation"))
    restore.append(ph.wrap(dg, "fit", fit_phase))
    restore.append(ph.wrap(ft, "simulate_all", sim_phase))
    try:
        yield ph
    finally:
        for r in reversed(restore):
            r()


def machine_baseline(campaign: Path, repeats: int = 10) -> Callable[[], dict[str, Any]]:
    """Fixed work, prepared once, and a function that times it in this
    process, the median of ``repeats``: one run of the campaign's records at
    the flexible model's start (hp-core in Rust, its threads: what a fit's
    Jacobians and evaluations are) and a QR of a 57,255 x 35 matrix (LAPACK
    on one thread: what the trust region does with them)."""
    import numpy as np

    import hpctl.identify.fit as ft
    from hpctl.data.records import read_record
    from hpctl.identify.blas import one_blas_thread
    from hpctl.identify.dataset import prepare
    from hpctl.model.effects import parse_model

    datasets = prepare([read_record(p) for p in sorted(campaign.glob("*.toml"))])
    m = ft.model_for(datasets, parse_model("seed"), flexible=True)
    values = ft.values_from_x(m.params, ft._start_x(m.params, {}))
    a = np.asfortranarray(np.random.default_rng(0).standard_normal((57255, 35)))

    def median_s(work: Callable[[], object]) -> float:
        work()  # warm: the gas table, the pages
        took = []
        for _ in range(repeats):
            t0 = time.perf_counter()
            work()
            took.append(time.perf_counter() - t0)
        return float(np.median(took))

    def measure() -> dict[str, Any]:
        with one_blas_thread():
            qr_s = median_s(lambda: np.linalg.qr(a, mode="r"))
        return {"runs_s": median_s(lambda: ft.simulate_all(m, datasets, [values])), "qr_s": qr_s, "load": uptime()}

    return measure


def breakdown(campaign: Path, flexible: bool, screening_jacobian: str | None) -> dict[str, Any]:
    """The campaign's diagnosis in this process, by phase, and the
    baseline: one run of every record at the declared model.
    ``screening_jacobian`` replaces the diagnosis's choice of Jacobian for
    its screening fits (:func:`hpctl.identify.diagnose.screening_jacobian`)
    to measure the other one."""
    from hpctl.data.records import read_record
    from hpctl.identify import diagnose as dg
    from hpctl.identify.dataset import prepare
    from hpctl.identify.fit import Model, simulate_all
    from hpctl.model.effects import LIBRARY, parse_model

    recs = [read_record(p) for p in sorted(campaign.glob("*.csv"))]
    start_effects = parse_model("seed")
    t0 = time.perf_counter()
    datasets = prepare(recs)
    prep_s = time.perf_counter() - t0
    model = Model(tuple(e for e in LIBRARY if e in start_effects), True)
    values = {p.name: p.initial for p in model.params}
    base = []
    for _ in range(3):
        t0 = time.perf_counter()
        simulate_all(model, datasets, [values])
        base.append(time.perf_counter() - t0)
    run_s = min(base)
    load = uptime()
    with phase_counters() as ph:
        t0 = time.perf_counter()
        lines: list[tuple[float, str]] = []

        def say(m: str) -> None:
            lines.append((time.perf_counter() - t0, m))
            print(f"    {lines[-1][0]:7.1f} s  {m}", flush=True)

        chosen = dg.screening_jacobian
        if screening_jacobian is not None:
            dg.screening_jacobian = lambda _flexible, _n: screening_jacobian
        try:
            diag = dg.diagnose(recs, start_effects, progress=say, flexible=flexible)
        finally:
            dg.screening_jacobian = chosen
        total = time.perf_counter() - t0
    how = ("flexible" if flexible else "seed") + (f", screening Jacobian {screening_jacobian}" if screening_jacobian else "")
    print(f"breakdown ({how}; in this process, load {load} -> {uptime()}): diagnosis {total:.1f} s, verdict {diag.verdict}, found {diag.found}, "
          f"RMS / noise {diag.initial.rms_ratio:.3g} -> {diag.final.rms_ratio:.3g}")
    print(f"  baseline: one run of the {len(datasets)} records at the declared model {run_s * 1e3:.0f} ms; preparing them {prep_s:.2f} s")
    print(f"  {'phase':32} {'thread-s':>8} {'share':>6} {'calls':>6} {'model runs':>11} {'x baseline':>11}")
    for k in sorted(ph.time_s, key=lambda k: -ph.time_s[k]):
        runs = ph.runs.get(k, 0)
        print(f"  {k:32} {ph.time_s[k]:8.1f} {ph.time_s[k] / total:6.0%} {ph.calls[k]:6d} {runs // max(len(datasets), 1) if runs else '':>11} "
              f"{ph.time_s[k] / run_s:11.0f}")
    print(f"  diagnosis = {total / run_s:.0f} x one run of the records")
    return {"flexible": flexible, "screening_jacobian": screening_jacobian, "total_s": total, "baseline_run_s": run_s, "prepare_s": prep_s, "load_before": load, "load_after": uptime(),
            "phases_s": ph.time_s, "calls": ph.calls, "record_runs": {k: v // len(datasets) for k, v in ph.runs.items()},
            "verdict": diag.verdict, "found": diag.found, "progress": lines}


#: Decimation criterion: a record's drive (the smoothed measured input) may
#: be given to the model on every m-th sample only where the cubic Hermite
#: interpolation between those samples (what the core does between knots)
#: reproduces the full-rate drive within this share of the drive's own
#: noise, in displacement and velocity: the interpolation then adds at most
#: 1 % to the input noise's variance. The steps of the adaptive integrator
#: end at every knot of a sampled drive (hp-core's motion.rs says why), so
#: the knots, not the output samples, set a run's cost.
DECIMATION_TOL = 0.1


def decimation_check(campaign: Path) -> dict[str, dict[int, tuple[float, float]]]:
    """Per record and factor m: the largest interpolation error of the
    drive on every m-th sample, over its noise (displacement, velocity)."""
    import numpy as np

    from hpctl.data.records import read_record
    from hpctl.identify.dataset import input_disp_m
    from hpctl.identify.signals import SMOOTH_NOISE_GAIN, derivative, noise_sigma, smooth, velocity_noise_gain

    out: dict[str, dict[int, tuple[float, float]]] = {}
    print(f"decimation check: the drive's Hermite interpolation on every m-th sample, largest error over the drive's noise "
          f"(displacement / velocity; decimation allowed below {DECIMATION_TOL})")
    for p in sorted(campaign.glob("*.csv")):
        rec = read_record(p)
        t = np.asarray(rec["time_s"], float)
        x_in = input_disp_m(rec)
        xs = smooth(t, x_in)
        vs = derivative(t, xs)
        sx = noise_sigma(x_in) * SMOOTH_NOISE_GAIN
        sv = noise_sigma(x_in) * velocity_noise_gain(float(np.median(np.diff(t))))
        row: dict[int, tuple[float, float]] = {}
        for m in (2, 4, 8):
            k = np.arange(0, len(t), m)
            if k[-1] != len(t) - 1:
                k = np.append(k, len(t) - 1)
            seg = np.clip(np.searchsorted(t[k], t, side="right") - 1, 0, len(k) - 2)
            a, b = k[seg], k[seg + 1]
            h = t[b] - t[a]
            s = (t - t[a]) / h
            x = (2 * s**3 - 3 * s**2 + 1) * xs[a] + (s**3 - 2 * s**2 + s) * h * vs[a] + (3 * s**2 - 2 * s**3) * xs[b] + (s**3 - s**2) * h * vs[b]
            v = (6 * s**2 - 6 * s) / h * (xs[a] - xs[b]) + (3 * s**2 - 4 * s + 1) * vs[a] + (3 * s**2 - 2 * s) * vs[b]
            row[m] = (float(np.max(np.abs(x - xs)) / sx), float(np.max(np.abs(v - vs)) / sv))
        out[rec.name] = row
        print(f"  {rec.name:20} {len(t):6d} samples, dt {np.median(np.diff(t)) * 1e3:6.1f} ms: "
              + "; ".join(f"m={m} {ex:.2g} / {ev:.2g}" + (" ok" if max(ex, ev) <= DECIMATION_TOL else "") for m, (ex, ev) in row.items()))
    return out


def step_counts(campaign: Path, heat: Path) -> dict[str, Any]:
    """Where a run's steps go (the flexible model at its start, the fits'
    tolerance, the reference gas's table): the campaign's heat piece with
    its sampled drive and with the same sine as an analytic one (a step
    ends at every sample of a sampled drive), and the heat run with and
    without oil compliance, whose stiff oil mode sets the steps of its
    candidate's runs, at several bulk moduli and tolerances."""
    import numpy as np

    import hpctl.identify.fit as ft
    from hpctl.data.records import read_record
    from hpctl.identify.dataset import prepare
    from hpctl.model.effects import parse_model
    from hpctl.sim.run import Case, Sine, characterisation_rig, run_many

    out: dict[str, Any] = {}
    piece = prepare([read_record(campaign / "heat_piece.toml")])
    m = ft.model_for(piece, parse_model("seed"), flexible=True)
    unit = m.unit_for(piece[0], ft.values_from_x(m.params, ft._start_x(m.params, {})))
    test = piece[0].record.test
    for label, rig in (("sampled drive", piece[0].rig), ("analytic sine", characterisation_rig(Sine(test.amplitude_m, test.frequency_hz)))):
        case = Case(unit, rig, piece[0].times_s, spring_hard=True, damper_on=True, rtol=ft.FIT_RTOL, gas_table=True, record_steps=True,
                    channels=["time_s", "force_n"])
        t0 = time.perf_counter()
        r = run_many([case])[0]
        el = time.perf_counter() - t0
        if isinstance(r, Exception):
            raise r
        n = len(np.asarray(r.step_end_s))
        out[f"heat_piece, {label}"] = {"steps": n, "s": el}
        print(f"  heat_piece ({len(piece[0].times_s)} samples), {label}: {n} steps, {el * 1e3:.1f} ms")
    run = prepare([read_record(p) for p in sorted(heat.glob("*.toml"))])
    base_rtol = ft.FIT_RTOL
    try:
        for effects, bulk, rtol in (("heat_transfer,real_gas", None, base_rtol), ("heat_transfer,real_gas,oil_compliance", 2.9e9, 1e-6),
                                    ("heat_transfer,real_gas,oil_compliance", 2.9e9, base_rtol), ("heat_transfer,real_gas,oil_compliance", 2.9e9, 1e-8),
                                    ("heat_transfer,real_gas,oil_compliance", 3e8, base_rtol)):
            ft.FIT_RTOL = rtol  # the fits' runs read it (hpctl.identify.fit._case)
            m = ft.model_for(run, parse_model(effects), flexible=True)
            values = ft.values_from_x(m.params, ft._start_x(m.params, {}))
            if bulk is not None:
                values["oil_bulk_modulus_pa"] = bulk
            t0 = time.perf_counter()
            sim = ft.simulate_all(m, run, [values], record_steps=True)[0][0]
            el = time.perf_counter() - t0
            if isinstance(sim, Exception):
                raise sim
            ends = np.asarray(sim["step_end_s"])
            h = np.diff(ends)
            label = f"heat run, {effects}" + ("" if bulk is None else f", B {bulk:.3g} Pa") + f", rtol {rtol:g}"
            out[label] = {"steps": len(ends), "s": el, "median_step_s": float(np.median(h))}
            print(f"  {label}: {len(ends)} steps (median {np.median(h) * 1e3:.2f} ms), {el:.2f} s")
    finally:
        ft.FIT_RTOL = base_rtol
    return out


def parallel_ratio(campaign: Path) -> dict[str, Any]:
    """The campaign's first round (every candidate's screening fit,
    cross-validation, the accepted model's fit) with the candidates one at
    a time and in the default thread pool, in the same run: the pool's
    gain, and a check that the result is the same."""
    from hpctl.data.records import read_record
    from hpctl.identify import diagnose as dg
    from hpctl.model.effects import parse_model

    recs = [read_record(p) for p in sorted(campaign.glob("*.csv"))]
    start = parse_model("seed")
    times: dict[int, float] = {}
    found = {}
    for workers in (1, dg.default_workers()):
        load = uptime()
        t0 = time.perf_counter()
        d = dg.diagnose(recs, start, max_rounds=1, workers=workers)
        times[workers] = time.perf_counter() - t0
        found[workers] = (d.found, d.final.values)
        print(f"first round, {workers} worker(s): {times[workers]:.1f} s (load {load} -> {uptime()}), found {d.found}", flush=True)
    w = dg.default_workers()
    same = found[1] == found[w]
    print(f"  thread pool of {w}: {times[1] / times[w]:.2f} x faster than one at a time; same result: {same}")
    return {"seconds": times, "speedup": times[1] / times[w], "same_result": same}


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--only", default="decimation,campaign,heat,fit,breakdown,parallel",
                    help="which timings (comma-separated): campaign, heat, fit (each in a fresh hpctl process), breakdown (the campaign's "
                         "diagnosis in this process, by phase), parallel (its first round with one worker and with the pool), decimation (how far the records' drives could be decimated), "
                         "steps (not by default: a run's steps with a sampled and an analytic drive, and with oil compliance)")
    ap.add_argument("--timeout-s", type=float, default=1800.0, help="give up on a timing after this long (reported as not finished)")
    ap.add_argument("--json", type=Path, default=None, help="also write the results here")
    ap.add_argument("--flexible", action="store_true",
                    help="time the flexible model (damper characteristic, friction shape, static state and charge identified: "
                         "the model that reaches the noise on foreign data) instead of the seed's assumed damper")
    ap.add_argument("--screening-jacobian", choices=("finite_difference", "broyden"), default=None,
                    help="breakdown only: the screening fits' Jacobian instead of the diagnosis's choice")
    a = ap.parse_args()
    only = set(a.only.split(","))
    print("python " + " ".join([str(Path(sys.argv[0]))] + sys.argv[1:]))
    print(f"hpctl benchmark (issue 12 item 4), {time.strftime('%Y-%m-%d %H:%M UTC', time.gmtime())}, {os.cpu_count()} cores, load {uptime()}")
    campaign = records("campaign", CAMPAIGN_EFFECT, CAMPAIGN_SEED, CAMPAIGN_TESTS)
    heat = records("heat-run", HEAT_EFFECT, HEAT_SEED, HEAT_TESTS) if only & {"heat", "steps"} else None
    out = CACHE / "runs"
    hpctl = [sys.executable, "-m", "hpctl"]
    model = ["--model", "seed"] + (["--flexible"] if a.flexible else [])
    tag = "-flexible" if a.flexible else ""
    rows = []
    timings = only & {"campaign", "heat", "fit"}
    baseline = machine_baseline(campaign) if timings else None
    baselines = [baseline()] if baseline is not None else []
    if "campaign" in only:
        rows.append(timed(hpctl + ["diagnose", str(campaign), *model, "--json", "--force", "--out", str(out / f"campaign{tag}")], f"campaign{tag}", a.timeout_s))
    if heat is not None and "heat" in only:
        rows.append(timed(hpctl + ["diagnose", str(heat), *model, "--json", "--force", "--out", str(out / f"heat{tag}")], f"heat{tag}", a.timeout_s))
    if "fit" in only:
        rows.append(timed(hpctl + ["fit", str(campaign), *model, "--json", "-q", "--force", "--out", str(out / f"fit{tag}")], f"fit{tag}", a.timeout_s))
    if baseline is not None:
        baselines.append(baseline())
        runs_s = sum(b["runs_s"] for b in baselines) / len(baselines)
        qr_s = sum(b["qr_s"] for b in baselines) / len(baselines)
        runs = ", ".join(f"{1e3 * b['runs_s']:.1f}" for b in baselines)
        qrs = ", ".join(f"{1e3 * b['qr_s']:.1f}" for b in baselines)
        loads = "; ".join(str(b["load"]) for b in baselines)
        print(f"machine baseline (before, after): the campaign's records run once {runs} ms, a 57,255 x 35 QR {qrs} ms (load {loads})")
        for r in rows:
            if r.get("wall_s") is not None:
                r["x_runs_baseline"], r["x_qr_baseline"] = r["wall_s"] / runs_s, r["wall_s"] / qr_s
                print(f"  {r['label']:16} {r['wall_s']:.1f} s = {r['x_runs_baseline']:.0f} x the records' run, {r['x_qr_baseline']:.0f} x the QR")
    for r in rows:
        if "error" in r:
            print(f"  {r['label']}: {r['error']}")
        elif "verdict" in r:
            print(f"  {r['label']}: {r['verdict']} found={r['found']} rms/noise {r.get('rms_ratio_before')} -> {r.get('rms_ratio_after')}")
        elif "rms_ratio" in r:
            print(f"  {r['label']}: rms/noise {r['rms_ratio']:.3g}")
    result: dict[str, Any] = {"timings": rows, "machine_baseline": baselines, "foreign_rig_version": code_version(), "cores": os.cpu_count()}
    if "parallel" in only:
        result["parallel"] = parallel_ratio(campaign)
    if "decimation" in only:
        result["decimation"] = decimation_check(campaign)
    if "breakdown" in only:
        result["breakdown"] = breakdown(campaign, a.flexible, a.screening_jacobian)
    if "steps" in only and heat is not None:
        result["steps"] = step_counts(campaign, heat)
    if a.json is not None:
        a.json.parent.mkdir(parents=True, exist_ok=True)
        a.json.write_text(json.dumps(result, indent=1, default=str) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())

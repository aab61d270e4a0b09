"""Collects criterion's results (target/criterion) into a Markdown table:
absolute times and ratios against the baseline of the same run.

    cargo bench -p hp-core --bench physics
    cargo bench -p hp-ctrl --bench step
    python scripts/bench_report.py

Benchmarks, not tests: nothing here fails because a machine is slow.
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
CRITERION = ROOT / "target" / "criterion"


def estimate_ns(bench_dir: Path) -> float | None:
    f = bench_dir / "new" / "estimates.json"
    if not f.exists():
        return None
    data = json.loads(f.read_text())
    return float(data["median"]["point_estimate"])


def main() -> None:
    if not CRITERION.exists():
        sys.exit("no criterion results: run the cargo bench commands in this script's docstring first")
    results: dict[str, float] = {}
    for est in CRITERION.rglob("new/estimates.json"):
        bench = est.parent.parent
        name = str(bench.relative_to(CRITERION))
        if name.endswith("/report") or "report" in bench.parts[-1:]:
            continue
        value = estimate_ns(bench)
        if value is not None:
            results[name] = value
    # criterion stores "baseline/exp" as "baseline_exp".
    baseline = results.get("baseline_exp")
    print("| benchmark | median | per | ratio to one libm exp (same run) |")
    print("|---|---|---|---|")
    for name in sorted(results):
        ns = results[name]
        shown = f"{ns / 1e6:.3f} ms" if ns > 1e5 else f"{ns:.1f} ns"
        ratio = f"{ns / baseline:,.1f}" if baseline else "-"
        print(f"| `{name}` | {shown} | call | {ratio} |")
    copy = results.get("controller/baseline_ copy Inputs")
    step = results.get("controller/step")
    if copy and step:
        print(f"Controller step: {step:.1f} ns, {step / copy:.0f} x copying its inputs (same run).")
    exp = baseline or float("nan")
    for variant in ("rk4_1ms", "adaptive", "adaptive_states_only"):
        run = results.get(f"sdof_10s_at_1khz/{variant}")
        if run:
            print(f"SDOF at 1 kHz, {variant}: {10.0 / (run * 1e-9):,.0f} x real time (target >= 5,000 x).")
    slow = results.get("slow_steps_20min_valve6_open/adaptive")
    if slow:
        print(f"20-minute slow-steps characterisation, valve 6 open, adaptive: {slow * 1e-9:.4f} s (target <= 0.1 s).")
    for gas in ("span", "bwr-textbook"):
        eos = results.get(f"eos_props/{gas}")
        if eos:
            print(f"EOS state ({gas}: pressure, two derivatives, c_v): {eos:.1f} ns = {eos / exp:.1f} exp (target <= 100 ns).")

if __name__ == "__main__":
    main()

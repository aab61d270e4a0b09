"""Coverage of the fit's standard errors (issue 12, item 2): N randomised
hp-core virtual-rig runs (truth and noise drawn per run), the fraction with
the truth within 2 standard errors, per parameter, and the z-scores.

    python scripts/coverage_stderr.py --runs 40 --seed 1000 [--flexible]

Run from the repository root. Run i uses seed SEED + i.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np
from scipy.stats import binom

sys.path.insert(0, str(Path(__file__).resolve().parent.parent / "tests"))

import coverage  # noqa: E402


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--runs", type=int, default=40)
    ap.add_argument("--seed", type=int, default=1000)
    ap.add_argument("--flexible", action="store_true")
    a = ap.parse_args()
    runs = []
    for i in range(a.runs):
        r = coverage.run(a.seed + i, a.flexible)
        runs.append(r)
        print(f"run {a.seed + i}: rms/noise {r.rms_ratio:.3f} " + " ".join(f"{n} z={r.z(n):+.2f}" for n in r.truth), flush=True)
    n = len(runs)
    lo, hi = binom.ppf(0.005, n, 0.9545), binom.ppf(0.995, n, 0.9545)
    print(f"{n} runs; 99 % band of the count inside 2 sigma for honest errors: {lo:.0f}-{hi:.0f}")
    for name in runs[0].truth:
        z = np.array([r.z(name) for r in runs])
        print(f"{name}: inside 2 sigma {coverage.inside(runs, name)}/{n}, z mean {z.mean():+.2f}, z sd {z.std(ddof=1):.2f}")


if __name__ == "__main__":
    main()

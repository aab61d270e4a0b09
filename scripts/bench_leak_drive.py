#!/usr/bin/env python3
"""Speed of one gas-charge drive (scripts/leak_study.py's unit of work),
the fast plant (the reference gas through its table) against the
reference plant (the direct equation) in the same run, one thread each,
the same drive: real-time factors and their ratio. The road and the plan
are built before the clock starts (the study builds them too: about 2 s
per hour of driving).

    scripts/bench_leak_drive.py [--seconds 1800] [--day warm] [--seed 5001]
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent.parent / "python"))

from hpctl.control import gas_charge as gc  # noqa: E402


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--seconds", type=float, default=1800.0, help="simulated driving, s (default 1800)")
    ap.add_argument("--day", default="warm", choices=list(gc.DAYS))
    ap.add_argument("--seed", type=int, default=5001)
    args = ap.parse_args()
    segments = gc.plan(np.random.default_rng(args.seed), args.seconds)
    case = gc.drive_case(segments, ambient_k=gc.DAYS[args.day], seed=args.seed)
    factors = {}
    for name, reference in (("fast (tabulated gas)", False), ("reference (direct equation)", True)):
        t0 = time.perf_counter()
        gc.run([{**case, "reference_plant": reference}], threads=1)
        factors[name] = args.seconds / (time.perf_counter() - t0)
        print(f"{name}: {factors[name]:.0f}x real time")
    fast, ref = factors.values()
    print(f"ratio {fast / ref:.2f}; {args.seconds:.0f} s on a {args.day} day, plan {[s.kind for s in segments]}; load average {os.getloadavg()[0]:.1f}")


if __name__ == "__main__":
    main()

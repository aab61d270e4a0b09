"""How far the diagnosis's progress lines' estimates of the time left in
the round are from the time it then took (issue 12, item 4): runs ``hpctl
diagnose`` on each record folder, stamps every progress line as it is
printed, and for each line that says "about T left in this round" prints
T, the time the round really took from that line on, and their ratio.

    python scripts/bench_progress.py FOLDER [FOLDER ...] [--model seed] [--flexible]

A round ends at its "added ..." line, at the next round's first line, or
at the report ("Diagnosis: ..."). This is a benchmark, not a test: the
estimates are estimates, and it never fails. BENCHMARKS.md (stop 78) has
what it printed for the bundled campaign and heat run and six foreign-rig
cases.
"""

from __future__ import annotations

import argparse
import math
import re
import subprocess
import sys
import tempfile
import time
from pathlib import Path

LEFT = re.compile(r"about (?:(\d+) min )?(\d+) s left in this round")
ROUND = re.compile(r"^round (\d+)/\d+: ")


def said_s(line: str) -> float | None:
    """The seconds a progress line says are left in the round, or None."""
    m = LEFT.search(line)
    return None if m is None else 60.0 * int(m.group(1) or 0) + int(m.group(2))


def stamped(argv: list[str]) -> list[tuple[float, str]]:
    """Each line ``argv`` writes to stderr with when it was read, s from the start."""
    t0 = time.perf_counter()
    out: list[tuple[float, str]] = []
    with subprocess.Popen(argv, stderr=subprocess.PIPE, stdout=subprocess.DEVNULL, text=True, bufsize=1) as p:
        assert p.stderr is not None
        for line in p.stderr:
            out.append((time.perf_counter() - t0, line.rstrip("\n")))
    return out


def round_ends(lines: list[tuple[float, str]]) -> dict[int, float]:
    """When each round ended (see the module's note)."""
    ends: dict[int, float] = {}
    current = None
    for t, line in lines:
        m = ROUND.match(line)
        if m:
            r = int(m.group(1))
            if current is not None and r != current:
                ends.setdefault(current, t)
            current = r
            if ": added " in line:
                ends.setdefault(r, t)
        elif line.startswith("Diagnosis:") and current is not None:
            ends.setdefault(current, t)
    return ends


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("folders", type=Path, nargs="+")
    ap.add_argument("--model", default="seed")
    ap.add_argument("--flexible", action="store_true")
    a = ap.parse_args()
    worst: list[float] = []
    for folder in a.folders:
        with tempfile.TemporaryDirectory() as out:
            argv = [sys.executable, "-m", "hpctl", "diagnose", str(folder), "--model", a.model, "--out", out, "--json"]
            lines = stamped(argv + (["--flexible"] if a.flexible else []))
        if not lines:
            print(f"== {folder}: hpctl diagnose said nothing")
            continue
        ends = round_ends(lines)
        print(f"== {folder} ({lines[-1][0]:.1f} s)")
        for t, line in lines:
            m, s = ROUND.match(line), said_s(line)
            if m is None or s is None or int(m.group(1)) not in ends:
                continue
            truth = ends[int(m.group(1))] - t
            ratio = s / truth if truth > 0 else math.inf
            if truth >= 1.0:
                worst.append(abs(math.log(ratio)))
            print(f"{t:7.1f} s  said {s:6.0f} s  took {truth:6.1f} s  x{ratio:5.2f}  {line[:100]}")
    if worst:
        print(f"lines with at least 1 s left: {len(worst)}; the farthest off by a factor {math.exp(max(worst)):.2f}, "
              f"the median by {math.exp(sorted(worst)[len(worst) // 2]):.2f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())

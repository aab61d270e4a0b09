"""Start-up benchmark of the command line: the wall time of ``hpctl --help``
and ``hpctl simulate --help`` (and other commands' help), each in a fresh
interpreter, best of ``--repeat``, beside the bare interpreter's start-up
measured in the same run; then the slowest imports of one start-up
(``python -X importtime``), to see what to make lazy.

    python scripts/bench_startup.py [--repeat 7] [--top 12]

The goal (issue 15): under 0.5 s. This is a benchmark, not a test: it
prints numbers and never fails because the machine is slow. (The test
``tests/test_cli_comfort.py`` checks what can be checked without a clock:
that ``import hpctl.cli`` loads neither SciPy nor matplotlib.)
"""

from __future__ import annotations

import argparse
import os
import re
import resource
import subprocess
import sys
import time

COMMANDS: tuple[tuple[str, ...], ...] = (
    ("--help",),
    ("simulate", "--help"),
    ("fit", "--help"),
    ("closed-loop", "--help"),
    ("--version",),
)


def wall_s(argv: list[str], repeat: int) -> tuple[float, float]:
    """The best wall time and the best CPU time (user + system) of ``argv``
    over ``repeat`` runs, s. On a busy machine the CPU time is the steadier
    of the two (the wall time includes waiting for a core)."""
    best, best_cpu = float("inf"), float("inf")
    for _ in range(repeat):
        before = resource.getrusage(resource.RUSAGE_CHILDREN)
        t0 = time.perf_counter()
        subprocess.run(argv, check=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        best = min(best, time.perf_counter() - t0)
        after = resource.getrusage(resource.RUSAGE_CHILDREN)
        best_cpu = min(best_cpu, after.ru_utime - before.ru_utime + after.ru_stime - before.ru_stime)
    return best, best_cpu


def slowest_imports(argv: list[str], top: int) -> list[tuple[float, str]]:
    """(cumulative seconds, module) of the ``top`` slowest top-level imports."""
    r = subprocess.run([sys.executable, "-X", "importtime", *argv], capture_output=True, text=True, check=True)
    rows = []
    for line in r.stderr.splitlines():
        m = re.match(r"import time:\s+(\d+) \|\s+(\d+) \|( *)(\S+)", line)
        if m and len(m.group(3)) <= 1:  # top level: one space of indent
            rows.append((int(m.group(2)) * 1e-6, m.group(4)))
    return sorted(rows, reverse=True)[:top]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--repeat", type=int, default=7)
    ap.add_argument("--top", type=int, default=12)
    args = ap.parse_args()
    print(f"start-up, best of {args.repeat} (python {sys.version.split()[0]}; load average {os.getloadavg()[0]:.1f} on {os.cpu_count()} cores):")
    print(f"  {'':34} {'wall':>7}     {'CPU':>7}")
    base, base_cpu = wall_s([sys.executable, "-c", "pass"], args.repeat)
    print(f"  {'python -c pass':34} {base * 1e3:7.0f} ms  {base_cpu * 1e3:7.0f} ms  (baseline)")
    rows: list[tuple[str, list[str]]] = [('python -c "import numpy"', [sys.executable, "-c", "import numpy"])]
    rows += [("hpctl " + " ".join(cmd), [sys.executable, "-m", "hpctl", *cmd]) for cmd in COMMANDS]
    for label, argv in rows:
        t, cpu = wall_s(argv, args.repeat)
        verdict = "" if label.startswith("python") else ("; ok" if t < 0.5 else "; OVER the 0.5 s goal")
        print(f"  {label:34} {t * 1e3:7.0f} ms  {cpu * 1e3:7.0f} ms  ({t / base:.1f} x baseline wall{verdict})")
    print("slowest top-level imports of `hpctl simulate --help` (cumulative, one run of python -X importtime):")
    for seconds, module in slowest_imports(["-m", "hpctl", "simulate", "--help"], args.top):
        print(f"  {seconds * 1e3:7.1f} ms  {module}")


if __name__ == "__main__":
    main()

"""How long a profile interval takes with its two sides fitted one after
the other and side by side (:func:`hpctl.identify.profile.profile_interval`
runs them side by side), in the same run, on the foreign rig's friction
draws: the same interval either way, checked.

    python scripts/bench_profile.py 1 8 --max-hz 10

Each seed: the flexible model with friction fitted to the draw's sweep
sines up to ``--max-hz`` (0.1: the three slow sines), then the profile of
``--name`` (the breakaway force by default) timed ``--repeats`` times each
way, which goes first alternating. Run from the repository root (``tests/`` holds the
foreign rig).
"""

from __future__ import annotations

import argparse
import statistics
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent.parent / "tests"))
sys.path.insert(0, str(Path(__file__).resolve().parent))

from foreign_breakaway_redraws import MODEL  # noqa: E402
from foreign_slow_sines import foreign  # noqa: E402
from hpctl.identify import MAX_NFEV_FLEXIBLE, profile  # noqa: E402
from hpctl.identify.dataset import prepare  # noqa: E402
from hpctl.identify.fit import fit  # noqa: E402
from in_turn import InTurn  # noqa: E402


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("seeds", type=int, nargs="+")
    ap.add_argument("--max-hz", type=float, default=0.1)
    ap.add_argument("--name", default="friction_breakaway_n")
    ap.add_argument("--repeats", type=int, default=2)
    a = ap.parse_args()
    parallel = profile.ThreadPoolExecutor
    for seed in a.seeds:
        records, _ = foreign(seed, "friction", a.max_hz, [], 0)
        r = fit(prepare(records), MODEL, flexible=True, max_nfev=MAX_NFEV_FLEXIBLE)
        times: dict[str, list[float]] = {"in turn": [], "side by side": []}
        intervals = set()
        ways = [("in turn", InTurn), ("side by side", parallel)]
        for k in range(a.repeats):
            for label, executor in ways if k % 2 == 0 else ways[::-1]:  # either first by turns
                profile.ThreadPoolExecutor = executor  # type: ignore[misc,assignment]
                t0 = time.perf_counter()
                iv = profile.profile_interval(r, a.name)
                times[label].append(time.perf_counter() - t0)
                intervals.add((iv.lower, iv.upper, tuple(q.value for q in iv.points)))
        profile.ThreadPoolExecutor = parallel  # type: ignore[misc]
        turn, side = statistics.median(times["in turn"]), statistics.median(times["side by side"])
        print(f"seed {seed}: {a.name} {iv.describe()}; in turn {turn:.1f} s, side by side {side:.1f} s ({side / turn:.2f} x); "
              f"{'the same interval' if len(intervals) == 1 else 'DIFFERENT intervals: ' + str(intervals)}", flush=True)


if __name__ == "__main__":
    main()

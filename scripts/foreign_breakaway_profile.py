"""The breakaway friction force's 2-sigma profile interval against its
linear one (estimate +- 2 errors, the delta method) on the foreign rig's
friction draws: how often each holds the truth (docs/foreign-rig.md, "The
breakaway force's profile interval", stop 68).

    python scripts/foreign_breakaway_profile.py 1 2 3 4 5 8 10 14 --redraws 3
    python scripts/foreign_breakaway_profile.py 1 3 8 --max-hz 10

Each draw's sweep sines up to ``--max-hz`` (0.1 by default: the three slow
sines, what a friction measurement runs), with the draw's own noise and
``--redraws - 1`` redraws of it, fitted by the flexible model with friction
(1-8 s a fit), then profiled (1-20 s). Run from the repository root
(``tests/`` holds the foreign rig).
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent.parent / "tests"))
sys.path.insert(0, str(Path(__file__).resolve().parent))

import foreign_rig.draw as foreign_draw  # noqa: E402
from foreign_breakaway_redraws import MODEL  # noqa: E402
from foreign_slow_sines import foreign  # noqa: E402
from hpctl.identify import MAX_NFEV_FLEXIBLE  # noqa: E402
from hpctl.identify.dataset import prepare  # noqa: E402
from hpctl.identify.derived import derived  # noqa: E402
from hpctl.identify.fit import fit  # noqa: E402
from hpctl.identify.profile import profile_interval  # noqa: E402

NAME = "friction_breakaway_n"


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("seeds", type=int, nargs="+")
    ap.add_argument("--redraws", type=int, default=1, help="noise draws per seed: its own and redraws 1..N-1")
    ap.add_argument("--max-hz", type=float, default=0.1, help="the sweep's sines up to this frequency")
    a = ap.parse_args()
    linear_in = profile_in = runs = 0
    for seed in a.seeds:
        f = foreign_draw.draw_case("friction", seed).unit.effects.friction
        assert f is not None
        truth = f.coulomb_n * f.static_ratio
        for redraw in range(a.redraws):
            t0 = time.perf_counter()
            records, _ = foreign(seed, "friction", a.max_hz, [], redraw)
            r = fit(prepare(records), MODEL, flexible=True, max_nfev=MAX_NFEV_FLEXIBLE)
            b = next(x for x in derived(r) if x.name == NAME)
            t1 = time.perf_counter()
            iv = profile_interval(r, NAME)
            runs += 1
            linear = abs(b.value - truth) <= 2.0 * b.stderr
            linear_in += linear
            profile_in += iv.covers(truth)
            print(f"seed {seed} redraw {redraw}: truth {truth:.1f} N; linear {b.value:.1f} +- {b.stderr:.3g} (z {(b.value - truth) / b.stderr:+.2f}, "
                  f"{'holds it' if linear else 'misses'}); profile {iv.describe()} ({'holds it' if iv.covers(truth) else 'misses'}); "
                  f"fit {t1 - t0:.0f} s, profile {time.perf_counter() - t1:.0f} s", flush=True)
    print(f"{runs} fits: the truth inside estimate +- 2 errors {linear_in}, inside the profile interval {profile_in}")


if __name__ == "__main__":
    main()

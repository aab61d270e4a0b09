"""``python -m tests.foreign_rig --effect friction --seed 3 --out DIR``"""

from __future__ import annotations

import argparse
import json
import secrets
import sys

from .draw import EFFECTS
from .programs import PROGRAMS, extra_tests
from .records import generate


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="python -m tests.foreign_rig", description=__doc__)
    ap.add_argument("--effect", default="none", help=f"none or one of: {', '.join(EFFECTS)}")
    ap.add_argument("--seed", type=int, default=None, help="seed of the draw (random if omitted; printed)")
    ap.add_argument("--out", default=None, help="output folder (new or empty); default: the cache")
    ap.add_argument("--program", default="effect", help=f"effect (the sweep plus what the effect needs) or one of: {', '.join(PROGRAMS)}")
    ap.add_argument("--extra", default="", help=f"comma-separated extra tests: {', '.join(extra_tests())}")
    ap.add_argument("--quiet-sensors", action="store_true", help="no noise, quantisation or jitter")
    ap.add_argument("--exact-gauge", action="store_true", help="declare the true static pressure (no gauge error)")
    a = ap.parse_args(argv)
    seed = a.seed if a.seed is not None else secrets.randbelow(2**31)
    effect = None if a.effect in ("none", "") else a.effect
    if effect is not None and effect not in EFFECTS:
        print(f"--effect {a.effect!r}: expected none or one of {', '.join(EFFECTS)}", file=sys.stderr)
        return 2
    print(f"foreign rig: effect={a.effect} seed={seed}", flush=True)
    try:
        g = generate(effect, seed, out=a.out, program=a.program, extra=tuple(x for x in a.extra.split(",") if x), noise=not a.quiet_sensors,
                     gauge_error=not a.exact_gauge)
    except (ValueError, FileExistsError) as e:
        print(f"error: {e}", file=sys.stderr)
        return 2
    t = g.truth
    print(f"wrote {len(g.records)} records to {g.folder} in {t['generation_s']} s")
    print("truth (hpctl names):", json.dumps(t["hpctl_params"]))
    if t["foreign_params"]:
        print("truth (foreign only):", json.dumps(t["foreign_params"], default=str))
    print("noise sigma: " + ", ".join(f"{k} {v['sigma']:.3g}" for k, v in t["noise"].items() if isinstance(v, dict)))
    return 0


if __name__ == "__main__":
    sys.exit(main())

"""The flexible diagnosis of one foreign-rig effect on the short sweep (three
of the five sines) plus the records the effect needs, per seed: what was
found, the residual over hpctl's noise and over the noise the rig drew, and
each parameter with a truth against it (docs/foreign-rig.md, stop 36).

    python scripts/foreign_effect_diagnosis.py --effects valve_lag,sensor_lag --seeds 11 12

Run from the repository root (``tests/`` holds the foreign rig). One JSON
line per case: params map a name to [estimate, truth, relative error, z].
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent.parent / "tests"))

from foreign_rig import EFFECT_TESTS, extra_tests, generate, sweep_tests  # noqa: E402
from hpctl.data.records import read_record  # noqa: E402
from hpctl.identify.diagnose import diagnose  # noqa: E402
from test_diagnose_foreign import SHORT, true_noise_ratio  # noqa: E402


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--effects", default="valve_lag", help="comma-separated foreign-rig effects")
    ap.add_argument("--seeds", type=int, nargs="+", default=[11])
    a = ap.parse_args()
    more = extra_tests()
    for seed in a.seeds:
        for effect in a.effects.split(","):
            tests = [t for t in sweep_tests() if t.name in SHORT] + [t for k in EFFECT_TESTS.get(effect, ()) for t in more[k]]
            g = generate(effect, seed, tests=tests)
            t0 = time.time()
            d = diagnose([read_record(p) for p in g.records], ("heat_transfer", "real_gas"), flexible=True)
            j = d.judgement
            params = {}
            for k, v in g.truth["hpctl_params"].items():
                if k in d.final.values:
                    est, err = d.final.values[k], d.final.stderr.get(k, float("nan"))
                    params[k] = [est, v, est / v - 1 if v else None, (est - v) / err if err else None]
            print(json.dumps({"effect": effect, "seed": seed, "time_s": round(time.time() - t0, 1), "found": d.found, "verdict": d.verdict,
                              "rms": d.final.rms_ratio, "worst": j.worst_rms_ratio if j else None,
                              "true_ratio": true_noise_ratio(d, g.truth), "params": params}), flush=True)


if __name__ == "__main__":
    main()

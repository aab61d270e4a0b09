"""The flexible diagnosis of one foreign-rig effect on the short sweep (three
of the five sines) plus the records the effect needs, per seed: what was
found, the residual over hpctl's noise and over the noise the rig drew, and
each parameter with a truth against it (docs/foreign-rig.md, stops 36-37).

    python scripts/foreign_effect_diagnosis.py --effects valve_lag,sensor_lag --seeds 11 12

With ``--fit``, the flexible fit of the model with the effect declared
instead of a diagnosis (its time, residual sum of squares, the effect's
shape parameters), on the short records or, with ``--records full``, on
the effect's whole case as tests/test_flexible_fit.py generates it (the
five sines and the effect's records); ``--jacobian broyden`` for Broyden's updates:

    python scripts/foreign_effect_diagnosis.py --fit --records full --effects leakage --seeds 11 12
    python scripts/foreign_effect_diagnosis.py --fit --max-nfev 200 --jacobian broyden --effects heat_buildup --seeds 7

Run from the repository root (``tests/`` holds the foreign rig). One JSON
line per case: params map a name to [estimate, truth, relative error, z].
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path
from typing import Any

sys.path.insert(0, str(Path(__file__).resolve().parent.parent / "tests"))

from foreign_rig import generate  # noqa: E402
from hpctl.data.records import read_record  # noqa: E402
from hpctl.identify.dataset import prepare  # noqa: E402
from hpctl.identify.diagnose import diagnose  # noqa: E402
from hpctl.identify.fit import FitResult, fit  # noqa: E402
from hpctl.model.effects import FRICTION_SHAPE, LEAKAGE_SHAPE, WALL_SHAPE  # noqa: E402
from test_diagnose_foreign import effect_case, true_noise_ratio  # noqa: E402

DECLARED = ("heat_transfer", "real_gas")
#: The shape parameters an effect brings to the flexible model, reported by --fit.
SHAPES = {p.name for p in (*FRICTION_SHAPE, *LEAKAGE_SHAPE, *WALL_SHAPE)}


def against_truth(result: FitResult, truth: dict[str, float]) -> dict[str, list[float | None]]:
    out: dict[str, list[float | None]] = {}
    for k, v in truth.items():
        if k in result.values:
            est, err = result.values[k], result.stderr.get(k, float("nan"))
            out[k] = [est, v, est / v - 1 if v else None, (est - v) / err if err else None]
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--effects", default="valve_lag", help="comma-separated foreign-rig effects")
    ap.add_argument("--seeds", type=int, nargs="+", default=[11])
    ap.add_argument("--fit", action="store_true", help="fit the model with the effect declared instead of diagnosing")
    ap.add_argument("--records", choices=("short", "full"), default="short", help="short: three sines; full: five (with --fit)")
    ap.add_argument("--jacobian", choices=("finite_difference", "broyden"), default="finite_difference", help="with --fit")
    ap.add_argument("--max-nfev", type=int, default=None, help="with --fit: the fit's evaluation budget")
    a = ap.parse_args()
    for seed in a.seeds:
        for effect in a.effects.split(","):
            g = effect_case(effect, seed) if a.records == "short" else generate(effect, seed)
            records = [read_record(p) for p in g.records]
            truth = g.truth["hpctl_params"]
            t0 = time.time()
            line: dict[str, Any] = {"effect": effect, "seed": seed}
            if a.fit:
                kw: dict[str, Any] = {} if a.max_nfev is None else {"max_nfev": a.max_nfev}
                r = fit(prepare(records), (*DECLARED, effect), flexible=True, jacobian=a.jacobian, **kw)
                line |= {"time_s": round(time.time() - t0, 1), "jacobian": a.jacobian, "rss": r.rss, "rms": r.rms_ratio,
                         "params": against_truth(r, truth),
                         "shape": {k: [r.values[k], r.stderr.get(k)] for k in r.values if k in SHAPES}}
            else:
                d = diagnose(records, DECLARED, flexible=True)
                j = d.judgement
                line |= {"time_s": round(time.time() - t0, 1), "found": d.found, "verdict": d.verdict, "rms": d.final.rms_ratio,
                         "worst": j.worst_rms_ratio if j else None, "true_ratio": true_noise_ratio(d, g.truth),
                         "params": against_truth(d.final, truth),
                         "place_step_max": d.final.place_step_max,
                         "message": d.final.message}
            print(json.dumps(line), flush=True)


if __name__ == "__main__":
    main()

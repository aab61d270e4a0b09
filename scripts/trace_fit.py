"""Every iteration of one fit: its residual sum of squares (in the noise's
units) and the three parameters it moved most, for seeing where a slow
fit spends its iterations (a poor start, or a crawl along a valley) and
whether its end depends on its start.

    python scripts/trace_fit.py out/bench-diagnose/<version>/campaign --model seed --flexible [--static-nfev 100]

``--static-nfev`` sets the flexible model's static damper fit's budget per
start (``hpctl.identify.damper_static.MAX_NFEV``), which moves the dynamic
fit's start a little: docs/foreign-rig.md ("The static damper fit reads the
SDOF steps") has the table this makes. The records are read as ``hpctl
fit`` reads them; nothing is written.
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path
from typing import Any

import numpy as np

import hpctl.identify.fit as fit_module
from hpctl.cli.calibrate import _records
from hpctl.identify import MAX_NFEV, MAX_NFEV_FLEXIBLE, damper_static
from hpctl.identify.dataset import prepare
from hpctl.model.effects import parse_model


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("records", type=Path, nargs="+", help="record files or folders, as for hpctl fit")
    ap.add_argument("--model", default="seed")
    ap.add_argument("--flexible", action="store_true")
    ap.add_argument("--static-nfev", type=int, default=None, help="the static damper fit's evaluations per start")
    args = ap.parse_args()
    if args.static_nfev is not None:
        damper_static.MAX_NFEV = args.static_nfev
    effects = parse_model(args.model)
    datasets = prepare(_records(tuple(args.records)))
    names = [p.name for p in fit_module.model_for(datasets, effects, flexible=args.flexible).params]
    trace: list[tuple[float, float, np.ndarray]] = []
    solver = getattr(fit_module, "least_squares")  # hpctl's trust region, as the fit imported it
    t0 = time.perf_counter()

    def traced(fun: Any, x0: Any, jac: Any, *args: Any, **kw: Any) -> Any:
        # The trust region asks for the Jacobian at each iterate it accepts
        # (and at the start), right after the residuals there, which the
        # fit has cached: asking for them again runs nothing.
        def jac_traced(x: np.ndarray) -> Any:
            r = fun(x)
            trace.append((time.perf_counter() - t0, float(r @ r), np.array(x)))
            return jac(x)
        return solver(fun, x0, jac_traced, *args, **kw)

    setattr(fit_module, "least_squares", traced)
    result = fit_module.fit(datasets, effects, flexible=args.flexible, max_nfev=MAX_NFEV_FLEXIBLE if args.flexible else MAX_NFEV)
    print(f"fit {time.perf_counter() - t0:.1f} s, RMS / noise {result.rms_ratio:.4f}: {result.message}")
    previous = None
    for k, (t, rss, x) in enumerate(trace):
        moved = ""
        if previous is not None and len(x) == len(previous):
            moved = ", ".join(f"{names[i]} {previous[i]:.3g} -> {x[i]:.3g}" for i in np.argsort(-np.abs(x - previous))[:3])
        print(f"{k:4d} {t:7.1f} s  RSS {rss:14.1f}  {moved}")
        previous = x


if __name__ == "__main__":
    main()

"""Seal friction from the sweep's slow sines alone (what a friction
measurement runs): the foreign rig's friction draw with only its sines up
to ``--max-hz`` (0.01-0.1 Hz by default: 3.8-38 mm/s, valve 5 open),
fitted by the flexible model with friction, the breakaway force against
the truth's (docs/foreign-rig.md, "Slow sines alone", stop 67).

    python scripts/foreign_slow_sines.py 1 2 3 4 5 8 10 14
    python scripts/foreign_slow_sines.py 3 --hold-damper [--quiet force] [--friction-at-truth]
    python scripts/foreign_slow_sines.py 3 14 --hp-core

``--hold-damper`` keeps the damper at the template's (as the fit did below
50 mm/s before stop 67); ``--quiet CHANNEL`` switches that part of the
foreign data system off (force, disp, pressure, temperature, jitter);
``--friction-at-truth`` holds the friction at the draw's true values (the
rest fitted), ``--start-at-truth`` starts it there; ``--effect none`` runs
the draw's control (no friction); ``--wide-priors`` widens the
flexible model's damper and friction priors a hundredfold; ``--hp-core`` fits hp-core's own virtual
rig with the draw's friction and tau_s instead. Run from the repository
root (``tests/`` holds the foreign rig); a fit takes 1-5 s.
"""

from __future__ import annotations

import argparse
import sys
import tempfile
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent.parent / "tests"))
sys.path.insert(0, str(Path(__file__).resolve().parent))

import foreign_rig.draw as foreign_draw  # noqa: E402
import foreign_rig.records as foreign_records  # noqa: E402
from foreign_breakaway_redraws import MODEL, REDRAW_STRIDE, hp_core_records_of, quiet, widen_priors  # noqa: E402
from foreign_rig import generate  # noqa: E402
from foreign_rig.programs import sweep_tests  # noqa: E402
from hpctl.data.records import RigRecord, read_record  # noqa: E402
from hpctl.identify import MAX_NFEV_FLEXIBLE  # noqa: E402
from hpctl.identify.dataset import prepare, uses_damper  # noqa: E402
from hpctl.identify.derived import derived  # noqa: E402
from hpctl.identify.fit import fit  # noqa: E402


def hz(name: str) -> float:
    return float(name.split("_")[1].removesuffix("hz"))


def foreign(seed: int, effect: str | None, max_hz: float, channels: list[str], redraw: int) -> tuple[list[RigRecord], dict[str, Any]]:
    """The draw's slow sines (its noise drawn again for ``redraw`` > 0) and its truth."""
    tests = [t for t in sweep_tests() if hz(t.name) <= max_hz]
    draw_data_system, run_test = foreign_draw.draw_data_system, foreign_records.run_test
    foreign_draw.draw_data_system = lambda rng: quiet(draw_data_system(rng), channels)
    if redraw:
        foreign_records.run_test = lambda case, test: run_test(replace(case, seed=case.seed + REDRAW_STRIDE * redraw), test)
    try:
        with tempfile.TemporaryDirectory(prefix="hpctl-slow-") as tmp:
            g = generate(effect, seed, out=Path(tmp) / "case", tests=tests)
            records = [read_record(p) for p in g.records]
    finally:
        foreign_draw.draw_data_system, foreign_records.run_test = draw_data_system, run_test
    return records, g.truth


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("seeds", type=int, nargs="+")
    ap.add_argument("--max-hz", type=float, default=0.1, help="the sweep's sines up to this frequency")
    ap.add_argument("--quiet", action="append", default=[], metavar="CHANNEL")
    ap.add_argument("--hold-damper", action="store_true", help="the damper held at the template's")
    ap.add_argument("--friction-at-truth", action="store_true")
    ap.add_argument("--start-at-truth", action="store_true")
    ap.add_argument("--effect", default="friction", choices=("friction", "none"))
    ap.add_argument("--hp-core", action="store_true")
    ap.add_argument("--wide-priors", action="store_true", help="the damper's and friction's priors a hundredfold wider")
    ap.add_argument("--redraw", type=int, default=0, help="the noise drawn again (0: the draw's own)")
    a = ap.parse_args()
    if a.wide_priors:
        widen_priors(100.0)
    for seed in a.seeds:
        case = foreign_draw.draw_case("friction", seed)
        f = case.unit.effects.friction
        assert f is not None
        true_friction = {"friction_coulomb_n": f.coulomb_n, "friction_viscous_n_s_per_m": f.viscous_n_s_per_m,
                         "friction_stribeck_ratio": f.static_ratio, "friction_stribeck_velocity_m_s": f.stribeck_velocity_m_s,
                         "friction_smoothing_velocity_m_s": f.smoothing_velocity_m_s}
        if a.hp_core:
            records, _ = hp_core_records_of(seed, a.redraw)
            records = [r for r in records if r.name.startswith("sine") and hz(r.name) <= a.max_hz]
        else:
            records, _ = foreign(seed, None if a.effect == "none" else a.effect, a.max_hz, a.quiet, a.redraw)
            if a.effect == "none":
                true_friction = dict.fromkeys(true_friction, 0.0)
        datasets = prepare(records)
        kw: dict[str, Any] = {"fit_damper": False} if a.hold_damper else {}
        if a.friction_at_truth:
            kw["fixed"] = {k: v for k, v in true_friction.items() if v > 0.0}
        elif a.start_at_truth:
            kw["initial"] = true_friction
        r = fit(datasets, MODEL, flexible=True, max_nfev=MAX_NFEV_FLEXIBLE, **kw)
        v = r.values
        line = (f"seed {seed} ({', '.join(d.name for d in datasets)}): damper {'fitted' if r.model.fit_damper else 'held'} "
                f"(the force shows it: {uses_damper(datasets)}), RMS / noise {r.rms_ratio:.3f}")
        for d, sim in zip(r.datasets, r.sims):
            if "force_n" in d.targets and not isinstance(sim, Exception):
                line += f"; {d.name} force residual {float(np.sqrt(np.mean((sim['force_n'] - d.targets['force_n']) ** 2))):.3g} N RMS"
        print(line)
        breakaway = next((x for x in derived(r) if x.name == "friction_breakaway_n"), None)
        truth = true_friction["friction_coulomb_n"] * (true_friction["friction_stribeck_ratio"] or 1.0)
        if breakaway is not None and truth > 0.0:
            print(f"  breakaway {breakaway.value:.1f} +- {breakaway.stderr:.3g} N, truth {truth:.1f} ({breakaway.value / truth - 1.0:+.1%}, "
                  f"z {(breakaway.value - truth) / breakaway.stderr:+.2f})")
        print("  " + ", ".join(f"{k} {v[k]:.4g} (truth {true_friction[k]:.4g})" for k in true_friction if k in v)
              + f"; tau_s {v.get('tau_s', float('nan')):.4g}")


if __name__ == "__main__":
    main()

"""The breakaway friction force's sampling distribution on one foreign
draw: the same unit, friction and data system, the noise (and the clock's
jitter) drawn again ``--redraws`` times, each five-sine sweep fitted by
the flexible model with friction; per redraw the breakaway force ``F_c r``
(hpctl.identify.derived) against the truth's, and the mean and spread of
its error against the errors the fits state (docs/foreign-rig.md, stop 66).

    python scripts/foreign_breakaway_redraws.py --seed 3 --redraws 12
    python scripts/foreign_breakaway_redraws.py --seed 3 --redraws 6 --quiet force
    python scripts/foreign_breakaway_redraws.py --seed 3 --redraws 6 --wide-priors
    python scripts/foreign_breakaway_redraws.py --seed 10 --redraws 10 --hp-core

``--quiet CHANNEL`` (force, disp, pressure, temperature, jitter; repeatable)
switches that part of the data system off; ``--wide-priors`` widens the
flexible model's damper and friction priors a hundredfold; ``--hp-core``
fits records of hp-core's own virtual rig instead (the seed's unit and
damper, the draw's friction and tau_s, its force noise as white noise):
the same estimator on data its model wrote. Run from the repository root
(``tests/`` holds the foreign rig); a fit takes 3-10 s.
"""

from __future__ import annotations

import argparse
import statistics
import sys
import tempfile
from dataclasses import replace
from pathlib import Path
from typing import Any

sys.path.insert(0, str(Path(__file__).resolve().parent.parent / "tests"))

import foreign_rig.draw as foreign_draw  # noqa: E402
import foreign_rig.records as foreign_records  # noqa: E402
from foreign_rig import generate  # noqa: E402
from foreign_rig.sensors import ChannelNoise, DataSystem  # noqa: E402
from hpctl.data.records import RigRecord, read_record  # noqa: E402
from hpctl.identify import virtual_rig  # noqa: E402
from hpctl.identify.dataset import prepare  # noqa: E402
from hpctl.identify.derived import derived  # noqa: E402
from hpctl.identify.fit import fit  # noqa: E402
from hpctl.model import effects  # noqa: E402

MODEL = ("heat_transfer", "real_gas", "friction")
#: A redraw's noise seed: the draw's own, shifted (the foreign rig seeds a
#: record's noise by its case's seed and the test's name).
REDRAW_STRIDE = 1_000_003


def quiet(ds: DataSystem, channels: list[str]) -> DataSystem:
    none = ChannelNoise()
    out = replace(ds, **{c: none for c in channels if c != "jitter"})
    return replace(out, jitter_s=0.0) if "jitter" in channels else out


def foreign_records_of(seed: int, redraw: int, channels: list[str]) -> tuple[list[RigRecord], float]:
    """One redraw's records and the truth's breakaway force."""
    draw_data_system, run_test = foreign_draw.draw_data_system, foreign_records.run_test
    foreign_draw.draw_data_system = lambda rng: quiet(draw_data_system(rng), channels)
    foreign_records.run_test = lambda case, test: run_test(replace(case, seed=case.seed + REDRAW_STRIDE * (redraw + 1)), test)
    try:
        with tempfile.TemporaryDirectory(prefix="hpctl-redraw-") as tmp:
            g = generate("friction", seed, out=Path(tmp) / "case")
            records = [read_record(p) for p in g.records]
    finally:
        foreign_draw.draw_data_system, foreign_records.run_test = draw_data_system, run_test
    t: dict[str, Any] = g.truth
    return records, t["hpctl_params"]["friction_coulomb_n"] * t["foreign_params"]["friction_static_ratio"]


def hp_core_records_of(seed: int, redraw: int) -> tuple[list[RigRecord], float]:
    """hp-core's virtual rig with the foreign draw's friction and tau_s."""
    case = foreign_draw.draw_case("friction", seed)
    f = case.unit.effects.friction
    assert f is not None
    truth = {"tau_s": case.unit.tau_s, "friction_coulomb_n": f.coulomb_n, "friction_viscous_n_s_per_m": f.viscous_n_s_per_m,
             "friction_stribeck_ratio": f.static_ratio, "friction_stribeck_velocity_m_s": f.stribeck_velocity_m_s,
             "friction_smoothing_velocity_m_s": f.smoothing_velocity_m_s}
    unit = virtual_rig.truth_unit(("friction",), truth)
    noise = virtual_rig.Noise(force_n=case.data_system.force.sigma)
    return virtual_rig.make_records(unit, "sweep", noise=noise, seed=REDRAW_STRIDE * (redraw + 1)), f.coulomb_n * f.static_ratio


def widen_priors(factor: float) -> None:
    for params in (effects.FRICTION_SHAPE, *effects.DAMPER_SHAPE.values()):
        for p in params:
            if p.prior_sigma is not None:
                object.__setattr__(p, "prior_sigma", p.prior_sigma * factor)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--seed", type=int, default=3, help="the foreign rig's friction draw")
    ap.add_argument("--redraws", type=int, default=12)
    ap.add_argument("--quiet", action="append", default=[], choices=("force", "disp", "pressure", "temperature", "jitter"))
    ap.add_argument("--wide-priors", action="store_true")
    ap.add_argument("--hp-core", action="store_true", help="hp-core's virtual rig with the draw's friction instead")
    a = ap.parse_args()
    if a.wide_priors:
        widen_priors(100.0)
    errors, stated = [], []
    for j in range(a.redraws):
        records, truth = hp_core_records_of(a.seed, j) if a.hp_core else foreign_records_of(a.seed, j, a.quiet)
        r = fit(prepare(records), MODEL, flexible=True, max_nfev=300)
        d = next(x for x in derived(r) if x.name == "friction_breakaway_n")
        v = r.values
        errors.append(d.value - truth)
        stated.append(d.stderr)
        print(f"redraw {j}: RMS/noise {r.rms_ratio:.3f}, breakaway {d.value:.1f} +- {d.stderr:.1f} N against {truth:.1f} "
              f"({d.value - truth:+.1f}, z {(d.value - truth) / d.stderr:+.2f}); Coulomb {v['friction_coulomb_n']:.0f} N, "
              f"ratio {v['friction_stribeck_ratio']:.3f}, Stribeck {v['friction_stribeck_velocity_m_s'] * 1e3:.1f} mm/s, "
              f"smoothing {v['friction_smoothing_velocity_m_s'] * 1e3:.2f} mm/s", flush=True)
    if len(errors) > 1:
        print(f"seed {a.seed}: error mean {statistics.mean(errors):+.1f} N, spread {statistics.stdev(errors):.1f} N, "
              f"stated errors {min(stated):.1f}-{max(stated):.1f} N (median {statistics.median(stated):.1f})")


if __name__ == "__main__":
    main()

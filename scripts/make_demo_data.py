"""Writes the bundled demonstration records (python/hpctl/data/demo/) used
by `hpctl demo`: the virtual rig's sine sweep on a unit with real gas, heat
transfer and seal friction, with noise on every channel.

    python scripts/make_demo_data.py
"""

from __future__ import annotations

from pathlib import Path

from hpctl.data.records import write_record
from hpctl.identify import virtual_rig

OUT = Path(__file__).resolve().parents[1] / "python" / "hpctl" / "data" / "demo"
EFFECTS = ("friction",)


def main() -> None:
    values = virtual_rig.effect_values(EFFECTS, overrides={"friction_coulomb_n": 350.0, "friction_viscous_n_s_per_m": 250.0})
    unit = virtual_rig.truth_unit(EFFECTS, values)
    OUT.mkdir(parents=True, exist_ok=True)
    for old in OUT.glob("*"):
        old.unlink()
    for rec in virtual_rig.make_records(unit, tests=virtual_rig.tests_for(EFFECTS), seed=2026):
        rec.description = "demonstration record (hpctl virtual rig)"
        write_record(rec, OUT / rec.name)
        print("wrote", rec.name)


if __name__ == "__main__":
    main()

"""A foreign rig: a second virtual test rig that shares no code with hp-core
or hpctl's simulation, to test the model on data it did not write.

Python with SciPy's stiff solvers and CoolProp's reference nitrogen; its own
damper (orifices, spring-loaded blow-off washers, a soft bypass pack,
cavitation), valve 6 orifice, seal friction with a Stribeck term, oil
compliance, a lumped thermal network, seal permeation, valve lag and a data
system with offsets, lags, white and coloured noise, quantisation and
sample-time jitter. It writes rig records in the documented format with its
own writer, and truth.json beside them. See docs/foreign-rig.md.

    from foreign_rig import generate          # from tests/ (pytest)
    g = generate("friction", seed=3)          # cached by (effect, seed, tests)
    g.records, g.truth["hpctl_params"]

    python -m tests.foreign_rig --effect friction --seed 3 --out DIR
"""

from .draw import EFFECTS, LIBRARY_EFFECTS, OUTSIDE_EFFECTS, Case, draw_case
from .programs import EFFECT_TESTS, PROGRAMS, Test, extra_tests, sweep_tests, tests_for
from .records import Generated, generate, run_test, write_record

__all__ = [
    "EFFECTS", "EFFECT_TESTS", "LIBRARY_EFFECTS", "OUTSIDE_EFFECTS", "PROGRAMS", "Case", "Generated", "Test", "draw_case",
    "extra_tests", "generate", "run_test", "sweep_tests", "tests_for", "write_record",
]

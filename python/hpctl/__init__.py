"""hpctl: simulation, calibration and control of a semi-active
hydro-pneumatic spring-damper unit.

The physics and the controller are in Rust (``hpctl._core``); this package
is the Python API and the ``hpctl`` command line.
"""

from hpctl._version import __version__
from hpctl.errors import (
    ConvergenceError,
    HpctlError,
    InternalError,
    ParameterError,
    RecordError,
    SimulationError,
)
from hpctl.model.unit import SEED_SPRUNG_MASS_KG, Damper, DamperCurve, Effects, Unit
from hpctl.sim.run import (
    Hold,
    Result,
    Sampled,
    Sine,
    Step,
    Steps,
    run,
    run_characterisation,
    run_many,
    run_sdof,
)

__all__ = [
    "__version__",
    "SEED_SPRUNG_MASS_KG",
    "ConvergenceError",
    "Damper",
    "DamperCurve",
    "Effects",
    "Hold",
    "HpctlError",
    "InternalError",
    "ParameterError",
    "RecordError",
    "Result",
    "Sampled",
    "SimulationError",
    "Sine",
    "Step",
    "Steps",
    "Unit",
    "run",
    "run_characterisation",
    "run_many",
    "run_sdof",
]

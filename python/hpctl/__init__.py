"""hpctl: simulation, calibration and control of a semi-active
hydro-pneumatic spring-damper unit.

The physics and the controller are in Rust (``hpctl._core``); this package
is the Python API and the ``hpctl`` command line.
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING, Any

from hpctl._version import __version__

# The public names are loaded on first use (PEP 562), not with the package:
# ``import hpctl.cli`` for ``hpctl --help`` must not pay for the simulation
# API it may never call (start-up goal 0.5 s, scripts/bench_startup.py).
# Where each name lives is written once, here; ``__all__`` is derived.
_LAZY: dict[str, str] = {
    "ConvergenceError": "hpctl.errors",
    "HpctlError": "hpctl.errors",
    "InternalError": "hpctl.errors",
    "ParameterError": "hpctl.errors",
    "RecordError": "hpctl.errors",
    "SimulationError": "hpctl.errors",
    "SEED_SPRUNG_MASS_KG": "hpctl.model.unit",
    "Damper": "hpctl.model.unit",
    "DamperCurve": "hpctl.model.unit",
    "Effects": "hpctl.model.unit",
    "Unit": "hpctl.model.unit",
    "Hold": "hpctl.sim.run",
    "Result": "hpctl.sim.run",
    "Sampled": "hpctl.sim.run",
    "Sine": "hpctl.sim.run",
    "Step": "hpctl.sim.run",
    "Steps": "hpctl.sim.run",
    "run": "hpctl.sim.run",
    "run_characterisation": "hpctl.sim.run",
    "run_many": "hpctl.sim.run",
    "run_sdof": "hpctl.sim.run",
}

__all__ = ["__version__", *sorted(_LAZY)]

if TYPE_CHECKING:  # what a type checker and an IDE see (explicit re-exports: mypy --strict); same names as _LAZY
    from hpctl.errors import (
        ConvergenceError as ConvergenceError,
        HpctlError as HpctlError,
        InternalError as InternalError,
        ParameterError as ParameterError,
        RecordError as RecordError,
        SimulationError as SimulationError,
    )
    from hpctl.model.unit import (
        SEED_SPRUNG_MASS_KG as SEED_SPRUNG_MASS_KG,
        Damper as Damper,
        DamperCurve as DamperCurve,
        Effects as Effects,
        Unit as Unit,
    )
    from hpctl.sim.run import (
        Hold as Hold,
        Result as Result,
        Sampled as Sampled,
        Sine as Sine,
        Step as Step,
        Steps as Steps,
        run as run,
        run_characterisation as run_characterisation,
        run_many as run_many,
        run_sdof as run_sdof,
    )


def __getattr__(name: str) -> Any:
    module = _LAZY.get(name)
    if module is None:
        raise AttributeError(f"module 'hpctl' has no attribute {name!r}")
    value = getattr(importlib.import_module(module), name)
    globals()[name] = value  # the next lookup is a plain attribute
    return value


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(_LAZY))

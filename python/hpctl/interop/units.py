"""Units: the SI unit of each record column, and foreign units converted
to it with pint (a unit pint does not know, or of the wrong kind, is
refused with a message saying which and what was expected)."""

from __future__ import annotations

from functools import lru_cache
from typing import Any

import numpy as np
from numpy.typing import NDArray

from hpctl.data.records import COLUMNS
from hpctl.errors import MappingError
from hpctl.interop._support import require

#: SI unit of a quantity named with its unit suffix (the project's naming
#: rule), longest suffix first; pint spelling.
SUFFIX_UNITS: tuple[tuple[str, str], ...] = (
    ("_m_s2", "m/s**2"),
    ("_rad_s", "rad/s"),
    ("_m3_s", "m**3/s"),
    ("_m_s", "m/s"),
    ("_m2", "m**2"),
    ("_m3", "m**3"),
    ("_kg", "kg"),
    ("_pa", "Pa"),
    ("_rad", "rad"),
    ("_hz", "Hz"),
    ("_k", "K"),
    ("_m", "m"),
    ("_n", "N"),
    ("_s", "s"),
    ("_w", "W"),
    ("_j", "J"),
)

#: Standard atmosphere, Pa: added to gauge pressures (``gauge = true``).
STANDARD_ATMOSPHERE_PA = 101_325.0


def si_unit(column: str) -> str | None:
    """The SI unit (pint spelling) of a record column or a suffixed name;
    ``""`` for the 0/1 flag columns, None when the name says no unit."""
    if column in COLUMNS and COLUMNS[column][0] == "0/1":
        return ""
    for suffix, unit in SUFFIX_UNITS:
        if column.endswith(suffix):
            return unit
    return None


@lru_cache(maxsize=1)
def _registry() -> Any:
    pint = require("pint", "unit conversion")
    return pint.UnitRegistry()


def _parse(ureg: Any, unit: str, where: str) -> Any:
    try:
        return ureg.Unit(unit)
    except Exception as e:  # pint raises UndefinedUnitError or a parser error
        raise MappingError(
            f"{where}: unit {unit!r} is not known ({type(e).__name__}); use a unit such as "
            "Pa, kPa, MPa, bar, psi, m, mm, cm, N, kN, K, degC, degF, s, ms, m/s, mm/s"
        ) from None


def to_si(values: NDArray[Any], unit: str | None, column: str, where: str) -> NDArray[np.float64]:
    """``values`` in ``unit`` converted to ``column``'s SI unit. An empty or
    missing unit is taken as already SI; flag columns take no unit."""
    target = si_unit(column)
    if target is None:
        raise MappingError(f"{where}: {column!r} has no unit suffix (e.g. _pa, _k, _m, _n, _s): hpctl cannot tell its SI unit")
    x = np.asarray(values, dtype=np.float64)
    if unit is None or unit.strip() in ("", "1", "-"):
        return x
    if target == "":
        raise MappingError(f"{where}: {column!r} is a 0/1 flag and takes no unit, got {unit!r}")
    ureg = _registry()
    source = _parse(ureg, unit, where)
    goal = ureg.Unit(target)
    if source.dimensionality != goal.dimensionality:
        raise MappingError(f"{where}: unit {unit!r} is {source.dimensionality}, but {column!r} needs {goal.dimensionality} ({target})")
    return np.asarray(ureg.Quantity(x, source).to(goal).magnitude, dtype=np.float64)

"""Nitrogen from CoolProp's reference equation of state (Span et al. 2000,
the Helmholtz formulation behind ``AbstractState("HEOS", "Nitrogen")``).

The Helmholtz energy is explicit in density and temperature, so every
property the gas spring needs (pressure, (dp/dT) at constant density,
c_v, internal energy) comes from one update without iteration. One
AbstractState per accumulator: an update costs a few tens of microseconds.
"""

from __future__ import annotations

from dataclasses import dataclass

import CoolProp.CoolProp as CP
from CoolProp.CoolProp import AbstractState

FLUID = "Nitrogen"


@dataclass(frozen=True)
class GasProps:
    p_pa: float
    dp_dt_pa_per_k: float  # (dp/dT) at constant density
    cv_j_per_kg_k: float


class Nitrogen:
    """One reusable property evaluator (not thread-safe: one per integration)."""

    def __init__(self) -> None:
        self._state = AbstractState("HEOS", FLUID)

    def props(self, rho_kg_m3: float, t_k: float) -> tuple[float, float, float]:
        """Pressure, (dp/dT)_rho and c_v at density ``rho_kg_m3`` and ``t_k``."""
        s = self._state
        s.update(CP.DmassT_INPUTS, rho_kg_m3, t_k)
        return s.p(), s.first_partial_deriv(CP.iP, CP.iT, CP.iDmass), s.cvmass()

    def pressure(self, rho_kg_m3: float, t_k: float) -> float:
        s = self._state
        s.update(CP.DmassT_INPUTS, rho_kg_m3, t_k)
        return s.p()

    def density(self, p_pa: float, t_k: float) -> float:
        s = self._state
        s.update(CP.PT_INPUTS, p_pa, t_k)
        return s.rhomass()

    def internal_energy(self, rho_kg_m3: float, t_k: float) -> float:
        """Specific internal energy, J/kg (CoolProp's reference state)."""
        s = self._state
        s.update(CP.DmassT_INPUTS, rho_kg_m3, t_k)
        return s.umass()

    def entropy(self, rho_kg_m3: float, t_k: float) -> float:
        s = self._state
        s.update(CP.DmassT_INPUTS, rho_kg_m3, t_k)
        return s.smass()

    def isentrope(self, rho_kg_m3: float, s_j_per_kg_k: float) -> tuple[float, float]:
        """Pressure and temperature at density and specific entropy."""
        s = self._state
        s.update(CP.DmassSmass_INPUTS, rho_kg_m3, s_j_per_kg_k)
        return s.p(), s.T()

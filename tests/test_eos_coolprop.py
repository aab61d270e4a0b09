"""The equations of state, through the bindings, against CoolProp's
reference nitrogen (Span et al. 2000) over 2-110 MPa and 233-473 K."""

from __future__ import annotations

import CoolProp.CoolProp as CP
import numpy as np
import pytest

from hpctl import _core

P_MPA = np.array([2, 5, 10, 20, 30, 50, 70, 90, 110], float)
T_K = np.array([233.15, 273.15, 313.15, 373.15, 473.15])


def reference(p_max_mpa: float) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    p, t = np.meshgrid(P_MPA[P_MPA <= p_max_mpa] * 1e6, T_K)
    p, t = p.ravel(), t.ravel()
    rho = np.array([CP.PropsSI("Dmass", "P", pi, "T", ti, "Nitrogen") for pi, ti in zip(p, t)])
    dpdt = np.array([CP.PropsSI("d(P)/d(T)|Dmass", "Dmass", r, "T", ti, "Nitrogen") for r, ti in zip(rho, t)])
    cv = np.array([CP.PropsSI("Cvmass", "Dmass", r, "T", ti, "Nitrogen") for r, ti in zip(rho, t)])
    return p, t, rho, dpdt, cv


@pytest.mark.parametrize(
    ("gas", "p_max_mpa", "max_p_error"),
    [("bwr-textbook", 30, 0.02), ("bwr-textbook", 110, 0.05), ("bwr-cg", 30, 0.01), ("ideal", 2, 0.025)],
)
def test_pressure_against_coolprop(gas: str, p_max_mpa: float, max_p_error: float) -> None:
    p, t, rho, _, _ = reference(p_max_mpa)
    props = _core.gas_props(gas, rho, t)
    err = np.abs(props["p_pa"] / p - 1)
    assert err.max() < max_p_error


@pytest.mark.parametrize("gas", ["bwr-textbook", "bwr-cg"])
def test_dp_dt_and_cv_against_coolprop_up_to_30_mpa(gas: str) -> None:
    _, t, rho, dpdt, cv = reference(30)
    props = _core.gas_props(gas, rho, t)
    assert np.abs(props["dp_dt_pa_per_k"] / dpdt - 1).max() < 0.03
    assert np.abs(props["cv_j_per_kg_k"] / cv - 1).max() < 0.03


def test_ideal_gas_is_badly_wrong_at_110_mpa() -> None:
    p, t, rho, _, _ = reference(110)
    props = _core.gas_props("ideal", rho, t)
    assert np.abs(props["p_pa"] / p - 1).max() > 0.3


def test_density_solve_matches_coolprop_within_the_eos_error() -> None:
    for p in (2e6, 15e6, 60e6):
        for t in (253.15, 353.15):
            rho_ref = CP.PropsSI("Dmass", "P", p, "T", t, "Nitrogen")
            rho = _core.gas_density_kg_m3("bwr-textbook", p, t)
            assert abs(rho / rho_ref - 1) < 0.03

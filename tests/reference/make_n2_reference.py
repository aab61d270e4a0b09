"""Generate CoolProp reference data for nitrogen, used by hp-core's tests.

CoolProp's nitrogen is the Span et al. (2000) reference equation of state.
It is a test-only dependency: the Rust tests read the CSV files this script
writes (committed under crates/hp-core/tests/data/), and the Python tests
query CoolProp directly.

    python tests/reference/make_n2_reference.py
"""

from __future__ import annotations

import csv
from pathlib import Path

import CoolProp
import CoolProp.CoolProp as CP

OUT = Path(__file__).resolve().parents[2] / "crates" / "hp-core" / "tests" / "data"
FLUID = "Nitrogen"

# The operating envelope of the seed: 2-110 MPa, 233-473 K.
PRESSURES_MPA = [2, 5, 10, 15, 20, 30, 40, 50, 60, 70, 80, 90, 100, 110]
TEMPERATURES_K = [233.15, 253.15, 273.15, 293.15, 313.15, 353.15, 393.15, 433.15, 473.15]


def grid() -> None:
    rows = []
    for p_mpa in PRESSURES_MPA:
        for t_k in TEMPERATURES_K:
            p = p_mpa * 1e6
            rho = CP.PropsSI("Dmass", "P", p, "T", t_k, FLUID)
            rows.append(
                {
                    "p_pa": p,
                    "t_k": t_k,
                    "rho_kg_m3": rho,
                    "dp_dt_pa_per_k": CP.PropsSI("d(P)/d(T)|Dmass", "Dmass", rho, "T", t_k, FLUID),
                    "dp_drho_pa_m3_per_kg": CP.PropsSI("d(P)/d(Dmass)|T", "Dmass", rho, "T", t_k, FLUID),
                    "cv_j_per_kg_k": CP.PropsSI("Cvmass", "Dmass", rho, "T", t_k, FLUID),
                    "cp0_j_per_mol_k": CP.PropsSI("Cp0molar", "Dmass", rho, "T", t_k, FLUID),
                    "s_j_per_kg_k": CP.PropsSI("Smass", "Dmass", rho, "T", t_k, FLUID),
                    "speed_of_sound_m_s": CP.PropsSI("A", "Dmass", rho, "T", t_k, FLUID),
                }
            )
    write("n2_grid.csv", rows)


def isentropes() -> None:
    """Points along isentropes: compress from a start state to higher densities."""
    starts = [(101_325.0 + 3000.0 * 9.80665 / 2.0e-3, 293.15), (5.0e6, 253.15), (2.0e6, 293.15), (30.0e6, 353.15)]
    rows = []
    for case, (p0, t0) in enumerate(starts):
        rho0 = CP.PropsSI("Dmass", "P", p0, "T", t0, FLUID)
        s0 = CP.PropsSI("Smass", "P", p0, "T", t0, FLUID)
        for ratio in [1.0, 1.25, 1.5, 2.0, 2.5, 3.0]:
            rho = rho0 * ratio
            t = CP.PropsSI("T", "Dmass", rho, "Smass", s0, FLUID)
            p = CP.PropsSI("P", "Dmass", rho, "Smass", s0, FLUID)
            if p > 120e6:
                continue
            rows.append(
                {
                    "case": case,
                    "rho_kg_m3": rho,
                    "t_k": t,
                    "p_pa": p,
                    "s_j_per_kg_k": s0,
                    "dp_dt_pa_per_k": CP.PropsSI("d(P)/d(T)|Dmass", "Dmass", rho, "T", t, FLUID),
                    "cv_j_per_kg_k": CP.PropsSI("Cvmass", "Dmass", rho, "T", t, FLUID),
                }
            )
    write("n2_isentropes.csv", rows)


def write(name: str, rows: list[dict[str, float]]) -> None:
    OUT.mkdir(parents=True, exist_ok=True)
    path = OUT / name
    with path.open("w", newline="") as f:
        f.write(f"# CoolProp {CoolProp.__version__} {FLUID} (Span et al. 2000), written by tests/reference/make_n2_reference.py\n")
        w = csv.DictWriter(f, fieldnames=list(rows[0]))
        w.writeheader()
        for r in rows:
            w.writerow({k: repr(float(v)) for k, v in r.items()})
    print(f"wrote {path} ({len(rows)} rows)")


def static_states() -> None:
    """Speed of sound at the static states used by the natural-frequency tests."""
    rows = []
    # The built-in unit's static charge: p = p_atm + m g / A (3000 kg, 2.0e-3 m^2).
    seed_static_pa = 101_325.0 + 3000.0 * 9.80665 / 2.0e-3
    for p, t in [(seed_static_pa, 293.15), (5.0e6, 293.15), (30.0e6, 293.15)]:
        rho = CP.PropsSI("Dmass", "P", p, "T", t, FLUID)
        rows.append({"p_pa": p, "t_k": t, "rho_kg_m3": rho, "speed_of_sound_m_s": CP.PropsSI("A", "P", p, "T", t, FLUID)})
    write("n2_static.csv", rows)


# The reference model's golden states: a dense grid over the envelope, and
# states beyond it up to the limits the code accepts (1 kPa - 300 MPa,
# 60 - 1000 K; CoolProp, and the formulation, start at the triple point,
# 63.151 K). Region 0 = envelope, 1 = beyond.
DENSE_PRESSURES_MPA = [2, 3, 4, 5, 6, 8, 10, 12, 15] + list(range(20, 111, 5))
DENSE_TEMPERATURES_K = [233.15 + 10.0 * k for k in range(25)]
BEYOND_PRESSURES_MPA = [0.001, 0.01, 0.1, 0.5, 1, 2, 5, 10, 30, 60, 110, 150, 200, 250, 300]
BEYOND_TEMPERATURES_K = [64.0, 80.0, 100.0, 120.0, 126.2, 140.0, 160.0, 200.0, 233.15, 473.15, 500.0, 600.0, 700.0, 800.0, 1000.0]


def span_golden() -> None:
    """Properties at fixed (p, T) states, to all digits: the golden values
    the reference model (`--gas span`) is held to."""
    state = CoolProp.AbstractState("HEOS", FLUID)
    rows = []

    def add(region: int, p: float, t: float) -> None:
        try:
            state.update(CoolProp.PT_INPUTS, p, t)
        except ValueError as e:  # solid nitrogen: outside every model
            print(f"skipped {p:g} Pa, {t:g} K: {e}")
            return
        # The derivatives at exactly this density: after a (p, T) update
        # CoolProp reports some from its solver's last iterate (1e-9 off).
        rho = state.rhomass()
        state.update(CoolProp.DmassT_INPUTS, rho, t)
        rows.append(
            {
                "region": region,
                "p_pa": p,
                "t_k": t,
                "rho_kg_m3": rho,
                "dp_dt_pa_per_k": state.first_partial_deriv(CoolProp.iP, CoolProp.iT, CoolProp.iDmass),
                "dp_drho_pa_m3_per_kg": state.first_partial_deriv(CoolProp.iP, CoolProp.iDmass, CoolProp.iT),
                "cv_j_per_kg_k": state.cvmass(),
            }
        )

    for p_mpa in DENSE_PRESSURES_MPA:
        for t_k in DENSE_TEMPERATURES_K:
            add(0, p_mpa * 1e6, t_k)
    for p_mpa in BEYOND_PRESSURES_MPA:
        for t_k in BEYOND_TEMPERATURES_K:
            inside = 2 <= p_mpa <= 110 and 233.15 <= t_k <= 473.15
            if not inside:
                add(1, p_mpa * 1e6, t_k)
    write("n2_span_golden.csv", rows)


if __name__ == "__main__":
    grid()
    isentropes()
    static_states()
    span_golden()

"""The seed's SDOF step measurements as data (issue 12, item 5;
docs/seed-explained.md, numbers from scripts/seed_explained.py).

The seed measured about 1.5 Hz (hard) and about 1 Hz (soft) with 3000 kg
on a 43 mm base step, under-damped with the damper off and damped out
within one cycle with it on. These tests hold the built-in unit and the
candidate explanations to those statements: the built-in unit misses both
frequencies; valve-6 throttling reaches 1 Hz soft only with a valve that
drops several MPa; a strut-side oil/hose compliance soft enough for the
frequencies breaks the damper-on statement.
"""

from __future__ import annotations

from typing import Any

import pytest

from hpctl.model.effects import build_unit
from hpctl.model.unit import SEED_SPRUNG_MASS_KG, STANDARD_GRAVITY_M_S2, Unit
from hpctl.sim.experiments import sdof_step

SEED_HARD_HZ, SEED_SOFT_HZ = 1.5, 1.0
# docs/seed-explained.md: the solved values.
THROTTLED_VALVE6_AREA_M2 = 1.89e-6
COMPLIANT_PISTON_AREA_M2 = 3.29e-3
COMPLIANT_BULK_MODULUS_PA = 4.95e7


def responses(u: Unit) -> dict[str, dict[str, Any]]:
    out = {}
    for hard in (True, False):
        for on in (False, True):
            # Error-controlled steps (the default), as scripts/seed_explained.py.
            e = sdof_step(u, spring_hard=hard, damper_on=on)
            s = e.summary.to_dict()
            ch = e.result.channels
            s["valve6_peak_dp_pa"] = float(abs(ch["p_gas_true_pa"] - ch["p_gas2_true_pa"]).max())
            out[f"{'hard' if hard else 'soft'}_{'on' if on else 'off'}"] = s
    return out


def seed_statements_hold(s: dict[str, dict[str, Any]]) -> dict[str, bool]:
    """Under-damped with the damper off (overshoots), damped out within one
    cycle with it on (inside the 5 % band within one damper-off period)."""
    out = {}
    for spring in ("hard", "soft"):
        off, on = s[f"{spring}_off"], s[f"{spring}_on"]
        out[f"{spring} off under-damped"] = off["overshoot_m"] > 1e-3 and off["natural_frequency_hz"] is not None
        out[f"{spring} on within one cycle"] = on["settling_time_s"] <= 1.0 / off["natural_frequency_hz"]
    return out


def with_area(u: Unit, area_m2: float) -> Unit:
    a = u.replace(piston_area_m2=area_m2)
    return a.replace(static_pressure_pa=a.load_pressure_pa(SEED_SPRUNG_MASS_KG * STANDARD_GRAVITY_M_S2))


@pytest.fixture(scope="module")
def built_in() -> dict[str, dict[str, Any]]:
    return responses(Unit.seed())


def test_the_built_in_unit_cannot_give_both_frequencies(built_in: dict[str, dict[str, Any]]) -> None:
    fh, fs = built_in["hard_off"]["natural_frequency_hz"], built_in["soft_off"]["natural_frequency_hz"]
    # The gas volumes force a ratio near sqrt(1.0 / 0.3): the residual in
    # the seed's own measured data (hard +10 %, soft -12 %).
    assert fh / fs > 1.8
    assert fh / SEED_HARD_HZ - 1 == pytest.approx(0.10, abs=0.02)
    assert fs / SEED_SOFT_HZ - 1 == pytest.approx(-0.12, abs=0.02)
    assert all(seed_statements_hold(built_in).values()), seed_statements_hold(built_in)


def test_valve6_throttling_gives_1_hz_soft_only_through_megapascals(built_in: dict[str, dict[str, Any]]) -> None:
    s = responses(Unit.seed().replace(valve6_flow_area_m2=THROTTLED_VALVE6_AREA_M2))
    assert s["soft_off"]["natural_frequency_hz"] == pytest.approx(SEED_SOFT_HZ, rel=0.03)
    # The hard spring does not pass valve 6: unchanged, still 10 % high.
    assert s["hard_off"]["natural_frequency_hz"] == pytest.approx(built_in["hard_off"]["natural_frequency_hz"], rel=1e-6)
    assert all(seed_statements_hold(s).values()), seed_statements_hold(s)
    # ... at the price of a valve dropping half the static pressure during
    # the step (15 times the built-in valve's drop): a switching valve
    # that is really a damper.
    assert s["soft_off"]["valve6_peak_dp_pa"] > 10 * built_in["soft_off"]["valve6_peak_dp_pa"]
    assert s["soft_off"]["valve6_peak_dp_pa"] > 0.4 * Unit.seed().static_pressure_pa


def test_strut_side_compliance_for_both_frequencies_breaks_the_damper_statement(built_in: dict[str, dict[str, Any]]) -> None:
    u = build_unit(with_area(Unit.seed(), COMPLIANT_PISTON_AREA_M2), ("oil_compliance",), {"oil_bulk_modulus_pa": COMPLIANT_BULK_MODULUS_PA})
    s = responses(u)
    fh, fs = s["hard_off"]["natural_frequency_hz"], s["soft_off"]["natural_frequency_hz"]
    # The compliance in series brings the ratio down from 1.87 ...
    assert fh / fs < 0.75 * built_in["hard_off"]["natural_frequency_hz"] / built_in["soft_off"]["natural_frequency_hz"]
    # ... but with the damper on the body rings on the compliance (the
    # damper behind it is blocked): not damped out within one cycle.
    held = seed_statements_hold(s)
    assert not held["hard on within one cycle"] and not held["soft on within one cycle"], held

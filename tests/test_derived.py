"""Quantities derived from fitted parameters (hpctl.identify.derived): the
breakaway friction force F_c r with its error carried through the fit's
covariance, checked against draws from that covariance (NumPy's
multivariate normal, not the delta method), and the ``confounded`` check.

The foreign rig's test of the breakaway force itself is in
tests/test_diagnose_foreign.py."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from hpctl.identify.derived import CONFOUNDED_CORRELATION, derived
from hpctl.identify.fit import FitResult, Model
from hpctl.model.effects import DERIVED, LIBRARY

FC, RATIO = "friction_coulomb_n", "friction_stribeck_ratio"


def result(corr: float, covariance: bool = True, flexible: bool = True, branches: tuple[str, ...] = ()) -> FitResult:
    model = Model(("friction",), bool(branches), flexible, branches)
    names = [p.name for p in model.params]
    values = {p.name: p.typical for p in model.params} | ({FC: 400.0, RATIO: 1.3} if flexible else {FC: 400.0})
    sd = np.array([0.02 * abs(values[n]) + 1e-3 for n in names])
    sd[names.index(FC)] = 20.0
    if flexible:
        sd[names.index(RATIO)] = 0.05
    c = np.diag(sd**2)
    if flexible:
        i, j = names.index(FC), names.index(RATIO)
        c[i, j] = c[j, i] = corr * sd[i] * sd[j]
    return FitResult(model, values, {n: float(s) for n, s in zip(names, sd)}, 0.0, 1, [], [], [],
                     covariance=c if covariance else None)


@pytest.mark.parametrize("corr", [-0.9, 0.0, 0.6])
def test_breakaway_force_and_its_error_agree_with_draws_from_the_covariance(corr: float) -> None:
    r = result(corr)
    (d,) = derived(r)
    assert d.name == "friction_breakaway_n" and d.factors == (FC, RATIO)
    assert d.value == pytest.approx(400.0 * 1.3, rel=1e-12)
    assert d.factor_correlation == pytest.approx(corr, abs=1e-12) and d.confounded is (abs(corr) >= CONFOUNDED_CORRELATION)
    names = [p.name for p in r.model.params]
    idx = [names.index(FC), names.index(RATIO)]
    assert r.covariance is not None
    draws = np.random.default_rng(5).multivariate_normal([400.0, 1.3], r.covariance[np.ix_(idx, idx)], size=400_000)
    spread = float(np.std(draws[:, 0] * draws[:, 1]))
    # First order in errors of 5 % and 3.8 %: the product's second-order
    # term adds under 0.2 % of its variance; the draws' own error 0.1 %.
    assert d.stderr == pytest.approx(spread, rel=0.01)
    # Anticorrelated factors pin the product: its error falls below either factor's share.
    if corr < 0:
        assert d.stderr < 1.3 * 20.0


def test_no_covariance_no_error_and_no_derived_value_without_its_factors() -> None:
    (d,) = derived(result(-0.99, covariance=False))
    assert math.isnan(d.stderr) and math.isnan(d.factor_correlation) and not d.confounded
    doc = d.to_json()
    assert doc["stderr"] is None and doc["factor_correlation"] is None and doc["confounded"] is False and doc["reason"] == ""
    json.dumps(doc, allow_nan=False)
    # The fixed model has no Stribeck ratio: nothing derived.
    assert derived(result(0.0, flexible=False)) == []


def test_derived_quantities_are_products_of_registered_parameters() -> None:
    known = {p.name for e in LIBRARY.values() for p in e.params} | {RATIO}
    for d in DERIVED:
        assert len(d.factors) >= 2 and set(d.factors) <= known, d


def test_correlation_of_the_fit_result() -> None:
    r = result(-0.97)
    assert r.correlation(FC, RATIO) == pytest.approx(-0.97) and r.correlation(RATIO, FC) == pytest.approx(-0.97)
    assert r.correlation(FC, FC) == pytest.approx(1.0)
    assert math.isnan(r.correlation(FC, "no_such_parameter"))
    assert math.isnan(result(-0.97, covariance=False).correlation(FC, RATIO))


def test_with_the_damper_characteristic_identified_the_coulomb_force_is_always_confounded() -> None:
    # Without noise the model's damper family and friction fit the foreign
    # rig's true curves best with the Coulomb force 67 % low to 20 % high
    # (scripts/foreign_friction_split.py): whatever the covariance says.
    (d,) = derived(result(0.1, branches=("off_compression", "off_rebound")))
    assert d.damper_shape and d.confounded and "damper" in d.reason and "correlation" not in d.reason
    (d,) = derived(result(-0.99, branches=("off_compression", "off_rebound")))
    assert d.confounded and "correlation is -0.99" in d.reason and "damper" in d.reason
    assert d.to_json()["confounded"] is True
    (d,) = derived(result(0.1))
    assert not d.damper_shape and not d.confounded and d.reason == ""


def test_a_failed_stribeck_restart_keeps_the_first_fit(monkeypatch: pytest.MonkeyPatch) -> None:
    # The restart (hpctl.identify.fit.fit) is a second opinion: a restarted
    # fit that cannot be simulated never costs the first one.
    import hpctl.identify.fit as fit_module
    from hpctl.errors import SimulationError

    first = result(0.0, branches=("off_compression", "off_rebound"))
    first.values["friction_stribeck_velocity_m_s"] = 1.5e-3
    first.values["friction_smoothing_velocity_m_s"] = 1.4e-3
    calls: list[dict[str, float] | None] = []

    def fake(datasets: object, effects: object, **kw: object) -> FitResult:
        calls.append(kw["initial"])  # type: ignore[arg-type]
        if len(calls) > 1:
            raise SimulationError("record x: the model cannot be simulated on it")
        return first

    monkeypatch.setattr(fit_module, "_fit", fake)
    r = fit_module.fit([], ("friction",), flexible=True)
    assert r is first and len(calls) == 2 and calls[1] is not None
    assert calls[1]["friction_stribeck_velocity_m_s"] == fit_module.STRIBECK_RESTART["friction_stribeck_velocity_m_s"]
    assert "restart with the Stribeck peak above the smoothing velocity failed" in r.message and "first optimum kept" in r.message

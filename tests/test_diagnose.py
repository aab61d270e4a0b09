"""The diagnosis on virtual-rig data with randomised effects and noise.

Every run draws new parameter values and new noise (the seed is printed on
failure, and HPCTL_TEST_SEED replays it), so the thresholds cannot have
been tuned to one dataset.
"""

from __future__ import annotations

import math
import os
import secrets
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from hpctl.identify import virtual_rig
from hpctl.identify.diagnose import Diagnosis, diagnose, summary
from hpctl.model.effects import LIBRARY
from hpctl.model.unit import Unit

SEED_MODEL = ("heat_transfer", "real_gas")
CANDIDATES = [e for e in LIBRARY if e not in SEED_MODEL]


@pytest.fixture
def seed() -> int:
    return int(os.environ.get("HPCTL_TEST_SEED", secrets.randbelow(2**31)))


def rig_data(effects: list[str], rng: np.random.Generator) -> tuple[dict[str, float], list]:  # type: ignore[type-arg]
    values = virtual_rig.effect_values(effects, rng)
    tau = virtual_rig.effect_values(["heat_transfer"], rng)["tau_s"]
    truth = virtual_rig.truth_unit(effects, values, template=Unit.seed().replace(tau_s=tau))
    values["tau_s"] = tau
    records = virtual_rig.make_records(truth, tests=virtual_rig.tests_for(effects), seed=int(rng.integers(2**31)))
    return values, records


def describe(d: Diagnosis, seed: int, values: dict[str, float]) -> str:
    rounds = [[(c.effect, round(c.delta_bic), round(c.explained, 3)) for c in r.candidates] for r in d.rounds]
    return f"seed={seed} truth={values} verdict={d.verdict} found={d.found} rounds={rounds}"


@pytest.mark.parametrize("effect", CANDIDATES)
def test_the_one_undeclared_effect_is_found(effect: str, seed: int) -> None:
    rng = np.random.default_rng(seed)
    values, records = rig_data([effect], rng)
    d = diagnose(records, SEED_MODEL)
    assert d.verdict == "effects_found" and d.found == [effect], describe(d, seed, values)
    # Its parameters come back: within four standard errors or 10 %.
    for p in LIBRARY[effect].params:
        est, err, true = d.final.values[p.name], d.final.stderr[p.name], values[p.name]
        assert abs(est - true) <= max(4 * err, 0.1 * abs(true)), f"{p.name}: {est} +- {err} vs {true}; {describe(d, seed, values)}"
    assert d.final.rms_ratio < 1.1


@pytest.mark.parametrize("pinned", [143783620, 310, 105, 1567099722])
def test_a_candidate_starts_again_where_the_model_it_extends_bent_a_parameter_onto_a_bound(pinned: int) -> None:
    # Draws where the declared model puts the gas's thermal time constant
    # on its lower bound to stand in for the oil's compliance; the
    # screening fit warm-started from there reached a local optimum with
    # the bulk modulus 2.2-3.9 x too stiff and sensor lag was named first
    # (the first was a CI failure). The time constant restarted at its
    # own start finds the truth (diagnose._try). The last (a failure of
    # the robustness suite, stop 75): the fit ended with the time constant
    # still on its bound, 31 % of the excess explained, and the restart's
    # start was 1.29 x that end, so it was not taken; it is now, being
    # better than the declared model.
    from hpctl.identify.dataset import prepare
    from hpctl.identify.diagnose import _try
    from hpctl.identify.fit import fit

    values, records = rig_data(["oil_compliance"], np.random.default_rng(pinned))
    declared = fit(prepare(records), SEED_MODEL)
    assert [b.name for b in declared.at_bounds() if b.on] == ["tau_s"], declared.at_bounds()
    c = _try(declared.datasets, declared, SEED_MODEL, ("oil_compliance",))
    est, true = c.result.values["oil_bulk_modulus_pa"], values["oil_bulk_modulus_pa"]
    assert abs(est / true - 1.0) < 0.01 and c.result.rms_ratio < 1.1, (est, true, c.result.rms_ratio)
    assert abs(c.result.values["tau_s"] / values["tau_s"] - 1.0) < 0.05, (c.result.values, values)


def test_nothing_left_when_the_declared_model_is_complete(seed: int) -> None:
    rng = np.random.default_rng(seed)
    values, records = rig_data([], rng)
    d = diagnose(records, SEED_MODEL)
    assert d.verdict == "nothing_left" and d.found == [], describe(d, seed, values)
    assert d.final.values["tau_s"] == pytest.approx(values["tau_s"], rel=0.05)
    s = summary(d)
    assert s["error_before"]["converged"] is d.initial.success and s["error_after"]["converged"] is d.final.success


def test_a_declared_fit_stopped_on_its_budget_says_so_in_the_json_the_report_and_a_warning(tmp_path: Path) -> None:
    # A declared model's fit that stops on its budget: its error (the
    # "before") is where it stopped, not its optimum's, and the gain from
    # it a little high; said, not hidden (the bundled campaign's flexible
    # declared fit stops on its 60 evaluations, 9 short of converging).
    from hpctl.cli.calibrate import _diagnosis_caveats
    from hpctl.data.output import OutputDir
    from hpctl.report.calibration import diagnosis_report

    values, records = rig_data([], np.random.default_rng(3))
    d = original = diagnose(records, SEED_MODEL, max_rounds=1)
    stopped = replace(d.initial, success=False, message="The maximum number of function evaluations is exceeded.; more")
    d = replace(d, rounds=[replace(d.rounds[0], before=stopped), *d.rounds[1:]])
    s = summary(d)
    assert s["error_before"]["converged"] is False and s["error_after"]["converged"] is d.final.success
    with OutputDir(tmp_path, "diagnose") as out:
        report = diagnosis_report(d, out)
    text = (tmp_path / report.name).read_text(encoding="utf-8")
    assert ("The declared model's fit stopped before converging (the maximum number of function evaluations is exceeded): its errors "
            "are where it stopped, no lower than at its optimum.") in text
    assert ("The final model's fit stopped" in text) is (not d.final.success)
    warned = [c for c in _diagnosis_caveats(d) if c.code == "not_converged"]
    assert [c.details["fit"] for c in warned] == ["declared"] + (["final"] if not d.final.success else [])
    assert warned[0].message.startswith("the declared model's fit stopped without converging (The maximum number of function evaluations")
    # The draw's own declared fit converged: no such warning.
    assert original.initial.success and not [c for c in _diagnosis_caveats(original) if c.details.get("fit") == "declared"]


def test_classical_model_recovers_heat_transfer_and_real_gas(seed: int) -> None:
    # The seed's story: the loop the classical model cannot produce is heat
    # transfer, and the ideal gas is wrong at these pressures. Which of the
    # two the data point to first depends on the thermal time constant: the
    # polytropic exponent stands in for the real gas's stiffening (up to
    # about 1.6 here), which an ideal gas with heat transfer cannot exceed
    # (1.4), so with a slow thermal response real gas can come first.
    rng = np.random.default_rng(seed)
    values, records = rig_data([], rng)
    d = diagnose(records, ())
    assert sorted(d.found) == ["heat_transfer", "real_gas"] and d.verdict == "effects_found", describe(d, seed, values)
    s = summary(d)
    assert s["error_after"]["rms_ratio"] < 1.1 < 10 < s["error_before"]["rms_ratio"]


def test_friction_is_not_mistaken_for_heat_transfer(seed: int) -> None:
    # Both make loops; only the thermal loop vanishes at both ends of the
    # frequency range. Declared: real gas with the classical polytropic law.
    rng = np.random.default_rng(seed)
    values, records = rig_data(["friction"], rng)
    d = diagnose(records, ("real_gas",))
    assert sorted(d.found) == ["friction", "heat_transfer"], describe(d, seed, values)
    areas = summary(d)["loop_area_by_frequency"]
    assert all(a["measured_j"] > 0 for a in areas)


def test_structure_no_candidate_explains_is_reported_not_forced(seed: int) -> None:
    # Friction in the data, but not among the candidates: the verdict must
    # be unexplained structure, not some other effect forced onto the data.
    rng = np.random.default_rng(seed)
    values, records = rig_data(["friction"], rng)
    lines: list[str] = []
    d = diagnose(records, SEED_MODEL, candidates=[e for e in CANDIDATES if e != "friction"], progress=lines.append)
    assert d.verdict == "unexplained_structure" and d.found == [], describe(d, seed, values)
    # With the seed's laws declared every candidate is nested: no pairs
    # (pairs_to_try), so the round ends after the single candidates.
    assert len(d.rounds) == 1 and all(len(c.effects) == 1 for c in d.rounds[0].candidates), describe(d, seed, values)
    assert not any("pair" in line for line in lines), lines


def test_an_effect_whose_parameters_sit_at_its_null_is_not_accepted() -> None:
    # The improvement of a candidate whose own parameters are within
    # NULL_Z standard errors of where the effect does nothing comes from
    # the other parameters (HPCTL_TEST_SEED=1104332819: the oil-compliance
    # model had stopped at its evaluation limit, and sensor offsets of
    # -0.2 +- 0.9 N and 350 +- 370 Pa "explained" 140 % of its excess).
    from hpctl.identify.diagnose import NULL_Z, Candidate
    from hpctl.identify.fit import FitResult, Model

    def candidate(values: dict[str, float], stderr: dict[str, float]) -> Candidate:
        r = FitResult(Model(("heat_transfer", "real_gas", "sensor_offset"), True), values, stderr, 1.0, 1, [], [], [])
        return Candidate(("sensor_offset",), 2, r, 5000.0, 1.4)

    at_null = candidate({"sensor_force_offset_n": -0.17, "sensor_pressure_offset_pa": 346.0},
                        {"sensor_force_offset_n": 0.90, "sensor_pressure_offset_pa": 368.0})
    assert not at_null.shows_itself and at_null.null_z["sensor_offset"] < 1.0
    shown = candidate({"sensor_force_offset_n": -0.17, "sensor_pressure_offset_pa": 346.0 + NULL_Z * 368.0},
                      {"sensor_force_offset_n": 0.90, "sensor_pressure_offset_pa": 368.0})
    assert shown.shows_itself
    # A parameter on its null bound (a Coulomb friction of 0) is at its null.
    r = FitResult(Model(("friction",), True), {"friction_coulomb_n": 0.0, "friction_viscous_n_s_per_m": 0.0},
                  {"friction_coulomb_n": 117.0, "friction_viscous_n_s_per_m": 1298.0}, 1.0, 1, [], [], [])
    assert not Candidate(("friction",), 2, r, 10.0, 0.1).shows_itself


def _reconsidered_case() -> tuple[list, object]:  # type: ignore[type-arg]
    """hp-core's rig with friction and no offset, fitted with both (the
    accepted model's fit: the input noise carried, errors)."""
    from hpctl.identify.dataset import prepare
    from hpctl.identify.fit import fit

    rng = np.random.default_rng(11)
    _values, records = rig_data(["friction"], rng)
    datasets = prepare(records)
    return datasets, fit(datasets, SEED_MODEL + ("friction", "sensor_offset"))


def test_a_found_effect_at_its_null_in_the_final_model_is_refitted_out_and_dropped(tmp_path: Path) -> None:
    # The final model's test of each effect found (diagnose._reconsider):
    # offsets the data do not have sit within NULL_Z errors of zero, are
    # refitted out and dropped (the model without them is better in BIC);
    # friction, many errors from its null, is not refitted. Against an
    # independent computation: the BIC change is the two fits' own.
    from hpctl.identify.diagnose import BIC_STRONG, NULL_Z, _Clock, _reconsider, null_z
    from hpctl.identify.fit import FitResult, at_own_noise

    datasets, final = _reconsidered_case()
    assert isinstance(final, FitResult)
    z = null_z(final, ("friction", "sensor_offset"))
    assert z["sensor_offset"] < NULL_Z <= z["friction"], z
    lines: list[str] = []
    current, judged, tested = _reconsider(datasets, final, at_own_noise(final), final.model.effects, ["friction", "sensor_offset"],
                                          _Clock(lines.append, 6))
    by = {t.effect: t for t in tested}
    assert set(by) == {"friction", "sensor_offset"} and not by["friction"].dropped and by["friction"].refit_delta_bic is None
    off = by["sensor_offset"]
    assert off.dropped and off.refit_delta_bic == pytest.approx(current.bic - final.bic) and off.refit_delta_bic <= BIC_STRONG
    assert current.model.effects == SEED_MODEL + ("friction",) and not any(k.startswith("sensor_") for k in current.values)
    assert judged.rms_ratio == pytest.approx(off.rms_ratio_without) and off.rms_ratio_with == pytest.approx(at_own_noise(final).rms_ratio)
    assert any(line.startswith("tested again at the final model: sensor_offset dropped") for line in lines), lines
    # The report's steps and its sentence say so (the rounds that found
    # them left out: this is the final test alone).
    from hpctl.data.output import OutputDir
    from hpctl.identify.diagnose import analyse
    from hpctl.report.calibration import diagnosis_report

    d = Diagnosis(SEED_MODEL, [], current, analyse(current), "effects_found", ["friction"], None, tested)
    with OutputDir(tmp_path, "diagnose") as out:
        report = diagnosis_report(d, out)
    text = (tmp_path / report.name).read_text(encoding="utf-8")
    assert f"| tested again | | | | `sensor_offset` dropped | {-off.refit_delta_bic:.1f} |" in text, text
    assert "sensor_offset dropped: its parameters" in text and "friction kept: its parameters" in text, text


def test_a_found_effect_the_model_needs_is_kept_when_its_errors_are_wide_or_its_refit_fails(monkeypatch: pytest.MonkeyPatch) -> None:
    # Wide errors put friction "near" its null, but the model refitted
    # without it is far worse: kept. A refit whose runs failed (a
    # non-finite BIC) is no evidence against an effect: kept too.
    from hpctl.identify import diagnose as diagnose_module
    from hpctl.identify.diagnose import BIC_STRONG, _Clock, _reconsider
    from hpctl.identify.fit import FitResult

    datasets, final = _reconsidered_case()
    assert isinstance(final, FitResult)
    wide = replace(final, stderr={k: 1e12 for k in final.values})  # every parameter within its errors of anything
    current, _judged, tested = _reconsider(datasets, wide, wide, wide.model.effects, ["friction"], _Clock(lambda _m: None, 6))
    [t] = tested
    assert not t.dropped and t.refit_delta_bic is not None and t.refit_delta_bic > BIC_STRONG and current is wide

    real_fit = diagnose_module.fit

    def failed(*args: object, **kwargs: object) -> FitResult:
        return replace(real_fit(*args, **kwargs), rss=float("nan"))  # type: ignore[arg-type]

    monkeypatch.setattr(diagnose_module, "fit", failed)
    current, _judged, tested = _reconsider(datasets, wide, wide, wide.model.effects, ["friction"], _Clock(lambda _m: None, 6))
    [t] = tested
    assert not t.dropped and not math.isfinite(t.refit_delta_bic or 0.0) and current is wide


def test_the_design_effect_is_one_on_noise_and_the_span_of_a_structured_residual() -> None:
    # diagnose.design_effect: the sandwich covariance of an effect's
    # parameters against the one the BIC assumes (independent residuals of
    # one variance). Analytic cases first: the mean of the generalised
    # eigenvalues, here the diagonal's ratios.
    from hpctl.identify.diagnose import design_effect, scaled_delta_bic
    from hpctl.identify.fit import FitResult, Model

    names = [p.name for p in Model(SEED_MODEL + ("friction",), True).params]
    i, j = names.index("friction_coulomb_n"), names.index("friction_viscous_n_s_per_m")
    iid = np.eye(len(names))
    iid[i, i], iid[j, j] = 1.0, 4.0
    robust = iid.copy()
    robust[i, i], robust[j, j] = 3.0, 8.0  # ratios 3 and 2
    r = FitResult(Model(SEED_MODEL + ("friction",), True), {n: 1.0 for n in names}, {}, 1.0, 10, [], [], [], covariance=robust,
                  covariance_iid=iid)
    assert design_effect(r, "friction") == pytest.approx(2.5)
    assert design_effect(replace(r, covariance_iid=None), "friction") is None
    assert design_effect(replace(r, covariance=np.full_like(robust, np.inf)), "friction") is None
    # The BIC change with its likelihood ratio divided by it: only ever
    # less evidence for the larger model, and the change itself at 1.
    n, k = 1000, 2
    assert scaled_delta_bic(50.0, k, n, 2.5) == pytest.approx((50.0 + k * math.log(n)) / 2.5 - k * math.log(n))
    assert scaled_delta_bic(50.0, k, n, 0.5) == 50.0 and scaled_delta_bic(50.0, k, n, None) == 50.0

    # Real fits on hp-core's rig (data with friction): the model that has
    # it leaves the noise, independent, and the design effect is about 1;
    # without it, the residual is 3 x the noise and correlated over many
    # samples, and the offsets' design effect is that span.
    from hpctl.identify.fit import fit

    datasets, final = _reconsidered_case()
    assert isinstance(final, FitResult) and final.rms_ratio < 1.1
    for effect in ("friction", "sensor_offset"):
        assert 0.8 < (design_effect(final, effect) or 0.0) < 1.4, effect
    structured = fit(datasets, SEED_MODEL + ("sensor_offset",))
    assert structured.rms_ratio > 2.0 and (design_effect(structured, "sensor_offset") or 0.0) > 5.0


def test_a_found_effect_whose_evidence_is_the_residuals_correlation_is_dropped() -> None:
    # hp-core's rig with heat build-up, fitted with sensor offsets instead:
    # the residual stays at several times the noise, correlated, and the
    # offsets take a little of it (within NULL_Z errors of zero). Refitted
    # without them, the BIC, which counts every residual as independent,
    # says they are worth keeping; with the likelihood ratio divided by the
    # residuals' design effect it does not, and they are dropped.
    from hpctl.identify.dataset import prepare
    from hpctl.identify.diagnose import BIC_STRONG, NULL_Z, _Clock, _reconsider, design_effect, null_z
    from hpctl.identify.fit import at_own_noise, fit

    _values, records = rig_data(["heat_buildup"], np.random.default_rng(11))
    datasets = prepare(records)
    final = fit(datasets, SEED_MODEL + ("sensor_offset",))
    assert null_z(final, ["sensor_offset"])["sensor_offset"] < NULL_Z
    design = design_effect(final, "sensor_offset")
    assert design is not None and design > 10.0
    lines: list[str] = []
    current, _judged, [t] = _reconsider(datasets, final, at_own_noise(final), final.model.effects, ["sensor_offset"], _Clock(lines.append, 6))
    assert t.refit_delta_bic is not None and t.refit_delta_bic == pytest.approx(current.bic - final.bic) and t.refit_delta_bic > BIC_STRONG
    k = final.k - current.k
    assert k == 3 and t.design_effect == design
    assert t.scaled_delta_bic == pytest.approx((t.refit_delta_bic + k * math.log(final.n)) / design - k * math.log(final.n))
    assert t.scaled_delta_bic is not None and t.scaled_delta_bic <= BIC_STRONG and t.dropped
    assert current.model.effects == SEED_MODEL and "with the residuals' correlation counted (design effect" in lines[-1], lines


def test_a_candidate_whose_gain_is_the_residuals_correlation_is_not_accepted() -> None:
    # hp-core's rig with valve lag, sensor offsets the only candidate: the
    # offsets take a little of the lag's structured residual, 1,082 in BIC
    # with every residual counted as independent, and pass the means' test
    # (offset_delta_bic). Until stop 75 they were accepted there and
    # dropped only at the final model's test (diagnose._reconsider). With
    # the likelihood ratio divided by the residuals' design effect at the
    # screening fit they are not accepted in the round.
    from hpctl.identify.diagnose import BIC_STRONG, design_effect

    _values, records = rig_data(["valve_lag"], np.random.default_rng(11))
    lines: list[str] = []
    d = diagnose(records, SEED_MODEL, candidates=["sensor_offset"], progress=lines.append)
    assert d.verdict == "unexplained_structure" and d.found == [] and d.reconsidered == [], describe(d, 11, {})
    [c] = d.rounds[0].candidates
    assert d.rounds[0].accepted is None and c.refit_delta_bic is None and c.offset_delta_bic is not None
    assert c.delta_bic > 100 * BIC_STRONG and c.offset_delta_bic > BIC_STRONG, describe(d, 11, {})
    design = design_effect(c.result, "sensor_offset")
    assert design is not None and design > 10.0 and c.design_effect == design
    k, n = c.added_params, c.result.n
    assert k == 3 and c.scaled_delta_bic == pytest.approx((c.delta_bic + k * math.log(n)) / design - k * math.log(n))
    assert c.scaled_delta_bic is not None and c.scaled_delta_bic <= BIC_STRONG
    assert any("sensor_offset not accepted" in line and "with the residuals' correlation counted" in line for line in lines), lines
    row = summary(d)["candidates_by_round"][0][0]
    assert row["design_effect"] == design and row["scaled_delta_bic"] == c.scaled_delta_bic


def test_an_effect_within_its_errors_of_the_null_shows_itself_by_what_switching_it_off_loses() -> None:
    # Wide errors (a flexible damper can take friction's role by moving far)
    # but switching the effect off at the candidate's own values loses much:
    # the effect shows itself. _null_delta_bic against an independent
    # computation: the candidate's model run with its effect's parameters
    # at their nulls, the BIC from the two sums of squares.
    from hpctl.identify.dataset import prepare
    from hpctl.identify.diagnose import BIC_STRONG, NULL_Z, Candidate, _null_delta_bic
    from hpctl.identify.fit import fit, rss_at

    rng = np.random.default_rng(11)
    values, records = rig_data(["friction"], rng)
    datasets = prepare(records)
    r = fit(datasets, SEED_MODEL + ("friction",), input_noise=False, errors=False)
    wide = {k: 1e9 for k in r.values}  # no parameter NULL_Z errors from anywhere
    c = Candidate(("friction",), 2, replace(r, stderr=wide), 100.0, 1.0)
    assert max(c.null_z.values()) < NULL_Z and not c.shows_itself
    off = dict(r.values, friction_coulomb_n=0.0, friction_viscous_n_s_per_m=0.0)
    rss_off = rss_at(datasets, r.model.effects, off)
    expected = r.n * np.log(rss_off / r.rss) - 2 * np.log(r.n)
    assert _null_delta_bic(datasets, c) == pytest.approx(expected, rel=1e-9)
    c.null_delta_bic = expected
    assert (expected > BIC_STRONG) == c.shows_itself, (values, expected)
    assert expected > BIC_STRONG, f"the drawn friction {values} should show: {expected}"
    c.null_delta_bic = BIC_STRONG
    assert not c.shows_itself


def test_sensor_offsets_must_show_in_the_residual_means() -> None:
    # offset_delta_bic: the offsets alone (the best constant per channel,
    # the rest held), against the same shift found by numpy's least squares
    # on the weighted residuals. A constant on the force shows; a larger
    # zero-mean structure (what a flexible damper leaves when it cannot
    # follow the true curve) does not, however big.
    from hpctl.identify.dataset import prepare
    from hpctl.identify.diagnose import BIC_STRONG, offset_delta_bic
    from hpctl.identify.fit import FitResult, Model
    from hpctl.model.effects import OFFSET_CHANNELS

    rng = np.random.default_rng(7)
    _, records = rig_data([], rng)
    datasets = prepare(records)
    sigma_f = float(np.median(datasets[0].weight_sigma["force_n"]))

    def result(force_offset: float, force_wave: float) -> tuple[FitResult, float]:
        """Residuals of unit weighted noise plus the given force terms, and
        the BIC change of the least-squares constants on the offset channels."""
        sims, rss, n, by_channel = [], 0.0, 0, {}
        for d in datasets:
            sim = {}
            for c, y in d.targets.items():
                r = rng.normal(0.0, 1.0, len(y)) * d.weight_sigma[c]
                if c == "force_n":
                    r = r + force_offset + force_wave * np.sin(np.linspace(0.0, 6 * np.pi, len(y), endpoint=False))
                sim[c] = y + r
                w = 1.0 / d.weight_sigma[c]
                rss += float(np.sum((r * w) ** 2))
                n += len(y)
                z, a = by_channel.get(c, (np.zeros(0), np.zeros(0)))
                by_channel[c] = (np.concatenate((z, r * w)), np.concatenate((a, w)))
            sims.append(sim)
        after = 0.0
        for c, (z, a) in by_channel.items():
            if c in OFFSET_CHANNELS.values():
                z = z - a * np.linalg.lstsq(a[:, None], z, rcond=None)[0][0]
            after += float(z @ z)
        k = sum(1 for c in OFFSET_CHANNELS.values() if c in by_channel)
        return FitResult(Model(("heat_transfer", "real_gas"), True), {}, {}, rss, n, [], sims, datasets), n * np.log(rss / after) - k * np.log(n)

    constant, expected = result(0.2 * sigma_f, 0.0)
    assert offset_delta_bic(constant) == pytest.approx(expected, rel=1e-9) and expected > BIC_STRONG
    shaped, expected = result(0.0, 2.0 * sigma_f)
    assert offset_delta_bic(shaped) == pytest.approx(expected, rel=1e-6) and expected < BIC_STRONG


def test_structure_carried_by_the_pooled_residual_alone_still_says_where() -> None:
    # Every channel within the ceiling (1.3 x its noise) but the pooled
    # residual above 1.1 x: structure remains, and the judgement names the
    # channels that carry it (a randomised foreign-rig case, seed
    # 2061819661, said "structure remains" with no place). Made here from a
    # fit at the noise read against noise levels 1/1.15 of its own.
    from hpctl.identify.dataset import prepare
    from hpctl.identify.diagnose import NOISE_CEILING, POOLED_RMS_RATIO, judge
    from hpctl.identify.fit import fit

    records = virtual_rig.make_records(Unit.seed(), "sweep", seed=5)
    r = fit(prepare(records), ("heat_transfer", "real_gas"), input_noise=False)
    k = 1.15
    tight = replace(r, rss=r.rss * k**2, datasets=[replace(d, weight_sigma={c: s / k for c, s in d.weight_sigma.items()}) for d in r.datasets])
    j = judge(tight)
    context = f"pooled {j.rms_ratio:.3f}, worst {j.worst_rms_ratio:.3f}, places {[p.describe() for p in j.places]}"
    assert POOLED_RMS_RATIO < j.rms_ratio and j.worst_rms_ratio <= NOISE_CEILING, context
    assert j.structure_remains and j.places, context
    assert all(p.rms_ratio > POOLED_RMS_RATIO and p.regimes for p in j.places), context
    assert "structure remains" in j.describe() and j.places[0].describe() in j.describe(), context

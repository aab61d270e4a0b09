"""The diagnosis never overclaims, on data its model did not write.

Records from the foreign rig (tests/foreign_rig: SciPy + CoolProp, its own
damper, friction and sensors; drawn anew on every run, the seed printed on
failure and FOREIGN_RIG_SEED replaying it). Short sweeps (three of the
five sines) keep each diagnosis to well under a minute.

What is asserted is honesty, not success: whatever the diagnosis finds, its
verdict must say whether structure remains, where, and with what it
correlates, and it may claim "nothing left" only when the residual is at
the noise, judged also against the true noise the foreign rig drew.
"""

from __future__ import annotations

import inspect
import json
import math
import os
import secrets
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from click.testing import CliRunner

from foreign_rig import generate, sweep_tests
from foreign_rig.draw import draw_case
from hpctl.cli import main as cli_main
from hpctl.data.records import read_record
from hpctl.identify.diagnose import BIC_STRONG, NOISE_CEILING, NULL_Z, Diagnosis, diagnose, summary
from hpctl.identify.profile import profile_point
from hpctl.model.effects import LIBRARY

SHORT = ("sine_0.03hz", "sine_0.3hz", "sine_1hz")
SIGMA_KEY = {"force_n": "force_n", "p_gas_pa": "p_pa", "p_gas2_pa": "p_pa", "body_disp_m": "disp_m"}


@pytest.fixture
def seed() -> int:
    return int(os.environ.get("FOREIGN_RIG_SEED", secrets.randbelow(2**31)))


def short_case(effect: str | None, seed: int) -> Any:
    return generate(effect, seed, tests=[t for t in sweep_tests() if t.name in SHORT])


def effect_case(effect: str, seed: int) -> Any:
    """The foreign case of ``effect`` on the short sweep and the records
    the effect needs (``EFFECT_TESTS``: the hold for a leak, the heat run
    for heat build-up, the switching record for valve lag)."""
    from foreign_rig import EFFECT_TESTS, extra_tests

    more = extra_tests()
    return generate(effect, seed, tests=[t for t in sweep_tests() if t.name in SHORT] + [t for k in EFFECT_TESTS.get(effect, ()) for t in more[k]])


def true_noise_ratio(d: Diagnosis, truth: dict[str, Any]) -> float:
    """The final residual's RMS over the noise the foreign rig drew, pooled
    over records and channels (hpctl estimates its noise from the data; this
    is the independent check).

    That noise is the transducer's (``sigma``) and the sample-time jitter's:
    the rig samples every channel at a jittered instant and logs the nominal
    one (tests/foreign_rig/sensors.py), so a channel changing at a rate
    dy/dt carries jitter_s * dy/dt more, sample by sample. Until stop 33
    this left the jitter out: on FOREIGN_RIG_SEED=70564130 (oil compliance,
    damper-off sines) the 1 Hz sine's gas pressure swings 20 MPa and its
    jitter (0.17 ms) adds 7.9 kPa RMS against the transducer's 2.2 kPa;
    hpctl's noise estimate there was 7.86 kPa, the residual 7.2 kPa, and
    this ratio read 1.54. The rate is the record's own (its noise adds
    under 0.5 N and 60 Pa to the jitter's term at these sample rates).

    Also the measured input's noise as it reaches the channel through the
    model, which no model driven by that input can take out: hpctl's
    weights carry it (``weight_sigma`` over ``sigma``, from the model's
    runs with the input's noise drawn, stop 29), and this adds that part.
    Until stop 71 it was left out: on FOREIGN_RIG_SEED=21's seal (935 N
    Coulomb, smoothing 0.34 mm/s; fitted 921 N and 0.40 mm/s) the 1 Hz
    sine's force read 4.75 x the transducer's noise, all of it at the
    flow reversals, where the displacement's 4 um noise moves the
    velocity the model sees by about 1 mm/s, three times the seal's
    smoothing, so the model's friction turns a sample early or late now
    and then (about 0.3 samples a cycle of 200, 1,840 N each: 71 N RMS
    against 15 N); this ratio read 1.62 and 1.02 with that part, hpctl's
    own 1.02."""
    jitter_s = truth["noise"]["jitter_s"]
    sq, n = 0.0, 0
    for i, ds in enumerate(d.final.datasets):
        for c in ds.targets:
            r = d.final.residuals(i, c)
            rate = np.gradient(ds.targets[c], ds.times_s)
            carried = np.maximum(ds.weight_sigma[c] ** 2 - ds.sigma[c] ** 2, 0.0)
            var = truth["noise"][SIGMA_KEY[c]]["sigma"] ** 2 + (jitter_s * rate) ** 2 + carried
            sq += float(np.sum(r**2 / var))
            n += len(r)
    return math.sqrt(sq / n)


def check_correction(delta: float, scaled: float | None, design: float | None, context: str) -> None:
    """A BIC change ``delta`` and the same with the residuals' correlation
    counted: never more evidence (where the design effect is above 1),
    and the change itself where it is not."""
    if scaled is None or not math.isfinite(delta):
        return
    assert scaled <= delta or scaled <= BIC_STRONG, context
    if design is None or design <= 1.0:
        assert scaled == delta, context


def check_honest(d: Diagnosis, truth: dict[str, Any], context: str) -> None:
    j = d.judgement
    assert j is not None, context
    s = summary(d)
    # The verdict carries both what was found and whether structure remains.
    assert s["found"] == d.found and s["structure_remains"] == j.structure_remains, context
    expected = {(True, True): "effects_found_structure_remains", (True, False): "effects_found",
                (False, True): "unexplained_structure", (False, False): "nothing_left"}[(bool(d.found), j.structure_remains)]
    assert d.verdict == expected, context
    # "Nothing left" only at the noise: hpctl's own ceiling, and the truth.
    if not j.structure_remains:
        assert j.rms_ratio <= NOISE_CEILING and j.worst_rms_ratio <= NOISE_CEILING, context
        assert true_noise_ratio(d, truth) <= 1.5, context
    else:
        # Where: every place names its record, channel and regimes.
        assert j.places, context
        names = {ds.name for ds in d.final.datasets}
        for p in j.places:
            assert p.record in names and p.rms_ratio > 1.0 and p.regimes, context
    # Each accepted effect: the errors before and after, and what it left.
    for step in s["effects"]:
        assert step["rms_ratio_after"] < step["rms_ratio_before"], context
        after = step["residual_after"]
        assert after["rms_ratio"] == pytest.approx(step["rms_ratio_after"]) and after["structure_remains"] == (not after["at_noise"]), context
    # Each effect found with a null tested again at the final model: one
    # near its null refitted out, dropped exactly where the model without
    # it was no worse than BIC_STRONG once the residuals' correlation is
    # counted (which only takes evidence away), and then nowhere in the result.
    nested = {e for r in d.rounds if r.accepted is not None for e in r.accepted.effects
              if any(p.null is not None for p in LIBRARY[e].params)}
    assert {t.effect for t in d.reconsidered} == nested, context
    for t in d.reconsidered:
        assert (t.refit_delta_bic is None) == (t.null_z >= NULL_Z), context
        assert (t.scaled_delta_bic is None) == (t.refit_delta_bic is None), context
        if t.refit_delta_bic is not None:
            check_correction(t.refit_delta_bic, t.scaled_delta_bic, t.design_effect, context)
        assert t.dropped == (t.scaled_delta_bic is not None and t.scaled_delta_bic <= BIC_STRONG), context
        assert (t.effect in d.found) != t.dropped and (t.effect in d.final.model.effects) != t.dropped, context
    assert s["dropped"] == d.dropped and len(s["reconsidered"]) == len(d.reconsidered), context
    # Each candidate weighed with its errors: its gain with the residuals'
    # correlation counted never above its own (where the design effect is
    # above 1), and an accepted one above BIC_STRONG with it.
    for r, rows in zip(d.rounds, s["candidates_by_round"]):
        for c, row in zip(r.candidates, rows):
            assert (row["design_effect"], row["scaled_delta_bic"]) == (c.design_effect, c.scaled_delta_bic), context
            check_correction(c.delta_bic, c.scaled_delta_bic, c.design_effect, context)
        if r.accepted is not None:
            assert r.accepted.scaled_delta_bic is not None and r.accepted.scaled_delta_bic > BIC_STRONG, context
    json.dumps(s)  # machine-readable as it is


def describe(d: Diagnosis, seed: int, truth: dict[str, Any]) -> str:
    j = d.judgement
    return f"seed={seed} truth={truth['hpctl_params']} verdict={d.verdict} found={d.found} left={j.describe(12) if j else None}"


def pinned_diagnosis(effect: str | None, seed: int, declared: tuple[str, ...]) -> tuple[Any, Diagnosis, list[str], str]:
    """A pinned draw of the short sweep diagnosed flexibly from ``declared``,
    checked honest: the case, the diagnosis, its progress lines, and the
    context an assertion prints (the lines with it)."""
    g = short_case(effect, seed)
    lines: list[str] = []
    d = diagnose([read_record(p) for p in g.records], declared, flexible=True, progress=lines.append)
    context = describe(d, seed, g.truth) + "\n" + "\n".join(lines)
    check_honest(d, g.truth, context)
    return g, d, lines, context


@pytest.mark.parametrize("flexible", [False, True], ids=["one_gain", "flexible"])
def test_an_effect_outside_the_library_leaves_structure_and_says_where(seed: int, flexible: bool) -> None:
    # An elastomer bump stop met at 35-50 mm of compression: no effect of
    # the library makes a force that rises steeply with compression only.
    # With one damper gain the damper's shape is left too; with the
    # flexible damper (where a control says "nothing left") the stop alone
    # (stop 71, seeds 1-3: a sensor offset taken, 33-74 x the noise left,
    # the force most in the compressed half, 11-12 s).
    g = short_case("bump_stop", seed)
    d = diagnose([read_record(p) for p in g.records], ("heat_transfer", "real_gas"), flexible=flexible)
    context = describe(d, seed, g.truth)
    check_honest(d, g.truth, context)
    assert d.structure_remains and d.verdict in ("unexplained_structure", "effects_found_structure_remains"), context
    assert d.judgement is not None
    # The force residual of the largest-amplitude records is where it is:
    # in the compressed half of the stroke, or correlated with compression.
    force = [p for p in d.judgement.places if p.channel == "force_n"]
    assert force, context
    assert any(p.worst_regimes.get("stroke") == "compressed" or any(q == "disp_m" for q, _ in p.correlates_with) for p in force), context


def test_an_offset_that_explains_nothing_as_the_verdict_judges_is_not_accepted() -> None:
    # The draw CI made for the flexible bump stop (stop 71): a sensor offset
    # explained 20 % of the excess in the weights its fit used and raised
    # the residual in each model's own weights, where the verdict judges
    # it, from 240.95 to 241.93 x the noise; it was "found". Stop 72
    # refused it there, with its share in the verdict's weights said
    # (-0.8 %). Since stop 75 it is refused before its full fit: its gain
    # with the residuals' correlation counted (design effect 50) is below
    # BIC_STRONG. What remains is said where it is. The assertions are on
    # the outcome, which does not depend on the rig drawing the same
    # numbers to the last digit. (The judged share's refusal stays pinned
    # by test_pairs_are_fitted_where_a_single_passed_its_screening_and_its_full_fit_was_refused.)
    _g, d, lines, context = pinned_diagnosis("bump_stop", 357950441, ("heat_transfer", "real_gas"))
    assert "sensor_offset" not in d.found and d.structure_remains, context
    offset = [c for c in summary(d)["candidates_by_round"][0] if c["effect"] == "sensor_offset"]
    assert offset and offset[0]["delta_bic"] > 10 * BIC_STRONG and offset[0]["scaled_delta_bic"] <= BIC_STRONG, context
    assert offset[0]["design_effect"] > 10.0 and offset[0]["refit_delta_bic"] is None, context
    assert any("sensor_offset not accepted: its BIC change" in line for line in lines), context


def test_a_damper_that_thins_as_its_oil_warms_is_left_as_structure_in_the_heat_run(seed: int) -> None:
    # The foreign rig's second effect outside the library: the damper's
    # oil viscosity falls with its temperature (exponentially, its
    # coefficient drawn in 2-3.5 % a kelvin), which the 10-minute heat run
    # shows and the short sines do not (there the flexible diagnosis says
    # "nothing left", at 0.98-1.03 x the noise: honest, the records do not
    # hold it).
    # Flexibly, with the heat run: no effect may be forced onto it, and
    # what remains is said where it is. Measured (stop 71, seeds 1-4):
    # nothing found ("unexplained structure", heat build-up screened at
    # -74 to +16 in BIC and not accepted), 8.2-16 x the noise left, the
    # heat run's force the worst place, most in rebound and fast, 22-26 s.
    g = effect_case("oil_viscosity", seed)
    d = diagnose([read_record(p) for p in g.records], ("heat_transfer", "real_gas"), flexible=True)
    context = describe(d, seed, g.truth)
    check_honest(d, g.truth, context)
    assert d.structure_remains and d.verdict in ("unexplained_structure", "effects_found_structure_remains"), context
    assert d.judgement is not None and d.judgement.places, context
    worst = d.judgement.places[0]
    assert (worst.record, worst.channel) == ("heat_run", "force_n") and worst.regimes, context


def test_diagnose_cli_reports_what_is_left_after_each_effect(seed: int, tmp_path: Path) -> None:
    # Seal friction (Coulomb, viscous, a Stribeck peak, its own smoothing):
    # whatever the model then leaves is reported, never hidden behind
    # "effects found".
    g = short_case("friction", seed)
    out = tmp_path / "diag"
    r = CliRunner().invoke(cli_main, ["diagnose", *[str(p) for p in g.records], "--model", "seed", "--out", str(out), "--json", "--quiet"])
    assert r.exit_code == 0, r.stderr
    s = json.loads(r.stdout)
    context = f"seed={seed} truth={g.truth['hpctl_params']} verdict={s['verdict']} left={s['remaining_structure']['text']}"
    assert s["verdict"] in ("effects_found", "effects_found_structure_remains", "nothing_left", "unexplained_structure"), context
    assert s["structure_remains"] == (not s["remaining_structure"]["at_noise"]), context
    codes = [w["code"] for w in s["warnings"]]
    assert ("residual_structured" in codes) == s["structure_remains"], context
    for step in s["effects"]:
        for k in ("rms_ratio_before", "rms_ratio_after", "worst_rms_ratio_before", "worst_rms_ratio_after", "residual_after"):
            assert step[k] is not None, (k, context)
    on_disk = json.loads((out / "diagnosis.json").read_text())
    assert on_disk["remaining_structure"] == s["remaining_structure"]
    report = (out / "report.md").read_text()
    assert "What is left:" in report
    if s["structure_remains"]:
        assert "## Remaining structure" in report and s["remaining_structure"]["places"], context
        for p in s["remaining_structure"]["places"]:
            assert p["record"] in {Path(x).name for x in g.records} and p["channel"] and p["regimes"], context


def test_a_control_is_judged_against_the_noise(seed: int) -> None:
    # No undeclared effect: the verdict is whatever the residual says, and
    # never "nothing left" above the noise (the foreign rig's real nitrogen,
    # damper and sensors are not hpctl's, so structure may well remain).
    g = short_case(None, seed)
    d = diagnose([read_record(p) for p in g.records], ("heat_transfer", "real_gas"))
    check_honest(d, g.truth, describe(d, seed, g.truth))


def test_flexible_diagnosis_of_a_control_adds_no_effect(seed: int, tmp_path: Path) -> None:
    # No undeclared effect, and a damper that is not hpctl's assumed curve:
    # with one gain on that curve the damper's shape is left in the
    # residual, where friction can stand in for it (seed 5: viscous
    # friction of 18,400 N s/m, 12.8x the noise left). With --flexible the
    # characteristic is identified with every model, so no effect of the
    # library is taken for it (measured on seeds 1-5: none found, four
    # "nothing left", one with the 1 Hz force at 2x the noise).
    g = short_case(None, seed)
    out = tmp_path / "diag"
    r = CliRunner().invoke(cli_main, ["diagnose", *[str(p) for p in g.records], "--model", "seed", "--flexible", "--out", str(out),
                                      "--json", "--quiet"])
    assert r.exit_code == 0, r.stderr
    s = json.loads(r.stdout)
    context = f"seed={seed} verdict={s['verdict']} found={s['found']} left={s['remaining_structure']['text']}"
    assert s["flexible"] is True and s["found"] == [] and s["verdict"] in ("nothing_left", "unexplained_structure"), context
    assert "tau_cv_exponent" in s["final_params"] and any(k.startswith("damper_off_") for k in s["final_params"]), context
    if s["verdict"] == "nothing_left":
        assert s["remaining_structure"]["worst_rms_ratio"] <= NOISE_CEILING, context
    assert "fitted flexibly" in (out / "report.md").read_text()


def test_a_channel_above_its_level_by_a_noise_colour_its_records_suggest_is_judged_with_it(tmp_path: Path) -> None:
    # FOREIGN_RIG_SEED=9's control (no effect), flexible: the 0.3 Hz sine's
    # force read 1.31 x its level, all of it noise: the rig drew 44.0 N
    # white and 39.1 N correlated over 38 ms, and the three records' levels
    # (58.0, 43.4 and 47.5 N at 167, 17 and 5 ms) suggest that colour
    # (evidence 8.9) without establishing it (12). With what the record's
    # level misses of it in the weights the channel is at the noise, and
    # its residual is no more correlated than that noise: "nothing left",
    # the colour said in the verdict, the JSON, a warning and the report.
    from hpctl.cli.calibrate import _diagnosis_caveats
    from hpctl.identify.signals import COLOUR_EVIDENCE, COLOUR_HINT_EVIDENCE

    g, d, _lines, context = pinned_diagnosis(None, 9, ("heat_transfer", "real_gas"))
    j = d.judgement
    assert j is not None and d.verdict == "nothing_left" and not j.places, context
    [c] = j.colours
    assert (c.record, c.channel) == ("sine_0.3hz", "force_n") and c.rms_ratio <= 1.1 and c.rms_ratio_without > NOISE_CEILING, context
    assert COLOUR_HINT_EVIDENCE <= c.colour.evidence < COLOUR_EVIDENCE, context
    assert all(a <= m for a, m in zip(c.autocorr, c.autocorr_max)) and c.lags[0] == 1 < c.lags[1], context
    truth = g.truth["noise"]["force_n"]
    assert abs(math.sqrt(c.colour.white_var + c.colour.coloured_var) / truth["sigma"] - 1.0) < 0.1, context
    [out] = summary(d)["remaining_structure"]["colours"]
    assert out["rms_ratio_without"] == c.rms_ratio_without and out["colour"]["evidence"] == c.colour.evidence, context
    [warned] = [w for w in _diagnosis_caveats(d) if w.code == "colour_counted"]
    assert warned.details["channels"] == ["sine_0.3hz/force_n"], context
    from hpctl.data.output import OutputDir
    from hpctl.report.calibration import diagnosis_report

    with OutputDir(tmp_path, "diagnose") as o:
        report = diagnosis_report(d, o)
    assert "counting a noise colour" in (tmp_path / report.name).read_text(encoding="utf-8"), context


def test_flexible_diagnosis_from_the_classical_model_finds_heat_transfer_and_real_gas(seed: int) -> None:
    # The seed's story on data hp-core did not write (test_diagnose.py's
    # test_classical_model_recovers_heat_transfer_and_real_gas on hp-core's
    # rig): the foreign rig's gas is always CoolProp's reference nitrogen
    # exchanging heat through a constant wall conductance, so from the
    # classical model (a polytropic ideal gas) both laws are undeclared.
    # Real gas alone fits worse than the polytropic law it replaces, so
    # the two are found as a pair. Measured (stop 71, seeds 1-26): found on
    # every one, the residual 0.94-1.10 x hpctl's noise (0.98-1.18 x the
    # noise the rig drew), tau within 0.1 % and 2 errors, 7-18 s.
    g = short_case(None, seed)
    d = diagnose([read_record(p) for p in g.records], (), flexible=True)
    context = describe(d, seed, g.truth)
    check_honest(d, g.truth, context)
    assert sorted(d.found) == ["heat_transfer", "real_gas"], context
    assert d.final.rms_ratio <= NOISE_CEILING < 10.0 < summary(d)["error_before"]["rms_ratio"], context
    est, err, true = estimate(d, g, "tau_s")
    assert abs(est - true) <= max(3.0 * err, 0.1 * true), f"tau {est} +- {err} vs {true}; {context}"


def test_pairs_are_fitted_where_a_single_passed_its_screening_and_its_full_fit_was_refused(tmp_path: Path) -> None:
    # A draw of the test above (stop 72): heat transfer alone explained
    # 5.5 % of the excess in the weights its fit used, enough to be weighed,
    # and its full fit -1.6 % as the verdict judges it (262.3 -> 264.3 x
    # the noise), so it was refused; the pairs were fitted only where no
    # single passed the screening's tests, so nothing was found. Pairs are
    # now fitted wherever no single is accepted in the end: heat transfer
    # with real gas, at the noise.
    _g, d, lines, context = pinned_diagnosis(None, 1273941668, ())
    assert sorted(d.found) == ["heat_transfer", "real_gas"] and d.verdict == "effects_found", context
    [single] = [c for c in d.rounds[0].candidates if c.effects == ("heat_transfer",)]
    assert single.judged_explained is not None and single.judged_explained < 0.05, context
    assert any(line.startswith("round 1/6: heat_transfer not accepted: judged in each model's own weights") for line in lines), context
    # The report's candidates say why a strong gain was not accepted.
    from hpctl.data.output import OutputDir
    from hpctl.report.calibration import diagnosis_report

    with OutputDir(tmp_path, "diagnose") as out:
        report = diagnosis_report(d, out)
    [row] = [r for r in (tmp_path / report.name).read_text(encoding="utf-8").splitlines() if r.startswith("| `heat_transfer` |")]
    assert "% of the excess as judged (own weights); not accepted |" in row, row


def test_an_offset_standing_in_for_the_gas_laws_is_not_accepted_on_the_residuals_correlation(tmp_path: Path) -> None:
    # A draw of the classical test above (stop 72): a sensor offset was
    # found first (round 1 at 262 x the noise: offsets of -82 N, 1.36 and
    # 1.53 MPa standing in for the gas laws), then heat transfer and real
    # gas, and the diagnosis named the offset found. Stop 73 tested each
    # effect found again at the final model, where the offset was dropped
    # (the model without it better by 19.0 in BIC; that test is pinned on
    # hp-core's rig in test_diagnose.py). Since stop 75 the round's own
    # test divides the gain's likelihood ratio by the residuals' design
    # effect (44.8 here: at 236 x the noise the residual is correlated
    # over many samples): the offset, +247.5 in BIC as if every residual
    # were independent, is not accepted, and the pair with the gas laws is.
    g, d, lines, context = pinned_diagnosis(None, 2028051846, ())
    [offset] = [c for c in d.rounds[0].candidates if c.effects == ("sensor_offset",)]
    assert offset.delta_bic > 10 * BIC_STRONG and offset.design_effect is not None and offset.design_effect > 10.0, context
    assert offset.scaled_delta_bic is not None and offset.scaled_delta_bic <= BIC_STRONG and offset.refit_delta_bic is None, context
    assert d.rounds[0].accepted is not None and "sensor_offset" not in d.rounds[0].accepted.effects, context
    assert any(line.startswith("round 1/6: sensor_offset not accepted: its BIC change") for line in lines), context
    assert sorted(d.found) == ["heat_transfer", "real_gas"] and d.verdict == "effects_found" and d.dropped == [], context
    assert not any(p.startswith("sensor_") for p in d.final.values), context
    est, err, true = estimate(d, g, "tau_s")
    assert abs(est - true) <= max(3.0 * err, 0.1 * true), f"tau {est} +- {err} vs {true}; {context}"
    # The report's candidates say why a strong gain was not accepted.
    from hpctl.data.output import OutputDir
    from hpctl.report.calibration import diagnosis_report

    with OutputDir(tmp_path, "diagnose") as out:
        report = diagnosis_report(d, out)
    [row] = [r for r in (tmp_path / report.name).read_text(encoding="utf-8").splitlines() if r.startswith("| `sensor_offset` |")]
    assert f"gain {offset.scaled_delta_bic:.1f} with the residuals' correlation counted (design effect" in row, row
    assert row.endswith("; not accepted |"), row


def test_flexible_diagnosis_does_not_take_friction_for_heat_transfer(seed: int) -> None:
    # test_diagnose.py's test_friction_is_not_mistaken_for_heat_transfer on
    # the foreign rig: both make loops, only the thermal one vanishes at
    # both ends of the frequency range. Declared: real gas with the
    # polytropic law; the foreign rig's seal friction (its own smoothed
    # Coulomb, viscous and Stribeck law) and its gas's heat transfer
    # undeclared, on the friction case's records (the sweep and the slow
    # tests that show friction). Measured (stop 71, seeds 1-30): both found,
    # heat transfer first, 0.95-1.06 x the noise, tau within 0.03 % and 2.2
    # errors, 9-21 s; seed 12 only once a later round at the noise screens
    # friction where the damper holds a force at no flow (the last test of
    # this file); on seed 21 the check against the rig's own noise read
    # 1.62 until the input's noise through the model was counted there
    # (true_noise_ratio).
    g = generate("friction", seed)
    d = diagnose([read_record(p) for p in g.records], ("real_gas",), flexible=True)
    context = describe(d, seed, g.truth)
    check_honest(d, g.truth, context)
    assert sorted(d.found) == ["friction", "heat_transfer"], context
    assert d.final.rms_ratio <= NOISE_CEILING, context
    est, err, true = estimate(d, g, "tau_s")
    assert abs(est - true) <= max(3.0 * err, 0.1 * true), f"tau {est} +- {err} vs {true}; {context}"
    assert all(a["measured_j"] > 0 for a in summary(d)["loop_area_by_frequency"]), context


def test_flexible_diagnosis_names_seal_friction(seed: int) -> None:
    # The flexible damper (two blow-off stages) can stand in for seal
    # friction: a first blow-off reached within a few mm/s behind a steep
    # bleed. On seed 1 the declared model then looked like noise (0.96 x)
    # and the diagnosis said "nothing left" before any candidate was tried,
    # and friction's Coulomb force was 2.3 errors from zero though it
    # gained 1,011 in BIC. The first round now always screens, and an
    # effect shows itself by what switching it off loses (measured on
    # seeds 1-6: friction named first and alone on all six).
    g = generate("friction", seed)
    d = diagnose([read_record(p) for p in g.records], ("heat_transfer", "real_gas"), flexible=True)
    context = f"seed={seed} verdict={d.verdict} found={d.found} truth={g.truth['hpctl_params']}"
    assert d.found and d.found[0] == "friction", context
    assert d.final.rms_ratio < d.initial.rms_ratio, context


def test_flexible_diagnosis_names_oil_compliance_on_damper_off_sines(seed: int) -> None:
    # The oil is a spring in series with the gas's whatever valve 5 does.
    # Until stop 32 the registry tried it only with a damper-on record: on
    # these three damper-off sines sensor offset and lag were named instead
    # with 49-99 x the noise left. Opening it was held back by slow fits,
    # which were the damper curve's inverse returning a wrong flow on some
    # fitted curves (fixed in hp-core; seeds 1, 2, 4: found, 0.98-1.04 x,
    # bulk modulus within 0.1 %, 22-41 s).
    g = short_case("oil_compliance", seed)
    d = diagnose([read_record(p) for p in g.records], ("heat_transfer", "real_gas"), flexible=True)
    context = describe(d, seed, g.truth)
    check_honest(d, g.truth, context)
    assert d.found and d.found[0] == "oil_compliance", context
    assert d.final.rms_ratio <= NOISE_CEILING, context
    est, err, true = (d.final.values["oil_bulk_modulus_pa"], d.final.stderr["oil_bulk_modulus_pa"],
                      g.truth["hpctl_params"]["oil_bulk_modulus_pa"])
    assert abs(est - true) <= max(2 * err, 0.1 * true), f"bulk modulus {est} +- {err} vs {true}; {context}"


def check_breakaway(r: Any, g: Any, seed: int) -> None:
    """A flexible fit's breakaway force against the foreign draw's: the
    Coulomb force's own error never offered, the breakaway force within 10 %
    or three errors of the truth's (or of the largest force its curve
    reaches), else the truth within the cost's three-sigma rise."""
    from hpctl.identify.derived import derived

    (d,) = [d for d in derived(r) if d.name == "friction_breakaway_n"]
    truth = g.truth["hpctl_params"]["friction_coulomb_n"] * g.truth["foreign_params"]["friction_static_ratio"]
    largest = draw_case("friction", seed).unit.effects.friction.peak_n()
    context = (f"seed={seed} breakaway {d.value:.1f} +- {d.stderr:.2g} truth {truth:.1f} (largest force {largest:.1f}); coulomb {r.values['friction_coulomb_n']:.1f} "
               f"+- {r.stderr['friction_coulomb_n']:.2g} truth {g.truth['hpctl_params']['friction_coulomb_n']:.1f}; "
               f"correlation {d.factor_correlation:+.2f}; {r.message}")
    # The Coulomb force's own error is never offered as one to stand behind.
    assert d.confounded and d.damper_shape, context
    # Where the truth's Stribeck velocity is within a few smoothing
    # velocities its curve never rises to F_c r: its largest force, which
    # the records show, is lower, and a fit may find either. On
    # FOREIGN_RIG_SEED=1681428444 (stop 65: Stribeck velocity 1.2 times the
    # smoothing) the curve rises to F_c = 988 N and never to F_c r = 1,220:
    # the first fit read F_c r = 1,029 (its own peak hidden too), the
    # restart, 1.6 lower in cost, 975 +- 12 (its Stribeck velocity 48 mm/s);
    # on seed 20 (1.8 times) the fit read F_c r within 1 % of the truth's
    # 562 N, whose largest force is 424. On 64 draws (seeds 1-20, 40 random,
    # and 109, 118, 2122707468, 1681428444; scripts/foreign_coverage.py) the
    # truth's largest force was under 0.9 F_c r on 12; the fitted F_c r was
    # within 10 % or three errors of F_c r or of the largest force on all
    # but 845385664, 977426417 and 109, whose held rises below are 0.04,
    # 5.1 and 7.9.
    if any(abs(d.value / t - 1.0) <= 0.10 or abs(d.value - t) <= 3.0 * d.stderr for t in (truth, largest)):
        return
    # Else the records must not tell the two apart: the model with the
    # truth's Coulomb force and ratio held (the rest fitted again, warm)
    # within the three-sigma rise of the cost (9; with two held it is a
    # stricter test than their 11.8). FOREIGN_RIG_SEED=109 (stop 42, the
    # same at stop 41's code): 142 +- 12 N against 235 N, a small friction
    # (190 N) smoothed over 2.9 mm/s with its peak under the smoothing; held
    # at the truth the cost rose about 8 (the viscous term 878 -> 0 N s/m,
    # the Stribeck velocity 8.3 -> 2.2 mm/s: a second valley the linear
    # error does not see). There the fit's stated error is too small: an
    # open defect (docs/foreign-rig.md, stop 42), which this test records
    # rather than hides.
    from hpctl.identify.profile import held_rise

    held = {"friction_coulomb_n": g.truth["hpctl_params"]["friction_coulomb_n"],
            "friction_stribeck_ratio": g.truth["foreign_params"]["friction_static_ratio"]}
    rise = held_rise(r, held)
    assert rise <= 9.0, context + f"; the cost rose {rise:.3g} with the truth's friction held"


def test_slow_sines_alone_identify_the_damper_beside_the_friction(seed: int) -> None:
    # The sweep's three slow sines only (0.01-0.1 Hz, up to 38 mm/s, valve 5
    # open): what a friction measurement runs. Their speeds never reach the
    # 50 mm/s that used to decide whether the damper's characteristic is
    # fitted, yet the foreign damper makes hundreds of newtons there: held
    # at the template's, it left the difference to the friction and the
    # breakaway force read 2-25 % low by 7-30 of its errors on seeds 1-5, 8,
    # 10 and 14 (stop 67, scripts/foreign_slow_sines.py --hold-damper).
    # Fitted, over five noise draws of each: 0-15 % low, its linear error
    # too small (seed 8: 12-15 % low, 3.5-4.5 errors, on four draws of six), the
    # truth within the cost's three-sigma rise (held at it, the cost rose
    # 2.3-7.3 on seed 8's draws): what the whole sweep's test asks (check_breakaway).
    from hpctl.identify import MAX_NFEV_FLEXIBLE
    from hpctl.identify.dataset import prepare, uses_damper
    from hpctl.identify.fit import fit

    g = generate("friction", seed, tests=[t for t in sweep_tests() if t.name in ("sine_0.01hz", "sine_0.03hz", "sine_0.1hz")])
    datasets = prepare([read_record(p) for p in g.records])
    assert uses_damper(datasets), f"seed={seed}"
    r = fit(datasets, ("heat_transfer", "real_gas", "friction"), flexible=True, max_nfev=MAX_NFEV_FLEXIBLE)
    assert r.model.fit_damper and any(name.startswith("damper_off_") for name in r.values), f"seed={seed}"
    check_breakaway(r, g, seed)
    check_breakaway_profile(r, g, seed)


def check_breakaway_profile(r: Any, g: Any, seed: int) -> None:
    """The breakaway force's profile on foreign data (stop 68: on 24 slow-sine
    fits it held the truth in 19 where the estimate +- 2 errors held 13; not
    asserted per draw, printed): an interval about the estimate unless it
    found the cost lower elsewhere (which it says); and the product held at
    the truth's by the tie costs what the two factors held there cost (the
    tied fit started where that one ended ends no higher). A profile point
    itself is a local fit, from two starts: it can end above the lowest
    Stribeck ratio's (FOREIGN_RIG_SEED=1599396050: 2.23 at the truth's
    product where both factors held at the truth's rose 1.66), which would
    make the interval narrower than the cost's."""
    from hpctl.identify.derived import derived
    from hpctl.identify.fit import Tie
    from hpctl.identify.profile import _refit, cost, profile_interval

    (d,) = [d for d in derived(r) if d.name == "friction_breakaway_n"]
    truth = g.truth["hpctl_params"]["friction_coulomb_n"] * g.truth["foreign_params"]["friction_static_ratio"]
    iv = profile_interval(r, "friction_breakaway_n")
    context = f"seed={seed} {iv.describe()} truth {truth:.1f}: {'held' if iv.covers(truth) else 'missed'} (linear +- {2 * d.stderr:.3g})"
    print(context)
    if iv.better_found is None:
        assert (iv.lower is None or iv.lower < d.value) and (iv.upper is None or d.value < iv.upper), context
    both = {"friction_coulomb_n": g.truth["hpctl_params"]["friction_coulomb_n"],
            "friction_stribeck_ratio": g.truth["foreign_params"]["friction_static_ratio"]}
    held = _refit(r, both, {**r.values, **both})
    tied = _refit(r, {}, held.values, Tie("friction_coulomb_n", truth, ("friction_stribeck_ratio",)))
    # (F_c = B / r reproduces the held Coulomb force to its last bits; the
    # optimiser takes no step that raises the cost.)
    assert cost(tied, tied.values) <= cost(held, held.values) + 1e-6, context


def test_a_damper_fitted_without_friction_says_when_it_took_the_seals(seed: int, tmp_path: Path) -> None:
    # The slow sines alone, fitted by the flexible model without friction:
    # its damper can make a step at no flow and take the seal's force into
    # its curve, the residual at the noise (draw 3: 305 N at 2 mm/s against
    # the template's 15, 0.99 x the noise; stop 67). The records cannot tell
    # the two apart. Such a fit is never silent about the seal wherever the
    # seal's own force at 2 mm/s is well above the warning's threshold
    # (twice it here, by the true noise: a small seal smoothed over 3 mm/s
    # under a noisy load cell shows less): at the noise, the warning says
    # the fitted curve holds such a step; where the damper could not take it
    # all (FOREIGN_RIG_SEED=1695540960: a 175 N seal, 183 N taken in
    # compression only, 1.41 x the noise) the residual's warning says the
    # model misses something. On the draw's control, neither.
    from hpctl.identify.no_flow import NO_FLOW_NOISES, NO_FLOW_SPEED_M_S

    slow = [t for t in sweep_tests() if t.name in ("sine_0.01hz", "sine_0.03hz", "sine_0.1hz")]
    for effect in ("friction", None):
        g = generate(effect, seed, tests=slow)
        out = tmp_path / f"fit-{effect}"
        r = CliRunner().invoke(cli_main, ["fit", *[str(p) for p in g.records], "--model", "seed", "--flexible", "--out", str(out), "--json", "--quiet"])
        assert r.exit_code == 0, r.stderr
        warnings = json.loads(r.stdout)["warnings"]
        warned = [w for w in warnings if w["code"] == "damper_force_at_no_flow"]
        structured = [w for w in warnings if w["code"] == "residual_structured"]
        context = f"seed={seed} effect={effect}: {[w['message'] for w in warned + structured]}"
        if effect is None:
            assert not warned, context
            continue
        case = draw_case("friction", seed)
        seal = float(case.unit.effects.friction.force_n(np.array([NO_FLOW_SPEED_M_S]))[0])
        if seal <= 2.0 * NO_FLOW_NOISES * case.data_system.force.sigma:
            continue
        assert warned or structured, context
        for w in warned:
            assert w["details"]["branches"] and all(x > w["details"]["noise_n"] * NO_FLOW_NOISES for x in w["details"]["force_n"]), context


def test_flexible_fit_determines_the_breakaway_friction(seed: int) -> None:
    # Seal friction's kinetic (Coulomb) level acts where the damper's force
    # is comparable or several times larger, and the flexible fit tells it
    # apart from the damper's low-speed curve and the Stribeck peak by the
    # shapes it assumes: on seeds 1-20 (docs/foreign-rig.md, stop 35;
    # scripts/foreign_coverage.py) F_c read 60 % low to 22 % high, z up to
    # 3.7, at correlations with the Stribeck ratio of -0.95 to -1.00 on 10.
    # The breakaway force F_c r is what the records determine: within 10 %
    # on 19 of the 20, within two errors on 17, and within 10 % or three
    # errors on all 20 (three sigma here: two would fail an honest error
    # one run in twenty); the budget of `hpctl fit --flexible` (300).
    from hpctl.identify import MAX_NFEV_FLEXIBLE
    from hpctl.identify.dataset import prepare
    from hpctl.identify.fit import fit

    g = generate("friction", seed)
    r = fit(prepare([read_record(p) for p in g.records]), ("heat_transfer", "real_gas", "friction"), flexible=True, max_nfev=MAX_NFEV_FLEXIBLE)
    check_breakaway(r, g, seed)


def test_a_seal_whose_stribeck_peak_hides_under_its_smoothing_reads_its_largest_force() -> None:
    # FOREIGN_RIG_SEED=1681428444 (CI, stop 65): Stribeck velocity 3.5 mm/s,
    # 1.2 times the smoothing; the curve rises to F_c = 988 N and never to
    # F_c r = 1,220 N. The fit read 975 +- 12 N (README's example): the
    # force the seal exerts, which the test above takes as a truth too.
    from hpctl.identify import MAX_NFEV_FLEXIBLE
    from hpctl.identify.dataset import prepare
    from hpctl.identify.derived import derived
    from hpctl.identify.fit import fit

    seed = 1681428444
    g = generate("friction", seed)
    friction = draw_case("friction", seed).unit.effects.friction
    largest = friction.peak_n()
    assert largest == pytest.approx(friction.coulomb_n, rel=1e-6) and largest < 0.85 * friction.coulomb_n * friction.static_ratio
    r = fit(prepare([read_record(p) for p in g.records]), ("heat_transfer", "real_gas", "friction"), flexible=True, max_nfev=MAX_NFEV_FLEXIBLE)
    (d,) = [d for d in derived(r) if d.name == "friction_breakaway_n"]
    assert abs(d.value / largest - 1.0) <= 0.05 and abs(d.value - largest) <= 3.0 * d.stderr, (d, largest)


def test_fit_cli_reports_the_breakaway_force_and_warns_when_its_factors_trade(tmp_path: Path) -> None:
    # Seed 5 (measured, stop 35): Coulomb force 1,091 +- 71 N against a true
    # 892 (z +2.8), Stribeck ratio 1.107 against 1.348, correlation -1.00;
    # their product 1,207 +- 5 N against 1,202. fit.json and fit.md carry the
    # product, and the trade is a warning naming both and the product.
    g = generate("friction", 5)
    out = tmp_path / "fit"
    r = CliRunner().invoke(cli_main, ["fit", *[str(p) for p in g.records], "--model", "seed,friction", "--flexible", "--out", str(out),
                                      "--json", "--quiet"])
    assert r.exit_code == 0, r.stderr
    s = json.loads(r.stdout)
    (d,) = s["derived"]
    fc, ratio = s["params"]["friction_coulomb_n"], s["params"]["friction_stribeck_ratio"]
    assert d["name"] == "friction_breakaway_n" and d["factors"] == ["friction_coulomb_n", "friction_stribeck_ratio"]
    assert d["value"] == pytest.approx(fc * ratio, rel=1e-12) and 0 < d["stderr"] < s["stderr"]["friction_coulomb_n"]
    truth = g.truth["hpctl_params"]["friction_coulomb_n"] * g.truth["foreign_params"]["friction_static_ratio"]
    assert abs(d["value"] - truth) <= 3 * d["stderr"], (d, truth)
    (w,) = [w for w in s["warnings"] if w["code"] == "confounded"]
    assert w["details"]["params"] == d["factors"] and w["details"]["correlation"] == pytest.approx(d["factor_correlation"])
    assert abs(d["factor_correlation"]) >= 0.95 and w["details"]["damper_shape"] is True and d["confounded"] is True
    assert "friction_breakaway_n = " in w["message"] and "correlation is" in w["message"] and "damper" in w["message"]
    # Its error is not offered as one beyond the model's shapes either (stop 67).
    assert "rests on the damper's shapes and priors" in w["message"]
    # ... and the command that gives its honest band (not asked for here).
    assert "--profile friction_breakaway_n" in w["message"]
    assert "| `friction_breakaway_n` |" in (out / "fit.md").read_text()


def test_a_flexible_fit_with_its_stribeck_peak_under_the_smoothing_is_restarted(monkeypatch: pytest.MonkeyPatch) -> None:
    # Seed 2122707468 (found on a random draw, stop 35): the flexible fit
    # started from the static fit's Coulomb force alone stopped with the
    # Stribeck velocity at 1.5 mm/s, next to the smoothing velocity (1.4),
    # where the force never reaches F_c r: the breakaway force read +12.4 %
    # (291 +- 56 N against 259). Restarted from a peak above the smoothing
    # it ends at a lower cost and within 3 %. The static fit now starts the
    # friction's shape too, and from there the fit stays out of that valley
    # (6.5 mm/s against a smoothing of 1.2; stop 42) at a cost lower still
    # (5,921.1 against the restart's 5,924.3), the breakaway force 8 % low
    # (238 +- 8 N): at the noise either way (0.992 x), the records pin it
    # no closer than the damper's shape lets (the test above's claim):
    # asserted first; the restart then on the start as it was.
    from hpctl.identify import MAX_NFEV_FLEXIBLE, damper_start
    from hpctl.identify.dataset import prepare
    from hpctl.identify.derived import derived
    from hpctl.identify.fit import STRIBECK_VALLEY_RATIO, _fit, fit, objective

    g = generate("friction", 2122707468)
    datasets = prepare([read_record(p) for p in g.records])
    model = ("heat_transfer", "real_gas", "friction")
    truth = g.truth["hpctl_params"]["friction_coulomb_n"] * g.truth["foreign_params"]["friction_static_ratio"]
    defaults = {k: q.default for k, q in inspect.signature(fit).parameters.items() if q.kind is q.KEYWORD_ONLY}
    now = _fit(datasets, model, **{**defaults, "flexible": True, "max_nfev": MAX_NFEV_FLEXIBLE})  # fit without the restart
    v = now.values
    assert v["friction_stribeck_velocity_m_s"] >= STRIBECK_VALLEY_RATIO * v["friction_smoothing_velocity_m_s"], v
    (d,) = derived(now)
    assert abs(d.value / truth - 1.0) <= 0.10, (d, truth)
    monkeypatch.setattr(damper_start, "_FRICTION_SHAPE", ())  # the static fit without the friction's shape
    first = _fit(datasets, model, **{**defaults, "flexible": True, "max_nfev": MAX_NFEV_FLEXIBLE})
    v = first.values
    assert v["friction_stribeck_velocity_m_s"] < STRIBECK_VALLEY_RATIO * v["friction_smoothing_velocity_m_s"], v
    r = fit(datasets, model, flexible=True, max_nfev=MAX_NFEV_FLEXIBLE)
    assert "restarted with the Stribeck peak above the smoothing velocity" in r.message and "lower, kept" in r.message, r.message
    assert objective(r) < objective(first)
    (d,) = derived(r)
    assert abs(d.value / truth - 1.0) <= 0.05, (d, truth)


def found_first_at_the_noise(effect: str, seed: int) -> tuple[Any, Diagnosis, str]:
    """The flexible diagnosis of the foreign rig's ``effect`` (:func:`effect_case`),
    checked on what the issue asks of every effect: the judgement honest,
    the effect named first, the residual within hpctl's ceiling. Returns
    the case, the diagnosis and the context to print on a failure."""
    g = effect_case(effect, seed)
    d = diagnose([read_record(p) for p in g.records], ("heat_transfer", "real_gas"), flexible=True)
    context = describe(d, seed, g.truth)
    check_honest(d, g.truth, context)
    assert d.found and d.found[0] == effect, context
    assert d.final.rms_ratio <= NOISE_CEILING, context
    return g, d, context


def estimate(d: Diagnosis, g: Any, name: str) -> tuple[float, float, float]:
    """A parameter's estimate, its standard error and the truth."""
    return d.final.values[name], d.final.stderr[name], g.truth["hpctl_params"][name]


@pytest.mark.parametrize("effect", ["sensor_offset", "sensor_lag"])
def test_flexible_diagnosis_names_a_sensor_effect_at_the_noise_with_its_parameters(effect: str, seed: int) -> None:
    # The criteria on a random draw: named first, the residual at
    # the noise (hpctl's ceiling, and the noise the foreign rig drew), each
    # parameter within 10 % or three errors (two would fail honest errors
    # one run in twenty per parameter). The foreign rig gives each of its
    # three transducers its own offset and lags force and both pressures
    # through one filter of its own (tests/foreign_rig/sensors.py).
    # Measured on the short sweep (stop 36, seeds 11 and 12): found alone,
    # 0.98-1.10 x the noise, every parameter within 0.7 % and 2 errors,
    # 24-69 s.
    g, d, context = found_first_at_the_noise(effect, seed)
    for p in LIBRARY[effect].params:
        est, err, true = estimate(d, g, p.name)
        assert abs(est - true) <= max(3.0 * err, 0.1 * abs(true)), f"{p.name} {est} +- {err} vs {true}; {context}"


def test_flexible_diagnosis_names_valve_lag_at_the_noise_with_its_time_constant(seed: int) -> None:
    # Valve lag on three sines and the switching record (valve 6 toggled
    # every 1.3 s during a 0.8 Hz sine): named first, the residual within
    # hpctl's ceiling, the valve's time constant within 10 % or three
    # errors. Measured (stop 36): 11 draws, 1.006-1.14 x the noise, the time
    # constant within 5.3 %; seed 11 read 1.41 x with "structure remains"
    # before the switch places' extrapolation (test_flexible_fit.py::
    # test_switch_places_that_trade_with_the_valve_reach_their_end). What
    # remains above 1.1 x is reported as structure (seeds 3, 11, 20), and a
    # second effect may follow (seed 3: a sensor offset).
    g, d, context = found_first_at_the_noise("valve_lag", seed)
    est, err, true = estimate(d, g, "valve_time_constant_s")
    assert abs(est - true) <= max(3.0 * err, 0.1 * true), f"valve tau {est} +- {err} vs {true}; {context}"


def test_flexible_diagnosis_names_a_leak_at_the_noise_with_honest_errors(seed: int) -> None:
    # Leakage on three sines and a 900 s hold with the strut compressed
    # (the foreign rig's permeation leak, dm/dt = -(m0 / tau_L) r): named
    # first, the residual within hpctl's ceiling, and the time constant
    # within 10 % *and* three errors. Before the flexible model fitted the
    # leak's mass exponent (stop 37) tau_L was short by the gas lost over
    # the hold, with errors far too narrow: seed 11 -1.25 % at z -19, seed
    # 12 -0.63 % at z -3.9; with it -0.13 % (z -1.55) and -0.12 % (z -0.51),
    # seeds 1-5 within 0.41 % and z -0.83 to +1.07, 1.02-1.04 x the noise;
    # 32-200 s a diagnosis alone. Seed 11's large accumulator's pressure on
    # the 0.3 Hz sine is 1.302 x its noise, so the verdict says structure
    # remains there (the true noise's ratio 1.075): reported, not asserted
    # away.
    g, d, context = found_first_at_the_noise("leakage", seed)
    est, err, true = estimate(d, g, "leak_time_constant_s")
    assert abs(est / true - 1.0) <= 0.1 and abs(est - true) <= 3.0 * err, f"tau_L {est} +- {err} vs {true}; {context}"


def test_flexible_diagnosis_names_heat_build_up_at_the_noise(seed: int) -> None:
    # Heat build-up on three sines and the 10-minute heat run (0.5 Hz, 60
    # mm, the damper on): named first, the residual within hpctl's ceiling,
    # the wall's heat capacity (what the gas's own heat warms) within 10 %
    # or three errors, the oil's within 10 % or three errors. The wall-to-
    # oil time constant's honest band is its profile, not its linear error
    # (test_flexible_fit.py::test_flexible_model_warms_the_gas_wall_with_the_gas_heat
    # asserts it on a fit); here it is reported, not asserted. Measured
    # (stop 37, seed 7, under load): named first (BIC -373,400 against
    # -1,823 for the next candidate), 0.988 x the noise, worst channel
    # 1.13, "nothing left"; wall +0.15 % (2.8 errors), oil +9.0 % (0.89
    # errors), wall-to-oil -33 % (2.3 errors); seed 725172577 passed (902 s
    # beside a CI run). 445 s a diagnosis alone (stop 33), the longest of
    # the foreign cases: about 7 of CI's 25-odd minutes.
    g, d, context = found_first_at_the_noise("heat_buildup", seed)
    est, err, true = estimate(d, g, "wall_heat_capacity_j_per_k")
    assert abs(est - true) <= max(3.0 * err, 0.1 * true), f"wall_heat_capacity_j_per_k {est} +- {err} vs {true}; {context}"
    # The oil's heat capacity trades with the wall-to-oil time constant
    # along a bending valley: its linear error missed the truth by 4.4 on
    # FOREIGN_RIG_SEED=541759892 (+133 %; wall-to-oil -77 %, 13 errors),
    # where the cost with it held at the truth rose 4.6 (6.2 for the wall-
    # to-oil), inside the three-sigma profile interval. Its honest band is
    # that profile, and the diagnosis says so (a profile_band warning for
    # both); within 10 % needs no profile.
    est, err, true = estimate(d, g, "oil_heat_capacity_j_per_k")
    if abs(est - true) > 0.1 * true:
        rise = profile_point(d.final, "oil_heat_capacity_j_per_k", true).rise
        assert rise <= 9.0, f"oil_heat_capacity_j_per_k {est} +- {err} vs {true}: the cost rose {rise:.3g} there; {context}"
    from hpctl.cli.calibrate import _diagnosis_caveats

    banded = {c.details["param"] for c in _diagnosis_caveats(d) if c.code == "profile_band"}
    assert {"oil_heat_capacity_j_per_k", "wall_to_oil_tau_s"} <= banded, context


def test_a_walk_toward_a_log_scaled_null_far_worse_than_the_model_is_not_waited_out(monkeypatch: pytest.MonkeyPatch) -> None:
    # A draw of the heat build-up test above (stop 72): oil compliance's
    # screening (the oil rigid in the rig) walked the modulus from 1.00 to
    # 1.86 GPa in 37 finite-difference Jacobians, 18 to 5 times the model's
    # residual sum of squares all the way, 140 s of the diagnosis's 161.
    # On a log scale FAR_WORSE now ends such a walk anywhere
    # (diagnose.at_null_and_no_better): the same rejection, stopped heading
    # for its null, in a few Jacobians. Counted, not timed.
    from hpctl.identify import diagnose as dg
    from hpctl.identify import fit as fit_module
    from hpctl.identify.dataset import prepare

    g = effect_case("heat_buildup", 1455421066)
    declared = ("heat_transfer", "real_gas")
    current = fit_module.fit(prepare([read_record(p) for p in g.records]), declared, flexible=True)
    sets: list[int] = []
    simulate = fit_module.simulate_all

    def counted(*args: Any, **kwargs: Any) -> Any:
        sets.append(len(args[2]))
        return simulate(*args, **kwargs)

    monkeypatch.setattr(fit_module, "simulate_all", counted)
    c = dg._try(current.datasets, current, declared, ("oil_compliance",))
    jacobians = sum(1 for k in sets if k > 1)
    context = f"{c.result.message}; {c.result.rss / current.rss:.3g} x the model's residual; {jacobians} Jacobians; {c.result.values['oil_bulk_modulus_pa']:.4g} Pa"
    assert c.stopped_at_null and c.delta_bic < -dg.BIC_STRONG and c.result.rss > current.rss, context
    assert jacobians <= 4, context


def test_a_damper_that_took_the_seal_in_after_an_accepted_effect_is_screened_for_friction(tmp_path: Path) -> None:
    # FOREIGN_RIG_SEED=12's seal (638 N Coulomb) from real gas alone (the
    # draw of test_flexible_diagnosis_does_not_take_friction_for_heat_transfer
    # that failed before stop 71): heat transfer was
    # accepted in round 1 at 1.06 x the noise, the flexible damper making
    # 593 N at 2 mm/s where the template makes a few, and the diagnosis
    # stopped there ("effects found", no friction), since later rounds
    # ended at the noise. Such a round now screens what makes a force at no
    # flow, friction and sensor offsets, and only those.
    from hpctl.data.output import OutputDir
    from hpctl.identify.no_flow import NO_FLOW_EFFECTS, force_at_no_flow
    from hpctl.report.calibration import diagnosis_report

    g = generate("friction", 12)
    lines: list[str] = []
    d = diagnose([read_record(p) for p in g.records], ("real_gas",), flexible=True, progress=lines.append)
    context = describe(d, 12, g.truth) + "\n" + "\n".join(lines)
    check_honest(d, g.truth, context)
    assert d.found == ["heat_transfer", "friction"], context
    first, second = d.rounds[0], d.rounds[1]
    assert first.judgement is not None and first.judgement.at_noise and force_at_no_flow(second.before), context
    assert sorted(c.effect for c in second.candidates) == sorted(NO_FLOW_EFFECTS), context
    assert any(line.startswith("round 2/6: at the noise, but the fitted damper makes a force at no flow") for line in lines), context
    # With friction in the model the damper holds none: nothing more screened.
    assert not force_at_no_flow(d.final) and d.rounds[-1].candidates == [], context
    # Why that round screened is in the JSON and the report.
    assert second.no_flow == force_at_no_flow(second.before) and not first.no_flow, context
    [step] = [s for s in summary(d)["effects"] if s["effect"] == "friction"]
    assert [f["branch"] for f in step["force_at_no_flow"]] == [f.branch for f in second.no_flow], context
    assert all(not s["force_at_no_flow"] for s in summary(d)["effects"] if s["effect"] != "friction"), context
    with OutputDir(tmp_path, "diagnose") as out:
        report = diagnosis_report(d, out)
    text = (tmp_path / report.name).read_text(encoding="utf-8")
    assert text.count("The model was at the noise, but its fitted damper made a force at no flow") == 1, context

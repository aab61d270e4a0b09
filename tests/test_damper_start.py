"""The flexible damper's static start (hpctl.identify.damper_start): hp-core's
curve as Python sees it, and the curve fitted to the foreign rig's records
against the foreign rig's own damper (which shares no code with hp-core)."""

from __future__ import annotations

import dataclasses
import os
import secrets
import sys
import threading
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import numpy as np
import pytest
from scipy.signal import savgol_coeffs, savgol_filter

from foreign_rig import extra_tests, generate, sweep_tests
from foreign_rig.damper import Damper as ForeignDamper
from foreign_rig.draw import draw_case
from hpctl import _core
from hpctl._coretypes import UnitDict
from hpctl._effect_params import Friction
from hpctl.data.records import read_record
from hpctl.errors import ParameterError
from hpctl.identify import damper_start, damper_static, workers
from hpctl.identify import fit as fit_module
from hpctl.identify.blas import one_blas_thread
from hpctl.identify.dataset import Dataset, carry_input_noise, measured_datasets, prepare
from hpctl.identify.diagnose import NOISE_CEILING, diagnose
from hpctl.identify.fit import fit, model_for, rss_at
from hpctl.model.effects import FRICTION_SMOOTHING_VELOCITY_M_S, shaped_damper
from hpctl.model.unit import Unit

SHORT = ("sine_0.03hz", "sine_0.3hz", "sine_1hz")


def _dict(damper: object) -> dict[str, object]:
    return dataclasses.asdict(damper)  # type: ignore[call-overload, no-any-return]


def test_the_core_drop_is_the_curve_per_branch_and_blend() -> None:
    # Below the blow-off every branch is R q + K q^2 (hp_core::damper's
    # definition, written out here); the sign of the flow picks the
    # direction, valve 5 open by a fraction blends the two states' drops.
    d = Unit.seed().damper
    for bypass, (comp, reb) in ((0.0, (d.on_compression, d.on_rebound)), (1.0, (d.off_compression, d.off_rebound))):
        for sign, c in ((1.0, comp), (-1.0, reb)):
            # A flow well below the blow-off flow of the sharp curve.
            q_b = 2.0 * c.blowoff_pa / (c.bleed_pa_s_per_m3 + np.sqrt(c.bleed_pa_s_per_m3**2 + 4.0 * c.orifice_pa_s2_per_m6 * c.blowoff_pa))
            q = np.linspace(0.0, 0.5 * q_b, 7)
            dp = _core.damper_pressure_drop_pa(_dict(d), sign * q, bypass)  # type: ignore[arg-type]
            np.testing.assert_allclose(dp, sign * (c.bleed_pa_s_per_m3 * q + c.orifice_pa_s2_per_m6 * q * q), rtol=1e-12)
    q = np.array([-2e-4, 3e-4])
    on, off = (_core.damper_pressure_drop_pa(_dict(d), q, b) for b in (0.0, 1.0))  # type: ignore[arg-type]
    np.testing.assert_allclose(_core.damper_pressure_drop_pa(_dict(d), q, 0.25), on + 0.25 * (off - on), rtol=1e-12)  # type: ignore[arg-type]


@pytest.mark.parametrize(("change", "names"), [
    (lambda d, q, b: (d, [1e-4, float("nan")], b), ("q_m3_s[1]", "nan")),
    (lambda d, q, b: (d, [1e-4, float("inf")], b), ("q_m3_s[1]", "inf")),
    (lambda d, q, b: (d, q, 1.5), ("bypass_open", "1.5")),
    (lambda d, q, b: ({**d, "on_compression": {**d["on_compression"], "bleed_pa_s_per_m3": -1.0}}, q, b), ("bleed_pa_s_per_m3", "-1")),
    (lambda d, q, b: ({k: v for k, v in d.items() if k != "off_rebound"}, q, b), ("damper.off_rebound",)),
    (lambda d, q, b: ({**d, "spare": {}}, q, b), ("damper.spare",)),
])
def test_the_core_drop_refuses_bad_input_naming_it(change: object, names: tuple[str, ...]) -> None:
    args = change(_dict(Unit.seed().damper), [1e-4], 0.0)  # type: ignore[operator]
    with pytest.raises(ParameterError) as e:
        _core.damper_pressure_drop_pa(*args)
    assert isinstance(e.value, ValueError)
    for n in names:
        assert n in str(e.value).lower(), str(e.value)


@pytest.fixture
def seed() -> int:
    return int(os.environ.get("FOREIGN_RIG_SEED", secrets.randbelow(2**31)))


def _true_force_n(effect: str | None, seed: int, branch: str, q_m3_s: np.ndarray, area_m2: np.ndarray) -> np.ndarray:
    """The foreign rig's damper force plus its friction's (its own
    formulas: a Stribeck peak, its own smoothing), at the flows given."""
    unit = draw_case(effect, seed).unit
    bypass = 0.0 if branch.startswith("on_") else 1.0
    force = np.array([ForeignDamper(unit.damper).drop(float(q), bypass) for q in q_m3_s]) * area_m2
    f = unit.effects.friction
    if f is not None:
        assert f.pressure_coefficient == 0.0  # the foreign rig's friction case draws none
        force = force + f.force_n(q_m3_s / area_m2)
    return np.asarray(force)


def _static_unit(values: dict[str, float]) -> UnitDict:
    """The seed unit with the friction the static fit found in ``values``."""
    friction = Friction(values.get("friction_coulomb_n", 0.0), 0.0, values.get("friction_smoothing_velocity_m_s", FRICTION_SMOOTHING_VELOCITY_M_S),
                        values.get("friction_stribeck_ratio", 1.0), values.get("friction_stribeck_velocity_m_s", 0.01))
    return Unit.seed().with_effects(friction=friction).to_dict()


def _curve_forces_n(datasets: list[Dataset], values: dict[str, float], branch: str, s: damper_static.Samples) -> dict[str, np.ndarray]:
    """hpctl's force at one branch's samples: the nominal curve's, and the
    static fit's ``values`` with the friction it found (hp-core's law)."""
    unit = _static_unit(values)
    bypass = 0.0 if branch.startswith("on_") else 1.0
    out = {}
    for name, v in (("nominal", {}), ("static", values)):
        out[name] = s.area_m2 * _core.damper_pressure_drop_pa(_dict(shaped_damper(datasets[0].base.damper, v)), s.q_m3_s, bypass)  # type: ignore[arg-type]
    out["static"] = out["static"] + _core.friction_force_n(unit, s.q_m3_s / s.area_m2)
    return out


#: The static fit's RMS distance from the foreign rig's force, in the
#: samples' noise: measured 0.13-0.41 without friction (seeds 1, 2, 3, 7;
#: 0.3 Hz sweeps and the heat run); with friction 0.07-0.45 (seeds 1-3, 7,
#: 100-119, 200-204, 345813898; the nominal curve 14-78), since the static
#: fit takes the friction's Stribeck peak and smoothing as the model has
#: them. With the Coulomb force alone it had been 0.13-5.15 (seed
#: 345813898: a peak of 1.35 x 1,063 N over 8 mm/s).
STATIC_CEILING = 1.0
#: The static fit's largest friction force (over the speeds) against the
#: foreign friction's (its Stribeck peak as its own smoothing lets it
#: rise; its viscous part, a force in proportion to the speed, is the
#: bleed's to take up beside a friction without one, as the static fit
#: has): the slow samples the force is judged on sit below the Stribeck
#: velocity, where the two frictions' shapes differ and a damper's
#: blow-off at low flow can take up part of a small friction. Measured
#: 0.67-1.02 on the seeds above and 300-479 (the low end where the
#: friction is small, 160-270 N, and rises over 2-3 mm/s); asserted with
#: a margin.
PEAK_BAND = (0.6, 1.1)


@pytest.mark.parametrize(("effect", "effects"), [(None, ()), ("friction", ("friction",)), ("sensor_offset", ("sensor_offset",))])
def test_the_static_fit_follows_the_foreign_rigs_damper(effect: str | None, effects: tuple[str, ...], seed: int) -> None:
    # The foreign rig's damper (two washer stacks opening progressively, a
    # bleed hole, a bypass, its own line losses) against hpctl's family,
    # fitted to the records' force less the gas's: over every branch's
    # samples the curve (with the Coulomb friction where the model has it)
    # within the records' noise of the foreign rig's true force, where the
    # nominal curve is ten and more times the noise off. With friction in
    # the model its Coulomb force is shared by the branches, with a sensor
    # offset a constant; without, neither: the curves may not move to make
    # up a force the model cannot make.
    g = generate(effect, seed, tests=[t for t in sweep_tests() if t.name in SHORT])
    datasets = prepare([read_record(p) for p in g.records])
    model = model_for(datasets, ("heat_transfer", "real_gas", *effects), flexible=True)
    values = damper_start.static_damper_values(datasets, model.params, model.effects)
    context = f"FOREIGN_RIG_SEED={seed} ({effect}): "
    assert {p.name for p in model.params if p.name.startswith("damper_")} <= set(values), context
    for branch in model.damper_branches:
        s = damper_start._branch_samples(datasets, branch)
        assert s is not None, context + branch
        true = _true_force_n(effect, seed, branch, s.q_m3_s, s.area_m2)
        errors = {name: float(np.sqrt(np.mean((force - true) ** 2)) / np.median(s.sigma_n))
                  for name, force in _curve_forces_n(datasets, values, branch, s).items()}
        context += f"{branch} {errors['nominal']:.1f} -> {errors['static']:.2f} x the noise; "
        assert errors["static"] <= STATIC_CEILING, context
        assert errors["nominal"] > 5.0 * errors["static"], context
    if effect == "friction":
        # The peak and smoothing the static fit found start the model's.
        assert {"friction_coulomb_n", "friction_stribeck_ratio", "friction_stribeck_velocity_m_s", "friction_smoothing_velocity_m_s"} <= set(values)
        v = np.linspace(1e-5, 0.05, 5000)
        peak = float(np.max(_core.friction_force_n(_static_unit(values), v)))
        true_peak = float(np.max(draw_case(effect, seed).unit.effects.friction.force_n(v, viscous=False)))
        assert PEAK_BAND[0] <= peak / true_peak <= PEAK_BAND[1], context + f"largest friction {peak:.0f} N against the truth's {true_peak:.0f} N"
    else:
        assert "friction_coulomb_n" not in values, context
    if effect == "sensor_offset":
        # The constant the force less the gas's shows: the force
        # transducer's offset less the pressure transducer's on the piston
        # (measured within 2.4-5.1 N, 0.06-0.3 x the noise: seeds 1, 2, 7).
        t, area = g.truth["hpctl_params"], datasets[0].base.piston_area_m2
        offset = t["sensor_force_offset_n"] - area * t["sensor_pressure_offset_pa"]
        noise = float(np.median(np.hypot([d.sigma["force_n"] for d in datasets], [area * d.sigma["p_gas_pa"] for d in datasets])))
        assert abs(values["sensor_force_offset_n"] - offset) <= noise, context + f"offset {values['sensor_force_offset_n']:.1f} N against {offset:.1f}"
    assert ("sensor_force_offset_n" in values) == (effect == "sensor_offset"), context


#: The static fit on SDOF steps alone, against the foreign rig's true
#: damper and friction force over the steps' samples, pooled over the
#: branches, in the errors :func:`damper_start._strut_force` gives the
#: samples (the body's acceleration's: its displacement's noise and the
#: clock's jitter at its speed; the pressure's). Measured over 52 draws
#: each without an effect, with friction and with a sensor offset (seeds
#: 1-45, 23, 37, 59, 97, 345813898, 425861063, 541218712): the curve
#: 0.10-2.52, the samples 0.35-5.6 and at least 1.51 x the curve's, the
#: nominal curve 0.35-43 and at least 2.58 x the curve's. The samples are
#: off by more than their errors where the acceleration is taken across
#: the step's corners or the strut's reversal (damper_start's comment on
#: SDOF_ACCEL_WINDOW), so no bound in their errors holds for the curve;
#: what is asserted is that it follows the truth more closely than the
#: samples it was fitted to and than the nominal curve. Until stop 64 the
#: errors left the clock's jitter out (at 0.4 m/s, 70 us is 28 um of the
#: body's displacement against 2.5 um of noise): CI's draw
#: FOREIGN_RIG_SEED=541218712 read the samples 6.35 x their errors off
#: and the curve fitted to them 6.56 (now 1.78 and 0.64).


@pytest.mark.parametrize(("effect", "effects"), [(None, ()), ("friction", ("friction",)), ("sensor_offset", ("sensor_offset",))])
def test_the_static_fit_reads_the_damper_from_an_sdof_bodys_motion(effect: str | None, effects: tuple[str, ...], seed: int) -> None:
    # No transducer measures an SDOF record's strut force, but the body's
    # weight and inertia are that force, m (g + a), and the steps drive the
    # damper at up to about 1.2 m/s: the foreign rig's SDOF steps (hard
    # spring, damper off and on) alone give every branch samples, and the
    # curve fitted to them (with the Coulomb friction where the model has
    # it) follows the foreign rig's true force (its own damper and
    # friction formulas) more closely than those samples do, the noise
    # averaged out, and than the nominal curve (the comment above the test
    # has the numbers).
    g = generate(effect, seed, tests=[t for t in extra_tests()["sdof_all"] if "_hard_" in t.name])
    datasets = prepare([read_record(p) for p in g.records])
    assert {d.record.kind for d in datasets} == {"sdof"}
    model = model_for(datasets, ("heat_transfer", "real_gas", *effects), flexible=True)
    values = damper_start.fit_static_damper(datasets, model.params, model.effects)
    context = f"FOREIGN_RIG_SEED={seed} ({effect}): "
    # A pressure transducer's offset is in every sample (the force is the
    # body's less the measured gas's), and nothing of an SDOF record tells
    # it from the damper's force (the static fit takes a force transducer's
    # offset only): samples and curves are held to what the samples read
    # without noise.
    pressure_offset_pa = g.truth["hpctl_params"].get("sensor_pressure_offset_pa", 0.0) if effect == "sensor_offset" else 0.0
    off: dict[str, list[np.ndarray]] = {"nominal": [], "static": [], "samples": []}
    for branch in model.damper_branches:
        s = damper_start._branch_samples(datasets, branch)
        if s is None:
            # A friction large enough stops the body before a branch has
            # enough samples at speed; that branch keeps its start.
            assert not any(k.startswith(f"damper_{branch}_") for k in values), context + branch
            continue
        assert not s.transducer.any(), context + "the force comes from the body, not a transducer"
        assert {p.name for p in model.params if p.name.startswith(f"damper_{branch}_")} <= set(values), context + branch
        true = _true_force_n(effect, seed, branch, s.q_m3_s, s.area_m2) - s.area_m2 * pressure_offset_pa
        for name, force in _curve_forces_n(datasets, values, branch, s).items():
            off[name].append((force - true) / s.sigma_n)
        off["samples"].append((s.force_n - true) / s.sigma_n)
    assert off["static"], context + "no branch has samples"
    rms = {k: float(np.sqrt(np.mean(np.concatenate(v) ** 2))) for k, v in off.items()}
    context += ", ".join(f"{k} {v:.2f}" for k, v in rms.items()) + " x the noise off the truth"
    assert rms["static"] < rms["samples"], context
    assert rms["nominal"] > rms["static"], context
    assert "sensor_force_offset_n" not in values or values["sensor_force_offset_n"] == 0.0, context


def test_a_flexible_fit_says_where_its_damper_started(seed: int) -> None:
    # Its message says so, and the start it took has the lower residual: a
    # fit given a damper characteristic keeps it.
    g = generate(None, seed, tests=[t for t in sweep_tests() if t.name == "sine_0.3hz"])
    datasets = prepare([read_record(p) for p in g.records])
    r = fit(datasets, ("heat_transfer", "real_gas"), flexible=True, max_nfev=2, errors=False)
    assert "started from a static fit" in r.message, f"FOREIGN_RIG_SEED={seed}: {r.message}"
    again = fit(datasets, ("heat_transfer", "real_gas"), flexible=True, max_nfev=2, errors=False, initial=r.values)
    assert "static fit" not in again.message, f"FOREIGN_RIG_SEED={seed}: {again.message}"


@pytest.mark.parametrize("fixed", [True, False], ids=["seed7", "random"])
def test_adding_oil_compliance_restarts_a_damper_fitted_without_it(seed: int, fixed: bool) -> None:
    # A damper fitted without the oil's compliance bends every branch to
    # stand in for its lag (foreign rig seed 7: 157 x the noise); the model
    # that adds it restarts the damper from the static fit where that
    # starts lower (seed 7's diagnosis: the 1 Hz force in compression
    # 1.35 -> 1.05 x the noise). On seed 7 it does; on a random draw it
    # takes whichever start is lower (at the compliance's own start, 1 GPa,
    # the static one was lower on 5 of 8 draws; measured). Given the
    # compliance's value, the fit keeps the damper it was given.
    seed = 7 if fixed else seed
    g = generate("oil_compliance", seed, tests=[t for t in sweep_tests() if t.name == "sine_1hz"])
    datasets = prepare([read_record(p) for p in g.records])
    base, effects = ("heat_transfer", "real_gas"), ("heat_transfer", "real_gas", "oil_compliance")
    bent = fit(datasets, base, flexible=True, max_nfev=10, errors=False)
    static = damper_start.static_damper_values(datasets, model_for(datasets, effects, flexible=True).params)
    assert static and all(static[k] != bent.values[k] for k in static)
    r = fit(datasets, effects, flexible=True, initial=bent.values, max_nfev=1, errors=False)
    given, restarted = rss_at(datasets, effects, bent.values, flexible=True), rss_at(datasets, effects, {**bent.values, **static}, flexible=True)
    context = f"FOREIGN_RIG_SEED={seed}: residual sum of squares from the given damper {given:.4g}, static {restarted:.4g}; {r.message}"
    took = "started from a static fit (new: oil_compliance)" in r.message
    if fixed or restarted < 0.98 * given:
        assert took, context
    elif restarted > 1.02 * given:
        assert not took, context
    again = fit(datasets, effects, flexible=True, initial={**bent.values, "oil_bulk_modulus_pa": 1e9}, max_nfev=1, errors=False)
    assert "static fit" not in again.message, f"FOREIGN_RIG_SEED={seed}: {again.message}"


def _reaches_the_noise_from_a_model_without_oil_compliance(seed: int) -> None:
    # The model without compliance bends its gas state and its damper to
    # stand in for it; from there the bulk modulus went to a local optimum
    # (two damper-off sines, seeds 1749587853 and 619441309: 70 and 142 x
    # the noise; with the damper inverse mended in stop 32, still 60 and
    # 140 x). The fit also starts from scratch and keeps the better end:
    # measured 1.01 x with the bulk modulus within 0.01 % on both, seed 1
    # 0.98 x. Asserted: at the noise (hpctl's ceiling) and the bulk
    # modulus within 10 % or two of its errors of the foreign truth (its
    # value at hpctl's oil volume). Fixed draws until stop 32: some fits
    # took minutes to a quarter of an hour, which was the damper curve's
    # inverse returning a wrong flow on fitted curves, not the compliance
    # (seeds 1749587853 and 101-104 since: 8-21 s each).
    g = generate("oil_compliance", seed, tests=[t for t in sweep_tests() if t.name in ("sine_0.3hz", "sine_1hz")])
    datasets = prepare([read_record(p) for p in g.records])
    base = ("heat_transfer", "real_gas")
    without = fit(datasets, base, flexible=True)
    r = fit(datasets, base + ("oil_compliance",), flexible=True, initial=without.values)
    truth = g.truth["hpctl_params"]["oil_bulk_modulus_pa"]
    b, err = r.values["oil_bulk_modulus_pa"], r.stderr["oil_bulk_modulus_pa"]
    context = f"FOREIGN_RIG_SEED={seed}: {without.rms_ratio:.1f} -> {r.rms_ratio:.3f} x the noise, bulk modulus {b:.5g} +- {err:.2g} Pa against {truth:.5g}; {r.message}"
    assert r.rms_ratio <= NOISE_CEILING, context
    assert abs(b - truth) <= max(0.1 * truth, 2.0 * err), context


@pytest.mark.parametrize("pinned", [1749587853, 619441309])
def test_adding_oil_compliance_leaves_the_local_optimum_the_model_without_it_sits_in(pinned: int) -> None:
    _reaches_the_noise_from_a_model_without_oil_compliance(pinned)


def test_adding_oil_compliance_reaches_the_noise_from_a_model_without_it(seed: int) -> None:
    _reaches_the_noise_from_a_model_without_oil_compliance(seed)


def test_the_static_fit_is_computed_once_per_records_shape_and_shared_terms(monkeypatch: pytest.MonkeyPatch) -> None:
    # The cache gives what the fit gives, without fitting again, for the
    # same records (the same objects), shape parameters and shared terms;
    # anything else is fitted anew, and a caller's changes to what it got
    # do not reach the next caller.
    g = generate(None, 7, tests=[t for t in sweep_tests() if t.name in SHORT])
    datasets = prepare([read_record(p) for p in g.records])
    fitted = damper_start.fit_static_damper
    calls = _counting(monkeypatch)
    plain = model_for(datasets, ("heat_transfer", "real_gas"), flexible=True)
    with_oil = model_for(datasets, ("heat_transfer", "real_gas", "oil_compliance"), flexible=True)
    with_friction = model_for(datasets, ("heat_transfer", "real_gas", "friction"), flexible=True)
    first = damper_start.static_damper_values(datasets, plain.params, plain.effects)
    first["damper_on_rebound_knee"] = -1.0
    again = damper_start.static_damper_values(datasets, with_oil.params, with_oil.effects)  # no shared term more: the same fit
    assert len(calls) == 1 and again == fitted(datasets, plain.params, plain.effects)
    friction = damper_start.static_damper_values(datasets, with_friction.params, with_friction.effects)
    assert len(calls) == 2 and "friction_coulomb_n" in friction
    other = prepare([read_record(p) for p in g.records])  # equal records, other objects: fitted again
    assert damper_start.static_damper_values(other, plain.params, plain.effects) == again
    assert len(calls) == 3


def test_the_bodys_acceleration_error_is_its_spread_over_noise_and_clock_jitter() -> None:
    # The error _strut_force gives each sample's acceleration, from the
    # displacement's noise and the clock's jitter at the body's speed,
    # against the spread of the estimate over 4,000 draws of both: a body
    # swinging at 2 Hz, 40 mm (0.5 m/s at its fastest), sampled every 5 ms
    # at instants 70 us off on average and read with 2.5 um of noise. At
    # the fastest samples the jitter is nearly all of it (0.5 m/s x 70 us
    # = 35 um), at the turns the noise is.
    rng = np.random.default_rng(20261206)
    dt, sigma_x, jitter_s, draws = 0.005, 2.5e-6, 70e-6, 4000
    t = np.arange(0.0, 1.0, dt)
    w = 2.0 * np.pi * 2.0
    delta = rng.normal(0.0, jitter_s, (draws, len(t)))
    x = 0.04 * np.sin(w * (t + delta)) + rng.normal(0.0, sigma_x, (draws, len(t)))
    speed = 0.04 * w * np.cos(w * t)
    for window, order in ((damper_start.SDOF_ACCEL_WINDOW, damper_start.SDOF_ACCEL_ORDER),
                          (damper_start.SDOF_ACCEL_SHORT_WINDOW, damper_start.SDOF_ACCEL_SHORT_ORDER)):
        _, error = damper_start._second_derivative(x[0], sigma_x**2 + (speed * jitter_s) ** 2, dt, window, order)
        # The estimate is the filter's second derivative: all draws at once.
        spread = np.std(savgol_filter(x, window, order, deriv=2, delta=dt, axis=1), axis=0)
        inner = slice(window, len(t) - window)
        ratio = spread[inner] / error[inner]
        # 4,000 draws read a standard deviation within about 1.1 % (3.3 % at
        # 3 of them): measured 0.972-1.025 of the error over both windows.
        assert np.all(np.abs(ratio - 1.0) < 0.04), (window, float(ratio.min()), float(ratio.max()))
        # Without the jitter the error would be the noise's alone: 14 x too
        # small where the body is fast.
        noise_only = float(np.linalg.norm(savgol_coeffs(window, order, deriv=2, delta=dt))) * sigma_x
        assert float(np.max(spread[inner])) > 5.0 * noise_only


def test_an_sdof_records_dropped_sample_leaves_out_only_its_neighbourhood(tmp_path: Path) -> None:
    # The body's acceleration takes the samples as evenly spaced; a record
    # that lost one sample keeps the rest of its force, the same as the
    # whole record's, and none near the gap (without the check, measured:
    # the gap's neighbours read the body's inertial force as -5.4 to
    # +10.8 kN where the whole record reads 1.6-2.9 kN).
    g = generate(None, 3, tests=[t for t in extra_tests()["sdof_all"] if t.name == "sdof_step_hard_off"])
    stem = g.records[0]
    lines = stem.with_suffix(".csv").read_text().splitlines()
    dropped = 200  # a data row (after the header), the body still moving after the step (0.5 s) at 1 s
    (tmp_path / f"{stem.name}.csv").write_text("\n".join(lines[:dropped + 1] + lines[dropped + 2:]) + "\n")
    (tmp_path / f"{stem.name}.toml").write_text(stem.with_suffix(".toml").read_text())
    whole, cut = (prepare([read_record(p)])[0] for p in (stem, tmp_path / stem.name))
    full, part = damper_start._strut_force(whole), damper_start._strut_force(cut)
    assert full is not None and part is not None
    j = np.arange(len(cut.times_s))
    # The gap lies between samples dropped - 1 and dropped: every window
    # that spans it is out.
    reach = damper_start.SDOF_ACCEL_WINDOW // 2
    assert np.all(np.isnan(part[0][(j >= dropped - 1 - reach) & (j <= dropped + reach)]))
    # The same samples of the whole record: before the gap at the same
    # index, after it one further on.
    same = np.where(j < dropped, j, j + 1)
    far = (np.abs(j - dropped) > 2 * damper_start.SDOF_ACCEL_WINDOW) & np.isfinite(part[0]) & np.isfinite(full[0][same])
    assert far[j < dropped].sum() > 50 and far[j > dropped].sum() > 50
    np.testing.assert_allclose(part[0][far], full[0][same][far], rtol=1e-12)


def _short_with_friction() -> tuple[list[Dataset], list[object], tuple[str, ...]]:
    g = generate(None, 7, tests=[t for t in sweep_tests() if t.name in SHORT])
    datasets = prepare([read_record(p) for p in g.records])
    model = model_for(datasets, ("heat_transfer", "real_gas", "friction"), flexible=True)
    return datasets, model.params, model.effects  # type: ignore[return-value]


def _counting(monkeypatch: pytest.MonkeyPatch) -> list[tuple[str, ...]]:
    # The static fits computed in this process from now on (the effects of
    # each), with an empty cache.
    calls: list[tuple[str, ...]] = []
    fitted = damper_start.fit_static_damper

    def counted(ds: object, params: object, effects: tuple[str, ...] = ()) -> dict[str, float]:
        calls.append(tuple(effects))
        return fitted(ds, params, effects)  # type: ignore[arg-type]

    monkeypatch.setattr(damper_start, "fit_static_damper", counted)
    monkeypatch.setattr(damper_start, "_cache", type(damper_start._cache)())
    monkeypatch.setattr(damper_start, "_take_backs", {})
    return calls


def test_a_static_fit_prefetched_in_worker_processes_is_the_fit_here_and_not_computed_again(monkeypatch: pytest.MonkeyPatch) -> None:
    # The diagnosis starts its candidates' static fits in processes of their
    # own; the screening fit that asks for one gets what this process would
    # have computed (the same code and inputs, BLAS on one thread in both),
    # and asks with the records as the declared model's fit placed their
    # valve switches: copies sharing what the static fit reads.
    datasets, params, effects = _short_with_friction()
    with one_blas_thread():
        here = damper_start.fit_static_damper(datasets, params, effects)  # type: ignore[arg-type]
        calls = _counting(monkeypatch)
        pool = workers.static_pool(2)
        try:
            damper_start.prefetch_static(datasets, params, effects, pool)  # type: ignore[arg-type]
            placed = [dataclasses.replace(d, switch_leads=d.switch_leads + 0.0) for d in datasets]
            got = damper_start.static_damper_values(placed, params, effects)  # type: ignore[arg-type]
        finally:
            pool.shutdown()
    assert "friction_coulomb_n" in here and "damper_off_compression_orifice_scale" in here
    assert got == here and calls == []


def test_a_static_fit_started_before_the_input_noise_is_carried_is_the_one_the_fit_asks_for(monkeypatch: pytest.MonkeyPatch) -> None:
    # The command line and the diagnosis start the static fits on the
    # records' measured noise (measured_datasets) and carry the input's
    # noise into the weights meanwhile: the fit on the carried datasets
    # finds them (nothing it reads was replaced) and gets what a fit on
    # prepare()'s datasets computes; carrying gives prepare()'s weights.
    g = generate(None, 7, tests=[t for t in sweep_tests() if t.name in SHORT])
    records = [read_record(p) for p in g.records]
    prepared = prepare(records)
    model = model_for(prepared, ("heat_transfer", "real_gas", "friction"), flexible=True)
    with one_blas_thread():
        here = damper_start.fit_static_damper(prepared, model.params, model.effects)
        calls = _counting(monkeypatch)
        measured = measured_datasets(records)
        pool = workers.static_pool(2)
        try:
            damper_start.prefetch_static(measured, model.params, model.effects, pool)
            carried = carry_input_noise(measured)
            got = damper_start.static_damper_values(carried, model.params, model.effects)
        finally:
            pool.shutdown()
    assert got == here and calls == []
    for c, p in zip(carried, prepared, strict=True):
        assert c.weight_sigma.keys() == p.weight_sigma.keys()
        for k in p.weight_sigma:
            np.testing.assert_array_equal(c.weight_sigma[k], p.weight_sigma[k])
    # The measured datasets' weights are the output noise alone, which carrying raised.
    assert any(np.any(c.weight_sigma[k] > m.weight_sigma[k]) for c, m in zip(carried, measured, strict=True) for k in m.weight_sigma)


def test_a_prefetch_the_caller_helps_takes_back_the_starts_no_worker_began(monkeypatch: pytest.MonkeyPatch) -> None:
    # hpctl fit --flexible (take_back): the starts still queued when the fit
    # asks are solved in its own thread, the last first, and give what the
    # fit here gives; the workers never begin them.
    from concurrent.futures import Executor, Future
    from typing import Any

    class Busy(Executor):  # every worker busy: nothing given to it begins
        def __init__(self) -> None:
            self.futures: list[Future[Any]] = []

        def submit(self, fn: Any, /, *args: Any, **kwargs: Any) -> Future[Any]:
            self.futures.append(Future())
            return self.futures[-1]

    datasets, params, effects = _short_with_friction()
    with one_blas_thread():
        here = damper_start.fit_static_damper(datasets, params, effects)  # type: ignore[arg-type]
        calls = _counting(monkeypatch)
        solved: list[int] = []
        solve = damper_static.solve_start

        def counted(problem: damper_static.StaticProblem, k: int) -> object:
            solved.append(k)
            return solve(problem, k)

        monkeypatch.setattr(damper_start, "solve_start", counted)
        pool = Busy()
        damper_start.prefetch_static(datasets, params, effects, pool, take_back=True)  # type: ignore[arg-type]
        got = damper_start.static_damper_values(datasets, params, effects)  # type: ignore[arg-type]
    assert got == here and calls == []
    assert solved == [2, 1, 0] and all(f.cancelled() for f in pool.futures)


def test_a_static_fit_whose_workers_fail_is_computed_here(monkeypatch: pytest.MonkeyPatch) -> None:
    datasets, params, effects = _short_with_friction()
    with one_blas_thread():
        here = damper_start.fit_static_damper(datasets, params, effects)  # type: ignore[arg-type]
        calls = _counting(monkeypatch)
        monkeypatch.setattr(sys, "executable", "/nonexistent/python")  # no worker can start
        pool = workers.static_pool(1)
        try:
            damper_start.prefetch_static(datasets, params, effects, pool)  # type: ignore[arg-type]
            got = damper_start.static_damper_values(datasets, params, effects)  # type: ignore[arg-type]
        finally:
            pool.shutdown()
    assert got == here and calls == [effects]


def test_a_static_fit_asked_for_by_two_threads_at_once_is_computed_once(monkeypatch: pytest.MonkeyPatch) -> None:
    # Two screening fits of a diagnosis (friction's and its confirmation)
    # can ask at the same moment: the second waits for the first's.
    datasets, params, effects = _short_with_friction()
    calls = _counting(monkeypatch)
    start = threading.Barrier(2)

    def ask() -> dict[str, float]:
        start.wait()
        return damper_start.static_damper_values(datasets, params, effects)  # type: ignore[arg-type]

    with ThreadPoolExecutor(2) as pool:
        first, second = (f.result() for f in [pool.submit(ask), pool.submit(ask)])
    assert first == second and calls == [effects]


def test_a_flexible_diagnosis_fits_its_candidates_static_starts_in_the_workers(monkeypatch: pytest.MonkeyPatch) -> None:
    # diagnose(flexible=True) starts friction's static fit in its worker
    # processes while the declared model is fitted: this process fits only
    # the declared model's (friction's screening finds its own kept), and
    # friction's screening starts from what the workers fitted.
    g = generate(None, 7, tests=[t for t in sweep_tests() if t.name in SHORT])
    records = [read_record(p) for p in g.records]
    fitted = damper_start.fit_static_damper
    calls = _counting(monkeypatch)
    asked: list[dict[str, float]] = []
    kept = damper_start.static_damper_values

    def seen(ds: object, params: object, effects: tuple[str, ...] = ()) -> dict[str, float]:
        values = kept(ds, params, effects)  # type: ignore[arg-type]
        if "friction" in effects:
            asked.append(values)
        return values

    monkeypatch.setattr(fit_module, "static_damper_values", seen)
    diag = diagnose(records, ("heat_transfer", "real_gas"), candidates=["friction"], max_rounds=1, flexible=True)
    assert calls == [("heat_transfer", "real_gas")], calls  # the declared model's, here
    assert asked and "friction_coulomb_n" in asked[0]
    datasets = prepare(records)
    model = model_for(datasets, ("heat_transfer", "real_gas", "friction"), flexible=True)
    with one_blas_thread():
        assert asked[0] == fitted(datasets, model.params, model.effects)
    assert [c.effect for c in diag.rounds[0].candidates] == ["friction"]

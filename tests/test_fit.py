"""Fitting: parameters with honest uncertainties, residual statistics per
record and channel, and the fitting of SDOF records."""

from __future__ import annotations

import math
import os

import numpy as np
import pytest

import hpctl
from hpctl._core import sensor_lag
from hpctl.errors import ParameterError
from hpctl.identify import virtual_rig
from hpctl.identify.dataset import prepare
from hpctl.identify.fit import FitResult, fit
from hpctl.identify.signals import derivative, noise_sigma, smooth
from hpctl.model.unit import Friction, Sensor
from hpctl.sim.run import characterisation_rig, sdof_rig, uniform_times


def test_noise_estimate_ignores_a_smooth_signal() -> None:
    rng = np.random.default_rng(1)
    t = np.linspace(0, 100, 2001)
    signal = 4e7 * (1 + 0.5 * np.sin(2 * np.pi * 0.02 * t) ** 3)
    for sd in (1e3, 5e3, 2e4):
        assert noise_sigma(signal + rng.normal(0, sd, t.size)) == pytest.approx(sd, rel=0.1)


def test_noise_estimate_is_efficient_and_ignores_steps_and_spikes() -> None:
    # One record's pressure once read 24 % low with the median absolute
    # deviation of the fourth differences (7.7 % scatter on 401 samples),
    # and its clean residual looked like 1.3x the noise. The cut RMS
    # scatters less (5.5 % by simulation; 2.9 % is the bound of an RMS of
    # 401 independent samples, the differences are correlated), stays
    # unbiased, and still ignores steps and spikes.
    rng = np.random.default_rng(7)
    t = np.linspace(0, 4, 401)
    reads = np.array([noise_sigma(3e3 * np.sin(2 * np.pi * t) + rng.normal(0, 1.0, t.size)) for _ in range(600)])
    assert abs(reads.mean() - 1.0) < 0.01 and reads.std() < 0.065, (reads.mean(), reads.std())
    mad = np.array([np.median(np.abs(d - np.median(d))) / 0.6745 / np.sqrt(70.0)
                    for d in (np.diff(rng.normal(0, 1.0, t.size), 4) for _ in range(600))])
    assert reads.std() < 0.8 * mad.std(), (reads.std(), mad.std())
    y = rng.normal(0, 1.0, 2001)
    y[1000:] += 50.0
    y[1500:] -= 80.0
    y[300] += 30.0
    assert noise_sigma(y) == pytest.approx(1.0, rel=0.08)
    assert noise_sigma(np.full(50, 3.0)) == 0.0 and noise_sigma(np.zeros(3)) == 0.0


@pytest.mark.parametrize(("per_cycle", "tolerance"), [(200, 2e-7), (100, 2e-6)])
def test_smoothing_does_not_shrink_the_excitation(per_cycle: int, tolerance: float) -> None:
    # The model is driven by the smoothed measured displacement: a filter
    # that shrinks the sine biases what the gas amplitude says about the
    # charge and time constant. The amplitude (least-squares projection on
    # the known sine) of the smoothed signal must equal the raw signal's to
    # well under the noise's own effect on it (the filter passes the noise
    # at the sine's frequency, so the two projections share it). A cubic
    # over 11 samples shrank it by 2.9e-6 (200 a cycle) and 4.7e-5 (100);
    # the quintic over 15 by 1.2e-8 and 5.8e-7 here (analytic: 4e-9, 3e-7).
    rng = np.random.default_rng(3)
    amp, cycles = 0.06, 2
    t = np.arange(cycles * per_cycle) / per_cycle
    s, c = np.sin(2 * np.pi * t), np.cos(2 * np.pi * t)
    x = amp * s + rng.normal(0.0, 5e-6, len(t))
    basis = np.column_stack((s, c))
    # Away from the ends, where the filter fits a one-sided polynomial.
    m = slice(20, len(t) - 20)

    def amplitude(y: np.ndarray) -> float:
        return float(np.hypot(*np.linalg.lstsq(basis[m], y[m], rcond=None)[0]))

    xs = smooth(t, x)
    assert np.mean(xs != x) > 0.9, "the test must exercise the filter, not the raw samples it keeps"
    assert abs(amplitude(xs) - amplitude(x)) < tolerance * amp


def test_derivative_is_fourth_order_on_irregular_samples() -> None:
    errs = []
    for n in (100, 200):
        h = 2.0 / n
        i = np.arange(n)
        t = (i + 0.3 * np.sin(1.7 * i)) * h  # irregular, with the same pattern at both resolutions
        errs.append(np.abs(derivative(t, np.sin(3 * t)) - 3 * np.cos(3 * t))[2:-2].max())
    assert 12 < errs[0] / errs[1] < 20  # 16 for fourth order


def test_sensor_lag_filter_matches_the_analytic_steady_state() -> None:
    tau, w = 0.01, 2 * math.pi
    t = np.arange(0, 5, 0.002)
    y = sensor_lag(t, np.sin(w * t), tau)
    ref = np.sin(w * t - math.atan(w * tau)) / math.sqrt(1 + (w * tau) ** 2)
    assert np.abs(y - ref)[-500:].max() < 2e-5


def test_sensor_lag_filter_matches_the_units_lag_state() -> None:
    # The fit applies the lag to its outputs; the unit integrates it as a
    # state: both must report the same force.
    unit = hpctl.Unit.seed()
    lagged = unit.with_effects(sensor=Sensor(0.0, 0.0, 0.02))
    times = uniform_times(4.0, 0.004)
    rig = characterisation_rig(hpctl.Sine(0.04, 1.0))
    a = hpctl.run(unit, rig, times, spring_hard=True, damper_on=True, dt_s=2e-4)
    b = hpctl.run(lagged, rig, times, spring_hard=True, damper_on=True, dt_s=2e-4)
    rest = a["force_n"][0] - a["damper_force_n"][0]
    filtered = sensor_lag(times, a["force_n"], 0.02, rest)
    # The filter assumes the force linear between samples (4 ms here): its
    # error is of the order of the force's curvature times h^2 / 8.
    assert np.abs(filtered - b["force_n"]).max() < 1e-4 * np.ptp(b["force_n"])


def test_sensor_lag_filter_is_exact_for_a_signal_linear_between_samples() -> None:
    # First-order hold: a ramp x = m t from rest gives exactly
    # y = m (t - tau (1 - exp(-t / tau))), on any sampling.
    tau, m = 0.01, 3.0
    rng = np.random.default_rng(5)
    t = np.concatenate(([0.0], np.cumsum(rng.uniform(1e-5, 0.03, 400))))
    y = sensor_lag(t, m * t, tau)
    assert np.abs(y - m * (t - tau * -np.expm1(-t / tau))).max() < 1e-12 * m * t[-1]


def test_sensor_lag_rejects_what_it_cannot_filter() -> None:
    t = np.arange(5.0)
    with pytest.raises(ParameterError, match="sensor_time_constant_s"):
        sensor_lag(t, t, -1.0)
    with pytest.raises(ParameterError, match="times_s"):
        sensor_lag(t[::-1], t, 0.1)
    with pytest.raises(ParameterError, match="values"):
        sensor_lag(t, t[:3], 0.1)


@pytest.fixture(scope="module")
def friction_fit() -> tuple[dict[str, float], FitResult]:
    truth = {"tau_s": 3.0, "friction_coulomb_n": 500.0, "friction_viscous_n_s_per_m": 400.0}
    unit = hpctl.Unit.seed().replace(tau_s=3.0).with_effects(friction=Friction(500.0, 400.0, 2e-3))
    records = virtual_rig.make_records(unit, "sweep", seed=11)
    return truth, fit(prepare(records), ("heat_transfer", "real_gas", "friction"))


def test_fit_recovers_parameters_within_their_uncertainty(friction_fit: tuple[dict[str, float], FitResult]) -> None:
    truth, r = friction_fit
    for name, value in truth.items():
        assert abs(r.values[name] - value) < 4 * r.stderr[name] + 1e-9, (name, r.values[name], r.stderr[name], value)
        assert 0 < r.stderr[name] < 0.2 * value
    assert r.values["charge_scale"] == pytest.approx(1.0, abs=1e-3)
    assert 0.8 < r.rms_ratio < 1.1


def test_fit_reports_every_record_and_channel(friction_fit: tuple[dict[str, float], FitResult]) -> None:
    _, r = friction_fit
    assert {(s.record, s.channel) for s in r.stats} == {(f"sine_{f:g}hz", c) for f in virtual_rig.SWEEP_FREQUENCIES_HZ for c in ("force_n", "p_gas_pa", "p_gas2_pa")}
    for s in r.stats:
        assert s.rms <= s.max_abs
        if s.channel != "p_gas2_pa":  # L is sealed off: a constant channel has no range to normalise by
            assert 0 < s.nrms < 0.01
        # A fitted complete model leaves residuals at the noise level.
        assert 0.6 * s.noise < s.rms < 1.6 * s.noise
        if s.channel == "force_n":
            assert s.loop_area_measured_j is not None and s.loop_area_measured_j > 0
            assert abs(s.loop_area_error_j or 0.0) < 0.05 * s.loop_area_measured_j


def test_fit_of_sdof_records_compares_body_displacement() -> None:
    unit = hpctl.Unit.seed().replace(tau_s=1.5)
    test = virtual_rig.effect_tests()["sdof"]
    records = virtual_rig.make_records(unit, tests=[test], seed=5)
    datasets = prepare(records)
    r = fit(datasets, ("heat_transfer", "real_gas"))
    assert {s.channel for s in r.stats} >= {"body_disp_m"}
    assert r.values["tau_s"] == pytest.approx(1.5, rel=0.3)
    # The pressures are fitted to their noise; the body displacement is
    # left about 1.5 x its noise: the fit drives the rig with the base
    # displacement as measured (6 ms samples with noise, smoothed and
    # interpolated through the 50 ms step), which is not the step that made
    # the record. Driven by the true step, the true unit's residual is the
    # noise alone (below). (With fixed steps, the record's and the fit's
    # step errors partly cancelled this and the pooled ratio was 1.05.)
    by_channel = {s.channel: s.rms / s.noise for s in r.stats}
    assert by_channel["p_gas_pa"] < 1.1 and by_channel["p_gas2_pa"] < 1.1
    assert r.rms_ratio < 1.3
    d = datasets[0]
    exact = hpctl.run(unit, sdof_rig(test.motion, hpctl.SEED_SPRUNG_MASS_KG), d.times_s, spring_hard=d.spring_hard, damper_on=d.damper_on,
                      ambient_k=d.ambient_k)
    noise_only = np.sqrt(np.mean((exact["body_disp_m"] - d.targets["body_disp_m"]) ** 2)) / d.sigma["body_disp_m"]
    assert noise_only == pytest.approx(1.0, abs=0.05)


def test_fitting_nothing_is_an_error() -> None:
    with pytest.raises(hpctl.HpctlError, match="no records"):
        prepare([])


def test_the_weights_describe_the_residual_at_the_truth() -> None:
    # The weights are each channel's noise plus what the measured input's
    # noise puts into the model's outputs. At the truth (hp-core's virtual
    # rig, its own unit) the residual holds exactly those two, drawn by the
    # rig, so its RMS over the weights must be 1 up to the noise levels'
    # scatter (5.5 % a record): pooled over the sweep's five records per
    # channel, about 2.5 %. A sliding regression on position and velocity
    # carried 3-7 x too much into the gas pressure's weights (the ratio read
    # 0.66-0.77 on the fast sines, 0.74 pooled; the force 0.92).
    import secrets

    from hpctl.data.records import LOGGED_SWITCH_LEAD
    from hpctl.sim.run import Case, run_many

    seed = int(os.environ.get("HPCTL_TEST_SEED", secrets.randbelow(2**31)))
    datasets = prepare(virtual_rig.make_records(hpctl.Unit.seed(), "sweep", seed=seed))
    runs = run_many([Case(d.base, d.rig, d.times_s, spring_hard=d.spring_hard, damper_on=d.damper_on, ambient_k=d.ambient_k,
                          switch_lead=LOGGED_SWITCH_LEAD) for d in datasets])
    for c in ("force_n", "p_gas_pa"):
        z2 = np.concatenate([((np.asarray(r.channels[c]) - d.targets[c]) / d.weight_sigma[c]) ** 2  # type: ignore[union-attr]
                             for d, r in zip(datasets, runs)])
        carried = [float(np.sqrt(np.mean(d.weight_sigma[c] ** 2 - d.sigma[c] ** 2))) for d in datasets]
        ratio = math.sqrt(float(np.mean(z2)))
        assert 0.92 <= ratio <= 1.08, f"HPCTL_TEST_SEED={seed}: {c} residual at the truth over its weights {ratio:.3f}, carried {carried}"
        # The carried part grows with the sine's speed (0.01 -> 1 Hz).
        assert carried[-1] > carried[0] > 0.0, carried


def test_a_record_shorter_than_the_weights_window_is_prepared() -> None:
    # The carried input noise is a moving mean over 31 samples; a record of
    # 12 still gets one weight per sample, each above its channel's noise.
    from hpctl.data.records import RigRecord

    r = virtual_rig.make_records(hpctl.Unit.seed(), "sweep", seed=1)[-1]
    short = RigRecord(kind=r.kind, unit=r.unit, static=r.static, test=r.test, data={k: np.asarray(v)[:12] for k, v in r.data.items()},
                      name="short")
    (d,) = prepare([short])
    for c, w in d.weight_sigma.items():
        assert w.shape == (12,) and np.all(np.isfinite(w)) and np.all(w >= d.sigma[c]), (c, w)


def test_a_record_its_unit_cannot_run_keeps_its_output_noise_as_weight() -> None:
    # The carried input noise comes from running the record's unit; a
    # record it refuses (times before zero) is still prepared, weighted by
    # its channels' own noise, and the fit then says why it cannot run.
    from hpctl.data.records import RecordStatic, RecordTest, RecordUnit, RigRecord

    rng = np.random.default_rng(1)
    t = np.linspace(-0.5, 20.0, 206)
    x = 0.02 * np.sin(2 * np.pi * 0.1 * t) + rng.normal(0.0, 5e-6, t.size)
    rec = RigRecord(kind="characterisation", unit=RecordUnit(2e-3, 0.3e-3, 0.7e-3), static=RecordStatic(14811300.0, 293.15, 293.15),
                    test=RecordTest("hard", "off", "sine", 0.02, 0.1),
                    data={"time_s": t, "disp_m": x, "force_n": 3e4 + 1e6 * x + rng.normal(0.0, 30.0, t.size)}, name="neg")
    (d,) = prepare([rec])
    assert d.input_noise_m > 0.0
    np.testing.assert_array_equal(d.weight_sigma["force_n"], np.full(t.size, d.sigma["force_n"]))
    with pytest.raises(hpctl.HpctlError, match="time_s = -0.5 is outside the valid range"):
        fit([d], ("heat_transfer", "real_gas"))


def test_the_fitted_models_own_weights_describe_its_residual_at_the_truth() -> None:
    # Seal friction of 900 N flipping within 0.5 mm/s: at each reversal of
    # the 1 Hz sine the force steps by 1.8 kN within about a millisecond,
    # and the measured displacement's noise moves the reversal's time. The
    # template unit (no friction) carries none of that into the weights, so
    # at the truth the record's force reads above its weights; the fitted
    # model's own weights (fit.at_own_noise) describe the residual the
    # truth leaves. A record's ratio rests on its ten reversals: over 60
    # draws of the rig (seeds 1000-1059) 1.016 +- 0.197 a record over the
    # model's own weights, 1.40 +- 0.27 over the template's (with 4 draws of
    # the input's noise in the weights instead of 16 the model's read 1.16
    # on seeds 1-6: the squares of few draws scatter, and the weight's
    # inverse is biased). The mean of forty draws is asserted, within 0.1
    # of 1 (about three of its standard errors).
    import secrets

    from hpctl.identify.fit import at_own_noise

    seed = int(os.environ.get("HPCTL_TEST_SEED", secrets.randbelow(2**31 - 40)))
    effects = ("heat_transfer", "real_gas", "friction")
    truth = {"tau_s": hpctl.Unit.seed().tau_s, "friction_coulomb_n": 900.0, "friction_viscous_n_s_per_m": 300.0}
    unit = hpctl.Unit.seed().with_effects(friction=Friction(900.0, 300.0, 5e-4))
    tests = [t for t in virtual_rig.sweep_tests() if getattr(t.motion, "frequency_hz", 0.0) == 1.0]
    template, own = [], []
    for k in range(40):
        datasets = prepare(virtual_rig.make_records(unit, tests=tests, seed=seed + k))
        # The model at the truth: one evaluation, started there, with the
        # truth's own friction smoothing held.
        at_truth = fit(datasets, effects, initial=truth, held={"friction_smoothing_velocity_m_s": 5e-4}, max_nfev=1, errors=False,
                       place_switches=False)
        judged = at_own_noise(at_truth)
        r = at_truth.residuals(0, "force_n")
        template.append(float(np.sqrt(np.mean((r / datasets[0].weight_sigma["force_n"]) ** 2))))
        own.append(float(np.sqrt(np.mean((r / judged.datasets[0].weight_sigma["force_n"]) ** 2))))
        # Judging is all it changes: the values and the runs are the fit's.
        assert judged.values == at_truth.values and judged.sims is at_truth.sims
    context = (f"HPCTL_TEST_SEED={seed}: the 1 Hz force at the truth over the template's weights {np.mean(template):.3f} "
               f"+- {np.std(template):.3f} a record, over the model's own {np.mean(own):.3f} +- {np.std(own):.3f}")
    assert abs(float(np.mean(own)) - 1.0) <= 0.1, context
    assert float(np.mean(template)) > float(np.mean(own)) + 0.1, context


def test_an_sdof_records_own_weights_carry_its_bases_noise_through_a_friction() -> None:
    # The SDOF body settling after a step with 900 N of seal friction
    # (damper off): the base's measured noise moves the friction's many
    # reversals, and the body with them. Until stop 48 SDOF records carried
    # none of their input's noise, and at the truth this residual read
    # 2.85 +- 0.44 x its weights a record (the template's, 40 draws). The
    # fitted model's own weights (fit.at_own_noise) now carry it: 0.925 +-
    # 0.154 a record over 40 draws, 7.5 % lenient (measured; the mean of
    # forty is asserted within 0.8-1.15). After the step's first 0.5 s
    # only: there, with the drive's velocity taken on each corner's own
    # side (stop 49), it reads 0.75 +- 0.28 over 12 draws, as it did
    # without (lenient where the friction sticks and slips; noted in
    # docs/foreign-rig.md). With the damper on the same reads 0.73 +- 0.18
    # after the first 0.5 s over 12 draws (1.59 +- 0.44 until stop 49),
    # not asserted.
    import secrets

    from hpctl.identify.fit import at_own_noise

    seed = int(os.environ.get("HPCTL_TEST_SEED", secrets.randbelow(2**31 - 40)))
    effects = ("heat_transfer", "real_gas", "friction")
    truth = {"tau_s": hpctl.Unit.seed().tau_s, "friction_coulomb_n": 900.0, "friction_viscous_n_s_per_m": 300.0}
    unit = hpctl.Unit.seed().with_effects(friction=Friction(900.0, 300.0, 5e-4))
    step = virtual_rig.Test("sdof_step", virtual_rig.Step(0.043, 0.5, 0.05), 5.0, 1000, sdof=True, damper_on=False, excitation="step")
    template, own = [], []
    for k in range(40):
        datasets = prepare(virtual_rig.make_records(unit, tests=[step], seed=seed + k))
        at_truth = fit(datasets, effects, initial=truth, held={"friction_smoothing_velocity_m_s": 5e-4}, max_nfev=1, errors=False,
                       place_switches=False)
        judged = at_own_noise(at_truth)
        after = datasets[0].times_s > 1.0
        r = at_truth.residuals(0, "body_disp_m")[after]
        template.append(float(np.sqrt(np.mean((r / datasets[0].weight_sigma["body_disp_m"][after]) ** 2))))
        own.append(float(np.sqrt(np.mean((r / judged.datasets[0].weight_sigma["body_disp_m"][after]) ** 2))))
    context = (f"HPCTL_TEST_SEED={seed}: the SDOF body at the truth over the template's weights {np.mean(template):.3f} "
               f"+- {np.std(template):.3f} a record, over the model's own {np.mean(own):.3f} +- {np.std(own):.3f}")
    assert 0.8 <= float(np.mean(own)) <= 1.15, context
    assert float(np.mean(template)) > float(np.mean(own)) + 1.0, context


def test_an_sdof_step_through_the_damper_is_at_the_noise_at_the_truth() -> None:
    # The SDOF step with the damper on, fitted at the truth by its own
    # model, the whole record. Until stop 49 the drive's velocity at the
    # step's corners was the centred quartic across them (up to 72 mm/s
    # off), which the damper passed to the body: 1.34 +- 0.07 x the body's
    # weights a record over 12 draws, 2.6 x in the half second after the
    # step. Taken on each corner's own side (hpctl.identify.corners): 1.065
    # +- 0.039, 0.93 +- 0.11 after the step (measured; the mean of twelve
    # asserted within 0.95-1.18).
    import secrets

    from hpctl.identify.fit import at_own_noise

    seed = int(os.environ.get("HPCTL_TEST_SEED", secrets.randbelow(2**31 - 12)))
    step = virtual_rig.Test("sdof_step", virtual_rig.Step(0.043, 0.5, 0.05), 5.0, 1000, sdof=True, damper_on=True, excitation="step")
    unit = hpctl.Unit.seed()
    own = []
    for k in range(12):
        datasets = prepare(virtual_rig.make_records(unit, tests=[step], seed=seed + k))
        at_truth = fit(datasets, ("heat_transfer", "real_gas"), initial={"tau_s": unit.tau_s}, max_nfev=1, errors=False,
                       place_switches=False)
        judged = at_own_noise(at_truth)
        r = at_truth.residuals(0, "body_disp_m")
        own.append(float(np.sqrt(np.mean((r / judged.datasets[0].weight_sigma["body_disp_m"]) ** 2))))
    context = f"HPCTL_TEST_SEED={seed}: the SDOF body at the truth over its own weights {np.mean(own):.3f} +- {np.std(own):.3f} a record"
    assert 0.95 <= float(np.mean(own)) <= 1.18, context


def test_an_sdof_step_sampled_by_a_jittering_clock_carries_the_jitter_through_the_damper() -> None:
    # The same step, its base and body sampled at instants off the logged
    # ones by the foreign rig's clock (tests/foreign_rig/sensors.py,
    # 100-200 us), at the truth. The base's late and early samples reach the
    # body through the damper: without the clock in the weights 1.52 +-
    # 0.23 x a record at 120 us (8 draws), 3.5 x in the half second after
    # the step. The weights carry the jitter read from the base's corners
    # (hpctl.identify.corners.clock_jitter, the eight records of one clock
    # read together) through the model: the mean of eight 0.96-1.04 over
    # four seeds, the reading 0.87-1.15 x the drawn jitter (each record
    # read alone: 0.4-2.3 x, the mean 0.92-1.12, and one draw in about
    # forty failed this test; 2.66 with none carried).
    import secrets

    from scipy.interpolate import CubicSpline

    from foreign_rig.motion import Step
    from foreign_rig.sensors import jittered
    from hpctl.identify.fit import at_own_noise

    seed = int(os.environ.get("HPCTL_TEST_SEED", secrets.randbelow(2**31 - 8)))
    rng = np.random.default_rng(seed)
    step = virtual_rig.Test("sdof_step", virtual_rig.Step(0.043, 0.5, 0.05), 5.0, 1000, sdof=True, damper_on=True, excitation="step")
    base = Step(0.043, 0.5, 0.05)
    unit = hpctl.Unit.seed()
    # One rig, one clock: eight records of it, read together.
    jitter_s = float(np.exp(rng.uniform(np.log(1e-4), np.log(2e-4))))
    records = []
    for k in range(8):
        [rec] = virtual_rig.make_records(unit, tests=[step], seed=seed + k)
        t = rec["time_s"]
        at = jittered(t, jitter_s, rng, float(t[-1]))
        rec.data["base_disp_m"] = rec["base_disp_m"] + np.array([base.x(s) for s in at]) - np.array([base.x(s) for s in t])
        rec.data["body_disp_m"] = rec["body_disp_m"] + CubicSpline(t, rec["body_disp_m"])(at) - rec["body_disp_m"]
        records.append(rec)
    datasets = prepare(records)
    read = datasets[0].input_jitter_s / jitter_s
    at_truth = fit(datasets, ("heat_transfer", "real_gas"), initial={"tau_s": unit.tau_s}, max_nfev=1, errors=False,
                   place_switches=False)
    judged = at_own_noise(at_truth)
    own = [float(np.sqrt(np.mean((at_truth.residuals(i, "body_disp_m") / judged.datasets[i].weight_sigma["body_disp_m"]) ** 2)))
           for i in range(len(datasets))]
    context = (f"HPCTL_TEST_SEED={seed}: the body over its own weights {np.round(own, 3)}, "
               f"the jitter read {read:.2f} x the drawn {jitter_s * 1e6:.1f} us")
    assert 0.75 <= float(np.mean(own)) <= 1.25, context
    assert 0.5 <= read <= 2.0, context
    # Said in the report and its JSON.
    from hpctl.identify.dataset import clock_jitters
    from hpctl.report.calibration import noise_section

    assert clock_jitters(datasets) == {"sdof": datasets[0].input_jitter_s}, context
    assert "## The rig's clock" in noise_section(datasets), context

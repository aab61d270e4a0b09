"""The flexible model (issue 12, item 2): the damper characteristic and the
friction's smoothing and Stribeck term identified from the data, and the
standard errors' coverage on randomised virtual-rig runs.

Both statistical tests draw anew on every run; the seed is printed on
failure (FOREIGN_RIG_SEED / COVERAGE_SEED / EXPONENT_SEED replay it)."""

from __future__ import annotations

import math
import os
import secrets
from dataclasses import dataclass, replace

import numpy as np
import pytest
from scipy.stats import binom, chi2

import coverage
import hpctl
from foreign_rig import generate, sweep_tests
from foreign_rig.programs import extra_tests
from foreign_rig.sensors import ChannelNoise, measure
from hpctl.data.records import read_record
from hpctl.identify.dataset import _drive, input_disp_m, prepare
from hpctl.identify.diagnose import NOISE_CEILING
from hpctl.identify.fit import FitResult, damper_branches, fit, simulate_all
from hpctl.identify.profile import profile_point
from hpctl.identify.switching import switch_samples
from hpctl.model.effects import (
    CORE_RANGES,
    DAMPER_BRANCHES,
    DAMPER_KNEE_BOUNDS,
    FRICTION_SHAPE,
    VALVE6_SHAPE,
    damper_shape_params,
    flexible_params,
    param,
    shaped_damper,
    shaped_valve6,
)
from hpctl.model.unit import Friction

SHORT = ("sine_0.03hz", "sine_0.3hz", "sine_1hz")
SIGMA_KEY = {"force_n": "force_n", "p_gas_pa": "p_pa", "p_gas2_pa": "p_pa", "body_disp_m": "disp_m"}


def test_nominal_shape_values_give_the_nominal_damper_and_friction() -> None:
    unit = hpctl.Unit.seed()
    nominal = {p.name: p.typical for p in flexible_params(("heat_transfer", "friction"), DAMPER_BRANCHES)}
    assert shaped_damper(unit.damper, nominal) == unit.damper
    assert shaped_damper(unit.damper, {}) == unit.damper
    # Every flexible parameter is found by name, with its prior.
    for p in flexible_params(("heat_transfer", "friction", "leakage"), DAMPER_BRANCHES, valve6=True):
        assert param(p.name) == p and p.prior_sigma is not None and p.lower <= p.initial <= p.upper
    # Valve 6's orifice: nominal at the prior's centre, scaled inside the
    # core's ranges at the fit's bounds.
    assert shaped_valve6(unit, {p.name: p.typical for p in VALVE6_SHAPE}) == unit and shaped_valve6(unit, {}) == unit
    for scale in (0, 1):
        bound = {p.name: (p.lower, p.upper)[scale] for p in VALVE6_SHAPE}
        u = shaped_valve6(unit, bound)
        assert u.valve6_flow_area_m2 == pytest.approx(unit.valve6_flow_area_m2 * bound["valve6_flow_area_scale"])
        assert u.valve6_transition_pa == pytest.approx(unit.valve6_transition_pa * bound["valve6_transition_scale"])
        for name in ("valve6_flow_area_m2", "valve6_transition_pa"):
            lo, hi = CORE_RANGES[name]
            assert lo <= getattr(u, name) <= hi, (name, getattr(u, name))
    assert len(damper_shape_params(("off_compression",))) == 8
    assert CORE_RANGES["blowoff_knee"][0] <= DAMPER_KNEE_BOUNDS[0] < DAMPER_KNEE_BOUNDS[1] <= CORE_RANGES["blowoff_knee"][1]
    for p in FRICTION_SHAPE:
        lo, hi = CORE_RANGES[p.name]
        assert lo <= p.lower < p.upper <= hi


def test_shape_changes_the_damper_force_as_the_core_curve_says() -> None:
    # Doubling the bleed and the orifice of a branch doubles its pressure
    # drop below blow-off: checked through a whole simulation.
    unit = hpctl.Unit.seed()
    from hpctl.sim.run import characterisation_rig, uniform_times

    times = uniform_times(2.0, 0.004)
    rig = characterisation_rig(hpctl.Sine(0.004, 1.0))  # slow: below blow-off
    a = hpctl.run(unit, rig, times, spring_hard=True, damper_on=False)
    doubled = shaped_damper(unit.damper, {f"damper_{b}_{k}": 2.0 for b in DAMPER_BRANCHES for k in ("bleed_scale", "orifice_scale")})
    b = hpctl.run(unit.replace(damper=doubled), rig, times, spring_hard=True, damper_on=False)
    big = np.abs(a["damper_force_n"]) > 10.0
    assert big.sum() > 100
    np.testing.assert_allclose(b["damper_force_n"][big], 2 * a["damper_force_n"][big], rtol=1e-3)


def test_a_second_blowoff_stage_gives_the_three_piece_curve_through_a_simulation() -> None:
    # A sharp second stage on the bypass branches (the flexible model's
    # stage-2 multipliers through shaped_damper, then the core's plant): at
    # every sample the damper force is the piston area times the closed
    # form R q + K q^2 / p_b + S (q - q_b) / p_b2 + S2 (q - q_b2), q the flow
    # the strut's own speed makes.
    unit = hpctl.Unit.seed()
    from hpctl.sim.run import characterisation_rig, uniform_times

    values = {f"damper_{b}_{k}": v for b in ("off_compression", "off_rebound")
              for k, v in (("knee", 0.0), ("blowoff2_scale", 1.3), ("slope2_scale", 0.25))}
    shaped = shaped_damper(unit.damper, values)
    c = shaped.off_compression
    assert c.blowoff2_pa == pytest.approx(1.3 * c.blowoff_pa) and c.blowoff2_slope_pa_s_per_m3 == pytest.approx(0.25 * c.blowoff_slope_pa_s_per_m3)
    times = uniform_times(2.0, 0.002)
    r = hpctl.run(unit.replace(damper=shaped), characterisation_rig(hpctl.Sine(0.06, 1.5)), times, spring_hard=True, damper_on=False)
    area = unit.piston_area_m2
    q = np.asarray(r["vel_m_s"]) * area
    expected = np.empty_like(q)
    reached = {1: 0, 2: 0}
    for i, qi in enumerate(q):
        b = shaped.off_compression if qi >= 0 else shaped.off_rebound
        m = abs(qi)
        q_b = (-b.bleed_pa_s_per_m3 + math.sqrt(b.bleed_pa_s_per_m3**2 + 4 * b.orifice_pa_s2_per_m6 * b.blowoff_pa)) / (2 * b.orifice_pa_s2_per_m6)
        q_b2 = q_b + (b.blowoff2_pa - b.blowoff_pa) / b.blowoff_slope_pa_s_per_m3
        if m <= q_b:
            dp = m * (b.bleed_pa_s_per_m3 + b.orifice_pa_s2_per_m6 * m)
        elif m <= q_b2:
            dp, reached[1] = b.blowoff_pa + b.blowoff_slope_pa_s_per_m3 * (m - q_b), reached[1] + 1
        else:
            dp, reached[2] = b.blowoff2_pa + b.blowoff2_slope_pa_s_per_m3 * (m - q_b2), reached[2] + 1
        expected[i] = math.copysign(dp, qi) * area
    assert reached[1] > 50 and reached[2] > 50, reached  # the drive reaches both stages
    np.testing.assert_allclose(r["damper_force_n"], expected, rtol=1e-7, atol=1e-6)


def test_a_bad_second_stage_is_refused_and_a_curve_without_one_still_reads() -> None:
    # The core refuses a second stage at or below the first blow-off or
    # with a slope that is not a finite positive number, naming the field,
    # its value and its range (a ValueError, never a panic); a unit written
    # before the second stage existed (no blowoff2 keys) reads as one stage.
    from dataclasses import replace as dc_replace

    from hpctl.errors import ParameterError
    from hpctl.sim.run import characterisation_rig, uniform_times

    unit = hpctl.Unit.seed()
    c = unit.damper.off_compression
    rig, times = characterisation_rig(hpctl.Sine(0.01, 1.0)), uniform_times(0.1, 0.01)
    for field_, kw in (("blowoff2_pa", {"blowoff2_pa": 0.5 * c.blowoff_pa, "blowoff2_slope_pa_s_per_m3": 1e9}),
                       ("blowoff2_pa", {"blowoff2_pa": c.blowoff_pa, "blowoff2_slope_pa_s_per_m3": 1e9}),
                       ("blowoff2_slope_pa_s_per_m3", {"blowoff2_pa": 2 * c.blowoff_pa, "blowoff2_slope_pa_s_per_m3": float("nan")}),
                       ("blowoff2_slope_pa_s_per_m3", {"blowoff2_pa": 2 * c.blowoff_pa, "blowoff2_slope_pa_s_per_m3": 0.0})):
        bad = dc_replace(unit.damper, off_compression=dc_replace(c, **kw))
        with pytest.raises(ParameterError, match=f"{field_} = .* outside the valid range"):
            hpctl.run(unit.replace(damper=bad), rig, times, spring_hard=True, damper_on=False)
    d = unit.to_dict()
    for branch in DAMPER_BRANCHES:
        for key in ("blowoff2_pa", "blowoff2_slope_pa_s_per_m3"):
            del d["damper"][branch][key]  # type: ignore[misc]
    old = hpctl.Unit.from_dict(d)
    assert old == unit and old.damper.off_compression.blowoff2_pa == 0.0


def test_a_parallel_bleed_adds_its_flow_at_the_drop_through_a_simulation() -> None:
    # The flexible model's parallel share through shaped_damper and the
    # core's plant: at every sample the strut's flow q is the parallel
    # bleed's G dp plus what the series bleed and orifice pass at dp
    # (R y + K y^2 = dp), found here by bisection on that definition; above
    # the (sharp) blow-off, p_b + S (q - q_b) with q_b the flow at p_b. The
    # share leaves the no-flow resistance R / (1 + R G) at the nominal R.
    from hpctl.errors import ParameterError
    from hpctl.sim.run import characterisation_rig, uniform_times

    unit = hpctl.Unit.seed()
    values = {f"damper_{b}_{k}": v for b in ("off_compression", "off_rebound") for k, v in (("knee", 0.0), ("parallel_share", 0.5))}
    shaped = shaped_damper(unit.damper, values)
    for b in ("off_compression", "off_rebound"):
        nominal, c = getattr(unit.damper, b), getattr(shaped, b)
        assert c.bleed_parallel_m3_per_s_pa == pytest.approx(0.5 / nominal.bleed_pa_s_per_m3)
        assert c.bleed_pa_s_per_m3 / (1 + c.bleed_pa_s_per_m3 * c.bleed_parallel_m3_per_s_pa) == pytest.approx(nominal.bleed_pa_s_per_m3)
    times = uniform_times(2.0, 0.002)
    r = hpctl.run(unit.replace(damper=shaped), characterisation_rig(hpctl.Sine(0.06, 1.5)), times, spring_hard=True, damper_on=False)
    area = unit.piston_area_m2

    def passes(b: object, dp: float) -> float:
        rr, kk, g = b.bleed_pa_s_per_m3, b.orifice_pa_s2_per_m6, b.bleed_parallel_m3_per_s_pa  # type: ignore[attr-defined]
        lo, hi = 0.0, 1.0
        for _ in range(200):
            mid = 0.5 * (lo + hi)
            lo, hi = (mid, hi) if mid * (rr + kk * mid) < dp else (lo, mid)
        return g * dp + 0.5 * (lo + hi)

    expected, below, above = [], 0, 0
    for qi in np.asarray(r["vel_m_s"]) * area:
        b = shaped.off_compression if qi >= 0 else shaped.off_rebound
        m, q_b = abs(qi), passes(b, b.blowoff_pa)
        if m <= q_b:
            lo, hi = 0.0, b.blowoff_pa
            for _ in range(200):
                mid = 0.5 * (lo + hi)
                lo, hi = (mid, hi) if passes(b, mid) < m else (lo, mid)
            dp, below = 0.5 * (lo + hi), below + 1
        else:
            dp, above = b.blowoff_pa + b.blowoff_slope_pa_s_per_m3 * (m - q_b), above + 1
        expected.append(math.copysign(dp, qi) * area)
    assert below > 100 and above > 100, (below, above)  # both regimes driven
    np.testing.assert_allclose(r["damper_force_n"], expected, rtol=1e-7, atol=1e-6)
    # Refused with the field named (a ValueError, never a panic); a unit
    # written before the parallel bleed existed reads with none.
    from dataclasses import replace as dc_replace

    for bad in (-1e-12, float("nan"), float("inf")):
        d = dc_replace(unit.damper, off_rebound=dc_replace(unit.damper.off_rebound, bleed_parallel_m3_per_s_pa=bad))
        with pytest.raises(ParameterError, match="bleed_parallel_m3_per_s_pa = .* outside the valid range"):
            hpctl.run(unit.replace(damper=d), characterisation_rig(hpctl.Sine(0.01, 1.0)), uniform_times(0.1, 0.01), spring_hard=True, damper_on=False)
    old = unit.to_dict()
    for branch in DAMPER_BRANCHES:
        del old["damper"][branch]["bleed_parallel_m3_per_s_pa"]  # type: ignore[misc]
    assert hpctl.Unit.from_dict(old) == unit and unit.damper.on_rebound.bleed_parallel_m3_per_s_pa == 0.0


def test_stribeck_friction_in_the_core_matches_the_formula() -> None:
    unit = hpctl.Unit.seed().with_effects(friction=Friction(400.0, 300.0, 1e-3, 1.4, 0.01))
    from hpctl.sim.run import characterisation_rig, uniform_times

    times = uniform_times(2.0, 0.002)
    r = hpctl.run(unit, characterisation_rig(hpctl.Sine(0.01, 1.0)), times, spring_hard=True, damper_on=False)
    v = np.asarray(r["vel_m_s"])
    expected = (400.0 * (1 + 0.4 * np.exp(-((v / 0.01) ** 2)))) * np.tanh(v / 1e-3) + 300.0 * v
    np.testing.assert_allclose(r["friction_force_n"], expected, atol=1e-6 * 560)


def _true_ratio(r: FitResult, truth: dict) -> float:
    sq, n = 0.0, 0
    for i, ds in enumerate(r.datasets):
        for c in ds.targets:
            res = r.residuals(i, c)
            sq += float(np.sum((res / truth["noise"][SIGMA_KEY[c]]["sigma"]) ** 2))
            n += len(res)
    return math.sqrt(sq / n)


@dataclass(frozen=True)
class ControlCase:
    """The foreign rig's control case (no effect) fitted with one damper gain
    and with the identified characteristic; drawn anew on every run."""

    context: str
    before: float
    after: float
    gain: FitResult
    flexible: FitResult
    truth: dict


@pytest.fixture(scope="module")
def control_case() -> ControlCase:
    seed = int(os.environ.get("FOREIGN_RIG_SEED", secrets.randbelow(2**31)))
    g = generate(None, seed, tests=[t for t in sweep_tests() if t.name in SHORT])
    datasets = prepare([read_record(p) for p in g.records])
    assert damper_branches(datasets) == ("off_compression", "off_rebound")
    gain = fit(datasets, ("heat_transfer", "real_gas"))
    flexible = fit(datasets, ("heat_transfer", "real_gas"), flexible=True)
    before, after = _true_ratio(gain, g.truth), _true_ratio(flexible, g.truth)
    context = f"FOREIGN_RIG_SEED={seed}: RMS/true noise {before:.2f} -> {after:.2f}"
    print(context)
    return ControlCase(context, before, after, gain, flexible, g.truth)


def _force_velocity_r(r: FitResult, i: int) -> float:
    return abs(float(np.corrcoef(r.residuals(i, "force_n"), r.datasets[i].strut_vel_m_s)[0, 1]))


def _force_rms(r: FitResult, i: int) -> float:
    return float(np.sqrt(np.mean(r.residuals(i, "force_n") ** 2)))


def test_flexible_damper_brings_the_foreign_control_case_near_the_noise(control_case: ControlCase) -> None:
    # The foreign rig's own orifice/blow-off damper, no effect: one gain on
    # the assumed curve leaves 9-24x the true noise (velocity-shaped); the
    # identified characteristic 1.2-2.7x (20 draws in docs/foreign-rig.md). What is left is mostly pressure (the gauge's
    # static-pressure error and the equation of state), not the damper.
    c = control_case
    assert c.after < 0.4 * c.before and c.after < 4.0, c.context
    # The velocity-shaped force residual is gone where the damper carries
    # the force (the 0.3 and 1 Hz sines, up to 0.11 and 0.38 m/s).
    for i, ds in enumerate(c.flexible.datasets):
        if ds.name == "sine_0.03hz":
            continue  # below 12 mm/s: the next test
        r = _force_velocity_r(c.flexible, i)
        assert r < 0.5, f"{c.context}: {ds.name} force residual correlates with velocity, r = {r:.2f}"


def test_flexible_damper_leaves_the_slowest_sine_no_worse(control_case: ControlCase) -> None:
    # The slowest sine (<= 12 mm/s) no worse than with one gain, and its
    # force residual not velocity-shaped. It used to fail on some draws
    # (FOREIGN_RIG_SEED=1960729116: 1.15x -> 1.61x the noise, r = 0.62,
    # 7 of 10 draws passed): the blow-off knee's rounding reached down to
    # no flow and stiffened the curve there, which the bleed could not take
    # back. Since the knee leaves the low-speed curve alone: 1.15x -> 1.21x,
    # r = 0.33, and 20 of 20 draws pass (docs/foreign-rig.md).
    c = control_case
    names = [ds.name for ds in c.flexible.datasets]
    i = names.index("sine_0.03hz")
    r = _force_velocity_r(c.flexible, i)
    assert r < 0.5, f"{c.context}: sine_0.03hz force residual correlates with velocity, r = {r:.2f}"
    assert _force_rms(c.flexible, i) <= 1.1 * _force_rms(c.gain, i), c.context


#: Foreign-rig draws for the coverage of the heat-transfer exponent's
#: standard error: one flexible fit of the three short sines each, about
#: 2 s (40-60 s in all on the shared 2-core machine).
EXPONENT_DRAWS = 20


@pytest.fixture(scope="module")
def exponent_draws() -> tuple[int, list[tuple[float, float]]]:
    base = int(os.environ.get("EXPONENT_SEED", secrets.randbelow(2**31 - EXPONENT_DRAWS)))
    out = []
    for seed in range(base, base + EXPONENT_DRAWS):
        g = generate(None, seed, tests=[t for t in sweep_tests() if t.name in SHORT])
        r = fit(prepare([read_record(p) for p in g.records]), ("heat_transfer", "real_gas"), flexible=True)
        out.append((r.values["tau_cv_exponent"], r.stderr["tau_cv_exponent"]))
    return base, out


def test_flexible_heat_transfer_finds_the_foreign_rigs_constant_wall_conductance(
    control_case: ControlCase, exponent_draws: tuple[int, list[tuple[float, float]]]
) -> None:
    # The foreign rig's gas exchanges heat through a constant conductance
    # h A (its own formulation: tau = m c_v / h A moves with c_v), which is
    # exponent 1 of m c_v in hpctl's time constant; the seed's constant
    # time constant is 0 (the prior's centre). Before the flexible model
    # fitted it, the strut-side pressure kept 3-8x the noise on the 0.3 and
    # 1 Hz sines (FOREIGN_RIG_SEED=1767147371: 6.0x and 6.4x).
    c = control_case
    err = c.flexible.stderr["tau_cv_exponent"]
    assert err < 0.25, f"{c.context}: exponent {c.flexible.values['tau_cv_exponent']:.3f} +- {err:.3f}: the sines should pin it"
    # Its standard error is honest, judged on 20 fresh draws as the
    # hp-core coverage test below judges its own: for honest errors the
    # count of draws with the truth within 2 sigma is Binomial(20, 0.9545),
    # fewer than 16 has probability 0.0017, and the mean z^2 is inside the
    # chi-square(20)/20 band of probability 0.998. This was a one-draw test
    # at 3 sigma until it failed in CI on FOREIGN_RIG_SEED=1696361428:
    # 1.119 +- 0.028 (z = 4.3), a draw whose pressure noise is 39 %
    # coloured with a 38 ms correlation time, sampled every 5 ms on the 1 Hz
    # sine; the errors took the residuals as independent. 16 fresh noise
    # draws on that unit gave 0.993 with a spread of 0.045: the error was
    # 0.029, with the output noise's autocorrelation in the covariance
    # (hpctl.identify.serial) 0.036, and on FOREIGN_RIG_SEED=100..129 29
    # of 30 inside 2 sigma, z mean +0.41, spread 0.94, largest 2.09
    # (2026-11-27; docs/foreign-rig.md). EXPONENT_SEED=2040467668 failed the
    # lower end (mean z^2 0.22, all 20 inside 2 sigma: errors too wide?);
    # 300 fresh draws (seeds 1000000-1000299, stop 65): mean z^2 0.99, z sd
    # 0.98, 96.7 % inside 2 sigma, 20-draw windows' mean z^2 0.42-1.32, and
    # a window as low as 0.22 at probability 1e-4 by chi-square and by
    # resampling those 300: chance, not errors too wide.
    base, draws = exponent_draws
    n = len(draws)
    z = np.array([(v - 1.0) / e for v, e in draws])
    least = int(binom.ppf(0.002, n, 0.9545))
    lo, hi = chi2.ppf(0.001, n) / n, chi2.ppf(0.999, n) / n
    inside = int(np.sum(np.abs(z) <= 2.0))
    context = (f"EXPONENT_SEED={base}: {inside}/{n} inside 2 sigma (need >= {least}), mean z^2 {np.mean(z**2):.2f} "
               f"(band [{lo:.2f}, {hi:.2f}]), z {np.array2string(z, precision=2)}")
    print(context)
    assert inside >= least, context
    assert lo <= float(np.mean(z**2)) <= hi, context


#: Draws of the measured input's noise per record for the part of the
#: pressure residual it carries (the mean square over 4 x 401 samples: a
#: few per cent sampling error in the expected RMS).
CARRIED_DRAWS = 4


def _carried_input_noise_ms(c: ControlCase, i: int, channel: str, rng: np.random.Generator) -> float:
    """Mean square of what the measured displacement's noise puts into the
    model's ``channel`` on record ``i``: the fitted model driven by the
    measured input plus a fresh draw of the foreign data system's own
    displacement noise (its white, coloured and quantisation parts, from
    the truth), against the model driven by the measured input alone."""
    r = c.flexible
    ds = r.datasets[i]
    noise = ChannelNoise(**{k: v for k, v in c.truth["noise"]["disp_m"].items() if k != "sigma"})
    x = input_disp_m(ds.record)
    noisy = []
    for _ in range(CARRIED_DRAWS):
        rig, _, _, _ = _drive(ds.record, ds.times_s, measure(x, ds.times_s, noise, rng))
        noisy.append(replace(ds, rig=rig))
    sims = simulate_all(r.model, noisy, [r.values])[0]
    base = np.asarray(r.sims[i][channel])
    out = []
    for s in sims:
        assert not isinstance(s, Exception), s
        out.append(float(np.mean((np.asarray(s[channel]) - base) ** 2)))
    return float(np.mean(out))


def test_flexible_fit_leaves_the_gas_pressure_at_the_noise(control_case: ControlCase) -> None:
    # What the pressure channels keep is the transducer's noise, the data
    # system's sample-time jitter times the signal's slope (the jitter is
    # the foreign rig's, not in the noise's sigma) and the measured input
    # displacement's noise carried through the model (it drives the model;
    # near full compression the small accumulator's pressure moves by up to
    # 0.6 Pa per um): nothing the model could still explain. Without the
    # carried part the test failed on FOREIGN_RIG_SEED=1941164716 (the 0.3 Hz
    # sine's strut-side pressure 3,263 Pa against 1.3 x 2,300 Pa; 10 um of
    # displacement noise carrying 2,050 Pa; with it 1.06 x).
    c = control_case
    sigma, jitter = c.truth["noise"]["p_pa"]["sigma"], c.truth["noise"]["jitter_s"]
    rng = np.random.default_rng(0)
    for i, ds in enumerate(c.flexible.datasets):
        sim = c.flexible.sims[i]
        assert not isinstance(sim, Exception)
        for ch in ("p_gas_pa", "p_gas2_pa"):
            rms = float(np.sqrt(np.mean(c.flexible.residuals(i, ch) ** 2)))
            slope = np.gradient(sim[ch], ds.times_s)
            carried = _carried_input_noise_ms(c, i, ch, rng)
            expected = math.sqrt(sigma**2 + float(np.mean((jitter * slope) ** 2)) + carried)
            assert rms <= 1.3 * expected, (f"{c.context}: {ds.name}/{ch} residual {rms:.0f} Pa, noise with jitter and the "
                                           f"input's noise {expected:.0f} Pa (carried {math.sqrt(carried):.0f} Pa)")


def test_input_noise_correction_holds_parameters_at_their_bounds() -> None:
    # The correction step moves only the free parameters: for those it is
    # the least-squares solution of the reduced problem (numpy's lstsq,
    # independent of the normal equations fit.py solves), the others stay.
    from hpctl.identify.fit import _free, _least_squares_step

    rng = np.random.default_rng(3)
    base = rng.normal(size=(200, 1))
    j = np.hstack([base + 0.05 * rng.normal(size=(200, 1)) for _ in range(3)])  # |r| ~ 0.998
    dr = rng.normal(size=200)
    lo, hi = np.zeros(3), np.ones(3)
    x = np.array([0.3, 0.6, 1.0])  # the third at its upper bound
    free = _free(x, lo, hi)
    assert list(free) == [True, True, False]
    step = _least_squares_step(j, np.zeros((0, 3)), dr, free)
    expected = np.linalg.lstsq(j[:, :2], dr, rcond=None)[0]
    assert step[2] == 0.0
    np.testing.assert_allclose(step[:2], expected, rtol=1e-8)
    # A parameter near its bound (not on it) that the step would take
    # across is held too, and the others solved without it; the result
    # stays inside the bounds.
    from hpctl.identify.fit import _bounded_step

    full = np.linalg.lstsq(j, dr, rcond=None)[0]
    wide_lo, wide_hi = np.array([-10.0, -10.0, 0.0]), np.array([10.0, 10.0, 1.0])
    near = np.array([0.3, 0.6, 1.0 - 1e-4 if full[2] > 0 else 1e-4])
    assert abs(full[2]) > 1e-3  # the unconstrained step crosses the bound
    held = _bounded_step(near, wide_lo, wide_hi, j, np.zeros((0, 3)), dr)
    assert held[2] == 0.0 and np.all(near + held >= wide_lo) and np.all(near + held <= wide_hi)
    np.testing.assert_allclose(held[:2], expected, rtol=1e-8)


#: Randomised runs per coverage test: one to two minutes on the shared
#: 2-core machine.
COVERAGE_RUNS = 40
@pytest.fixture(scope="module")
def coverage_runs() -> tuple[int, list[coverage.Run]]:
    base = int(os.environ.get("COVERAGE_SEED", secrets.randbelow(2**31)))
    return base, [coverage.run(base + i) for i in range(COVERAGE_RUNS)]


# All five strict: tau_s and charge_scale were overconfident (88 and 91 of
# 100 runs inside 2 sigma) until the fit carried the input displacement's
# noise into the covariance and stopped the smoothing from shrinking the
# excitation (94 and 94 of 100 since: docs/foreign-rig.md). Measured on
# more draws at stop 64, tau_s read 16 % overconfident (271 of 300
# inside, z sd 1.12-1.19; a 40-run window failed this test's criteria
# once in 122); at stop 65 sets of fresh noise read z sd 0.95-1.18 by
# set, about 8-10 % overall: docs/foreign-rig.md says what was ruled out.
@pytest.mark.parametrize("name", ["tau_s", "friction_coulomb_n", "friction_viscous_n_s_per_m", "charge_scale", "damper_gain"])
def test_standard_errors_cover_the_truth_in_randomised_runs(coverage_runs: tuple[int, list[coverage.Run]], name: str) -> None:
    # 40 virtual-rig runs (truth drawn from the registry's random ranges,
    # noise anew): for honest standard errors the count of runs with the
    # truth within 2 sigma is Binomial(40, 0.9545), and fewer than 33
    # (its 0.2 % quantile) has probability 0.0004. The spread of the
    # z-scores is checked too (errors too wide would pass the count): mean
    # z^2 within the chi-square(40)/40 band of probability 0.998. Over the
    # five parameters a false alarm is at most 1.2 % of CI runs.
    base, runs = coverage_runs
    n = len(runs)
    least = int(binom.ppf(0.002, n, 0.9545))
    lo, hi = chi2.ppf(0.001, n) / n, chi2.ppf(0.999, n) / n
    z = np.array([r.z(name) for r in runs])
    inside = coverage.inside(runs, name)
    context = (f"COVERAGE_SEED={base}: {name} {inside}/{n} inside 2 sigma (need >= {least}), "
               f"mean z^2 {np.mean(z**2):.2f} (band [{lo:.2f}, {hi:.2f}]), z mean {z.mean():+.2f}")
    print(context)
    assert inside >= least, context
    assert lo <= float(np.mean(z**2)) <= hi, context


def test_a_flexible_fit_beside_its_bounds_does_not_crawl() -> None:
    # A regression test on one fixed draw (the randomised tests above and
    # the diagnosis tests cover the rest): the foreign rig's friction case,
    # seed 1, its five-sine sweep. The flexible model without friction puts
    # a damper knee on its bound; friction added to that model, with unit
    # variable scales, crawled: every step cut short where it met the bound,
    # 60 evaluations gaining about 20 in the residual sum of squares each,
    # ending at 1.78x the noise where the model without friction had 1.51x.
    # Scaled by the Jacobian's columns (fit's x_scale="jac"): 0.88x in 28.
    from hpctl.identify.diagnose import screening_ftol

    g = generate("friction", 1)
    datasets = prepare([read_record(p) for p in g.records])
    seed_model = ("heat_transfer", "real_gas")
    base = fit(datasets, seed_model, input_noise=False, flexible=True)
    with_friction = fit(datasets, seed_model + ("friction",), initial=base.values, input_noise=False, flexible=True,
                        ftol=screening_ftol(base.n))
    assert with_friction.success, with_friction.message
    assert with_friction.rss < base.rss and with_friction.rms_ratio < 1.1, (base.rms_ratio, with_friction.rms_ratio)


def test_switch_places_that_trade_with_the_valve_reach_their_end() -> None:
    # Foreign rig, valve-lag case, seed 11 (a 17.6 ms valve; three sines and
    # the switching record): the switches are made on a nominal sample time
    # and logged one sample later, so the openings' places are at the end of
    # their intervals (0.99 here). Placing and fitting again moved them 0.61
    # -> 0.71 -> 0.79 -> 0.85, three quarters of the move before each pass,
    # and stopped at the pass limit: the valve's time constant 2 % short, the
    # small accumulator's pressure 13-19 kPa off in the first 20 ms after the
    # first openings (noise 3 kPa), the diagnosis at 1.41 x the noise with
    # "structure remains". Extrapolated (switching.extrapolated_leads):
    # 0.99, the time constant within 0.1 %, residual sum of squares 1,456
    # lower (stop 36).
    g = generate("valve_lag", 11, tests=[t for t in sweep_tests() if t.name in SHORT] + extra_tests()["switching"])
    datasets = prepare([read_record(p) for p in g.records])
    r = fit(datasets, ("heat_transfer", "real_gas", "valve_lag"), flexible=True, input_noise=False)
    (switching,) = [d for d in r.datasets if d.switch_leads.size]
    openings = switching.switch_leads[~np.asarray(switching.spring_hard)[switch_samples(switching)]]
    true_tau = g.truth["hpctl_params"]["valve_time_constant_s"]
    context = f"places {np.round(switching.switch_leads, 3)}; valve tau {r.values['valve_time_constant_s']:.5f} against {true_tau:.5f}; {r.rms_ratio:.3f} x"
    assert openings.size == 4 and np.all(openings >= 0.95), context
    assert r.values["valve_time_constant_s"] == pytest.approx(true_tau, rel=0.01), context


def test_closings_that_trade_with_the_valve_reach_the_joint_optimum() -> None:
    # Foreign rig, valve-lag case, FOREIGN_RIG_SEED=1137061372 (a 13.5 ms
    # valve, 5 ms samples): every switch is made on a nominal sample time,
    # the first four logged a sample later (their true places 0.99). The
    # passes of placing with the parameters held and fitting with the
    # places held left the two closings at 0.56 and 0.50 and the valve's
    # time constant at 12.46 +- 0.13 ms (8.7 errors short; CI failed on it
    # in test_diagnose_foreign.py, stop 42), the cost 10,300 above the fit
    # at the true places. Two joint steps of the places and the parameters
    # (fit._joint_places, stop 43): all four at 0.99, 13.52 +- 0.10 ms, the
    # cost 519 lower, 1.057 x the noise (was 1.082).
    g = generate("valve_lag", 1137061372, tests=[t for t in sweep_tests() if t.name in SHORT] + extra_tests()["switching"])
    datasets = prepare([read_record(p) for p in g.records])
    r = fit(datasets, ("heat_transfer", "real_gas", "valve_lag"), flexible=True, input_noise=False)
    (switching,) = [d for d in r.datasets if d.switch_leads.size]
    true_tau = g.truth["hpctl_params"]["valve_time_constant_s"]
    tau, err = r.values["valve_time_constant_s"], r.stderr["valve_time_constant_s"]
    context = f"places {np.round(switching.switch_leads, 3)}; valve tau {tau:.5f} +- {err:.5f} against {true_tau:.5f}; {r.rms_ratio:.3f} x; {r.message}"
    assert np.all(switching.switch_leads[:4] >= 0.95), context
    assert abs(tau - true_tau) <= min(3.0 * err, 0.01 * true_tau), context


def test_flexible_model_identifies_valve6_where_the_records_open_it(monkeypatch: pytest.MonkeyPatch) -> None:
    # A record declares the accumulators and the piston, not valve 6: the
    # foreign rig's valves (Cd 0.65 on 2-5e-5 m^2, a Reynolds-number law of
    # their own) flow 1.5-3.7 times less than hpctl's nominal one. Where
    # the records open valve 6, the flexible model fits its flow area and
    # transition pressure. On the valve-lag case (valve 6 switched during a
    # sine), seeds 1-5 and 11-16 on 2026-11-27: the residual over hpctl's
    # noise estimate 1.02-1.99 with them against 1.74-5.57 without, the
    # excess over the noise (RMS^2 - 1) down to at most 0.51 of what it was;
    # Cd A within 1.0-26.9 % of the truth (seeds 1-5, 11, 13, 15; the
    # nominal valve 55-162 % off; biased high where the residual stays
    # structured: the two orifice laws differ in shape), the valve time
    # constant within 0-13.5 % (10-41 % without). What is asserted: the
    # excess cut by a third at least, and Cd A nearer the truth than the
    # nominal valve by a factor 1.5 at least (the worst corner of the
    # foreign rig's draws, a truth at 3.25e-5 m^2 and +27 %: 1.85).
    # It failed on seeds 1981622276 (Cd A +37 %, the bound +35 %) and 20
    # (1.441 -> 1.325 x the noise, a third of the excess needs 1.318), 2 of
    # about 25 draws: the foreign rig switches valve 6 exactly on a nominal
    # sample time and the sample-time jitter decides which sample logs the
    # switch, so midway was half a sample early or late at every switch,
    # which a larger, smoother valve partly made up for. Since the fit
    # places each logged switch within its interval (hpctl.identify.
    # switching): 1981622276 1.046 -> 0.928, Cd A +24 %; 20 1.340 -> 1.041,
    # Cd A +5 %, valve tau 0.0256 against 0.0256 (2026-11-27, stop 26).
    from hpctl.identify import fit as fit_module

    seed = int(os.environ.get("FOREIGN_RIG_SEED", secrets.randbelow(2**31)))
    g = generate("valve_lag", seed)
    datasets = prepare([read_record(p) for p in g.records])
    model = ("heat_transfer", "real_gas", "valve_lag")
    with_valve = fit(datasets, model, flexible=True, input_noise=False)
    assert {p.name for p in VALVE6_SHAPE} <= set(with_valve.values) and with_valve.model.valve6
    monkeypatch.setattr(fit_module, "opens_valve6", lambda _d: False)
    without = fit(datasets, model, flexible=True, input_noise=False)
    assert not set(without.values) & {p.name for p in VALVE6_SHAPE}
    v6 = g.truth["unit"]["valve6"]
    true_area = v6["area_m2"] * v6["cd_inf"]
    nominal = hpctl.Unit.seed().valve6_flow_area_m2  # what the records' units have: they do not declare a valve
    area = with_valve.values["valve6_flow_area_scale"] * nominal
    context = (f"FOREIGN_RIG_SEED={seed}: RMS/noise {without.rms_ratio:.3f} -> {with_valve.rms_ratio:.3f}, Cd A {area:.3e} against {true_area:.3e}, "
               f"valve tau {with_valve.values['valve_time_constant_s']:.4f} against {g.truth['hpctl_params']['valve_time_constant_s']:.4f}")
    print(context)
    assert with_valve.rms_ratio**2 - 1.0 <= 2.0 / 3.0 * (without.rms_ratio**2 - 1.0), context
    assert abs(area - true_area) <= abs(nominal - true_area) / 1.5, context


def test_flexible_model_finds_a_pressure_driven_leak() -> None:
    # The foreign rig's leak goes with the gauge pressure (permeation:
    # dm/dt = -(m0 / tau_L)(p - p_atm) / (p0 - p_atm)); hpctl's fixed law
    # decays at one time constant whatever the pressure, so in the hold the
    # compressed accumulator's pressure residual trended up with time and
    # the other's down (r = +1.00 / -0.99; diagnosis with --flexible: leakage
    # and a sensor offset, 1.63 x the noise left). The flexible model fits
    # the exponent n of hp-core's dm/dt = -(m / tau_L) r^n: the foreign law
    # is n = 1 to first order in the gas lost. Seeds 1-7 on 2026-11-27:
    # n 0.98-1.03, tau_L within 1.4 %, the residual 0.81-0.94 x the noise
    # as the weights then read it (they carried 3-7 x too much of the input's
    # noise); with the input's noise from the model (stop 29), seeds 1-7 and
    # 11-17: n 1.003-1.013, tau_L within 1.3 %, the residual 0.98-1.14 x
    # (the 1 Hz force and the hold's pressure the worst channels, 1.2-1.5 x).
    # The residual asserted at the "at the noise", as elsewhere.
    #
    # That first order was not enough for the errors: the rate also fell
    # with the mass lost over the hold (m / tau_L), the foreign one does not
    # (m0 / tau_L), and tau_L came out short by about that loss with errors
    # far too narrow (seeds 11, 12: -1.22 % at z -19.4, -0.61 % at z -3.9).
    # With the mass exponent k of dm/dt = -(m0 / tau_L)(m / m0)^k r^n
    # fitted (stop 37; the foreign law is k = 0, n = 1 exactly), seeds 1-8
    # and 11-14: tau_L within 0.35 %, |z| <= 1.48; k within 2.3 errors of 0
    # (errors 0.04-0.97: k shows only in the decay's curvature).
    seed = int(os.environ.get("FOREIGN_RIG_SEED", secrets.randbelow(2**31)))
    g = generate("leakage", seed)
    r = fit(prepare([read_record(p) for p in g.records]), ("heat_transfer", "real_gas", "leakage"), flexible=True)
    truth = g.truth["hpctl_params"]["leak_time_constant_s"]
    tau, n, k = r.values["leak_time_constant_s"], r.values["leak_pressure_exponent"], r.values["leak_mass_exponent"]
    tau_err, k_err = r.stderr["leak_time_constant_s"], r.stderr["leak_mass_exponent"]
    context = (f"FOREIGN_RIG_SEED={seed}: tau_L {tau:.4g} +- {tau_err:.2g} against {truth:.4g}, n {n:.3f}, "
               f"k {k:.3f} +- {k_err:.2g}, RMS/noise {r.rms_ratio:.3f}")
    assert abs(tau / truth - 1.0) <= 0.1, context
    assert abs(n - 1.0) <= 0.1, context
    # Honest errors: the truth within three of them (0.3 % of honest draws
    # fail), tau_L's and k's.
    assert abs(tau - truth) <= 3.0 * tau_err, context
    assert abs(k) <= 3.0 * k_err, context
    assert r.rms_ratio <= NOISE_CEILING, context


def test_flexible_model_warms_the_gas_wall_with_the_gas_heat() -> None:
    # The foreign rig's heat build-up: the gas cylinders' walls one node
    # (3,000-10,000 J/K) warmed by the oil and by the gas's own heat, which
    # on the 10-minute heat run (0.5 Hz, 60 mm, the damper on) is hundreds
    # of W: on seed 7 the sealed large accumulator ended 5 K above the oil
    # that was to warm it. hpctl's wall followed the oil and ambient only:
    # the flexible diagnosis put the wall's time constant on its bound and
    # left 7.1 x the noise (the large accumulator's pressure 17-26 x). With
    # the wall's heat capacity fitted (seeds 7, 8, 9: 7,598 / 3,683 / 8,177
    # against 7,582 / 3,673 / 8,152 J/K) the residual is at the noise.
    # The fit sees the oil only through the gas (t_oil_k is not a fitted
    # channel). With the wall's time constant to ambient held at the seed's
    # 20,000 s (the foreign rig draws 12,000-30,000 s) the oil's heat
    # capacity came out +6.7 +- 0.5 % (12.8 errors) and +33 +- 12 % on seeds
    # 7 and 8; fitted (WALL_SHAPE, a prior on the seed's value) the oil is
    # within its errors on seeds 7-12 and 100 (z +0.87, +0.23, +0.02, -0.80,
    # -0.77, -1.48, +0.59), the wall to ambient mostly its prior's. The
    # wall-to-oil time constant's linear errors do not cover the truth
    # (-33, -33, -3, -33, -31, -58, -14 % on those seeds, z down to -3.7):
    # the valley bends (the wall's loss to the oil and to ambient trade, the
    # prior on the ambient side bends it). At the truth hpctl's model
    # reproduces the foreign wall, gas and oil temperatures within 0.01 K
    # (seed 7); the profile interval covers it (below; docs/foreign-rig.md,
    # stop 34).
    seed = int(os.environ.get("FOREIGN_RIG_SEED", secrets.randbelow(2**31)))
    g = generate("heat_buildup", seed, tests=[*[t for t in sweep_tests() if t.name in SHORT], *extra_tests()["heat"]])
    datasets = prepare([read_record(p) for p in g.records])
    r = fit(datasets, ("heat_transfer", "real_gas", "heat_buildup"), flexible=True)
    truth = g.truth["hpctl_params"]
    c, sc = r.values["wall_heat_capacity_j_per_k"], r.stderr["wall_heat_capacity_j_per_k"]
    context = (f"FOREIGN_RIG_SEED={seed}: wall {c:.5g} +- {sc:.2g} against {truth['wall_heat_capacity_j_per_k']:.5g} J/K, oil "
               f"{r.values['oil_heat_capacity_j_per_k']:.5g} against {truth['oil_heat_capacity_j_per_k']:.5g} J/K, RMS/noise {r.rms_ratio:.3f}; "
               + ", ".join(f"{s.record}/{s.channel} {s.rms / s.noise:.2f}" for s in r.stats))
    assert abs(c / truth["wall_heat_capacity_j_per_k"] - 1.0) <= max(0.1, 2.0 * sc / c), context
    oil, so = r.values["oil_heat_capacity_j_per_k"], r.stderr["oil_heat_capacity_j_per_k"]
    if abs(oil - truth["oil_heat_capacity_j_per_k"]) > max(0.1 * truth["oil_heat_capacity_j_per_k"], 2.0 * so):
        # The oil's honest band is its profile too (Param.profile_band: it
        # trades with the wall-to-oil time constant along the bending
        # valley below). FOREIGN_RIG_SEED=1138648182: 21,999 +- 2,837
        # against 28,134 J/K (-22 %, 2.2 errors), pre-existing (stop 40's
        # code the same), the residual at the noise (0.97 x).
        point = profile_point(r, "oil_heat_capacity_j_per_k", truth["oil_heat_capacity_j_per_k"])
        assert point.rise <= 9.0, f"oil {oil:.5g} +- {so:.3g}: the cost rose {point.rise:.3g} at the truth; {context}"
    # The wall-to-oil time constant's honest band is its profile: the cost
    # with it held at the truth (the rest fitted again) rose by 1.1, 1.1 and
    # 1.6 on seeds 7, 8 and 12 (linear z -2.25, -0.98, -3.76), 4.8 on seed 8
    # from a fit stopped at its budget; at most 9, the three-sigma interval
    # (an honest one misses 0.3 % of the draws, a two-sigma one 5 %: a
    # test on one draw per run would fail one CI run in twenty).
    tau = profile_point(r, "wall_to_oil_tau_s", truth["wall_to_oil_tau_s"])
    assert tau.rise <= 9.0, (f"wall-to-oil {r.values['wall_to_oil_tau_s']:.5g} +- {r.stderr['wall_to_oil_tau_s']:.3g} against "
                             f"{truth['wall_to_oil_tau_s']:.5g} s: the cost rose {tau.rise:.3g} there; {context}")
    # The residual at the noise as the issue puts it (at most 1.3 x), and
    # the heat run's every channel (seeds 7-10, 100, 106, 109, 1942323016:
    # pooled 0.96-1.08, the heat run's channels 0.96-1.24). The heat run
    # samples the damper-on curve at 11 speeds a direction 300 times: with
    # the bleed only in series with the orifice its force stayed at 1.50
    # and 1.61 x on 1942323016 and 100 (the residual a function of the
    # rebound speed alone), the bleed beside it (`parallel_share`) 1.24 and
    # 1.20 (docs/foreign-rig.md, "The bleed beside the orifice").
    assert r.rms_ratio <= NOISE_CEILING, context
    for s in r.stats:
        assert s.record != "heat_run" or s.rms / s.noise <= NOISE_CEILING, context
    # The heat run's noise levels: no order of differences holds only the
    # force's noise there (seed 7: 99, 41 and 33 N from the fourth, sixth and
    # eighth, against 16); the channel's noise from the sines is taken. The
    # noise a record holds is the transducer's and the sample-time jitter's,
    # the rate times the jitter (seed 488147967: the heat run's strut
    # pressure 5.7 kPa, the transducer's 2.6; with the jitter 5.5).
    heat = next(d for d in r.datasets if d.name == "heat_run")
    for c_name, key in (("force_n", "force_n"), ("p_gas_pa", "p_pa"), ("p_gas2_pa", "p_pa")):
        rate = np.gradient(heat.targets[c_name], heat.times_s)
        noise = math.hypot(g.truth["noise"][key]["sigma"], g.truth["noise"]["jitter_s"] * float(np.sqrt(np.mean(rate**2))))
        assert 0.75 * noise <= heat.sigma[c_name] <= 1.25 * noise, (c_name, heat.sigma[c_name], noise, context)

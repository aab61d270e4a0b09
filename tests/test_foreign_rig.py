"""The foreign rig (tests/foreign_rig) checked against what it did not
write: CoolProp's reference nitrogen in its isothermal and isentropic
limits, conservation of energy, static equilibrium, analytic friction
loops and series stiffness, the damper's blow-off and cavitation, noise
statistics; and its records read by hpctl's reader.

None of these use hp-core: the rig is the independent reference the
diagnosis tests are run against, so it has to stand on its own physics.
Randomised draws print their seed (FOREIGN_RIG_SEED replays one).
"""

from __future__ import annotations

import json
import math
import os
import secrets

import CoolProp.CoolProp as CP
import numpy as np
import pytest

from foreign_rig import EFFECTS, LIBRARY_EFFECTS, draw_case, extra_tests, generate, run_test, sweep_tests
from foreign_rig.damper import Damper, default_pack, scalar_valve_flow
from foreign_rig.gas import Nitrogen
from foreign_rig.model import Segment, simulate
from foreign_rig.motion import Hold, Sine, Step
from foreign_rig.programs import Test
from foreign_rig.sensors import ChannelNoise, jittered, measure, ou_noise
from foreign_rig.unit import G_M_S2, BumpStop, Friction, OilCompliance, SensorLag, Unit, ValveLag

HARD_OFF = [Segment(0.0, False, True)]  # valve 6 closed (hard), bypass open (damper off)
HARD_ON = [Segment(0.0, False, False)]
SOFT_ON = [Segment(0.0, True, False)]


@pytest.fixture
def seed() -> int:
    s = int(os.environ.get("FOREIGN_RIG_SEED", secrets.randbelow(2**31)))
    print(f"FOREIGN_RIG_SEED={s}")
    return s


def coolprop(out: str, a: str, av: float, b: str, bv: float) -> float:
    return float(CP.PropsSI(out, a, av, b, bv, "Nitrogen"))


# -- the gas ---------------------------------------------------------------

def test_gas_is_coolprop_reference_nitrogen() -> None:
    n = Nitrogen()
    rho = n.density(14.8e6, 293.15)
    p, dpdt, cv = n.props(rho, 293.15)
    assert p == pytest.approx(14.8e6, rel=1e-9)
    assert dpdt == pytest.approx(coolprop("d(P)/d(T)|Dmass", "Dmass", rho, "T", 293.15), rel=1e-9)
    assert cv == pytest.approx(coolprop("Cvmass", "Dmass", rho, "T", 293.15), rel=1e-9)


def slow_sine_record(unit: Unit, frequency_hz: float = 0.2, n: int = 201) -> tuple[np.ndarray, dict[str, np.ndarray]]:
    dur = 1.0 / frequency_hz
    ts = np.linspace(0.0, dur, n)
    r = simulate(unit, Sine(0.06, frequency_hz), ts, HARD_OFF, dur, rtol=1e-10)
    return ts, r.channels


def test_isothermal_limit_is_coolprop_at_constant_temperature() -> None:
    u = Unit(tau_s=0.0)
    _, c = slow_sine_record(u)
    m = Nitrogen().density(u.static_pressure_pa, u.static_temperature_k) * u.small_acc_volume_m3
    ref = np.array([coolprop("P", "Dmass", m / (u.small_acc_volume_m3 - u.piston_area_m2 * x), "T", u.static_temperature_k) for x in c["disp_m"]])
    assert np.abs(c["p_gas_pa"] / ref - 1).max() < 1e-9
    assert c["p_gas_pa"].max() > 1.75 * u.static_pressure_pa  # a real compression, 14.8 -> 27 MPa


def test_adiabatic_limit_is_the_coolprop_isentrope() -> None:
    u = Unit(tau_s=math.inf)
    _, c = slow_sine_record(u)
    n = Nitrogen()
    rho0 = n.density(u.static_pressure_pa, u.static_temperature_k)
    s0 = coolprop("Smass", "Dmass", rho0, "T", u.static_temperature_k)
    m = rho0 * u.small_acc_volume_m3
    ref = np.array([coolprop("P", "Dmass", m / (u.small_acc_volume_m3 - u.piston_area_m2 * x), "Smass", s0) for x in c["disp_m"]])
    assert np.abs(c["p_gas_pa"] / ref - 1).max() < 2e-6


def test_finite_tau_tends_to_both_limits_at_first_order() -> None:
    # The energy equation between the limits: the distance to the isotherm
    # falls in proportion to tau (first order), and so does the distance to
    # the isentrope in proportion to 1/tau.
    _, iso = slow_sine_record(Unit(tau_s=0.0))
    _, ise = slow_sine_record(Unit(tau_s=math.inf))
    d_iso = [np.abs(slow_sine_record(Unit(tau_s=t))[1]["p_gas_pa"] - iso["p_gas_pa"]).max() for t in (0.02, 0.01)]
    d_ise = [np.abs(slow_sine_record(Unit(tau_s=t))[1]["p_gas_pa"] - ise["p_gas_pa"]).max() for t in (500.0, 1000.0)]
    assert d_iso[0] / d_iso[1] == pytest.approx(2.0, rel=0.05)
    assert d_ise[0] / d_ise[1] == pytest.approx(2.0, rel=0.05)


# -- conservation ----------------------------------------------------------

def energy_residual(u: Unit, motion: Sine, duration_s: float, segments: list[Segment]) -> tuple[float, float, int]:
    """Work in minus (gas internal energy change + heat to the walls +
    dissipation + stored elastic energy), over the total |work| exchanged."""
    ts = np.linspace(0.0, duration_s, 801)
    r = simulate(u, motion, ts, segments, duration_s, energy=True, rtol=1e-10)
    c, e, gas = r.channels, r.energy, Nitrogen()

    def internal(m: float, v: float, t: float) -> float:
        return m * gas.internal_energy(m / v, t)

    du = sum(internal(c[f"mass_{g}_kg"][-1], c[f"v_{g}_m3"][-1], c[f"t_{g}_k"][-1]) - internal(c[f"mass_{g}_kg"][0], c[f"v_{g}_m3"][0], c[f"t_{g}_k"][0])
             for g in ("gas", "gas2"))
    area = u.piston_area_m2
    work = e["work_in_j"][-1] + u.ambient_pressure_pa * area * (c["disp_m"][-1] - c["disp_m"][0])
    stored = 0.0
    if (bs := u.effects.bump_stop) is not None:
        stored += bs.stiffness_n_per_m1_5 * max(c["disp_m"][-1] - bs.start_m, 0.0) ** 2.5 / 2.5
    if (oc := u.effects.oil_compliance) is not None:
        k = oc.bulk_modulus_pa / oc.oil_volume_m3

        def oil(p: float) -> float:
            z = (p - u.vapour_pressure_pa) / k
            return u.vapour_pressure_pa * z + 0.5 * k * z * z

        stored += oil(c["p_strut_pa"][-1]) - oil(c["p_strut_pa"][0])
    losses = sum(e[k][-1] for k in ("heat_gas_j", "heat_gas2_j", "damper_j", "valve6_j", "friction_j", "bump_j"))
    void_work = -u.vapour_pressure_pa * (c["void_m3"][-1] - c["void_m3"][0])
    scale = float(np.sum(np.abs(np.diff(c["disp_m"])) * np.abs(c["force_n"][1:])))
    return (work - du - losses - stored - void_work) / scale, scale, len(r.cavitation_events)


@pytest.mark.parametrize(
    ("label", "unit", "motion", "duration_s", "segments"),
    [
        ("soft, damper on, friction, bump stop", Unit().with_effects(friction=Friction(400.0, 800.0, 1.3, 0.01, 1e-3), bump_stop=BumpStop(0.04, 5e6)),
         Sine(0.06, 0.5), 4.0, SOFT_ON),
        ("valve switching", Unit().with_effects(valve_lag=ValveLag(0.03)), Sine(0.06, 0.5), 4.0,
         [Segment(0.0, False, False), Segment(1.3, True, False), Segment(2.6, False, True)]),
        ("cavitation at 3 MPa", Unit(static_pressure_pa=3e6), Sine(0.05, 3.0), 1.0, HARD_ON),
        ("oil compliance", Unit().with_effects(oil_compliance=OilCompliance(3e8, 1e-3)), Sine(0.03, 2.0), 2.0, SOFT_ON),
    ],
)
def test_energy_balance(label: str, unit: Unit, motion: Sine, duration_s: float, segments: list[Segment]) -> None:
    rel, scale, cavitations = energy_residual(unit, motion, duration_s, segments)
    assert scale > 1e3
    assert abs(rel) < 1e-6, label
    assert (cavitations > 0) == ("cavitation" in label)


# -- the SDOF rig ----------------------------------------------------------

def test_static_equilibrium_holds_without_input() -> None:
    u = Unit()
    mass = u.static_force_n / G_M_S2
    ts = np.linspace(0.0, 10.0, 101)
    c = simulate(u, Hold(), ts, HARD_ON, 10.0, sprung_mass_kg=mass).channels
    assert np.abs(c["body_disp_m"]).max() < 1e-9
    assert np.abs(c["p_gas_pa"] / u.static_pressure_pa - 1).max() < 1e-9


def test_heavier_mass_settles_where_coolprop_says() -> None:
    # 8 % more mass on a unit charged for the nominal one: after the
    # motion and the gas temperature have settled, (p - p_atm) A = m g with
    # p on CoolProp's isotherm at the compressed volume.
    u = Unit(tau_s=1.0)
    mass = 1.08 * u.static_force_n / G_M_S2
    ts = np.linspace(0.0, 40.0, 81)
    c = simulate(u, Hold(), ts, HARD_ON, 40.0, sprung_mass_kg=mass, balanced=False).channels
    m_gas = Nitrogen().density(u.static_pressure_pa, u.static_temperature_k) * u.small_acc_volume_m3
    target = u.ambient_pressure_pa + mass * G_M_S2 / u.piston_area_m2
    rho = coolprop("Dmass", "P", target, "T", u.ambient_k)
    x_eq = (u.small_acc_volume_m3 - m_gas / rho) / u.piston_area_m2
    assert -c["body_disp_m"][-1] == pytest.approx(x_eq, abs=2e-6)
    assert 0.005 < x_eq < 0.03


def test_sdof_step_returns_to_the_static_position_raised_by_the_step() -> None:
    u = Unit(tau_s=1.5)
    mass = u.static_force_n / G_M_S2
    ts = np.linspace(0.0, 30.0, 301)
    c = simulate(u, Step(0.043, 0.5, 0.05), ts, HARD_ON, 30.0, sprung_mass_kg=mass).channels
    assert c["body_disp_m"][-1] == pytest.approx(0.043, abs=5e-6)
    assert c["body_disp_m"].max() > 0.043  # it overshoots first
    assert c["p_gas_pa"][-1] == pytest.approx(u.static_pressure_pa, rel=1e-5)


# -- the damper ------------------------------------------------------------

def strut_force(d: Damper, v: float, bypass_open: float, area: float = 2e-3) -> float:
    return d.drop(area * v, bypass_open) * area


def test_damper_blows_off_and_off_is_half_of_on_in_compression() -> None:
    d = Damper(default_pack())
    v = np.linspace(0.0, 1.5, 301)
    for bypass in (0.0, 1.0):
        f_c = np.array([strut_force(d, x, bypass) for x in v])
        f_r = np.array([-strut_force(d, -x, bypass) for x in v])
        assert np.all(np.diff(f_c) > 0) and np.all(np.diff(f_r) > 0)
    # Blow-off: the incremental damping falls once the washer lifts.
    crack = d.pack.compression.blowoff.crack_pa
    v_crack = d.table(0.0).flow(crack) / 2e-3
    slope = [(strut_force(d, x + 1e-3, 0.0) - strut_force(d, x - 1e-3, 0.0)) / 2e-3 for x in (0.5 * v_crack, 1.5 * v_crack)]
    assert slope[1] < 0.5 * slope[0]
    for x in (0.25, 0.4, 0.6, 1.0):
        assert 0.4 < strut_force(d, x, 1.0) / strut_force(d, x, 0.0) < 0.6
    # Rebound is stiffer than compression (valving), both several kN at 0.25 m/s.
    assert -strut_force(d, -0.25, 0.0) > strut_force(d, 0.25, 0.0) > 5e3


def test_damper_tables_and_newton_agree() -> None:
    d = Damper(default_pack())
    f = scalar_valve_flow(d.pack)
    for dp in (-3e7, -1e6, -10.0, 0.0, 5.0, 2e5, 3e6, 5e7):
        for s in (0.0, 0.3, 1.0):
            assert f(dp, s, d.pack.nu_ref_m2_s) == pytest.approx(float(d.pack.valve_flow(dp, s)), rel=1e-12, abs=1e-20)
    for q in (-1e-3, -1e-5, 1e-6, 3e-4, 2e-3):
        for s in (0.0, 1.0):
            newton = d.drop(q, s, nu=d.pack.nu_ref_m2_s)  # forces the iterative path
            assert d.drop(q, s) == pytest.approx(newton, rel=1e-6)
            assert d.flow(d.drop(q, s), s) == pytest.approx(q, rel=1e-6)
        # a half-open bypass lies between closed and open
        assert d.drop(q, 1.0) < d.drop(q, 0.5) < d.drop(q, 0.0) if q > 0 else d.drop(q, 1.0) > d.drop(q, 0.5) > d.drop(q, 0.0)


def test_rig_force_is_gas_plus_damper() -> None:
    u = Unit()
    ts = np.linspace(0.0, 1.5, 301)
    c = simulate(u, Sine(0.03, 2.0), ts, HARD_ON, 1.5).channels
    d = Damper(u.damper)
    expected = (c["p_gas_pa"] - u.ambient_pressure_pa) * u.piston_area_m2 + np.array([d.drop(u.piston_area_m2 * v, 0.0) for v in c["vel_m_s"]]) * u.piston_area_m2
    assert np.abs(c["force_n"] - expected).max() < 1e-6 * np.abs(c["force_n"]).max()


@pytest.mark.parametrize("p0", [6e6, 8e6, 10e6])
def test_cavitation_limits_rebound_to_the_gas_pressure(p0: float) -> None:
    # The seed: the rebound force saturates because the strut pressure
    # cannot fall below the vapour pressure; the limit rises with the charge.
    u = Unit(static_pressure_pa=p0)
    ts = np.linspace(0.0, 0.5, 2001)
    r = simulate(u, Sine(0.03, 6.0), ts, HARD_ON, 0.5)
    c = r.channels
    assert c["p_strut_pa"].min() >= u.vapour_pressure_pa * (1 - 1e-12)
    rebound_damper = (c["p_gas_pa"] - c["p_strut_pa"]) * u.piston_area_m2
    limit = (c["p_gas_pa"] - u.vapour_pressure_pa) * u.piston_area_m2
    assert np.all(rebound_damper <= limit * (1 + 1e-9))
    k = int(np.argmax(rebound_damper))
    assert rebound_damper[k] == pytest.approx(limit[k], rel=1e-9)
    assert c["void_m3"].max() > 1e-6
    kinds = [k for _, k in r.cavitation_events]
    assert kinds[0] == "onset" and kinds.count("closure") >= 1 and all(a != b for a, b in zip(kinds, kinds[1:]))


def test_rigid_cavitation_is_the_stiff_oil_limit() -> None:
    # Two formulations of cavitation (events with a void state; a compliant
    # oil whose pressure stops at the vapour pressure) converge as the oil
    # stiffens: the difference falls about tenfold per decade of modulus.
    u = Unit(static_pressure_pa=8e6)
    ts = np.linspace(0.0, 0.4, 1601)
    rigid = simulate(u, Sine(0.03, 6.0), ts, HARD_ON, 0.4).channels["force_n"]
    late = ts > 0.02
    errs = []
    for beta in (2e10, 2e11):
        stiff = simulate(u.with_effects(oil_compliance=OilCompliance(beta, 1e-4)), Sine(0.03, 6.0), ts, HARD_ON, 0.4).channels["force_n"]
        errs.append(float(np.percentile(np.abs(stiff - rigid)[late], 95)))
    assert errs[1] < errs[0] / 5 and errs[1] < 20.0


# -- effects against analytic results ----------------------------------------

def test_friction_loop_area_is_coulomb_plus_viscous() -> None:
    # Per cycle of x = X sin(wt): Coulomb dissipates 4 Fc X, viscous pi c w X^2
    # (smoothing and Stribeck velocities far below the peak speed; the
    # Stribeck peak adds a little, bounded here).
    u0 = Unit(tau_s=0.0)
    fc, c = 500.0, 1500.0
    f = Friction(fc, c, static_ratio=1.0, smoothing_velocity_m_s=1e-4)
    x, fr = 0.05, 0.2
    ts = np.linspace(0.0, 1 / fr, 4001)
    with_f = simulate(u0.with_effects(friction=f), Sine(x, fr), ts, HARD_OFF, 1 / fr, energy=True, rtol=1e-10).energy["friction_j"][-1]
    assert with_f == pytest.approx(4 * fc * x + math.pi * c * 2 * math.pi * fr * x * x, rel=1e-4)


def test_oil_compliance_is_a_spring_in_series() -> None:
    # Slow, small motion with isothermal gas and the damper bypassed: the
    # strut's stiffness is the gas's (CoolProp's isotherm) in series with
    # beta A^2 / V_oil.
    beta, v_oil = 2e8, 1e-3
    u = Unit(tau_s=0.0).with_effects(oil_compliance=OilCompliance(beta, v_oil))
    ts = np.linspace(0.0, 50.0, 201)
    c = simulate(u, Sine(0.002, 0.02), ts, HARD_OFF, 50.0, rtol=1e-10).channels
    k_meas = np.polyfit(c["disp_m"], c["force_n"], 1)[0]
    a = u.piston_area_m2
    rho0 = Nitrogen().density(u.static_pressure_pa, u.static_temperature_k)
    dp_drho = coolprop("d(P)/d(Dmass)|T", "Dmass", rho0, "T", u.static_temperature_k)
    k_gas = a * a * dp_drho * rho0 / u.small_acc_volume_m3
    k_oil = beta * a * a / v_oil
    assert k_meas == pytest.approx(1 / (1 / k_gas + 1 / k_oil), rel=5e-3)


def test_leakage_rate_and_valve_lag_follow_their_laws() -> None:
    from foreign_rig.unit import Leakage

    u = Unit().with_effects(leakage=Leakage(1e4), valve_lag=ValveLag(0.05))
    ts = np.linspace(0.0, 0.5, 501)
    r = simulate(u, Hold(), ts, [Segment(0.0, False, True), Segment(0.1, True, True)], 0.5, rtol=1e-10)
    c = r.channels
    m0 = c["mass_gas_kg"][0]
    slope = (c["mass_gas_kg"][10] - m0) / ts[10]
    assert slope == pytest.approx(-m0 / 1e4, rel=1e-3)
    after = ts >= 0.1
    assert c["valve6_open"][after] == pytest.approx(1 - np.exp(-(ts[after] - 0.1) / 0.05), abs=1e-6)
    assert np.all(c["valve6_open"][~after] == 0)


def test_sensor_lag_is_a_first_order_filter_of_the_force() -> None:
    tau = 0.01
    u = Unit().with_effects(sensor_lag=SensorLag(tau))
    ts = np.linspace(0.0, 1.0, 4001)
    c = simulate(u, Sine(0.03, 2.0), ts, HARD_ON, 1.0, rtol=1e-10).channels
    # exact discretisation of dy/dt = (u - y)/tau for piecewise-linear u
    dt = ts[1] - ts[0]
    a = math.exp(-dt / tau)
    b1 = 1 - tau / dt * (1 - a)
    y = np.empty_like(ts)
    y[0] = c["force_n_lagged"][0]
    f = c["force_n"]
    for k in range(1, len(ts)):
        y[k] = a * y[k - 1] + (1 - a - b1) * f[k - 1] + b1 * f[k]
    late = ts > 0.05  # after the start transient of the force
    assert np.abs(y - c["force_n_lagged"])[late].max() < 1e-3 * np.ptp(f)
    assert np.abs(f - c["force_n_lagged"])[late].max() > 20 * np.abs(y - c["force_n_lagged"])[late].max()


def test_heat_buildup_warms_the_gas_only_with_the_effect() -> None:
    case = draw_case("heat_buildup", 11, noise=False)
    test = Test("heat", Sine(0.06, 0.5), 200.0, 400, damper_on=True)
    hot = run_test(case, test)[1]
    cold = run_test(draw_case(None, 11, noise=False), test)[1]
    assert hot["t_oil_k"][-1] > case.unit.ambient_k + 5
    assert cold["t_oil_k"][-1] == pytest.approx(hot["t_oil_k"][-1], abs=1.0)  # the oil heats either way
    # the gas's cycle-mean temperature rises only through the wall
    assert hot["t_gas_k"][-100:].mean() - cold["t_gas_k"][-100:].mean() > 0.2


# -- the data system -------------------------------------------------------

def test_noise_statistics() -> None:
    rng = np.random.default_rng(1)
    t = np.arange(200_000) * 1e-3
    white = measure(np.zeros_like(t), t, ChannelNoise(white=30.0), rng)
    assert white.std() == pytest.approx(30.0, rel=0.01) and abs(white.mean()) < 0.3
    ou = ou_noise(t, 20.0, 0.01, rng)
    assert ou.std() == pytest.approx(20.0, rel=0.05)
    r1 = np.corrcoef(ou[:-1], ou[1:])[0, 1]
    assert r1 == pytest.approx(math.exp(-0.1), abs=0.01)
    q = measure(np.full_like(t, 1234.5), t, ChannelNoise(white=10.0, lsb=4.0), rng, offset=100.0)
    assert np.allclose(q / 4.0, np.round(q / 4.0))
    assert q.mean() == pytest.approx(1334.5, abs=0.2)
    # irregular spacing: the OU process is exact at any spacing
    t_irr = np.cumsum(rng.uniform(0.5e-3, 1.5e-3, 200_000))
    assert ou_noise(t_irr, 5.0, 0.02, rng).std() == pytest.approx(5.0, rel=0.05)


def test_jitter_keeps_order_and_has_its_spread() -> None:
    rng = np.random.default_rng(2)
    nominal = np.arange(100_001) * 2e-3
    t = jittered(nominal, 1e-4, rng, float(nominal[-1]))
    assert np.all(np.diff(t) > 0) and t[0] >= 0 and t[-1] <= nominal[-1]
    assert (t - nominal).std() == pytest.approx(1e-4, rel=0.02)


def test_record_noise_matches_truth(seed: int) -> None:
    case = draw_case(None, seed)
    rec, true = run_test(case, Test("fast", Sine(0.03, 2.0), 3.0, 1500, damper_on=True))
    ds = case.data_system
    # Residual of the measured channel against the truth sampled at the
    # same instants is the data system's noise (plus quantisation).
    for col, noise in (("force_n", ds.force), ("p_gas_pa", ds.pressure), ("disp_m", ds.disp)):
        err = rec.columns[col] - true[col]
        assert err.std() == pytest.approx(noise.sigma, rel=0.15), (col, seed)
    # and the written time is the nominal one, not the jittered instant
    assert np.array_equal(rec.columns["time_s"], np.linspace(0.0, 3.0, 1501))
    assert 0 < np.abs(true["time_s"] - rec.columns["time_s"]).max() < 5 * ds.jitter_s


# -- draws, records, cache --------------------------------------------------

@pytest.mark.parametrize("effect", [None, *EFFECTS])
def test_draws_are_reproducible_and_named(effect: str | None) -> None:
    a, b = draw_case(effect, 5), draw_case(effect, 5)
    assert json.dumps(a.truth(), default=str) == json.dumps(b.truth(), default=str)
    t = a.truth()
    assert t["seed"] == 5 and t["effect"] == effect and "tau_s" in t["hpctl_params"]
    assert t["in_hpctl_library"] == (effect is None or effect in LIBRARY_EFFECTS)
    # same unit and noise with and without the effect
    assert a.data_system == draw_case(None, 5).data_system
    assert draw_case(effect, 6).truth()["hpctl_params"] != t["hpctl_params"]


def test_records_are_readable_by_hpctl(tmp_path: os.PathLike[str]) -> None:
    # hpctl is imported here only: the rig itself shares no code with it.
    from hpctl.data import records
    more = extra_tests()
    tests = [sweep_tests()[-1], *more["switching"], *more["sdof"]]
    g = generate("friction", 3, out=os.path.join(tmp_path, "case"), tests=tests)
    truth = json.loads((g.folder / "truth.json").read_text())
    assert truth["seed"] == 3 and truth["records"] == [t.name for t in tests]
    for path, test, rec in zip(g.records, tests, g.read()):
        again = records.read_record(path)
        assert list(rec.data) == list(again.data) and all(np.array_equal(rec[c], again[c]) for c in rec.data)
        assert rec.kind == ("sdof" if test.sdof else "characterisation")
        assert rec.test.spring == "hard" and rec.static.pressure_pa == truth["unit"]["declared_static_pressure_pa"]
        assert len(rec["time_s"]) == len(test.times_s())
        if test.sdof:
            assert rec.sprung_mass_kg == pytest.approx(truth["unit"]["sprung_mass_kg"])
            assert {"body_disp_m", "base_disp_m", "force_n"} <= set(rec.data)
        if test.switch_period_s is not None:
            hard = rec.spring_hard()
            assert hard[0] and not hard.all()
        # The values read back are the values written (shortest repr floats).
        raw = np.loadtxt(path.with_suffix(".csv"), delimiter=",", skiprows=1)
        assert np.array_equal(raw[:, 0], rec["time_s"]) and np.array_equal(raw[:, 2], rec["force_n"])


def test_generate_caches_by_effect_and_seed(tmp_path: os.PathLike[str], monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("FOREIGN_RIG_CACHE", str(tmp_path))
    tests = [sweep_tests()[-1]]
    g1 = generate("sensor_offset", 4, tests=tests)
    g2 = generate("sensor_offset", 4, tests=tests)
    assert g1.folder == g2.folder and g2.truth == g1.truth
    assert generate("sensor_offset", 5, tests=tests).folder != g1.folder
    assert not [p for p in g1.folder.parent.iterdir() if p.name.startswith(".partial")]


def test_cli_prints_the_seed_and_refuses_bad_input(tmp_path: os.PathLike[str], capsys: pytest.CaptureFixture[str]) -> None:
    from foreign_rig.__main__ import main

    out = os.path.join(tmp_path, "case")
    assert main(["--effect", "sensor_lag", "--seed", "3", "--out", out, "--program", "sweep"]) == 0
    text = capsys.readouterr().out
    assert "seed=3" in text and "sensor_time_constant_s" in text
    truth = json.loads(open(os.path.join(out, "truth.json")).read())
    assert truth["seed"] == 3 and len(truth["records"]) == 5
    assert main(["--effect", "gremlins", "--seed", "1", "--out", os.path.join(tmp_path, "x")]) == 2
    assert main(["--effect", "none", "--seed", "1", "--out", out]) == 2  # not empty: never overwritten
    assert "gremlins" in capsys.readouterr().err

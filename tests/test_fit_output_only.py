"""Jacobian columns without runs (:mod:`hpctl.identify.output_only`): on a
characterisation record a damper-shape parameter changes only the force,
by hp-core's curve at the base run's flows. Checked against what the code
did not compute that way: the perturbed runs themselves (hp-core's
integration of the whole unit, the steps replayed as the Jacobian replays
them), the drive's velocity as hp-core interpolates it, and fits made with
every column run."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from hpctl import _core
from hpctl.errors import ParameterError
from hpctl.identify import fit as fit_module
from hpctl.identify import output_only, virtual_rig
from hpctl.identify.dataset import Dataset, prepare
from hpctl.identify.fit import fit, model_for, reach, simulate_all, values_from_x
from hpctl.model.effects import DAMPER_SHAPE, FRICTION_SHAPE, LIBRARY
from hpctl.model.unit import Friction, Unit
from hpctl.sim.run import characterisation_rig, run

#: The fits of these tests: the flexible model with the seed's effects.
EFFECTS = ("heat_transfer", "real_gas")


@pytest.fixture(scope="module")
def datasets() -> list[Dataset]:
    # A sine with valve 5 open, a fast one with it closed, one switching
    # valve 6, and the fast sine again with valve 5 switched every 0.4 s
    # (the record's flags rewritten: the model's valve follows them, placed
    # between samples as a fit places logged switches); plus an SDOF step,
    # which the columns must leave to runs.
    extra = virtual_rig.effect_tests()
    sine = virtual_rig.sweep_tests(cycles=1.0, per_cycle=100)[3]
    tests = [sine, extra["fast"], extra["switching"], extra["sdof"]]
    records = virtual_rig.make_records(virtual_rig.truth_unit((), {}), tests=tests, seed=5)
    fast = records[1]
    data = dict(fast.data)
    data["damper_on"] = (np.floor(fast["time_s"] / 0.4) % 2 == 0).astype(float)
    switched = dataclasses.replace(fast, data=data, name="fast_valve5_switched")
    return prepare([*records, switched])


def _perturbed(params: list, x0: np.ndarray, i: int) -> np.ndarray:
    # The Jacobian's own step (fit.fd_jac).
    p = params[i]
    h = 1e-4 * max(1.0, abs(x0[i])) if p.log else 1e-4 * max(abs(x0[i]), 1e-2)
    x = x0.copy()
    x[i] = x0[i] + h if x0[i] + h <= p.x_bounds()[1] else x0[i] - h
    return x


def test_each_case_is_present(datasets: list[Dataset]) -> None:
    kinds = [d.record.kind for d in datasets]
    assert "sdof" in kinds and kinds.count("characterisation") == 4
    switched = datasets[-1]
    assert np.any(np.diff(switched.damper_on.astype(int)))


@pytest.mark.parametrize("effects", [EFFECTS, (*EFFECTS, "friction"), (*EFFECTS, "friction", "oil_compliance")])
def test_columns_from_the_outputs_are_the_perturbed_runs(datasets: list[Dataset], effects: tuple[str, ...]) -> None:
    # With oil compliance the damper's columns are runs, the friction's not.
    model = model_for(datasets, effects, flexible=True)
    params = model.params
    reaches = reach(params, datasets)
    x0 = np.array([p.to_x(p.initial) for p in params])
    at = values_from_x(params, x0)
    base = simulate_all(model, datasets, [at], record_steps=True)[0]
    ends = [b.pop("step_end_s") for b in base if not isinstance(b, Exception)]
    shape = [i for i, p in enumerate(params) if p.name in {q.name for ps in DAMPER_SHAPE.values() for q in ps}]
    friction = [i for i, p in enumerate(params) if p.name in {q.name for q in (*LIBRARY["friction"].params, *FRICTION_SHAPE)}]
    assert len(friction) == (5 if "friction" in effects else 0)
    perturbed = [values_from_x(params, _perturbed(params, x0, i)) for i in range(len(params))]
    pairs, outputs = fit_module._output_only_plan(model, datasets, params, at, perturbed, reaches, base)
    quiet = outputs()
    assert set(quiet) == pairs
    # Every shape column (friction column) of every characterisation record
    # in its reach, none of the SDOF record or of another parameter.
    prescribed = {j for j, d in enumerate(datasets) if d.record.kind == "characterisation"}
    expected = {(i, j) for i in friction for j in reaches[i] if j in prescribed}
    if "oil_compliance" not in effects:
        expected |= {(i, j) for i in shape for j in reaches[i] if j in prescribed}
    assert set(quiet) == expected and expected
    columns = sorted({i for i, _ in quiet})
    runs = simulate_all(model, datasets, [perturbed[i] for i in columns], steps=ends)
    changed = 0
    for i, row in zip(columns, runs):
        for j, full in enumerate(row):
            if (i, j) not in quiet:
                continue
            assert not isinstance(full, Exception)
            mine = quiet[(i, j)]
            # The state's channels bit for bit (the damper never reached
            # them); the force to its rounding (the run sums A (p_S + dp)).
            for c in ("p_gas_pa", "p_gas2_pa", "t_gas_k", "disp_m", "flow_damper_m3_s"):
                assert np.array_equal(mine[c], full[c]), (params[i].name, datasets[j].name, c)
            scale = np.max(np.abs(full["force_n"]))
            assert np.max(np.abs(mine["force_n"] - full["force_n"])) <= 1e-14 * scale, (params[i].name, datasets[j].name)
            changed += bool(np.any(full["force_n"] != base[j]["force_n"]))
    # The steps are large enough to show on most of them.
    assert changed >= len(quiet) // 2


def test_a_fit_is_the_fit_with_every_column_run(datasets: list[Dataset], monkeypatch: pytest.MonkeyPatch) -> None:
    # One step: the Jacobian at the start and the errors' at the end. Not
    # bit for bit: a column's force differs in its last bits (the run
    # rounds A (p_S + dp), these A dp; the columns themselves are compared
    # above), and on these short records several shape parameters are all
    # but unidentified (knees on their bound, orifices beside a bleed:
    # errors of 1-2 on values near 1), whose columns are that rounding; the
    # optimiser's later steps along them follow it, and how far depends on
    # the machine's arithmetic. Measured after 2 evaluations: values 0.0025
    # of their errors apart, the residual sum of squares 2e-7 (stop 42, AMD
    # EPYC, numpy 2.4); after 4, 0.0062 and 3.4e-7 on the machine of stop
    # 41, 0.5-1.1 errors and 6e-5 on this one (from the static start
    # of stop 41 or 42); after 30, 2.5 errors on the blow-offs. The standard
    # errors of the unidentified parameters move by up to 60 % (the
    # Hessian's smallest eigenvalues are the rounding's), so they are not
    # compared.
    #
    # Without the logged switches' placement: it fits again from each
    # pass's places (a dozen fits of two evaluations here), and its
    # accept-or-not decisions (a joint step of the places and the
    # parameters) follow that rounding too. With it, the model's powers as
    # exp(n ln x) instead of pow (stop 60) flipped one such decision and
    # the two ended 1.5e-4 apart in the residual sum of squares, 0.29
    # errors on a blow-off; one step, as here, 1e-9 and 0.0000 errors
    # apart with either arithmetic (7e-10 and 1.1e-9).
    effects = (*EFFECTS, "friction")
    quick = fit(datasets, effects, flexible=True, max_nfev=2, input_noise=False, place_switches=False)
    monkeypatch.setattr(fit_module, "OUTPUT_ONLY_COLUMNS", False)
    runs = fit(datasets, effects, flexible=True, max_nfev=2, input_noise=False, place_switches=False)
    assert quick.rss == pytest.approx(runs.rss, rel=1e-7)
    for name, value in runs.values.items():
        assert abs(quick.values[name] - value) <= 0.01 * runs.stderr[name], name


def test_models_whose_damper_reaches_the_state_run_every_column(datasets: list[Dataset]) -> None:
    for effect in output_only.STATE_COUPLED:
        assert not output_only.applies((*EFFECTS, effect), datasets[0])
    for effect in output_only.FRICTION_COUPLED:
        assert not output_only.friction_applies((*EFFECTS, effect), datasets[0])
    assert output_only.applies(EFFECTS, datasets[0]) and output_only.friction_applies((*EFFECTS, "oil_compliance", "valve_lag"), datasets[0])
    sdof = next(d for d in datasets if d.record.kind == "sdof")
    assert not output_only.applies(EFFECTS, sdof) and not output_only.friction_applies(EFFECTS, sdof)
    model = model_for(datasets, (*EFFECTS, "oil_compliance"), flexible=True)
    params = model.params
    at = {p.name: p.initial for p in params}
    base = simulate_all(model, datasets, [at])[0]
    x0 = np.array([p.to_x(p.initial) for p in params])
    perturbed = [values_from_x(params, _perturbed(params, x0, i)) for i in range(len(params))]
    assert fit_module._output_only_plan(model, datasets, params, at, perturbed, reach(params, datasets), base)[1]() == {}


def test_a_record_that_could_cavitate_runs_its_columns(datasets: list[Dataset], monkeypatch: pytest.MonkeyPatch) -> None:
    model = model_for(datasets, EFFECTS, flexible=True)
    params = model.params
    fast = datasets[1]
    at = {p.name: p.initial for p in params}
    unit = model.unit_for(fast, at)
    base = simulate_all(model, [fast], [at])[0][0]
    assert not isinstance(base, Exception)
    area, vapour = unit.piston_area_m2, unit.vapour_pressure_pa
    assert output_only.cannot_cavitate(fast, [unit.damper], base, area, vapour)
    # A rebound orifice 200 times as stiff: at the drive's fastest rebound
    # the strut pressure would fall below the vapour's.
    stiff = model.unit_for(fast, {**at, "damper_on_rebound_orifice_scale": 200.0, "damper_off_rebound_orifice_scale": 200.0}).damper
    assert not output_only.cannot_cavitate(fast, [unit.damper, stiff], base, area, vapour)
    # No columns from outputs where the gas's pressure could be that low.
    monkeypatch.setattr(output_only, "GAS_DIP", 0.9999)
    x0 = np.array([p.to_x(p.initial) for p in params])
    perturbed = [values_from_x(params, _perturbed(params, x0, i)) for i in range(len(params))]
    bases = simulate_all(model, datasets, [at])[0]
    assert fit_module._output_only_plan(model, datasets, params, at, perturbed, reach(params, datasets), bases)[1]() == {}


def test_a_force_that_is_not_the_curve_gives_no_columns(datasets: list[Dataset]) -> None:
    model = model_for(datasets, EFFECTS, flexible=True)
    fast = datasets[1]
    at = {p.name: p.initial for p in model.params}
    unit = model.unit_for(fast, at)
    base = simulate_all(model, [fast], [at])[0][0]
    assert not isinstance(base, Exception)
    assert output_only.force_changes_n(fast, base, unit.damper, [unit.damper], unit.piston_area_m2) is not None
    # One sample's damper force off by a newton (a void would pin it): refused.
    damper_force = base["damper_force_n"].copy()
    damper_force[len(damper_force) // 2] += 1.0
    assert output_only.force_changes_n(fast, {**base, "damper_force_n": damper_force}, unit.damper, [unit.damper], unit.piston_area_m2) is None


@pytest.mark.parametrize("index", [0, 1, 2])
def test_the_extreme_flows_are_hp_cores_drive(datasets: list[Dataset], index: int) -> None:
    # hp-core's own velocity of the drive (the characterisation rig's
    # vel_m_s channel), sampled twenty times per interval: never beyond the
    # computed extremes, and reaching them within a part in 10^4 of the range.
    d = datasets[index]
    lowest, highest = output_only.extreme_flows_m3_s(d, 1.0)
    t = d.times_s
    fine = np.concatenate([np.linspace(a, b, 20, endpoint=False) for a, b in zip(t[:-1], t[1:])] + [t[-1:]])
    model = model_for([d], EFFECTS, flexible=True)
    unit = model.unit_for(d, {p.name: p.initial for p in model.params})
    v = run(unit, characterisation_rig(d.rig.strut), fine, spring_hard=True, damper_on=False, channels=["vel_m_s"])["vel_m_s"]
    span = highest - lowest
    assert lowest - 1e-12 * span <= v.min() <= lowest + 1e-4 * span
    assert highest - 1e-4 * span <= v.max() <= highest + 1e-12 * span


def test_the_core_friction_is_the_law_and_refuses_bad_velocities() -> None:
    # hp-core's Friction::force_n as its documentation writes it out:
    # [F_c + (F_s - F_c) exp(-(v/v_s)^2)] tanh(v/v_e) + c v.
    unit = Unit.seed().with_effects(friction=Friction(400.0, 300.0, 1e-3, stribeck_ratio=1.5, stribeck_velocity_m_s=0.01))
    v = np.array([-0.5, -0.004, 0.0, 0.0007, 0.02, 0.3])
    law = 400.0 * (1.0 + 0.5 * np.exp(-((v / 0.01) ** 2))) * np.tanh(v / 1e-3) + 300.0 * v
    np.testing.assert_allclose(_core.friction_force_n(unit.to_dict(), v), law, rtol=1e-12, atol=1e-12)
    assert np.array_equal(_core.friction_force_n(Unit.seed().to_dict(), v), np.zeros(len(v)))
    with pytest.raises(ParameterError, match=r"vel_m_s\[1\] = NaN: expected finite"):
        _core.friction_force_n(unit.to_dict(), [0.1, float("nan")])


def test_bad_inputs_are_refused_naming_them(datasets: list[Dataset]) -> None:
    # The drive's extremes need a characterisation rig driven by samples
    # and their velocities; the friction binding a whole unit and a
    # sequence of velocities. Each refusal a ValueError naming what.
    sdof = next(d for d in datasets if d.record.kind == "sdof")
    with pytest.raises(ParameterError, match=r"d\.rig = 'SdofRig': expected a characterisation rig"):
        output_only.extreme_flows_m3_s(sdof, 1.0)
    unit = Unit.seed().to_dict()
    broken = {k: v for k, v in unit.items() if k != "piston_area_m2"}
    with pytest.raises(ParameterError, match="piston_area_m2"):
        _core.friction_force_n(broken, [0.1])  # type: ignore[arg-type]
    with pytest.raises(ParameterError, match="vel_m_s"):
        _core.friction_force_n(unit, "fast")  # type: ignore[arg-type]
    with pytest.raises(ParameterError, match=r"vel_m_s\[0\] = inf"):
        _core.friction_force_n(unit, [float("inf")])


def test_the_runs_beside_the_columns_from_outputs_end_before_either_raises() -> None:
    # fd_jac runs the other columns in a thread while it computes these:
    # both results, or an exception in the caller's thread only once both
    # halves have ended (the runs' own, or the caller's half's).
    import threading

    assert fit_module._beside(lambda: 1, lambda: 2) == (1, 2)

    def runs_fail() -> int:
        raise ValueError("the runs failed")

    with pytest.raises(ValueError, match="the runs failed"):
        fit_module._beside(runs_fail, lambda: 2)
    began, ended = threading.Event(), threading.Event()

    def slow_runs() -> int:
        began.wait(5.0)
        ended.set()
        return 1

    def here_fails() -> int:
        began.set()
        raise KeyError("here")

    with pytest.raises(KeyError, match="here"):
        fit_module._beside(slow_runs, here_fails)
    assert ended.is_set()

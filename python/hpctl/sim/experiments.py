"""The seed's experiments on a unit, turned into rig records and summaries.

- Spring characterisation: a sine of ~100 mm at 0.01 m/s excitation speed
  (the seed's Fig. 3.5), per spring state.
- SDOF step: the 43 mm base step under the sprung mass, per spring/damper
  combination (the seed's Fig. 3.7).
- Heat build-up: 75 min at 0.5 Hz, 60 mm, damper on, with the lumped oil
  node warming the gas (the seed's section 4.5).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any, Literal

import numpy as np
from numpy.typing import NDArray

from hpctl import _core
from hpctl.caveats import Caveat, Code
from hpctl.data.records import RecordTest, RigRecord
from hpctl.model.unit import SEED_SPRUNG_MASS_KG, STANDARD_GRAVITY_M_S2, OilNode, Unit
from hpctl.sim import checks, metrics
from hpctl.sim.run import (
    DEFAULT_RTOL,
    Motion,
    Progress,
    Result,
    Sine,
    Step,
    motion_test,
    record_of,
    run_characterisation,
    run_sdof,
)

SEED_STEP_M = 0.043
SEED_SPEED_M_S = 0.01
SEED_AMPLITUDE_M = 0.1


@dataclass
class Experiment:
    """One simulated test: its record, what it showed, and what the result
    cannot stand behind (:mod:`hpctl.caveats`)."""

    name: str
    record: RigRecord
    result: Result
    summary: dict[str, Any] = field(default_factory=dict)
    caveats: list[Caveat] = field(default_factory=list)
    #: Derived time series a plot tells the story with (e.g. the heat
    #: build-up's cycle means), SI units, each with its ``*_time_s``.
    series: dict[str, NDArray[np.float64]] = field(default_factory=dict)


def spring_name(hard: bool) -> Literal["hard", "soft"]:
    return "hard" if hard else "soft"


def damper_name(on: bool) -> Literal["on", "off"]:
    return "on" if on else "off"


def _record(
    unit: Unit,
    result: Result,
    *,
    kind: str,
    test: RecordTest,
    name: str,
    description: str,
    ambient_k: float,
    sprung_mass_kg: float | None = None,
) -> RigRecord:
    return record_of(unit, result.channels, kind="sdof" if kind == "sdof" else "characterisation", test=test, name=name,
                     description=description, ambient_k=ambient_k, sprung_mass_kg=sprung_mass_kg)


def characterisation(
    unit: Unit,
    motion: Motion,
    duration_s: float,
    *,
    spring_hard: bool,
    damper_on: bool,
    dt_s: float | None = None,
    rtol: float | None = DEFAULT_RTOL,
    sample_dt_s: float = 1e-2,
    ambient_k: float | None = None,
    progress: Progress | None = None,
) -> Experiment:
    """A characterisation-rig test, summarised: loop area over the last
    whole cycle of a sine, force range."""
    ambient = unit.static_temperature_k if ambient_k is None else ambient_k
    result = run_characterisation(
        unit, motion, duration_s, sample_dt_s=sample_dt_s, spring_hard=spring_hard, damper_on=damper_on, dt_s=dt_s, rtol=rtol, ambient_k=ambient, progress=progress
    )
    test = motion_test(motion, spring_hard=spring_hard, damper_on=damper_on)
    excitation = test.excitation
    name = f"char_{excitation}_{spring_name(spring_hard)}_{damper_name(damper_on)}"
    record = _record(unit, result, kind="characterisation", test=test, name=name, description=f"hpctl simulation: characterisation, {excitation}", ambient_k=ambient)
    t, x, f = result["time_s"], result["disp_m"], result["force_n"]
    summary: dict[str, Any] = {
        "spring": spring_name(spring_hard),
        "damper": damper_name(damper_on),
        "excitation": excitation,
        "force_min_n": float(f.min()),
        "force_max_n": float(f.max()),
        "peak_p_gas_pa": float(result["p_gas_true_pa"].max()),
        "peak_t_gas_k": float(result["t_gas_k"].max()),
    }
    caveats = checks.channels(unit, result.channels, name) + checks.step_size(dt_s, rtol, result.time_s, name)
    if isinstance(motion, Sine) and motion.frequency_hz * (t[-1] - t[0]) >= 1.0 - 1e-9:
        m = metrics.last_cycle(t, motion.frequency_hz)
        summary["loop_area_j"] = metrics.loop_area_j(x[m], f[m])
        spring_force = unit.piston_area_m2 * (result["p_gas_true_pa"] - unit.ambient_pressure_pa)
        summary["gas_loop_area_j"] = metrics.loop_area_j(x[m], spring_force[m])
        caveats += _loop_caveats(unit, result, m, summary["gas_loop_area_j"], name)
    return Experiment(name, record, result, summary, caveats)


def _loop_caveats(unit: Unit, result: Result, cycle: Any, gas_loop_area_j: float, name: str) -> list[Caveat]:
    """The gas loops of the last cycle: the gas's own p-V work cannot be
    negative (second law); its force over the strut's stroke can be only
    when the gas volume does not follow the strut (the oil cavitated)."""
    work = sum(metrics.gas_work_j(result[p][cycle], result[v][cycle]) for p, v in (("p_gas_true_pa", "v_gas_m3"), ("p_gas2_true_pa", "v_gas2_m3")))
    pv_scale = float(np.ptp(result["p_gas_true_pa"][cycle]) * np.ptp(result["v_gas_m3"][cycle]))
    out = checks.loop_energy(work, pv_scale, name, "gas p-V")
    stroke_scale = float(np.ptp(result["force_n"][cycle]) * np.ptp(result["disp_m"][cycle]))
    if gas_loop_area_j < -1e-6 * stroke_scale:
        if np.any(result["cavitating"][cycle] > 0.5):
            out.append(Caveat(
                Code.CAVITATION,
                f"{name}: the oil cavitated in the strut, so the gas volume did not follow the strut and the gas spring's loop over the "
                f"stroke is negative ({gas_loop_area_j:.4g} J); the unit is far outside its operating range",
                {"run": name, "gas_loop_area_j": gas_loop_area_j},
            ))
        elif not out:
            out += checks.loop_energy(gas_loop_area_j, stroke_scale, name, "gas force over the stroke")
    return out


def spring_characterisation(
    unit: Unit, *, spring_hard: bool, amplitude_m: float = SEED_AMPLITUDE_M, speed_m_s: float = SEED_SPEED_M_S,
    cycles: float = 2.0, dt_s: float | None = None, progress: Progress | None = None,
) -> Experiment:
    """The seed's spring characterisation: a slow sine (damper bypassed)."""
    motion = Sine.with_speed(amplitude_m, speed_m_s)
    return characterisation(
        unit, motion, cycles / motion.frequency_hz, spring_hard=spring_hard, damper_on=False, dt_s=dt_s, sample_dt_s=0.05, progress=progress
    )


def sdof_step(
    unit: Unit,
    *,
    spring_hard: bool,
    damper_on: bool,
    height_m: float = SEED_STEP_M,
    duration_s: float = 6.0,
    sprung_mass_kg: float = SEED_SPRUNG_MASS_KG,
    dt_s: float | None = None,
    rtol: float | None = DEFAULT_RTOL,
    start_s: float = 0.5,
    rise_s: float = 0.05,
    progress: Progress | None = None,
) -> Experiment:
    """The seed's SDOF step test, summarised: natural frequency, damping
    ratio, overshoot, settling time (5 % band), peak pressure."""
    base = Step(height_m, start_s, rise_s)
    result = run_sdof(
        unit, base, duration_s, sprung_mass_kg=sprung_mass_kg, sample_dt_s=1e-3, spring_hard=spring_hard, damper_on=damper_on, dt_s=dt_s, rtol=rtol, progress=progress
    )
    test = RecordTest(spring=spring_name(spring_hard), damper=damper_name(damper_on), excitation="step", amplitude_m=height_m)
    name = f"sdof_step_{spring_name(spring_hard)}_{damper_name(damper_on)}"
    record = _record(
        unit, result, kind="sdof", test=test, name=name, description=f"hpctl simulation: SDOF {height_m * 1e3:g} mm base step",
        ambient_k=unit.static_temperature_k, sprung_mass_kg=sprung_mass_kg,
    )
    summary: dict[str, Any] = {"spring": spring_name(spring_hard), "damper": damper_name(damper_on)}
    summary.update(metrics.step_response(result["time_s"], result["body_disp_m"], result["disp_m"], result["p_gas_true_pa"], height_m, start_s, rise_s))
    caveats = checks.channels(unit, result.channels, name) + checks.step_size(dt_s, rtol, result.time_s, name)
    return Experiment(name, record, result, summary, caveats)


def seed_experiments(unit: Unit, progress: Callable[[str], Progress | None] | None = None) -> list[Experiment]:
    """Everything `hpctl simulate` runs by default."""
    bar = progress or (lambda _name: None)
    out = []
    for hard in (True, False):
        out.append(spring_characterisation(unit, spring_hard=hard, progress=bar(f"spring characterisation ({spring_name(hard)})")))
    for hard in (True, False):
        for on in (False, True):
            out.append(sdof_step(unit, spring_hard=hard, damper_on=on, progress=bar(f"43 mm step ({spring_name(hard)}, damper {damper_name(on)})")))
    return out


def headline(experiments: list[Experiment]) -> dict[str, Any]:
    """The numbers a summary leads with: natural frequency per spring state
    (from the damper-off steps, where the response oscillates), in Hz."""
    out: dict[str, Any] = {}
    for e in experiments:
        s = e.summary
        if "natural_frequency_hz" in s and s["damper"] == "off" and s["natural_frequency_hz"] is not None:
            out[f"natural_frequency_{s['spring']}_hz"] = s["natural_frequency_hz"]
    return out


def seed_oil_node() -> OilNode:
    """The seed's lumped oil / gas-wall thermal nodes (see hp-core presets)."""
    return OilNode(**_core.seed_oil_node())


# The seed's section 4.5, for comparison.
SEED_HEAT_BUILDUP = {
    "duration_s": 75 * 60.0,
    "gas_temperature_start_c": 23.0,
    "gas_temperature_end_c": 68.0,
    "oil_temperature_end_c": 130.0,
    "spring_rate_change": 0.58,
    "ride_height_change_m": 0.018,
    "ride_height_change": 0.15,
}


def heat_buildup(
    unit: Unit,
    *,
    duration_s: float = 75 * 60.0,
    frequency_hz: float = 0.5,
    amplitude_m: float = 0.06,
    spring_hard: bool = True,
    ambient_k: float = 296.15,
    sprung_mass_kg: float = SEED_SPRUNG_MASS_KG,
    dt_s: float | None = None,
    rtol: float | None = DEFAULT_RTOL,
    progress: Progress | None = None,
) -> Experiment:
    """The seed's damper heat build-up run: a long sine with the damper on,
    the damper power heating a lumped oil node that slowly warms the gas.

    Reports the gas and oil temperature rise, the change of the static
    spring rate at the static position (gas at its final temperature,
    same gas mass), and the change of ride height under the sprung mass.
    """
    if unit.effects.oil_node is None:
        unit = unit.with_effects(oil_node=seed_oil_node())
    unit = unit.replace(static_temperature_k=ambient_k)
    e = characterisation(
        unit, Sine(amplitude_m, frequency_hz), duration_s, spring_hard=spring_hard, damper_on=True, dt_s=dt_s, rtol=rtol,
        sample_dt_s=0.1, ambient_k=ambient_k, progress=progress,
    )
    r = e.result
    t = r["time_s"]
    last = metrics.last_cycle(t, frequency_hz)
    t_gas_end = float(np.mean(r["t_gas_k"][last]))
    t_oil_end = float(np.mean(r["t_oil_k"][last]))
    load = sprung_mass_kg * STANDARD_GRAVITY_M_S2

    def rate(t_k: float) -> float:
        h = 1e-3
        return (unit.static_force_n(h, t_k, spring_hard) - unit.static_force_n(-h, t_k, spring_hard)) / (2 * h)

    k0, k1 = rate(ambient_k), rate(t_gas_end)
    x0 = unit.static_disp_for_load_m(load, ambient_k, spring_hard)
    x1 = unit.static_disp_for_load_m(load, t_gas_end, spring_hard)
    first = (t >= 0) & (t < 1.0 / frequency_hz)
    # The run as the story it tells: cycle means and envelopes (groups of
    # cycles, at most ~300 points), and the ride height the gas
    # temperature gives at rest under the sprung mass.
    every = max(1, math.ceil(frequency_hz * duration_s / 300))
    gas = metrics.cycle_stats(t, r["t_gas_k"], frequency_hz, every)
    oil = metrics.cycle_stats(t, r["t_oil_k"], frequency_hz, every)
    force = metrics.cycle_stats(t, r["force_n"], frequency_hz, every)
    e.series = {
        "cycle_time_s": gas["time_s"],
        "t_gas_mean_k": gas["mean"], "t_gas_min_k": gas["min"], "t_gas_max_k": gas["max"],
        "t_oil_mean_k": oil["mean"],
        "force_min_n": force["min"], "force_max_n": force["max"],
        "ride_height_change_m": np.array([x0 - unit.static_disp_for_load_m(load, float(tk), spring_hard) for tk in gas["mean"]]),
    }
    e.name = f"heat_buildup_{spring_name(spring_hard)}"
    e.record.name = e.name
    e.record.description = f"hpctl simulation: damper heat build-up, {duration_s / 60:g} min at {frequency_hz:g} Hz, {amplitude_m * 1e3:g} mm"
    e.summary.update(
        {
            "duration_s": duration_s,
            "damper_energy_j": float(r["e_damper_j"][-1]),
            "mean_damper_power_w": float(r["e_damper_j"][-1] / duration_s),
            "gas_temperature_start_k": ambient_k,
            "gas_temperature_end_k": t_gas_end,
            "oil_temperature_end_k": t_oil_end,
            "static_spring_rate_start_n_per_m": k0,
            "static_spring_rate_end_n_per_m": k1,
            "static_spring_rate_change": k1 / k0 - 1.0,
            "dynamic_force_range_start_n": float(np.ptp(r["force_n"][first])),
            "dynamic_force_range_end_n": float(np.ptp(r["force_n"][last])),
            "ride_height_change_m": x0 - x1,
            "ambient_k": ambient_k,
            "frequency_hz": frequency_hz,
            "amplitude_m": amplitude_m,
            "sprung_mass_kg": sprung_mass_kg,
            "ride_height_change_of_gas_volume": (x0 - x1) * unit.piston_area_m2 / (unit.small_acc_volume_m3 if spring_hard else unit.small_acc_volume_m3 + unit.large_acc_volume_m3),
        }
    )
    return e

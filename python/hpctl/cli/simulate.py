"""``hpctl simulate``: the seed's experiments, one test, or a sweep."""

from __future__ import annotations

import csv
import io
import json
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import click
from click.core import ParameterSource

from hpctl.caveats import Caveat
from hpctl.cli._ui import (
    FINITE,
    Reporter,
    errors,
    finish,
    fmt,
    force_option,
    format_option,
    load_unit,
    modes,
    output_dir,
    parse_floats,
    parse_tau,
    strict_option,
    table,
    with_warnings,
)
from hpctl.data.output import OutputDir
from hpctl.data.records import write_record
from hpctl.errors import SimulationError
from hpctl.model.unit import GAS_MODELS, SEED_SPRUNG_MASS_KG, Unit
from hpctl.sim import experiments
from hpctl.sim.run import DEFAULT_RTOL, Sine, Step, Steps


@click.command()
@click.option("--unit", "unit_file", type=click.Path(exists=True, dir_okay=False, path_type=Path), help="Unit description (TOML, [unit] table); default: the built-in seed unit.")
@click.option("--test", "test", type=click.Choice(["seed", "sine", "steps", "step", "sdof-step", "heat"]), default="seed", show_default=True,
              help="seed: the seed's experiments; sine/steps/step: characterisation rig; sdof-step: sprung mass over a base step; heat: damper heat build-up run.")
@click.option("--amplitude-m", type=FINITE, help="Sine amplitude or step height, m.")
@click.option("--frequency-hz", type=FINITE, help="Sine frequency, Hz.")
@click.option("--spring", type=click.Choice(["hard", "soft", "both"]), default="both", show_default=True)
@click.option("--damper", type=click.Choice(["on", "off", "both"]), default="both", show_default=True)
@click.option("--tau-s", "tau_s", type=str, help="Gas thermal time constant, s (0 = isothermal, inf = adiabatic).")
@click.option("--gas", type=click.Choice(GAS_MODELS), help="Equation of state.")
@click.option("--duration-s", type=FINITE, help="Simulated duration, s.")
@click.option("--dt-s", type=FINITE, default=None,
              help="Largest integration step, s (default: none; the steps are error-controlled and follow the dynamics). With --fixed-steps, "
                   "the step (default 1e-3); a fixed step longer than the output interval is not taken: the output interval is, with a warning.")
@click.option("--fixed-steps", is_flag=True, help="Fixed RK4 steps of --dt-s landing on every output time (as the firmware runs) instead of error-controlled steps.")
@click.option("--mass-kg", type=FINITE, default=SEED_SPRUNG_MASS_KG, show_default=True, help="Sprung mass for SDOF tests, kg.")
@click.option("--sweep", is_flag=True, help="Sweep a grid (charge pressure x tau x damper) of SDOF step tests in parallel.")
@click.option("--sweep-pressure-pa", type=str, help="Comma-separated static charge pressures, Pa (default: the unit's x 0.8..1.2).")
@click.option("--sweep-tau-s", type=str, help="Comma-separated tau values, s (default: 0.5,2,8).")
@click.option("--threads", type=click.IntRange(min=0), default=None,
              help="Threads for --sweep: 0 (the default) = all cores, at most 4 x the cores.")
@click.option("--out", "out_dir", type=click.Path(file_okay=False, path_type=Path), default=Path("hpctl-out"), show_default=True, help="Output folder.")
@format_option
@force_option
@strict_option
@click.option("--quiet", "-q", is_flag=True, help="No progress bars or tables.")
@click.option("--json", "as_json", is_flag=True, help="Print the summary as JSON on stdout.")
def simulate(
    unit_file: Path | None, test: str, amplitude_m: float | None, frequency_hz: float | None, spring: str, damper: str,
    tau_s: str | None, gas: str | None, duration_s: float | None, dt_s: float | None, fixed_steps: bool, mass_kg: float, sweep: bool,
    sweep_pressure_pa: str | None, sweep_tau_s: str | None, threads: int | None, out_dir: Path, fig_format: str, force: bool, strict: bool, quiet: bool, as_json: bool,
) -> None:
    """Run the seed's experiments (default) or one test on a unit, and write
    rig records, plots (PNG, SVG or PDF) and a summary into the output folder. What a
    result cannot stand behind (end stops, the gas model's range, the
    rated speed, a failed case...) is printed as a warning and listed in
    summary.json under "warnings"."""
    _refuse_unused_options("sweep" if sweep else test)
    rep = Reporter(quiet, as_json)
    with errors(rep):
        unit = load_unit(unit_file, parse_tau(tau_s), gas)
        with output_dir(out_dir, "simulate", force=force, protect=("summary.json",)) as out:
            if sweep:
                summary, caveats = _sweep(rep, unit, spring, damper, amplitude_m, mass_kg, sweep_pressure_pa, sweep_tau_s, threads, out, fig_format)
            else:
                rtol = None if fixed_steps else DEFAULT_RTOL
                summary, caveats = _simulate(rep, unit, test, amplitude_m, frequency_hz, spring, damper, duration_s, dt_s, rtol, mass_kg, out, fig_format)
            document = with_warnings(summary, caveats)
            out.write_json("summary.json", document)
        if as_json:
            click.echo(json.dumps(document, indent=2))
        else:
            what = f"sweep.csv, sweep.{fig_format}" if sweep else "records, plots"
            rep.say(("Wrote", "bold"), f" {what} and summary.json to {out_dir}/")
        finish(rep, caveats, strict)


# The options each kind of run reads (beyond --unit, --tau-s, --gas and the
# output options). An option given to a run that does not read it is an
# error: silently ignoring --dt-s on the seed's experiments looked as if the
# step had been used.
_READS: dict[str, frozenset[str]] = {
    "seed": frozenset(),
    "sine": frozenset({"amplitude_m", "frequency_hz", "spring", "damper", "duration_s", "dt_s", "fixed_steps"}),
    "steps": frozenset({"amplitude_m", "spring", "damper", "duration_s", "dt_s", "fixed_steps"}),
    "step": frozenset({"amplitude_m", "spring", "damper", "duration_s", "dt_s", "fixed_steps"}),
    "sdof-step": frozenset({"amplitude_m", "spring", "damper", "duration_s", "dt_s", "fixed_steps", "mass_kg"}),
    "heat": frozenset({"amplitude_m", "frequency_hz", "spring", "duration_s", "dt_s", "fixed_steps", "mass_kg"}),
    "sweep": frozenset({"amplitude_m", "spring", "damper", "mass_kg", "sweep_pressure_pa", "sweep_tau_s", "threads"}),
}
_RUN_OPTIONS = frozenset().union(*_READS.values(), {"test"})


def _refuse_unused_options(run: str) -> None:
    ctx = click.get_current_context()
    reads = _READS[run] | ({"test"} if run != "sweep" else frozenset())
    given = [
        p for p in ctx.command.params
        if p.name in _RUN_OPTIONS and p.name not in reads
        and ctx.get_parameter_source(p.name) in (ParameterSource.COMMANDLINE, ParameterSource.ENVIRONMENT)
    ]
    if given:
        names = ", ".join(p.opts[0] for p in given)
        what = "--sweep" if run == "sweep" else f"--test {run}"
        reads_names = ", ".join(p.opts[0] for p in ctx.command.params if p.name in _READS[run]) or "none of the run options"
        raise click.UsageError(f"{names} does not apply to {what} (it reads {reads_names})")


def _sweep(
    rep: Reporter, unit: Unit, spring: str, damper: str, amplitude_m: float | None, mass_kg: float,
    pressures: str | None, taus: str | None, threads: int | None, out: OutputDir, fig_format: str = "png",
) -> tuple[dict[str, Any], list[Caveat]]:
    from hpctl.report.plots import sweep_plot
    from hpctl.sim import sweep

    summary, caveats = sweep.run_sweep(
        unit, spring_hard=spring != "soft", mass_kg=mass_kg,
        pressures_pa=parse_floats(pressures, "--sweep-pressure-pa"), taus_s=parse_floats(taus, "--sweep-tau-s"),
        damper=damper, height_m=amplitude_m if amplitude_m is not None else experiments.SEED_STEP_M, threads=threads,
        say=lambda text: rep.note(text),
    )
    if summary["cases"] and summary["failed"] == summary["cases"]:
        first = next(r["error"] for r in summary["rows"] if r["error"])
        raise SimulationError(f"every one of the {summary['cases']} sweep cases failed; the first: {first}")
    buf = io.StringIO()
    w = csv.DictWriter(buf, fieldnames=sweep.COLUMNS, lineterminator="\n")
    w.writeheader()
    for row in summary["rows"]:
        w.writerow({k: ("" if row.get(k) is None else row.get(k)) for k in sweep.COLUMNS})
    out.write_text("sweep.csv", buf.getvalue())
    height_m = amplitude_m if amplitude_m is not None else experiments.SEED_STEP_M
    sweep_plot(summary["rows"], out.path(f"sweep.{fig_format}"), spring != "soft", height_m=height_m, mass_kg=mass_kg)
    if summary["failed"]:
        rep.note(f"{summary['failed']} of {summary['cases']} sweep cases failed (see the warnings and the error column of sweep.csv)")
    return summary, caveats


def _simulate(
    rep: Reporter, unit: Unit, test: str, amplitude_m: float | None, frequency_hz: float | None, spring: str, damper: str,
    duration_s: float | None, dt_s: float | None, rtol: float | None, mass_kg: float, out: OutputDir, fig_format: str = "png",
) -> tuple[dict[str, Any], list[Caveat]]:
    def given(value: float | None, default: float) -> float:
        return default if value is None else value

    springs = modes(spring, ("hard", "soft"))
    dampers = modes(damper, ("on", "off"))
    runs: list[experiments.Experiment] = []
    from hpctl.report import plots

    with rep.bars() as bar:
        if test == "seed":
            runs = experiments.seed_experiments(unit, progress=bar)
        elif test == "sdof-step":
            for hard in springs:
                for on in dampers:
                    runs.append(experiments.sdof_step(
                        unit, spring_hard=hard, damper_on=on, height_m=given(amplitude_m, experiments.SEED_STEP_M),
                        duration_s=given(duration_s, 6.0), sprung_mass_kg=mass_kg, dt_s=dt_s, rtol=rtol,
                        progress=bar(f"SDOF step ({experiments.spring_name(hard)}, damper {experiments.damper_name(on)})"),
                    ))
        elif test == "heat":
            for hard in springs:
                runs.append(experiments.heat_buildup(
                    unit, duration_s=given(duration_s, 75 * 60.0), frequency_hz=given(frequency_hz, 0.5), amplitude_m=given(amplitude_m, 0.06),
                    spring_hard=hard, sprung_mass_kg=mass_kg, dt_s=dt_s, rtol=rtol, progress=bar(f"heat build-up ({experiments.spring_name(hard)})"),
                ))
        else:
            for hard in springs:
                for on in dampers:
                    name = f"{test} ({experiments.spring_name(hard)}, damper {experiments.damper_name(on)})"
                    if test == "sine":
                        f = given(frequency_hz, 0.1)
                        motion: Sine | Steps | Step = Sine(given(amplitude_m, 0.05), f)
                        dur = given(duration_s, 3.0 / f)
                    elif test == "steps":
                        motion = Steps(given(amplitude_m, 0.02), 4, ramp_s=2.0, dwell_s=30.0)
                        dur = given(duration_s, motion.duration_s)
                    else:
                        motion = Step(given(amplitude_m, 0.05), start_s=1.0, rise_s=0.05)
                        dur = given(duration_s, 30.0)
                    sample = min(0.01, dur / 2000) if dur > 0 else 0.01
                    runs.append(experiments.characterisation(unit, motion, dur, spring_hard=hard, damper_on=on, dt_s=dt_s, rtol=rtol, sample_dt_s=sample, progress=bar(name)))

    for e in runs:
        write_record(e.record, out.path(f"records/{e.name}"))
    chars = [e for e in runs if e.record.kind == "characterisation"]
    steps = [e for e in runs if e.record.kind == "sdof"]
    if test == "heat":
        for e in runs:
            plots.heat_buildup(e, out.path(f"{e.name}.{fig_format}"))
    elif chars:
        plots.force_displacement(chars, out.path(f"force_displacement.{fig_format}"))
    if steps:
        plots.step_responses(steps, out.path(f"step_responses.{fig_format}"))
    summary: dict[str, Any] = {"test": test, "unit": {"piston_area_m2": unit.piston_area_m2, "static_pressure_pa": unit.static_pressure_pa, "tau_s": unit.tau_s, "gas": unit.gas}}
    summary.update(experiments.headline(runs))
    summary["runs"] = [dict(e.summary, name=e.name) for e in runs]
    if test == "heat":
        summary["seed"] = experiments.SEED_HEAT_BUILDUP
    _print_summary(rep, runs, test)
    return summary, [c for e in runs for c in e.caveats]


def _print_summary(rep: Reporter, runs: Sequence[experiments.Experiment], test: str) -> None:
    steps = [e.summary for e in runs if e.record.kind == "sdof"]
    chars = [e.summary for e in runs if e.record.kind == "characterisation"]
    if steps:
        t = table("SDOF step response", ("spring", "damper", "natural freq. [Hz]", "damping ratio", "overshoot [mm]", "settling [s]", "peak p_gas [MPa]"))
        for s in steps:
            t.add_row(s["spring"], s["damper"], fmt(s["natural_frequency_hz"]), fmt(s["damping_ratio"]), fmt(s["overshoot_m"], 1e3, 1),
                      fmt(s["settling_time_s"]), fmt(s["peak_p_gas_pa"], 1e-6, 1))
        rep.out.print(t)
    if chars and test != "heat":
        t = table("Characterisation", ("spring", "damper", "excitation", "force range [kN]", "loop area [J]", "gas loop area [J]", "peak p_gas [MPa]"))
        for s in chars:
            t.add_row(s["spring"], s["damper"], s["excitation"], f"{s['force_min_n'] / 1e3:.1f} .. {s['force_max_n'] / 1e3:.1f}",
                      fmt(s.get("loop_area_j"), 1, 0), fmt(s.get("gas_loop_area_j"), 1, 0), fmt(s["peak_p_gas_pa"], 1e-6, 1))
        rep.out.print(t)
    if test == "heat":
        seed = experiments.SEED_HEAT_BUILDUP
        t = table("Damper heat build-up: this model vs the seed", ("quantity", "hpctl", "seed"))
        for s in (e.summary for e in runs):
            t.add_row("gas temperature [C]", f"{s['gas_temperature_start_k'] - 273.15:.0f} -> {s['gas_temperature_end_k'] - 273.15:.0f}",
                      f"{seed['gas_temperature_start_c']:.0f} -> {seed['gas_temperature_end_c']:.0f}")
            t.add_row("oil temperature at end [C]", f"{s['oil_temperature_end_k'] - 273.15:.0f}", f"{seed['oil_temperature_end_c']:.0f}")
            t.add_row("static spring rate change", f"{100 * s['static_spring_rate_change']:+.0f} %", f"{100 * seed['spring_rate_change']:+.0f} %")
            t.add_row("ride height change", f"{1e3 * s['ride_height_change_m']:+.1f} mm ({100 * s['ride_height_change_of_gas_volume']:+.0f} % of gas volume)",
                      f"+{1e3 * seed['ride_height_change_m']:.0f} mm (+{100 * seed['ride_height_change']:.0f} %)")
            t.add_row("mean damper power [W]", f"{s['mean_damper_power_w']:.0f}", "-")
        rep.out.print(t)


"""The ``hpctl`` command line.

Exit codes: 0 ok, 2 bad input (usage errors, invalid parameters, malformed
records), 1 internal error.
"""

from __future__ import annotations

import json
import math
import sys
import traceback
from collections.abc import Callable, Iterator, Sequence
from contextlib import contextmanager
from pathlib import Path
from typing import Any

import click
from rich.console import Console
from rich.progress import BarColumn, Progress, TextColumn, TimeRemainingColumn
from rich.table import Table

from hpctl import experiments as ex
from hpctl.errors import HpctlError
from hpctl.records import write_record
from hpctl.sim import Sine, Step, Steps
from hpctl.unit import GAS_MODELS, SEED_SPRUNG_MASS_KG, Unit

EXIT_OK, EXIT_INTERNAL, EXIT_BAD_INPUT = 0, 1, 2


class Reporter:
    """Progress bars and human output on stderr/stdout, silenced by
    ``--quiet``; ``--json`` keeps stdout for the JSON document alone."""

    def __init__(self, quiet: bool, as_json: bool) -> None:
        self.quiet = quiet
        self.as_json = as_json
        # Tables keep their columns when written to a file or a pipe.
        wide = None if sys.stdout.isatty() else 160
        self.out = Console(quiet=quiet or as_json, width=wide)
        self.err = Console(stderr=True, quiet=quiet)
        # Errors are printed even with --quiet.
        self.errors = Console(stderr=True)

    @contextmanager
    def bars(self) -> Iterator[Callable[[str], Callable[[int, int], None] | None]]:
        """A factory of progress callbacks, one bar per simulation. Bars
        appear only for runs that report progress (longer than ~0.1 s)."""
        if self.quiet:
            yield lambda _name: None
            return
        with Progress(
            TextColumn("{task.description}"), BarColumn(), TextColumn("{task.percentage:>3.0f}%"), TimeRemainingColumn(),
            console=self.err, transient=True,
        ) as progress:

            def make(name: str) -> Callable[[int, int], None]:
                task = progress.add_task(name, total=None)

                def update(done: int, total: int) -> None:
                    progress.update(task, completed=done, total=total)

                return update

            yield make


class _Status:
    """A spinner with a changing message, for work without a known total."""

    def __init__(self, rep: Reporter, message: str) -> None:
        self._status = None if rep.quiet else rep.err.status(message)

    def __enter__(self) -> _Status:
        if self._status is not None:
            self._status.__enter__()
        return self

    def __exit__(self, *exc: object) -> None:
        if self._status is not None:
            self._status.__exit__(None, None, None)

    def update(self, message: str) -> None:
        if self._status is not None:
            self._status.update(message)


def status(rep: Reporter, message: str) -> _Status:
    """A spinner on stderr (nothing with --quiet)."""
    return _Status(rep, message)


def _jsonable(x: Any) -> Any:
    if isinstance(x, float) and not math.isfinite(x):
        return None
    if isinstance(x, dict):
        return {k: _jsonable(v) for k, v in x.items()}
    if isinstance(x, (list, tuple)):
        return [_jsonable(v) for v in x]
    return x


def _fmt(v: Any, scale: float = 1.0, digits: int = 2) -> str:
    return "-" if v is None else f"{v * scale:.{digits}f}"


def _load_unit(unit_file: Path | None, tau_s: float | None, gas: str | None) -> Unit:
    unit = Unit.seed() if unit_file is None else Unit.from_toml(unit_file)
    if tau_s is not None:
        unit = unit.replace(tau_s=tau_s)
    if gas is not None:
        unit = unit.replace(gas=gas)
    unit.check()
    return unit


def _modes(option: str, names: tuple[str, str]) -> list[bool]:
    """'both' -> [True, False]; otherwise the one state (True = first name)."""
    return [True, False] if option == "both" else [option == names[0]]


@click.group(context_settings={"help_option_names": ["-h", "--help"]})
@click.version_option(package_name="hpctl")
def main() -> None:
    """Simulate, calibrate and control a semi-active hydro-pneumatic
    spring-damper unit. All quantities are SI."""


def _tau(value: str | None) -> float | None:
    if value is None:
        return None
    try:
        return float(value)
    except ValueError:
        raise click.BadParameter(f"{value!r} is not a number (seconds; 0 = isothermal, inf = adiabatic)") from None


@main.command()
@click.option("--unit", "unit_file", type=click.Path(exists=True, dir_okay=False, path_type=Path), help="Unit description (TOML, [unit] table); default: the built-in seed unit.")
@click.option("--test", "test", type=click.Choice(["seed", "sine", "steps", "step", "sdof-step", "heat"]), default="seed", show_default=True,
              help="seed: the seed's experiments; sine/steps/step: characterisation rig; sdof-step: sprung mass over a base step; heat: damper heat build-up run.")
@click.option("--amplitude-m", type=float, help="Sine amplitude or step height, m.")
@click.option("--frequency-hz", type=float, help="Sine frequency, Hz.")
@click.option("--spring", type=click.Choice(["hard", "soft", "both"]), default="both", show_default=True)
@click.option("--damper", type=click.Choice(["on", "off", "both"]), default="both", show_default=True)
@click.option("--tau-s", "tau_s", type=str, help="Gas thermal time constant, s (0 = isothermal, inf = adiabatic).")
@click.option("--gas", type=click.Choice(GAS_MODELS), help="Equation of state.")
@click.option("--duration-s", type=float, help="Simulated duration, s.")
@click.option("--dt-s", type=float, default=None, help="Integration step, s (default 1e-3; 2e-3 for the heat run; keep <= 1e-3 with valve 6 open).")
@click.option("--mass-kg", type=float, default=SEED_SPRUNG_MASS_KG, show_default=True, help="Sprung mass for SDOF tests, kg.")
@click.option("--sweep", is_flag=True, help="Sweep a grid (charge pressure x tau x damper) of SDOF step tests in parallel.")
@click.option("--sweep-pressure-pa", type=str, help="Comma-separated static charge pressures, Pa (default: the unit's x 0.8..1.2).")
@click.option("--sweep-tau-s", type=str, help="Comma-separated tau values, s (default: 0.5,2,8).")
@click.option("--threads", type=int, default=None, help="Threads for --sweep (default: all cores).")
@click.option("--out", "out_dir", type=click.Path(file_okay=False, path_type=Path), default=Path("hpctl-out"), show_default=True, help="Output folder.")
@click.option("--quiet", "-q", is_flag=True, help="No progress bars or tables.")
@click.option("--json", "as_json", is_flag=True, help="Print the summary as JSON on stdout.")
def simulate(
    unit_file: Path | None, test: str, amplitude_m: float | None, frequency_hz: float | None, spring: str, damper: str,
    tau_s: str | None, gas: str | None, duration_s: float | None, dt_s: float | None, mass_kg: float, sweep: bool,
    sweep_pressure_pa: str | None, sweep_tau_s: str | None, threads: int | None, out_dir: Path, quiet: bool, as_json: bool,
) -> None:
    """Run the seed's experiments (default) or one test on a unit, and write
    rig records, PNG plots and a summary into the output folder."""
    rep = Reporter(quiet, as_json)
    with _errors(rep):
        unit = _load_unit(unit_file, _tau(tau_s), gas)
        out_dir.mkdir(parents=True, exist_ok=True)
        if sweep:
            from hpctl import sweep as sw

            summary = sw.run_sweep(
                unit, out_dir, spring_hard=spring != "soft", mass_kg=mass_kg,
                pressures_pa=_floats(sweep_pressure_pa, "--sweep-pressure-pa"), taus_s=_floats(sweep_tau_s, "--sweep-tau-s"),
                damper=damper, height_m=amplitude_m if amplitude_m is not None else ex.SEED_STEP_M, threads=threads, reporter=rep,
            )
        else:
            summary = _simulate(rep, unit, test, amplitude_m, frequency_hz, spring, damper, duration_s, dt_s, mass_kg, out_dir)
        (out_dir / "summary.json").write_text(json.dumps(_jsonable(summary), indent=2) + "\n")
        if as_json:
            click.echo(json.dumps(_jsonable(summary), indent=2))
        else:
            rep.out.print(f"[bold]Wrote[/bold] records, plots and summary.json to {out_dir}/")


def _floats(text: str | None, option: str) -> list[float] | None:
    if text is None:
        return None
    try:
        return [float(v) for v in text.split(",") if v.strip()]
    except ValueError:
        raise click.BadParameter(f"{text!r}: expected comma-separated numbers", param_hint=option) from None


def _simulate(
    rep: Reporter, unit: Unit, test: str, amplitude_m: float | None, frequency_hz: float | None, spring: str, damper: str,
    duration_s: float | None, dt_s: float | None, mass_kg: float, out_dir: Path,
) -> dict[str, Any]:
    def given(value: float | None, default: float) -> float:
        return default if value is None else value

    springs = _modes(spring, ("hard", "soft"))
    dampers = _modes(damper, ("on", "off"))
    runs: list[ex.Experiment] = []
    from hpctl import plots

    with rep.bars() as bar:
        if test == "seed":
            runs = ex.seed_experiments(unit, progress=bar)
        elif test == "sdof-step":
            for hard in springs:
                for on in dampers:
                    runs.append(ex.sdof_step(
                        unit, spring_hard=hard, damper_on=on, height_m=given(amplitude_m, ex.SEED_STEP_M),
                        duration_s=given(duration_s, 6.0), sprung_mass_kg=mass_kg, dt_s=given(dt_s, 1e-3),
                        progress=bar(f"SDOF step ({ex.spring_name(hard)}, damper {ex.damper_name(on)})"),
                    ))
        elif test == "heat":
            for hard in springs:
                runs.append(ex.heat_buildup(
                    unit, duration_s=given(duration_s, 75 * 60.0), frequency_hz=given(frequency_hz, 0.5), amplitude_m=given(amplitude_m, 0.06),
                    spring_hard=hard, sprung_mass_kg=mass_kg, dt_s=given(dt_s, 2e-3), progress=bar(f"heat build-up ({ex.spring_name(hard)})"),
                ))
        else:
            for hard in springs:
                for on in dampers:
                    name = f"{test} ({ex.spring_name(hard)}, damper {ex.damper_name(on)})"
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
                    runs.append(ex.characterisation(unit, motion, dur, spring_hard=hard, damper_on=on, dt_s=given(dt_s, min(1e-3, sample)), sample_dt_s=sample, progress=bar(name)))

    records = out_dir / "records"
    for e in runs:
        write_record(e.record, records / e.name)
    chars = [e for e in runs if e.record.kind == "characterisation"]
    steps = [e for e in runs if e.record.kind == "sdof"]
    if test == "heat":
        for e in runs:
            r = e.result
            plots.time_series(
                [("gas", r["time_s"], r["t_gas_k"] - 273.15, "gas [C]"), ("oil", r["time_s"], r["t_oil_k"] - 273.15, "oil [C]"),
                 ("force", r["time_s"], 1e-3 * r["force_n"], "force [kN]")],
                out_dir / f"{e.name}.png", "Damper heat build-up",
            )
    elif chars:
        plots.force_displacement(chars, out_dir / "force_displacement.png")
    if steps:
        plots.step_responses(steps, out_dir / "step_responses.png", title=f"SDOF step response ({mass_kg:g} kg)")
    summary: dict[str, Any] = {"test": test, "unit": {"piston_area_m2": unit.piston_area_m2, "static_pressure_pa": unit.static_pressure_pa, "tau_s": unit.tau_s, "gas": unit.gas}}
    summary.update(ex.headline(runs))
    summary["runs"] = [dict(e.summary, name=e.name) for e in runs]
    if test == "heat":
        summary["seed"] = ex.SEED_HEAT_BUILDUP
    _print_summary(rep, runs, test)
    return summary


def _print_summary(rep: Reporter, runs: Sequence[ex.Experiment], test: str) -> None:
    steps = [e.summary for e in runs if e.record.kind == "sdof"]
    chars = [e.summary for e in runs if e.record.kind == "characterisation"]
    if steps:
        t = Table(title="SDOF step response")
        for col in ("spring", "damper", "natural freq. [Hz]", "damping ratio", "overshoot [mm]", "settling [s]", "peak p_gas [MPa]"):
            t.add_column(col, justify="right")
        for s in steps:
            t.add_row(s["spring"], s["damper"], _fmt(s["natural_frequency_hz"]), _fmt(s["damping_ratio"]), _fmt(s["overshoot_m"], 1e3, 1),
                      _fmt(s["settling_time_s"]), _fmt(s["peak_p_gas_pa"], 1e-6, 1))
        rep.out.print(t)
    if chars and test != "heat":
        t = Table(title="Characterisation")
        for col in ("spring", "damper", "excitation", "force range [kN]", "loop area [J]", "gas loop area [J]", "peak p_gas [MPa]"):
            t.add_column(col, justify="right")
        for s in chars:
            t.add_row(s["spring"], s["damper"], s["excitation"], f"{s['force_min_n'] / 1e3:.1f} .. {s['force_max_n'] / 1e3:.1f}",
                      _fmt(s.get("loop_area_j"), 1, 0), _fmt(s.get("gas_loop_area_j"), 1, 0), _fmt(s["peak_p_gas_pa"], 1e-6, 1))
        rep.out.print(t)
    if test == "heat":
        seed = ex.SEED_HEAT_BUILDUP
        t = Table(title="Damper heat build-up: this model vs the seed")
        for col in ("quantity", "hpctl", "seed"):
            t.add_column(col, justify="right")
        for s in (e.summary for e in runs):
            t.add_row("gas temperature [C]", f"{s['gas_temperature_start_k'] - 273.15:.0f} -> {s['gas_temperature_end_k'] - 273.15:.0f}",
                      f"{seed['gas_temperature_start_c']:.0f} -> {seed['gas_temperature_end_c']:.0f}")
            t.add_row("oil temperature at end [C]", f"{s['oil_temperature_end_k'] - 273.15:.0f}", f"{seed['oil_temperature_end_c']:.0f}")
            t.add_row("static spring rate change", f"{100 * s['static_spring_rate_change']:+.0f} %", f"{100 * seed['spring_rate_change']:+.0f} %")
            t.add_row("ride height change", f"{1e3 * s['ride_height_change_m']:+.1f} mm ({100 * s['ride_height_change_of_gas_volume']:+.0f} % of gas volume)",
                      f"+{1e3 * seed['ride_height_change_m']:.0f} mm (+{100 * seed['ride_height_change']:.0f} %)")
            t.add_row("mean damper power [W]", f"{s['mean_damper_power_w']:.0f}", "-")
        rep.out.print(t)


@contextmanager
def _errors(rep: Reporter) -> Iterator[None]:
    """Bad input -> message and exit 2; anything else -> exit 1."""
    try:
        yield
    except (click.ClickException, click.exceptions.Exit, click.exceptions.Abort):
        raise
    except HpctlError as e:
        rep.errors.print(f"[red]error:[/red] {e}", markup=True, highlight=False)
        sys.exit(EXIT_BAD_INPUT)
    except KeyboardInterrupt:
        rep.errors.print("interrupted")
        sys.exit(130)
    except Exception as e:  # noqa: BLE001 - the last line of defence
        rep.errors.print(f"[red]internal error:[/red] {type(e).__name__}: {e}", markup=True, highlight=False)
        if rep.errors.is_terminal:
            traceback.print_exc()
        sys.exit(EXIT_INTERNAL)


@main.command("closed-loop")
@click.option("--unit", "unit_file", type=click.Path(exists=True, dir_okay=False, path_type=Path), help="Unit description (TOML, [unit] table); default: the built-in seed unit.")
@click.option("--road-class", type=click.Choice(list("ABCDEFGH"), case_sensitive=False), default="C", show_default=True, help="ISO 8608 road class.")
@click.option("--speed-m-s", type=float, default=10.0, show_default=True, help="Vehicle speed, m/s.")
@click.option("--lower-m", type=float, default=0.03, show_default=True, help="How far to lower the ride height (then raise it back), m.")
@click.option("--seed", type=int, default=1, show_default=True, help="Road seed (same seed, same road).")
@click.option("--out", "out_dir", type=click.Path(file_okay=False, path_type=Path), default=Path("hpctl-out/closed-loop"), show_default=True, help="Output folder.")
@click.option("--quiet", "-q", is_flag=True, help="No tables.")
@click.option("--json", "as_json", is_flag=True, help="Print the summary as JSON on stdout.")
def closed_loop(unit_file: Path | None, road_class: str, speed_m_s: float, lower_m: float, seed: int, out_dir: Path, quiet: bool, as_json: bool) -> None:
    """Run the controller in closed loop with the unit (3000 kg SDOF) over a
    random road: lower the ride height without a pump and raise it back,
    then switch modes on a lane change and a braking burst. Writes PNG plots
    and summary.json into the output folder."""
    rep = Reporter(quiet, as_json)
    with _errors(rep):
        from hpctl import closed_loop as cl

        unit = _load_unit(unit_file, None, None)
        summary = cl.demo(out_dir, road_class=road_class, speed_m_s=speed_m_s, lower_m=lower_m, seed=seed, unit=unit)
        (out_dir / "summary.json").write_text(json.dumps(_jsonable(summary), indent=2) + "\n")
        if as_json:
            click.echo(json.dumps(_jsonable(summary), indent=2))
        else:
            t = Table(title=f"Pump-free ride height (class {summary['road_class']}, {speed_m_s:g} m/s), mm")
            for col in ("change", "target", "held at rest", "estimate", "on the road", "time [s]", "valve-6 openings"):
                t.add_column(col, justify="right")
            for name in ("lowering", "raising"):
                s = summary[name]
                t.add_row(name, _fmt(s["target_m"], 1e3, 1), _fmt(s["held_offset_m"], 1e3, 1), _fmt(s["estimate_m"], 1e3, 1),
                          _fmt(s["road_mean_change_m"], 1e3, 1), _fmt(s["time_to_reach_s"]), str(s["valve6_openings"]))
            rep.out.print(t)
            t = Table(title="Pressures when done, MPa")
            for col in ("change", "p_S", "p_L", "target p_L", "load (estimate)", "load (true)"):
                t.add_column(col, justify="right")
            for name in ("lowering", "raising"):
                s = summary[name]
                t.add_row(name, *(_fmt(s[k], 1e-6, 2) for k in ("p_small_pa", "p_large_pa", "p_large_target_pa", "p_load_estimate_pa", "p_load_true_pa")))
            rep.out.print(t)
            m = summary["modes"]
            rep.out.print(f"Handling entered at {', '.join(f'{x:.2f}' for x in m['handling_entered_s']) or '-'} s, Ride again at "
                          f"{', '.join(f'{x:.2f}' for x in m['ride_returned_s']) or '-'} s; triggers: {', '.join(m['triggers']) or '-'}")
            rep.out.print(f"[bold]Wrote[/bold] plots and summary.json to {out_dir}/")


from hpctl import cli_calibrate as _calibrate  # noqa: E402

_calibrate.register(main)

if __name__ == "__main__":  # pragma: no cover
    main()

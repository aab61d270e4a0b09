"""Command-line calibration: ``hpctl fit``, ``hpctl diagnose``, ``hpctl rig``
and ``hpctl demo``."""

from __future__ import annotations

import json
from pathlib import Path

import click
import numpy as np
from rich.table import Table

from hpctl.cli._ui import Reporter, errors, jsonable, status
from hpctl.data import DEMO_DIR
from hpctl.data.records import RigRecord, read_record, record_paths, write_record
from hpctl.errors import ParameterError
from hpctl.identify import diagnose, virtual_rig
from hpctl.identify.dataset import prepare
from hpctl.identify.fit import FitResult, fit
from hpctl.model.effects import LIBRARY, MODELS, model_params, parse_model
from hpctl.report import calibration as report


def _records(paths: tuple[Path, ...]) -> list[RigRecord]:
    if not paths:
        raise click.UsageError("give at least one rig record (NAME, NAME.csv or NAME.toml)")
    recs = [read_record(p) for p in paths]
    names = [r.name for r in recs]
    if len(set(names)) != len(names):
        raise ParameterError(f"records given twice: {sorted({n for n in names if names.count(n) > 1})}")
    return recs


def _expand(paths: tuple[Path, ...]) -> tuple[Path, ...]:
    """Folders stand for the records in them."""
    out: list[Path] = []
    for p in paths:
        if p.is_dir():
            out += sorted(record_paths(c)[0] for c in p.glob("*.toml"))
        else:
            out.append(p)
    return tuple(out)


def _print_fit(rep: Reporter, result: FitResult) -> None:
    t = Table(title=f"Fitted parameters ({', '.join(result.model.effects) or 'classical polytropic ideal gas'})")
    for col in ("parameter", "value", "standard error"):
        t.add_column(col, justify="right")
    for p in result.model.params:
        t.add_row(p.name, f"{result.values[p.name]:.5g}", f"{result.stderr.get(p.name, float('nan')):.2g}")
    rep.out.print(t)
    t = Table(title=f"Residual per record and channel (RMS / noise overall {result.rms_ratio:.3f})")
    for col in ("record", "channel", "noise", "RMS", "NRMS", "max", "loop area err [J]"):
        t.add_column(col, justify="right")
    for s in result.stats:
        loop = "-" if s.loop_area_error_j is None else f"{s.loop_area_error_j:.2f}"
        t.add_row(s.record, s.channel, f"{s.noise:.3g}", f"{s.rms:.3g}", f"{s.nrms:.2e}", f"{s.max_abs:.3g}", loop)
    rep.out.print(t)


MODEL_HELP = f"Model: {', '.join(MODELS)}, or effects separated by commas (from: {', '.join(LIBRARY)})."

@click.command("fit")
@click.argument("records", nargs=-1, type=click.Path(path_type=Path))
@click.option("--model", "model", default="seed", show_default=True, help=MODEL_HELP)
@click.option("--out", "out_dir", type=click.Path(file_okay=False, path_type=Path), default=Path("hpctl-fit"), show_default=True)
@click.option("--quiet", "-q", is_flag=True)
@click.option("--json", "as_json", is_flag=True, help="Print parameters and residuals as JSON.")
def fit_cmd(records: tuple[Path, ...], model: str, out_dir: Path, quiet: bool, as_json: bool) -> None:
    """Fit the model's free parameters to one or more rig records (a
    folder stands for the records in it), with uncertainties and the
    residual per record and channel; writes fit.md, fit.json and plots."""
    rep = Reporter(quiet, as_json)
    with errors(rep):
        effects = parse_model(model)
        datasets = prepare(_records(_expand(records)))
        with status(rep, f"fitting {len(model_params(effects)) + 1} parameters to {len(datasets)} record(s)"):
            result = fit(datasets, effects)
        out_dir.mkdir(parents=True, exist_ok=True)
        report.fit_report(result, out_dir)
        summary = report.fit_summary(result)
        (out_dir / "fit.json").write_text(json.dumps(jsonable(summary), indent=2) + "\n")
        if as_json:
            click.echo(json.dumps(jsonable(summary), indent=2))
        else:
            _print_fit(rep, result)
            rep.out.print(f"Wrote fit.md, fit.json and plots to {out_dir}/")

@click.command("diagnose")
@click.argument("records", nargs=-1, type=click.Path(path_type=Path))
@click.option("--model", "model", default="classical", show_default=True, help="Declared starting model. " + MODEL_HELP)
@click.option("--list-effects", is_flag=True, help="List the effect library and exit.")
@click.option("--max-rounds", type=click.IntRange(1, 20), default=6, show_default=True)
@click.option("--out", "out_dir", type=click.Path(file_okay=False, path_type=Path), default=Path("hpctl-diagnosis"), show_default=True)
@click.option("--quiet", "-q", is_flag=True)
@click.option("--json", "as_json", is_flag=True, help="Print the conclusion as JSON.")
def diagnose_cmd(records: tuple[Path, ...], model: str, list_effects: bool, max_rounds: int, out_dir: Path, quiet: bool, as_json: bool) -> None:
    """Find what the declared model lacks: fit it, analyse the residual,
    try each effect of the library, keep what the evidence supports,
    repeat; writes report.md (with plots) and diagnosis.json."""
    rep = Reporter(quiet, as_json)
    if list_effects:
        if as_json:
            click.echo(json.dumps({n: e.to_json() for n, e in LIBRARY.items()}, indent=2))
        else:
            for n, e in LIBRARY.items():
                click.echo(f"{n:16} {e.description} [{', '.join(p.name for p in e.params) or 'no parameters'}]")
        return
    with errors(rep):
        effects = parse_model(model)
        _run_diagnosis(rep, _records(_expand(records)), effects, max_rounds, out_dir, as_json)

@click.command("rig")
@click.option("--out", "out_dir", type=click.Path(file_okay=False, path_type=Path), default=Path("hpctl-rig"), show_default=True)
@click.option("--program", type=click.Choice(list(virtual_rig.PROGRAMS)), default="sweep", show_default=True,
              help="sweep: sines 0.01-1 Hz; full: plus a fast damper-on sine, valve switching, a long hold, a heat run and an SDOF step.")
@click.option("--effect", "effects", multiple=True, type=click.Choice([e for e in LIBRARY if e not in ("heat_transfer", "real_gas")]),
              help="Effect present in the rig's unit (repeatable); real gas and heat transfer always are.")
@click.option("--set", "sets", multiple=True, metavar="PARAM=VALUE", help="Effect parameter value, SI (repeatable).")
@click.option("--random", "random_values", is_flag=True, help="Draw effect parameters at random (see --seed).")
@click.option("--seed", type=int, default=0, show_default=True, help="Seed of the noise and of --random.")
@click.option("--noise-scale", type=click.FloatRange(0.0, 100.0), default=1.0, show_default=True)
@click.option("--quiet", "-q", is_flag=True)
def rig_cmd(out_dir: Path, program: str, effects: tuple[str, ...], sets: tuple[str, ...], random_values: bool, seed: int, noise_scale: float, quiet: bool) -> None:
    """A virtual test rig: write rig records from a unit with the chosen
    effects and noise on every channel. The records do not say which
    effects they contain; truth.json beside them does."""
    rep = Reporter(quiet, False)
    with errors(rep):
        overrides = _parse_sets(sets)
        rng = np.random.default_rng(seed)
        values = virtual_rig.effect_values(effects, rng if random_values else None, overrides)
        unit = virtual_rig.truth_unit(effects, values)
        tests = virtual_rig.tests_for(effects, program)
        recs = virtual_rig.make_records(unit, tests=tests, noise=virtual_rig.Noise().scaled(noise_scale), seed=seed)
        out_dir.mkdir(parents=True, exist_ok=True)
        for r in recs:
            write_record(r, out_dir / r.name)
        truth = {"effects": ["heat_transfer", "real_gas", *effects], "params": {"tau_s": unit.tau_s, **values}, "seed": seed,
                 "noise": vars(virtual_rig.Noise().scaled(noise_scale))}
        (out_dir / "truth.json").write_text(json.dumps(truth, indent=2) + "\n")
        rep.out.print(f"Wrote {len(recs)} records and truth.json to {out_dir}/")

@click.command("demo")
@click.option("--out", "out_dir", type=click.Path(file_okay=False, path_type=Path), default=Path("hpctl-demo"), show_default=True)
@click.option("--quiet", "-q", is_flag=True)
@click.option("--json", "as_json", is_flag=True)
def demo_cmd(out_dir: Path, quiet: bool, as_json: bool) -> None:
    """The whole story on bundled rig data: start from the classical
    polytropic ideal-gas model, find heat transfer, then real gas, then
    whatever else is hidden, and print the errors before and after."""
    rep = Reporter(quiet, as_json)
    with errors(rep):
        recs = [read_record(p) for p in sorted(DEMO_DIR.glob("*.toml"))]
        rep.err.print(f"{len(recs)} bundled records from a rig unit with undeclared effects; declared model: classical polytropic ideal gas")
        rep.err.print("(each step fits the model with the Rust simulator in the loop; about 15 s in all)")
        _run_diagnosis(rep, recs, (), 6, out_dir, as_json)


def _parse_sets(sets: tuple[str, ...]) -> dict[str, float]:
    known = {p.name for e in LIBRARY.values() for p in e.params}
    out = {}
    for s in sets:
        name, sep, value = s.partition("=")
        if not sep or name not in known:
            raise ParameterError(f"--set {s!r}: expected PARAM=VALUE with PARAM one of {', '.join(sorted(known))}")
        try:
            out[name] = float(value)
        except ValueError:
            raise ParameterError(f"--set {s!r}: {value!r} is not a number") from None
    return out


def _run_diagnosis(rep: Reporter, recs: list[RigRecord], start: tuple[str, ...], max_rounds: int, out_dir: Path, as_json: bool) -> None:

    with status(rep, "diagnosing") as spinner:
        diag = diagnose.diagnose(recs, start, max_rounds=max_rounds, progress=spinner.update)
    path = report.diagnosis_report(diag, out_dir)
    summary = diagnose.summary(diag)
    (out_dir / "diagnosis.json").write_text(json.dumps(jsonable(summary), indent=2) + "\n")
    if as_json:
        click.echo(json.dumps(jsonable(summary), indent=2))
        return
    t = Table(title=f"Diagnosis: {diag.verdict.replace('_', ' ')}")
    for col in ("step", "model", "RMS / noise", "BIC", "added", "BIC gain", "parameters"):
        t.add_column(col, justify="right")
    for k, rnd in enumerate(diag.rounds):
        c = rnd.accepted
        params = "" if c is None else ", ".join(f"{p.name}={c.result.values[p.name]:.4g}" for e in c.effects for p in LIBRARY[e].params)
        t.add_row(str(k), ", ".join(rnd.before.model.effects) or "classical", f"{rnd.before.rms_ratio:.3g}", f"{rnd.before.bic:.0f}",
                  "-" if c is None else c.effect, "-" if c is None else f"{c.delta_bic:.0f}", params)
    t.add_row("final", ", ".join(diag.final.model.effects) or "classical", f"{diag.final.rms_ratio:.3g}", f"{diag.final.bic:.0f}", "", "", "")
    rep.out.print(t)
    rep.out.print(f"Report: {path}")


COMMANDS = (fit_cmd, diagnose_cmd, rig_cmd, demo_cmd)

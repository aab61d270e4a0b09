"""``hpctl evaluate`` and ``hpctl tune``: the whole vehicle, passive against
semi-active, and the controller's thresholds tuned over routes."""

from __future__ import annotations

import json
import math
import sys
from pathlib import Path
from typing import Any

import click
from rich.text import Text

from hpctl.cli._ui import Reporter, errors, force_option, jsonable, output_dir, provenance, table

#: Some cases failed (their results are missing; the others were written).
EXIT_CASES_FAILED = 3


def _warn(rep: Reporter, warnings: list[str]) -> None:
    # Text, never markup (a message is data), no hard wrap.
    for w in warnings:
        rep.errors.print(Text.assemble(("warning: ", "yellow"), w), soft_wrap=True, highlight=False)


@click.command("evaluate")
@click.option("--vehicle", "vehicles", multiple=True, type=click.Choice(["4x4", "8x8"]), help="Built-in vehicle (repeat for several; default: both).")
@click.option("--route", "route_name", type=click.Choice(["mixed"]), default="mixed", show_default=True, help="The route.")
@click.option("--seed", type=int, default=1, show_default=True, help="Road seed (same seed, same roads).")
@click.option("--scale", type=float, default=1.0, show_default=True, help="Shorten the route's segments by this factor (0-1], for quick looks.")
@click.option("--setting", "settings", multiple=True, type=click.Choice(["soft-low", "soft-high", "hard-low", "hard-high", "semi-active"]), help="Suspension setting (repeat; default: all five).")
@click.option("--config", "config_file", type=click.Path(exists=True, dir_okay=False, path_type=Path),
              help="Controller configuration for the semi-active runs: TOML (all or some values, merged over each vehicle's default) or tuned.json from hpctl tune.")
@click.option("--records", type=click.Choice(["semi-active", "all", "none"]), default="semi-active", show_default=True, help="Write rig records (one per wheel, 100 Hz) of these runs.")
@click.option("--threads", type=int, default=None, help="Parallel runs (default: all cores).")
@click.option("--out", "out_dir", type=click.Path(file_okay=False, path_type=Path), default=Path("hpctl-out/evaluate"), show_default=True, help="Output folder.")
@force_option
@click.option("--quiet", "-q", is_flag=True, help="No tables.")
@click.option("--json", "as_json", is_flag=True, help="Print the results as JSON on stdout.")
def evaluate(vehicles: tuple[str, ...], route_name: str, seed: int, scale: float, settings: tuple[str, ...], config_file: Path | None,
             records: str, threads: int | None, out_dir: Path, force: bool, quiet: bool, as_json: bool) -> None:
    """Drive the vehicles along the mixed route (smooth start, highway,
    double lane change, rough track, obstacles) with the four passive
    settings and the semi-active controller (one per wheel), and compare
    ride (ISO 2631-1 at the seat) and handling (roll, tyre loads). Writes
    comparison.md, comparison.json, ride_handling.png, lane_change_*.png and
    rig records. Warnings (end stops, lift-off, safe states, failed cases)
    go to stderr and into the JSON; exit 3 if a case failed."""
    rep = Reporter(quiet, as_json)
    with errors(rep):
        from hpctl.data.records import write_record
        from hpctl.errors import ParameterError
        from hpctl.report.vehicle import comparison_rows, lane_change_plot, markdown_table, ride_handling_plot
        from hpctl.vehicle import comparison
        from hpctl.vehicle.model import preset
        from hpctl.vehicle.route import mixed

        if threads is not None and threads < 1:
            raise ParameterError(f"threads = {threads} must be at least 1")
        names = {"soft-low": comparison.PASSIVE[0], "soft-high": comparison.PASSIVE[1], "hard-low": comparison.PASSIVE[2], "hard-high": comparison.PASSIVE[3], "semi-active": comparison.SEMI_ACTIVE}
        chosen = [names[s] for s in settings] if settings else list(comparison.SETTINGS)
        specs = [preset(v) for v in (vehicles or ("4x4", "8x8"))]
        if config_file is not None:
            config = _read_config(config_file, specs)
            chosen = [comparison.Setting(s.name, semi_active=True, config=config) if s.semi_active else s for s in chosen]
        spec = mixed(seed=seed, scale=scale)
        plots = ["ride_handling.png", *(f"lane_change_{s.name}.png" for s in specs)]
        # The folder is locked and checked before the drives (minutes), and
        # everything is staged and moved into place at the end: an
        # interrupted or failed run leaves the previous results whole.
        with output_dir(out_dir, "evaluate", force=force, protect=("comparison.md", "comparison.json", *plots)) as out:
            with rep.err.status("driving") if not quiet else _null():
                result = comparison.evaluate(specs, spec, chosen, threads=threads)
            rows = comparison_rows(result)
            from hpctl.data.output import provenance_line

            out.write_text("comparison.md", provenance_line(provenance()) + "\n\n" + markdown_table(rows))
            plots = ["ride_handling.png"]
            ride_handling_plot(result, out.path(plots[0]))
            for name, rs in result.by_vehicle().items():
                plots.append(f"lane_change_{name}.png")
                lane_change_plot(rs, out.path(plots[-1]))
            written = []
            if records != "none":
                for r in result.results:
                    if records == "all" or r.case.setting.semi_active:
                        for stem, rec in comparison.wheel_records(r):
                            write_record(rec, out.path(f"records/{stem}"))
                            written.append(stem)
            summary = {
                "hpctl": provenance(),
                "route": {"name": spec.name, "seed": seed, "scale": scale, "sections": [s.__dict__ for s in result.results[0].route.sections] if result.results and result.results[0].route else []},
                "cases": [_case_json(r) for r in result.results],
                "table": rows,
                "warnings": result.warnings,
                "failed": [r.case.label for r in result.failed],
                "plots": plots,
                "records": written,
            }
            out.write_text("comparison.json", json.dumps(jsonable(summary), indent=2) + "\n")
        _warn(rep, result.warnings)
        if as_json:
            click.echo(json.dumps(jsonable(summary), indent=2))
        else:
            keys = ["vehicle", "setting", "rough a_v [m/s²]", "lane change roll [deg]", "tyre load DLC, lane change", "tyre load DLC, rough", "travel used, rough [%]", "end-stop hits", "lift-off [s]"]
            t = table("Ride versus handling on the mixed route", keys)
            for row in rows:
                t.add_row(*(row.get(k, "") for k in keys))
            rep.out.print(t)
            rep.say(("Wrote", "bold"), f" comparison.md, comparison.json, {', '.join(plots)} and {len(written)} records to {out_dir}/")
        if result.failed:
            sys.exit(EXIT_CASES_FAILED)


class _null:
    def __enter__(self) -> None:
        return None

    def __exit__(self, *exc: object) -> None:
        return None


def _read_config(path: Path, vehicles: list[Any]) -> dict[str, Any]:
    """The values of a configuration file, checked over each vehicle's
    default (an unknown key or a value out of range names itself)."""
    from hpctl.control import config

    for v in vehicles:
        config.read_config(path, v.controller_config())
    return config.read_changes(path)


def _case_json(r: Any) -> dict[str, Any]:
    return {
        "vehicle": r.case.vehicle.name,
        "setting": r.case.setting.name,
        "error": r.error,
        "warnings": r.warnings,
        "sections": [
            {"name": s.name, "kind": s.kind, "duration_s": s.duration_s, "ride": s.ride.__dict__, "handling": s.handling.__dict__,
             "wheels": {**s.wheels.__dict__, "end_stop_wheels": list(s.wheels.end_stop_wheels), "lifted_wheels": list(s.wheels.lifted_wheels)},
             "safe_state_s": s.safe_state_s}
            for s in r.sections
        ],
    }


@click.command("tune")
@click.option("--vehicle", "vehicles", multiple=True, type=click.Choice(["4x4", "8x8"]), help="Built-in vehicle (repeat; default: 4x4).")
@click.option("--seeds", default="1,2", show_default=True, help="Road seeds of the route set (comma-separated): one mixed route per seed.")
@click.option("--scale", type=float, default=0.5, show_default=True, help="Route segment scale (0-1].")
@click.option("--popsize", type=int, default=2, show_default=True, help="Differential evolution: population per parameter.")
@click.option("--maxiter", type=int, default=4, show_default=True, help="Differential evolution: generations.")
@click.option("--seed", type=int, default=1, show_default=True, help="Optimiser seed.")
@click.option("--threads", type=int, default=None, help="Local parallel evaluations (default: all cores).")
@click.option("--config", "config_file", type=click.Path(exists=True, dir_okay=False, path_type=Path),
              help="Controller configuration to start from (TOML: all or some values, merged over each vehicle's default; or tuned.json).")
@click.option("--cluster", default=None, help="A Dask scheduler (tcp://HOST:PORT) to evaluate on instead of this machine.")
@click.option("--out", "out_dir", type=click.Path(file_okay=False, path_type=Path), default=Path("hpctl-out/tune"), show_default=True, help="Output folder.")
@force_option
@click.option("--quiet", "-q", is_flag=True, help="No tables.")
@click.option("--json", "as_json", is_flag=True, help="Print the result as JSON on stdout.")
def tune(vehicles: tuple[str, ...], seeds: str, scale: float, popsize: int, maxiter: int, seed: int, threads: int | None, config_file: Path | None, cluster: str | None,
         out_dir: Path, force: bool, quiet: bool, as_json: bool) -> None:
    """Tune the semi-active controller's thresholds (handling triggers,
    hold, skyhook estimator and switching) over a set of routes with
    differential evolution, locally or on a Dask cluster. Objective:
    comfort on the rough track relative to soft passive plus roll in the
    lane change relative to hard passive (2 = both goals met). Writes
    tuned.json (the configuration, for hpctl evaluate --config),
    tuning.json and tuning.png."""
    rep = Reporter(quiet, as_json)
    with errors(rep):
        from hpctl.cli._ui import parse_floats
        from hpctl.errors import ParameterError
        from hpctl.report.vehicle import tuning_plot
        from hpctl.vehicle import tuning
        from hpctl.vehicle.route import mixed

        seed_list = [int(s) for s in (parse_floats(seeds, "--seeds") or [])]
        if not seed_list:
            raise ParameterError("--seeds must name at least one road seed")
        if popsize < 1 or maxiter < 1:
            raise ParameterError(f"popsize = {popsize} and maxiter = {maxiter} must be at least 1")
        routes = tuple(mixed(seed=s, scale=scale) for s in seed_list)
        names = tuple(vehicles or ("4x4",))
        from hpctl.vehicle.model import preset

        start = None if config_file is None else _read_config(config_file, [preset(v) for v in names])
        with output_dir(out_dir, "tune", force=force, protect=("tuned.json", "tuning.json", "tuning.png")) as out:
            executor: tuning.Executor = tuning.DaskExecutor(cluster) if cluster else tuning.LocalExecutor(threads)
            try:
                with rep.err.status("passive references") if not quiet else _null():
                    refs = tuning.references(names, routes, threads=threads)
                problem = tuning.Problem(names, routes, references=refs, config=start)
                result = tuning.tune(problem, executor, popsize=popsize, maxiter=maxiter, seed=seed,
                                     on_generation=lambda g, f: rep.err.print(f"generation {g}: best J = {f:.4f}"))
            finally:
                executor.close()
            out.write_text("tuned.json", json.dumps({"config": result.config}, indent=2) + "\n")
            tuning_plot(result, out.path("tuning.png"))
            warnings: list[str] = []
            if result.best.end_stop_hits:
                warnings.append(f"{result.best.end_stop_hits} end-stop hit(s) with the tuned configuration")
            if result.best.failures:
                warnings.append(f"{result.best.failures} case(s) failed with the tuned configuration")
            summary = {
                "hpctl": provenance(),
                "vehicles": list(names),
                "seeds": seed_list,
                "scale": scale,
                "executor": f"dask {cluster}" if cluster else f"local, {getattr(executor, 'threads', 1)} threads",
                "default": result.default.__dict__,
                "best": result.best.__dict__,
                "improvement": result.default.j - result.best.j,
                "changes": [{"parameter": n, "default": a, "tuned": b} for n, a, b in result.changes()],
                "generations": result.generations,
                "evaluations": result.evaluations,
                "history": list(result.history),
                "warnings": warnings,
            }
            out.write_text("tuning.json", json.dumps(jsonable(summary), indent=2) + "\n")
        _warn(rep, warnings)
        if as_json:
            click.echo(json.dumps(jsonable(summary), indent=2))
        else:
            t = table(f"Tuned over {len(routes)} route(s) x {len(names)} vehicle(s): J {result.default.j:.4f} -> {result.best.j:.4f}", ("parameter", "default", "tuned"))
            for n, a, b in result.changes():
                t.add_row(n, f"{a:.4g}", f"{b:.4g}")
            rep.out.print(t)
            rep.out.print(f"comfort ratio {result.default.comfort_ratio:.3f} -> {result.best.comfort_ratio:.3f}, "
                          f"roll ratio {result.default.roll_ratio:.3f} -> {result.best.roll_ratio:.3f} (1 = the passive reference)")
            rep.say(("Wrote", "bold"), f" tuned.json, tuning.json, tuning.png to {out_dir}/")
        if not math.isfinite(result.best.j):
            sys.exit(EXIT_CASES_FAILED)


COMMANDS = (evaluate, tune)

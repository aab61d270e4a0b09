"""``hpctl closed-loop``: the controller on the plant over a random road."""

from __future__ import annotations

import json
from pathlib import Path
from typing import TYPE_CHECKING

import click

from hpctl.cli._ui import FINITE, Reporter, errors, finish, fmt, force_option, format_option, load_unit, output_dir, strict_option, table, with_warnings

if TYPE_CHECKING:
    from hpctl.control.closed_loop import DemoSummary


@click.command("closed-loop")
@click.option("--unit", "unit_file", type=click.Path(exists=True, dir_okay=False, path_type=Path), help="Unit description (TOML, [unit] table); default: the built-in seed unit.")
@click.option("--config", "config_file", type=click.Path(exists=True, dir_okay=False, path_type=Path),
              help="Controller configuration (TOML: all or some values, merged over the one derived from the unit; or tuned.json); default: derived from the unit.")
@click.option("--road-class", type=click.Choice(list("ABCDEFGH"), case_sensitive=False), default="C", show_default=True, help="ISO 8608 road class.")
@click.option("--speed-m-s", type=FINITE, default=10.0, show_default=True, help="Vehicle speed, m/s.")
@click.option("--lower-m", type=FINITE, default=0.03, show_default=True, help="How far to lower the ride height (then raise it back), m.")
@click.option("--seed", type=click.IntRange(0, 2**63 - 1), default=1, show_default=True, help="Road seed (same seed, same road).")
@click.option("--out", "out_dir", type=click.Path(file_okay=False, path_type=Path), default=Path("hpctl-out/closed-loop"), show_default=True, help="Output folder.")
@format_option
@force_option
@strict_option
@click.option("--quiet", "-q", is_flag=True, help="No tables.")
@click.option("--json", "as_json", is_flag=True, help="Print the summary as JSON on stdout.")
def closed_loop_cmd(unit_file: Path | None, config_file: Path | None, road_class: str, speed_m_s: float, lower_m: float, seed: int, out_dir: Path, fig_format: str, force: bool, strict: bool,
                    quiet: bool, as_json: bool) -> None:
    """Run the controller in closed loop with the unit (3000 kg SDOF) over a
    random road: lower the ride height without a pump and raise it back,
    then switch modes on a lane change and a braking burst. The controller
    is configured for the unit (--unit). Writes plots (PNG, SVG or PDF) and summary.json
    into the output folder; what did not go as requested (a blocked
    sequencer, a missed target, end stops, the gas model's range, the safe
    state) is printed as a warning and listed under "warnings"."""
    rep = Reporter(quiet, as_json)
    with errors(rep):
        from hpctl.control import closed_loop
        from hpctl.control.config import read_config
        from hpctl.report.closed_loop import plot_height_change, plot_modes

        unit = load_unit(unit_file, None, None)
        config = None if config_file is None else read_config(config_file, closed_loop.config_for_unit(unit))
        plots = [f"ride_height.{fig_format}", f"modes.{fig_format}"]
        with output_dir(out_dir, "closed-loop", force=force, protect=("summary.json", *plots)) as out:
            height, modes, demo = closed_loop.demo(road_class=road_class, speed_m_s=speed_m_s, lower_m=lower_m, seed=seed, unit=unit, config=config)
            caveats = closed_loop.demo_caveats(height, modes, demo)
            where = f"ISO 8608 class {road_class.upper()} road at {speed_m_s:g} m/s, seed {seed}"
            plot_height_change(height, out.path(plots[0]), _height_title(demo, lower_m, where))
            plot_modes(modes, out.path(plots[1]), f"Mode switching: lane change at 8 s, braking at 18 s ({where})")
            summary = {
                **demo.to_dict(),
                "plots": plots,
                "config": closed_loop.config_for_unit(unit) if config is None else config,
                "config_source": "derived from the unit" if config_file is None else str(config_file),
            }
            document = with_warnings(summary, caveats)
            out.write_json("summary.json", document)
        if as_json:
            click.echo(json.dumps(document, indent=2))
        else:
            t = table(f"Pump-free ride height (class {demo.road_class}, {speed_m_s:g} m/s), mm",
                      ("change", "target", "held at rest", "estimate", "on the road", "time [s]", "valve-6 openings"))
            changes = (("lowering", demo.lowering), ("raising", demo.raising))
            for name, s in changes:
                t.add_row(name, fmt(s.target_m, 1e3, 1), fmt(s.held_offset_m, 1e3, 1), fmt(s.estimate_m, 1e3, 1),
                          fmt(s.road_mean_change_m, 1e3, 1), fmt(s.time_to_reach_s), str(s.valve6_openings))
            rep.out.print(t)
            t = table("Pressures when done, MPa", ("change", "p_S", "p_L", "target p_L", "load (estimate)", "load (true)"))
            for name, s in changes:
                t.add_row(name, *(fmt(v, 1e-6, 2) for v in (s.p_gas_pa, s.p_gas2_pa, s.p_gas2_target_pa, s.p_load_estimate_pa, s.p_load_true_pa)))
            rep.out.print(t)
            m = demo.modes
            rep.out.print(f"Handling entered at {', '.join(f'{x:.2f}' for x in m.handling_entered_s) or '-'} s, Ride again at "
                          f"{', '.join(f'{x:.2f}' for x in m.ride_returned_s) or '-'} s; triggers: {', '.join(m.triggers) or '-'}")
            rep.say(("Wrote", "bold"), f" plots and summary.json to {out_dir}/")
        finish(rep, caveats, strict)


def _height_title(demo: DemoSummary, lower_m: float, where: str) -> str:
    """The ride-height plot's title says what happened, not what was asked."""
    low, back = demo.lowering, demo.raising
    if low.reached and back.reached:
        return f"Pump-free lowering by {1e3 * lower_m:g} mm and back ({where})"
    said = "reached" if low.reached else "NOT reached"
    said_back = "reached" if back.reached else "NOT reached"
    return f"Pump-free lowering by {1e3 * lower_m:g} mm requested: {said}; back to 0: {said_back} ({where})"


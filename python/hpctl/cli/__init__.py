"""The ``hpctl`` command line: one module per command group, sharing
:mod:`hpctl.cli._ui`.

Exit codes: 0 ok, 2 bad input (usage errors, invalid parameters, malformed
records), 1 internal error.
"""

from __future__ import annotations

import click

from hpctl._version import __version__
from hpctl.cli import calibrate, can, closed_loop, convert, simulate, vehicle
from hpctl.cli._ui import ARGS_KEY


class _Root(click.Group):
    """The root command; it keeps the arguments it was given, for the
    provenance of every output (:func:`hpctl.cli._ui.invocation`)."""

    def parse_args(self, ctx: click.Context, args: list[str]) -> list[str]:
        ctx.meta[ARGS_KEY] = list(args)
        return super().parse_args(ctx, args)


# Start-up: the command modules import only what their options need; NumPy
# and the Rust core are loaded with the package, SciPy and matplotlib only
# by the commands that compute or draw (scripts/bench_startup.py measures).
@click.group(cls=_Root, context_settings={"help_option_names": ["-h", "--help"]})
@click.version_option(__version__, package_name="hpctl")
def main() -> None:
    """Simulate, calibrate and control a semi-active hydro-pneumatic
    spring-damper unit. All quantities are SI."""



main.add_command(simulate.simulate)
main.add_command(closed_loop.closed_loop_cmd)
main.add_command(convert.convert_cmd)
for command in calibrate.COMMANDS + vehicle.COMMANDS + can.COMMANDS:
    main.add_command(command)

if __name__ == "__main__":  # pragma: no cover
    main()

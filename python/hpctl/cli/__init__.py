"""The ``hpctl`` command line: one module per command group, sharing
:mod:`hpctl.cli._ui`.

Exit codes: 0 ok, 2 bad input (usage errors, invalid parameters, malformed
records), 1 internal error.
"""

from __future__ import annotations

import click

from hpctl.cli import calibrate, closed_loop, simulate, vehicle


@click.group(context_settings={"help_option_names": ["-h", "--help"]})
@click.version_option(package_name="hpctl")
def main() -> None:
    """Simulate, calibrate and control a semi-active hydro-pneumatic
    spring-damper unit. All quantities are SI."""



main.add_command(simulate.simulate)
main.add_command(closed_loop.closed_loop_cmd)
for command in calibrate.COMMANDS + vehicle.COMMANDS:
    main.add_command(command)

if __name__ == "__main__":  # pragma: no cover
    main()

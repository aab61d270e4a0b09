"""``python -m hpctl``: the command line."""

from hpctl.cli import main

main()

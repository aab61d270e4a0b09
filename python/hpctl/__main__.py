"""``python -m hpctl``: the command line."""

from hpctl.cli import main

# Guarded: a worker process the diagnosis starts (spawn) imports the main
# module, as __mp_main__; it must not run the command again.
if __name__ == "__main__":
    main()

"""hpctl's version, in one place: the package's ``__version__``, ``hpctl
--version`` and the provenance of every output read it (a test keeps it
equal to the installed distribution's, from ``pyproject.toml``)."""

__version__ = "0.1.0"

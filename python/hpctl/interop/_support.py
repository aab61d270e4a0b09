"""What every format module shares: optional imports that say which extra
to install, and writes that land whole or not at all."""

from __future__ import annotations

import importlib
import os
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from types import ModuleType

from hpctl.errors import MissingDependencyError

#: Distribution name of each optional module (for the error message).
_DISTRIBUTIONS = {
    "asammdf": "asammdf",
    "nptdms": "npTDMS",
    "pyarrow": "pyarrow",
    "pyarrow.parquet": "pyarrow",
    "pandas": "pandas",
    "pint": "pint",
    "cantools": "cantools",
    "can": "python-can",
    "scipy.io": "scipy",
}


def require(module: str, purpose: str) -> ModuleType:
    """Imports an optional dependency, or raises
    :class:`~hpctl.errors.MissingDependencyError` naming the extra."""
    try:
        return importlib.import_module(module)
    except ImportError as e:
        dist = _DISTRIBUTIONS.get(module, module)
        raise MissingDependencyError(
            f"{purpose} needs {dist}, which is not installed ({e}): pip install 'hpctl[interop]' (or pip install {dist})"
        ) from None


@contextmanager
def atomic_path(path: Path) -> Iterator[Path]:
    """A temporary name beside ``path`` (same suffix, so libraries that
    append one do not) to write to; renamed onto ``path`` when the block
    succeeds, removed when it fails: a reader never sees half a file and a
    failed write never destroys the old one.

    (Written here because the project's atomic output writer was not on
    main yet when this module was; see docs/interop.md.)"""
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(f".{path.stem}.{os.getpid()}.tmp{path.suffix}")
    try:
        yield tmp
        os.replace(tmp, path)
    finally:
        if tmp.exists():
            tmp.unlink()

"""What every format module shares: optional imports that say which extra
to install, and writes that land whole or not at all."""

from __future__ import annotations

import importlib
import os
import threading
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from types import ModuleType

from hpctl.data.output import replace_in_order
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

    The format libraries write the file themselves (given a path), so
    :func:`hpctl.data.output.atomic_write_bytes`, which takes bytes, does
    not fit; this is its counterpart for them, for the Python API. The
    command line writes into an :class:`~hpctl.data.output.OutputDir`'s
    staging folder on top of it (manifest, lock, no silent overwrite)."""
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(f".{path.stem}.{os.getpid()}.{threading.get_ident()}.tmp{path.suffix}")
    try:
        yield tmp
        with tmp.open("rb") as f:  # on disk before the rename makes it the file
            os.fsync(f.fileno())
        replace_in_order([(tmp, path)])
    finally:
        tmp.unlink(missing_ok=True)

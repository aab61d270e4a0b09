"""An executor that runs what it is given at once, in the caller's thread:
work that hpctl runs side by side (a profile interval's two sides,
:func:`hpctl.identify.profile.profile_interval`) done one after the other,
for comparing the two (tests/test_profile.py, scripts/bench_profile.py)."""

from __future__ import annotations

from collections.abc import Callable
from concurrent.futures import Future
from typing import Any


class InTurn:
    """Takes the arguments of ``ThreadPoolExecutor`` and ignores them;
    ``submit`` runs the call before it returns."""

    def __init__(self, **_: Any) -> None:
        pass

    def __enter__(self) -> InTurn:
        return self

    def __exit__(self, *_: object) -> None:
        pass

    def submit(self, fn: Callable[..., Any], *args: Any) -> Future[Any]:
        f: Future[Any] = Future()
        f.set_result(fn(*args))
        return f

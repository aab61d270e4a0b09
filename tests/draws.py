"""The seeds of randomised tests, where CI time went: a test that takes a
``seed`` fixture (a new draw each run, replayed through the environment
variable its fixture reads, FOREIGN_RIG_SEED or HPCTL_TEST_SEED) keeps the
seed on its report, and the run's summary lists the draws that took
longest, each with the command that replays it.

Why: the slowest test of a CI run (a foreign-rig leak diagnosis, 32-200 s
a draw; of eleven draws measured since, ten took 34-73 s and one 279 s)
once took 1,974 s, and which draw it was could not be told afterwards
(stop 56). ``conftest.py`` registers
this module as a plugin; ``test_draws.py`` checks it.
"""

from __future__ import annotations

import inspect
import os
import re
from collections.abc import Generator

import pytest

#: Draws that took at least this long are listed (seconds; the environment
#: variable HPCTL_SLOW_DRAW_S sets another; a value that is not a number
#: leaves this one).
SLOW_DRAW_S = 120.0

_READS = re.compile(r"environ\.get\(\s*[\"']([A-Z0-9_]+)[\"']")


def slow_draw_s() -> float:
    try:
        return float(os.environ.get("HPCTL_SLOW_DRAW_S", SLOW_DRAW_S))
    except ValueError:
        return SLOW_DRAW_S


def replay_variable(item: pytest.Item) -> str:
    """The environment variable the item's ``seed`` fixture reads (from its
    source), or "" where it cannot be told."""
    info = getattr(item, "_fixtureinfo", None)
    defs = info.name2fixturedefs.get("seed") if info is not None else None
    if not defs:
        return ""
    try:
        found = _READS.search(inspect.getsource(defs[-1].func))
    except (OSError, TypeError):
        return ""
    return found.group(1) if found else ""


@pytest.hookimpl(hookwrapper=True)
def pytest_runtest_makereport(item: pytest.Item, call: pytest.CallInfo[None]) -> Generator[None, object, None]:
    outcome = yield
    report = outcome.get_result()  # type: ignore[attr-defined]
    seed = getattr(item, "funcargs", {}).get("seed")
    if report.when == "call" and isinstance(seed, int):
        # user_properties travel with the report (pytest-xdist's workers too).
        report.user_properties.append(("seed", seed))
        report.user_properties.append(("seed_variable", replay_variable(item)))


def pytest_terminal_summary(terminalreporter: pytest.TerminalReporter) -> None:
    least = slow_draw_s()
    rows = []
    for key in ("passed", "failed"):
        for report in terminalreporter.stats.get(key, []):
            props = dict(getattr(report, "user_properties", ()))
            if getattr(report, "when", "") == "call" and "seed" in props and report.duration >= least:
                rows.append((report.duration, report.nodeid, props["seed"], props.get("seed_variable", "")))
    if not rows:
        return
    terminalreporter.write_sep("=", f"randomised draws that took {least:g} s or longer (to replay one)")
    for duration, nodeid, seed, variable in sorted(rows, reverse=True):
        setting = f"{variable}={seed}" if variable else f"seed {seed}"
        terminalreporter.write_line(f"{duration:8.1f} s  {setting} python -m pytest '{nodeid}'")

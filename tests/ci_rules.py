"""A test that cannot run fails in CI; elsewhere it is skipped with its reason.

CI is recognised by the environment variable ``CI`` (CI services set it;
``.ci/run`` sets it if the machine does not), unless it is empty or one of
``0``, ``false``, ``no``. Under CI every skip (``pytest.skip``,
``pytest.importorskip``, skip marks, a fixture that skips, a module skipped
at collection) is reported as a failure that gives the skip's reason: a
skipped test in CI is a hidden failure. Expected failures (``xfail``) are
left alone. ``scripts/test.sh`` applies the same rule (same definition of
CI) to the firmware cross-build.

``conftest.py`` installs the two hooks below; ``test_ci_rules.py`` checks
them.
"""

from __future__ import annotations

import os
from collections.abc import Generator, Mapping

import pytest

NOT_CI = ("", "0", "false", "no")


def in_ci(environ: Mapping[str, str] = os.environ) -> bool:
    """True when running in CI (``CI`` set to anything but empty/0/false/no)."""
    return environ.get("CI", "").strip().lower() not in NOT_CI


def _reason(longrepr: object) -> str:
    # A skip's longrepr is (path, line, "Skipped: reason").
    if isinstance(longrepr, tuple) and len(longrepr) == 3:
        return str(longrepr[2]).removeprefix("Skipped: ")
    return str(longrepr)


def _fail_skip(report: pytest.TestReport | pytest.CollectReport) -> None:
    if report.skipped and not hasattr(report, "wasxfail") and in_ci():
        report.outcome = "failed"
        report.longrepr = (
            f"would be skipped, but CI={os.environ.get('CI')!r}: a test that cannot run in CI fails "
            f"(tests/ci_rules.py). Reason: {_reason(report.longrepr)}"
        )


@pytest.hookimpl(hookwrapper=True)
def pytest_runtest_makereport(item: pytest.Item, call: pytest.CallInfo[None]) -> Generator[None, object, None]:
    outcome = yield
    _fail_skip(outcome.get_result())  # type: ignore[attr-defined]


@pytest.hookimpl(hookwrapper=True)
def pytest_make_collect_report(collector: pytest.Collector) -> Generator[None, object, None]:
    outcome = yield
    _fail_skip(outcome.get_result())  # type: ignore[attr-defined]

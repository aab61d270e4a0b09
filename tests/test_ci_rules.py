"""The CI rule (ci_rules.py): under CI a test that cannot run fails with
its reason; on a developer machine it is skipped with that reason. Runs
small test files in a separate pytest session (pytester) with and without
the environment variable CI."""

from __future__ import annotations

from pathlib import Path

import pytest

from ci_rules import in_ci

pytest_plugins = ["pytester"]

TESTS = Path(__file__).resolve().parent

CANNOT_RUN = """
import pytest

@pytest.fixture(scope="session")
def tool():
    pytest.skip("frobnicator not installed")

def test_needs_a_tool(tool):
    pass

def test_skips_itself():
    pytest.skip("no widget here")

def test_needs_a_module():
    pytest.importorskip("no_such_module_hpctl_test")

@pytest.mark.skip(reason="marked")
def test_marked():
    pass

@pytest.mark.xfail(reason="known", strict=True)
def test_expected_failure():
    assert False

def test_runs():
    pass
"""


@pytest.mark.parametrize(
    ("value", "expect"),
    [(None, False), ("", False), ("0", False), ("false", False), ("False", False), ("no", False),
     ("true", True), ("1", True), ("yes", True), ("github-actions", True)],
)  # fmt: skip
def test_what_counts_as_ci(value: str | None, expect: bool) -> None:
    assert in_ci({} if value is None else {"CI": value}) is expect


SKIPPED_MODULE = """
import pytest

pytest.importorskip("no_such_module_hpctl_test")

def test_never_collected():
    pass
"""

REASONS = ("frobnicator not installed", "no widget here", "no_such_module_hpctl_test", "marked")


@pytest.fixture
def run(pytester: pytest.Pytester, monkeypatch: pytest.MonkeyPatch):
    """Runs pytest on the given test files with CI set to a value (None:
    unset), with the hooks of conftest.py."""
    pytester.syspathinsert(TESTS)
    pytester.makeconftest("from ci_rules import pytest_make_collect_report, pytest_runtest_makereport  # noqa: F401\n")

    def go(ci: str | None, **files: str) -> pytest.RunResult:
        pytester.makepyfile(**files)
        if ci is None:
            monkeypatch.delenv("CI", raising=False)
        else:
            monkeypatch.setenv("CI", ci)
        return pytester.runpytest("-rA", "-p", "no:cacheprovider")

    return go


@pytest.mark.parametrize("ci", [None, "false", "0"])
def test_a_developer_machine_skips_with_the_reason(run, ci: str | None) -> None:
    result = run(ci, test_cannot_run=CANNOT_RUN, test_skipped_module=SKIPPED_MODULE)
    result.assert_outcomes(passed=1, skipped=5, xfailed=1)
    for reason in REASONS:
        result.stdout.fnmatch_lines([f"SKIPPED*{reason}*"])
    assert result.ret == 0


def test_ci_fails_every_test_that_cannot_run_with_the_reason(run) -> None:
    result = run("true", test_cannot_run=CANNOT_RUN)
    # A skip in setup (a fixture's, a skip mark's) becomes an error, one in
    # the test a failure; the expected failure and the test that runs stay.
    result.assert_outcomes(passed=1, failed=2, errors=2, xfailed=1)
    for reason in REASONS:
        result.stdout.fnmatch_lines([f"*CI='true'*Reason:*{reason}*"])
    assert result.ret == 1


def test_ci_fails_a_module_skipped_at_collection(run) -> None:
    result = run("1", test_skipped_module=SKIPPED_MODULE)
    result.assert_outcomes(errors=1)
    result.stdout.fnmatch_lines(["*ERROR collecting test_skipped_module.py*", "*CI='1'*no_such_module_hpctl_test*"])
    assert result.ret != 0

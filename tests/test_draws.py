"""draws.py: a randomised test's seed is kept on its report and the slowest
draws are listed with the command that replays them. Runs a small test
file in a separate pytest session (pytester)."""

from __future__ import annotations

from pathlib import Path

import pytest

pytest_plugins = ["pytester"]

TESTS = Path(__file__).resolve().parent

DRAWN = """
import os
import secrets

import pytest


@pytest.fixture
def seed() -> int:
    return int(os.environ.get("DEMO_DRAW_SEED", secrets.randbelow(2**31)))


def test_a_draw(seed):
    assert seed >= 0


def test_a_failing_draw(seed):
    assert seed < 0


def test_without_a_draw():
    pass
"""


def _run(pytester: pytest.Pytester, monkeypatch: pytest.MonkeyPatch, slow_s: str) -> pytest.RunResult:
    pytester.syspathinsert(TESTS)
    pytester.makeconftest("import draws\n\ndef pytest_configure(config):\n    config.pluginmanager.register(draws, 'hpctl-draws')\n")
    pytester.makepyfile(test_drawn=DRAWN)
    monkeypatch.setenv("DEMO_DRAW_SEED", "123456789")
    monkeypatch.setenv("HPCTL_SLOW_DRAW_S", slow_s)
    return pytester.runpytest("-p", "no:cacheprovider")


def test_the_slowest_draws_are_listed_with_how_to_replay_them(pytester: pytest.Pytester, monkeypatch: pytest.MonkeyPatch) -> None:
    result = _run(pytester, monkeypatch, "0")
    result.assert_outcomes(passed=2, failed=1)
    result.stdout.fnmatch_lines([
        "*randomised draws that took 0 s or longer*",
        "* s  DEMO_DRAW_SEED=123456789 python -m pytest 'test_drawn.py::test_a_*draw'",
        "* s  DEMO_DRAW_SEED=123456789 python -m pytest 'test_drawn.py::test_a_*draw'",
    ])  # fmt: skip
    # A test without a seed is not a draw.
    assert "test_without_a_draw'" not in result.stdout.str()


def test_fast_draws_are_not_listed(pytester: pytest.Pytester, monkeypatch: pytest.MonkeyPatch) -> None:
    result = _run(pytester, monkeypatch, "120")
    result.assert_outcomes(passed=2, failed=1)
    assert "randomised draws" not in result.stdout.str()

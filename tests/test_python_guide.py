"""docs/python.md runs: its ```python blocks, in order, in one namespace,
in a fresh folder (what the guide writes stays there)."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

GUIDE = Path(__file__).resolve().parents[1] / "docs" / "python.md"


def blocks() -> list[tuple[int, str]]:
    """(line number, code) of each ```python block."""
    text = GUIDE.read_text()
    out = []
    for m in re.finditer(r"^```python\n(.*?)^```", text, re.S | re.M):
        out.append((text[: m.start()].count("\n") + 2, m.group(1)))
    return out


def test_the_guide_has_the_promised_sections() -> None:
    text = GUIDE.read_text()
    for heading in ("## A unit", "## A run", "## A record", "## A fit", "## A diagnosis", "## The controller", "## A sweep", "## Plots"):
        assert heading in text
    assert len(blocks()) >= 10


def test_the_guide_runs(tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]) -> None:
    monkeypatch.chdir(tmp_path)
    namespace: dict[str, object] = {"__name__": "guide"}
    for line, code in blocks():
        try:
            exec(compile(code, f"{GUIDE}:{line}", "exec"), namespace)
        except Exception as e:  # noqa: BLE001 - say which block failed
            raise AssertionError(f"docs/python.md, the block at line {line} failed: {type(e).__name__}: {e}") from e
    printed = capsys.readouterr().out
    # What the guide says is printed is: names, not numbers, and errors that name their key.
    assert "RIDE" in printed and "lat_acc_enter_m_s2" in printed and "force_kn" in printed

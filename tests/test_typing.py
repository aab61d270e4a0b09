"""The package type-checks under mypy --strict, and the hand-kept stub of
the extension agrees with the extension (stubtest)."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def test_mypy_strict() -> None:
    r = subprocess.run([sys.executable, "-m", "mypy", "--strict", str(ROOT / "python" / "hpctl")], capture_output=True, text=True, cwd=ROOT)
    assert r.returncode == 0, r.stdout + r.stderr


def test_stubtest_agrees_with_extension() -> None:
    r = subprocess.run([sys.executable, "-m", "mypy.stubtest", "hpctl._core"], capture_output=True, text=True, cwd=ROOT)
    assert r.returncode == 0, r.stdout + r.stderr

"""The package type-checks under mypy --strict, and the hand-kept stub of
the extension agrees with the extension (stubtest)."""

from __future__ import annotations

import os
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


def test_a_users_strict_code_sees_the_public_names(tmp_path: Path) -> None:
    # The package loads its names lazily (PEP 562); a type checker must still
    # see each one as exported (mypy --strict refuses implicit re-exports).
    import hpctl

    user = tmp_path / "user.py"
    user.write_text("import hpctl\n\n" + "".join(f"print(hpctl.{n})\n" for n in hpctl.__all__))
    env = {**os.environ, "MYPYPATH": str(ROOT / "python")}
    r = subprocess.run([sys.executable, "-m", "mypy", "--strict", "--no-incremental", str(user)], capture_output=True, text=True, cwd=tmp_path, env=env)
    assert r.returncode == 0, r.stdout + r.stderr

"""The command line's comfort (issue 15, item 5): a start-up that loads no
SciPy or matplotlib (the time itself is a benchmark:
``scripts/bench_startup.py``), tables that fit a narrow terminal without
losing a digit, and the version and exact command in every summary."""

from __future__ import annotations

import importlib.metadata
import io
import json
import re
import shlex
import subprocess
import sys
from pathlib import Path

from click.testing import CliRunner
from rich.console import Console

import hpctl
from hpctl.cli import main
from hpctl.cli._ui import console_width, table
from hpctl.data.output import provenance


def test_the_command_line_starts_without_scipy_or_matplotlib() -> None:
    code = "import sys, hpctl.cli; print(sorted(m for m in ('scipy', 'matplotlib', 'pandas') if m in sys.modules))"
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert r.stdout.strip() == "[]", r.stdout
    # ... and neither does printing a command's help.
    code = ("import sys\nfrom hpctl.cli import main\ntry:\n    main(['simulate', '--help'])\nexcept SystemExit:\n    pass\n"
            "print(sorted(m for m in ('scipy', 'matplotlib') if m in sys.modules), file=sys.stderr)")
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert r.stderr.strip() == "[]" and "--test" in r.stdout


def test_version_is_the_installed_distributions() -> None:
    assert hpctl.__version__ == importlib.metadata.version("hpctl")
    r = CliRunner().invoke(main, ["--version"])
    assert r.exit_code == 0 and hpctl.__version__ in r.stdout


def _render(columns: int) -> list[str]:
    t = table("SDOF step response", ("spring", "damper", "natural freq. [Hz]", "damping ratio", "overshoot [mm]", "settling [s]", "peak p_gas [MPa]"))
    t.add_row("hard", "off", "1.2345", "0.0123", "42.1234", "12.3456", "19.8765")
    buf = io.StringIO()
    Console(file=buf, width=columns, color_system=None).print(t)
    return buf.getvalue().splitlines()


def test_tables_fit_a_narrow_console_and_keep_every_digit() -> None:
    for columns in (60, 80, 160):
        lines = _render(columns)
        assert max(len(line) for line in lines) <= columns
        text = "\n".join(lines)
        # Headers may wrap; the numbers stay whole on their row, nothing is cut.
        (row,) = [line for line in lines if line.startswith("hard")]
        assert row.split() == ["hard", "off", "1.2345", "0.0123", "42.1234", "12.3456", "19.8765"], (columns, lines)
        assert "…" not in text
    wide = _render(160)
    assert any("natural freq. [Hz]" in line for line in wide)  # no wrapping when there is room


def test_a_long_cell_folds_instead_of_being_cut() -> None:
    t = table("records", ("channel", "record"))
    t.add_row("force_n", "a_record_name_much_longer_than_the_console_is_wide_" * 2)
    buf = io.StringIO()
    Console(file=buf, width=40, color_system=None).print(t)
    text = buf.getvalue()
    assert max(len(line) for line in text.splitlines()) <= 40
    assert "…" not in text and re.sub(r"\s", "", text).count("a_record_name_much_longer_than_the_console_is_wide_") == 2


def test_console_width_follows_the_terminal_or_columns() -> None:
    assert console_width(True, {"COLUMNS": "60"}) is None  # a terminal: rich asks it (and honours COLUMNS)
    assert console_width(False, {"COLUMNS": "60"}) == 60
    assert console_width(False, {}) == 160
    assert console_width(False, {"COLUMNS": "wide"}) == 160


def test_cli_tables_fit_columns_60(tmp_path: Path) -> None:
    r = CliRunner().invoke(main, ["simulate", "--test", "step", "--spring", "hard", "--damper", "on", "--duration-s", "2", "--out", str(tmp_path)],
                           env={"COLUMNS": "60"})
    assert r.exit_code == 0, r.stderr
    lines = r.stdout.splitlines()
    assert any("Characterisation" in line for line in lines)
    assert max(len(line) for line in lines if "Wrote" not in line) <= 60, r.stdout
    summary = json.loads((tmp_path / "summary.json").read_text())
    (run,) = summary["runs"]
    force_range = f"{run['force_min_n'] / 1e3:.1f}"
    assert force_range in re.sub(r"\s", "", r.stdout)


def test_every_summary_says_which_hpctl_wrote_it_and_how(tmp_path: Path) -> None:
    out = tmp_path / "a folder with spaces"
    args = ["simulate", "--test", "step", "--spring", "soft", "--damper", "off", "--duration-s", "1", "--out", str(out), "--quiet"]
    r = CliRunner().invoke(main, args)
    assert r.exit_code == 0, r.stderr
    summary = json.loads((out / "summary.json").read_text())
    assert list(summary)[0] == "hpctl"
    assert summary["hpctl"] == {"version": hpctl.__version__, "command": shlex.join(["hpctl", *args])}
    # The command reads back as the same arguments (quoted for a shell).
    assert shlex.split(summary["hpctl"]["command"]) == ["hpctl", *args]


def test_provenance_quotes_the_command_for_a_shell() -> None:
    p = provenance(["hpctl", "fit", "my records/a.toml", "--model", "seed,leakage"])
    assert p == {"version": hpctl.__version__, "command": "hpctl fit 'my records/a.toml' --model seed,leakage"}

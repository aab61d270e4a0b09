"""`hpctl simulate`: outputs checked for physical sense, not just existence;
exit codes 0 / 2 / 1."""

from __future__ import annotations

import csv
import json
import subprocess
import sys
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from click.testing import CliRunner

import hpctl
from hpctl.cli import main
from hpctl.data.records import read_record


def simulate(*args: str) -> tuple[int, str, str]:
    r = CliRunner().invoke(main, ["simulate", *args])
    return r.exit_code, r.stdout, r.stderr


@pytest.fixture(scope="module")
def default_run(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, dict[str, Any]]:
    out = tmp_path_factory.mktemp("sim")
    code, stdout, _ = simulate("--out", str(out), "--json")
    assert code == 0
    return out, json.loads(stdout)


def test_default_run_reports_the_seeds_frequencies(default_run: tuple[Path, dict[str, Any]]) -> None:
    _, summary = default_run
    assert 1.35 < summary["natural_frequency_hard_hz"] < 1.8
    assert 0.8 < summary["natural_frequency_soft_hz"] < 1.1
    steps = {(r["spring"], r["damper"]): r for r in summary["runs"] if "overshoot_m" in r}
    assert len(steps) == 4
    for spring in ("hard", "soft"):
        # Damper on: less overshoot and faster settling than off.
        assert steps[(spring, "on")]["overshoot_m"] < 0.3 * steps[(spring, "off")]["overshoot_m"]
        assert steps[(spring, "off")]["damping_ratio"] < 0.4
    chars = {r["spring"]: r for r in summary["runs"] if r.get("excitation") == "sine"}
    # The hard spring's loop is the larger and its force range the wider (seed Fig. 3.5).
    assert chars["hard"]["loop_area_j"] > chars["soft"]["loop_area_j"] > 0
    assert chars["hard"]["force_max_n"] - chars["hard"]["force_min_n"] > 3 * (chars["soft"]["force_max_n"] - chars["soft"]["force_min_n"])


def test_default_run_writes_readable_records_and_plots(default_run: tuple[Path, dict[str, Any]]) -> None:
    out, summary = default_run
    assert json.loads((out / "summary.json").read_text()) == summary
    for png in ("force_displacement.png", "step_responses.png"):
        assert (out / png).read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    names = sorted(p.stem for p in (out / "records").glob("*.csv"))
    assert len(names) == 6
    step = read_record(out / "records" / "sdof_step_hard_off")
    assert step.kind == "sdof" and step.sprung_mass_kg == hpctl.SEED_SPRUNG_MASS_KG
    # The body ends on the new base level; static force carries the mass.
    assert step["body_disp_m"][-1] == pytest.approx(0.043, abs=1e-3)
    assert step["force_n"][0] == pytest.approx(3000 * 9.80665, rel=1e-6)
    char = read_record(out / "records" / "char_sine_soft_off")
    # 0.01 m/s through the static position, 100 mm amplitude.
    v = np.gradient(char["disp_m"], char["time_s"])
    assert np.abs(v).max() == pytest.approx(0.01, rel=0.01)
    assert np.abs(char["disp_m"]).max() == pytest.approx(0.1, rel=1e-3)


def test_options_select_test_modes_and_model(tmp_path: Path) -> None:
    code, stdout, _ = simulate("--test", "sine", "--spring", "hard", "--damper", "off", "--amplitude-m", "0.02", "--frequency-hz", "0.08",
                               "--tau-s", "2", "--gas", "ideal", "--out", str(tmp_path), "--json", "--quiet")
    assert code == 0
    s = json.loads(stdout)
    assert s["unit"]["gas"] == "ideal" and s["unit"]["tau_s"] == 2.0
    (run,) = s["runs"]
    assert run["spring"] == "hard" and run["damper"] == "off" and run["loop_area_j"] > 0


def test_thermal_loop_vanishes_in_the_limits(tmp_path: Path) -> None:
    def area(tau: str) -> float:
        code, stdout, _ = simulate("--test", "sine", "--spring", "hard", "--damper", "off", "--amplitude-m", "0.02", "--frequency-hz", "0.08",
                                   "--tau-s", tau, "--out", str(tmp_path / tau), "--json", "--quiet")
        assert code == 0
        return float(json.loads(stdout)["runs"][0]["gas_loop_area_j"])

    finite = area("2")
    assert abs(area("0")) < 1e-3 * finite
    assert abs(area("inf")) < 1e-3 * finite


def test_sweep_writes_table_and_frequency_falls_with_charge(tmp_path: Path) -> None:
    code, stdout, _ = simulate("--sweep", "--sweep-pressure-pa", "12e6,14811300,18e6", "--sweep-tau-s", "2", "--damper", "off",
                               "--spring", "hard", "--out", str(tmp_path), "--json", "--quiet")
    assert code == 0
    s = json.loads(stdout)
    assert s["cases"] == 3 and s["failed"] == 0
    with (tmp_path / "sweep.csv").open() as f:
        rows = list(csv.DictReader(f))
    f_hz = [float(r["natural_frequency_hz"]) for r in rows]
    disp = [float(r["static_disp_m"]) for r in rows]
    # More gas for the same load: it sits higher (less compressed) and is softer.
    assert f_hz[0] > f_hz[1] > f_hz[2]
    assert disp[0] > 0 > disp[2] and abs(disp[1]) < 1e-8
    assert (tmp_path / "sweep.png").exists()


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["--tau-s", "-1"], "tau_s = -1 is outside the valid range"),
        (["--tau-s", "abc"], "not a number"),
        (["--mass-kg", "0", "--test", "sdof-step"], "sprung_mass_kg = 0 is outside the valid range"),
        (["--dt-s", "0", "--test", "sdof-step"], "dt_s = 0 is outside the valid range"),
        (["--test", "nonsense"], "Invalid value for '--test'"),
        (["--sweep", "--sweep-pressure-pa", "1e7,x"], "expected comma-separated numbers"),
    ],
)
def test_bad_input_exits_2_with_a_message(tmp_path: Path, args: list[str], message: str) -> None:
    code, stdout, stderr = simulate(*args, "--out", str(tmp_path))
    assert code == 2
    assert message in stderr


def test_bad_unit_file_exits_2(tmp_path: Path) -> None:
    bad = tmp_path / "unit.toml"
    hpctl.Unit.seed().to_toml(bad)
    bad.write_text(bad.read_text().replace("small_acc_volume_m3 = 0.0003", "small_acc_volume_m3 = -0.0003"))
    code, _, stderr = simulate("--unit", str(bad), "--out", str(tmp_path))
    assert code == 2 and "small_acc_volume_m3 = -3e-4 is outside the valid range" in stderr


def test_installed_entry_point_and_internal_error_exit_code(tmp_path: Path) -> None:
    r = subprocess.run([sys.executable, "-m", "hpctl", "simulate", "--test", "sdof-step", "--spring", "hard", "--damper", "on",
                        "--duration-s", "1", "--out", str(tmp_path), "--json", "--quiet"], capture_output=True, text=True, check=False)
    assert r.returncode == 0, r.stderr
    assert json.loads(r.stdout)["runs"][0]["spring"] == "hard"
    # An unwritable output folder is not bad *input* to the model but an
    # environment failure: exit 1, with the path and the reason (no traceback).
    blocker = tmp_path / "file"
    blocker.write_text("x")
    r = subprocess.run([sys.executable, "-m", "hpctl", "simulate", "--test", "sdof-step", "--duration-s", "1", "--out", str(blocker / "sub"), "--quiet"],
                       capture_output=True, text=True, check=False)
    assert r.returncode == 1 and f"error: {blocker / 'sub'}: Not a directory" in r.stderr and "Traceback" not in r.stderr


@pytest.mark.parametrize(
    ("args", "named"),
    [
        (["--dt-s", "0.1"], "--dt-s does not apply to --test seed"),
        (["--test", "sine", "--mass-kg", "3000"], "--mass-kg does not apply to --test sine"),
        (["--test", "heat", "--damper", "off"], "--damper does not apply to --test heat"),
        (["--sweep", "--frequency-hz", "2", "--duration-s", "3"], "--frequency-hz, --duration-s does not apply to --sweep"),
        (["--test", "sdof-step", "--threads", "2"], "--threads does not apply to --test sdof-step"),
        (["--sweep", "--fixed-steps"], "--fixed-steps does not apply to --sweep"),
    ],
)
def test_an_option_the_run_does_not_read_is_refused(tmp_path: Path, args: list[str], named: str) -> None:
    # The seed's experiments used to ignore --dt-s silently: the output
    # looked as if the step had been taken.
    code, stdout, stderr = simulate(*args, "--out", str(tmp_path / "out"))
    assert code == 2, stdout + stderr
    assert named in stderr
    assert not (tmp_path / "out").exists()

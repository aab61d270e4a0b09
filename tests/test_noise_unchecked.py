"""A noise level that may hold the signal is said so (the
``noise_unchecked`` warning), never judged against silently.

The records are the foreign rig's (tests/foreign_rig, no code shared with
hp-core): a 0.5 Hz sine with the damper on sampled 20 times a cycle, where
the damper's knees put the signal into every order of the force's
differences (hpctl.identify.signals.noise_level); the 75-minute heat run of
scripts/bench_diagnose.py is the same case at length, its force read at
178 N where the rig drew 58 N, and its flexible diagnosis said "0.32 x the
noise" with no warning. Drawn anew on every run: FOREIGN_RIG_SEED replays
a draw.
"""

from __future__ import annotations

import json
import os
import secrets
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner

from foreign_rig import Test, draw_case, generate, run_test
from foreign_rig.motion import Sine
from hpctl.cli import main as cli_main
from hpctl.data.records import read_record
from hpctl.identify.dataset import prepare
from hpctl.identify.signals import noise_sigma

PIECE = Test("heat_piece", Sine(0.06, 0.5), 60.0, 1200, damper_on=True)
SLOW = Test("sine_0.03hz", Sine(0.06, 0.03), 100.0, 400)


@pytest.fixture
def seed() -> int:
    return int(os.environ.get("FOREIGN_RIG_SEED", secrets.randbelow(2**31)))


def test_a_level_no_difference_holds_alone_is_flagged_and_one_checked_elsewhere_is_not(seed: int, tmp_path: Path) -> None:
    g = generate("heat_buildup", seed, out=tmp_path / "r", tests=[PIECE, SLOW])
    piece, slow = (read_record(p) for p in g.records)
    # The piece's noise alone, as the rig drew it: its record less the true
    # force it sampled (the same draw: the rig seeds each test's noise).
    record, true = run_test(draw_case("heat_buildup", seed), PIECE)
    noise_alone = np.asarray(record.columns["force_n"]) - np.asarray(true["force_n"])
    # What the differences read of the noise alone, at whichever order.
    noise_n = max(noise_sigma(noise_alone, order) for order in (4, 6, 8))
    (alone,) = prepare([piece])
    context = (f"FOREIGN_RIG_SEED={seed}: force level {alone.sigma['force_n']:.4g} N, its noise alone {noise_n:.4g} N, "
               f"the rig's {g.truth['noise']['force_n']['sigma']:.4g} N")
    # Over 40 draws the force was flagged in every one, the small
    # accumulator's pressure too in 11.
    assert "force_n" in alone.noise_unchecked and set(alone.noise_unchecked) <= {"force_n", "p_gas_pa", "p_gas2_pa"}, context
    # Why it matters: the level holds the signal, above what the same
    # differences read of the noise alone. By how much is the draw's: the
    # damper's knees against the noise drawn. Over 41 draws 1.12-5.1 x
    # (median 2.4 x; 1.12 x at FOREIGN_RIG_SEED=1754266673, 56 N of noise
    # drawn against 31 N that the signal alone reads, where this asked for
    # 1.2 x the rig's level and failed). Even there the excess, 0.2 of the
    # level's square, is about four times the scatter the noise's cross
    # term with the signal can make.
    assert alone.sigma["force_n"] > noise_n, context
    both = prepare([piece, slow])
    assert [d.noise_unchecked for d in both] == [(), ()], context
    assert both[0].sigma["force_n"] < alone.sigma["force_n"], context


def test_fit_and_diagnose_warn_of_an_unchecked_level_and_strict_fails(seed: int, tmp_path: Path) -> None:
    g = generate("heat_buildup", seed, out=tmp_path / "r", tests=[PIECE, SLOW])
    piece = str(g.records[0])
    runner = CliRunner()
    r = runner.invoke(cli_main, ["fit", piece, "--model", "seed", "--json", "--quiet", "--out", str(tmp_path / "fit")])
    assert r.exit_code == 0, r.stderr
    (w,) = [w for w in json.loads(r.stdout)["warnings"] if w["code"] == "noise_unchecked"]
    flagged = w["details"]["channels"]
    assert "heat_piece/force_n" in flagged, w
    for level, rms in zip(w["details"]["noise"], w["details"]["residual_rms"], strict=True):
        assert level > 0 and rms > 0 and f"{level:.4g}" in w["message"] and f"{rms:.4g}" in w["message"], w
    assert "noise_unchecked" in (tmp_path / "fit" / "fit.md").read_text()
    r = runner.invoke(cli_main, ["fit", piece, "--model", "seed", "--json", "--quiet", "--strict", "--out", str(tmp_path / "strict")])
    assert r.exit_code == 3, r.stderr
    r = runner.invoke(cli_main, ["diagnose", piece, "--model", "seed", "--json", "--quiet", "--max-rounds", "1", "--out",
                                 str(tmp_path / "diag")])
    assert r.exit_code == 0, r.stderr
    assert [w["details"]["channels"] for w in json.loads(r.stdout)["warnings"] if w["code"] == "noise_unchecked"] == [flagged]
    # With a record whose force differences hold noise only, nothing to say.
    r = runner.invoke(cli_main, ["fit", *map(str, g.records), "--model", "seed", "--json", "--quiet", "--out", str(tmp_path / "both")])
    assert r.exit_code == 0, r.stderr
    assert not [w for w in json.loads(r.stdout)["warnings"] if w["code"] == "noise_unchecked"]

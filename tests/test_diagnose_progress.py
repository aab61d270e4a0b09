"""The diagnosis's progress (issue 12, item 4): each line says the round,
the candidate and an estimate of the time left, on stderr and never in the
JSON; and the candidates' fits run in parallel without changing the
result."""

from __future__ import annotations

import json
import re
from pathlib import Path


from hpctl.data.records import read_record
from hpctl.identify.diagnose import diagnose
from tests.test_calibrate_cli import hpctl, leaky_rig  # noqa: F401  (the CLI runner and the leaky rig's records, one definition)

CANDIDATE_LINE = re.compile(r"^round 1/1: candidate (\d+)/(\d+) \((\w+)\) fitted, BIC change \S+; about (\d+) s left in this round$")


def test_progress_lines_carry_the_round_the_candidate_and_the_time_left(leaky_rig: Path, tmp_path: Path) -> None:
    code, out, err = hpctl("diagnose", str(leaky_rig), "--model", "seed", "--out", str(tmp_path), "--json", "--max-rounds", "1")
    assert code == 0, err
    # stdout is the JSON document alone: no progress in it.
    doc = json.loads(out)
    assert doc["found"] == ["leakage"]
    lines = err.splitlines()
    matches = [m for m in map(CANDIDATE_LINE.match, lines) if m]
    assert matches, err
    total = int(matches[0].group(2))
    # One line per candidate as its fit completes, counted 1..n, each
    # naming a different candidate, every one with an estimate.
    assert [int(m.group(1)) for m in matches] == list(range(1, total + 1)), err
    assert total == len({m.group(3) for m in matches}) >= 2
    assert "leakage" in {m.group(3) for m in matches}
    # The estimate of what is left falls from the first candidate to the
    # last (cross-validation and the final fit remain after them).
    assert int(matches[-1].group(4)) < int(matches[0].group(4)), err
    assert any(line.startswith("round 1/1: cross-validating leakage; about ") for line in lines), err
    assert any(line.startswith("round 1/1: added leakage: ") for line in lines), err


def test_quiet_prints_no_progress(leaky_rig: Path, tmp_path: Path) -> None:
    code, out, err = hpctl("diagnose", str(leaky_rig), "--model", "seed", "--out", str(tmp_path), "--json", "--quiet", "--max-rounds", "1")
    assert code == 0, err
    assert not any(CANDIDATE_LINE.match(line) for line in err.splitlines()), err
    assert json.loads(out)["found"] == ["leakage"]


def test_candidates_in_parallel_give_the_serial_result(leaky_rig: Path) -> None:
    records = [read_record(p) for p in sorted(leaky_rig.glob("*.csv"))]
    serial = diagnose(records, ("heat_transfer", "real_gas"), max_rounds=1, workers=1)
    parallel = diagnose(records, ("heat_transfer", "real_gas"), max_rounds=1, workers=4)
    assert serial.found == parallel.found == ["leakage"]
    # The same fits, whatever order they complete in: bit for bit.
    assert serial.final.values == parallel.final.values
    assert serial.final.stderr == parallel.final.stderr
    assert [(c.effect, c.delta_bic) for c in serial.rounds[0].candidates] == [(c.effect, c.delta_bic) for c in parallel.rounds[0].candidates]

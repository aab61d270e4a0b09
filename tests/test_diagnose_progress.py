"""The diagnosis's progress (issue 12, item 4): each line says the round,
the candidate and an estimate of the time left, on stderr and never in the
JSON; and the candidates' fits run in parallel without changing the
result."""

from __future__ import annotations

import dataclasses
import json
import re
import time
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path
from types import SimpleNamespace
from typing import Any

import pytest
from tests.test_calibrate_cli import hpctl, leaky_rig  # noqa: F401  (the CLI runner and the leaky rig's records, one definition)

import hpctl.identify.diagnose as diagnose_module
from hpctl.data.records import read_record
from hpctl.identify.diagnose import diagnose, summary
from hpctl.model.effects import LIBRARY

ROUND_START_LINE = re.compile(r"^round 1/1: candidates 1-\d+ of \d+ started \(.*\); about ((?:\d+ min )?\d+) s left in this round$")
CANDIDATE_LINE = re.compile(r"^round 1/1: candidate (\d+)/(\d+) \((\w+)\) fitted, BIC change \S+(?: \(stopped heading for its null, no better\))?; about ((?:\d+ min )?\d+) s left in this round$")


def seconds(said: str) -> int:
    """'87' or '2 min 04' (the progress line's estimate) in seconds."""
    minutes, _, rest = said.rpartition(" min ")
    return 60 * int(minutes or 0) + int(rest)


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
    # The estimate of what is left falls over the round, from its start to
    # the last candidate (cross-validation and the final fit remain after
    # them), and does not rise from the first candidate to the last. In
    # whole seconds: on a fast machine (an AMD EPYC, stop 47) the round
    # said 4 s at its start, then 1 s at the first candidate and at the
    # last, so the first and the last may tie.
    started = [seconds(m.group(1)) for m in map(ROUND_START_LINE.match, lines) if m]
    assert len(started) == 1, err
    assert seconds(matches[-1].group(4)) < started[0], err
    assert seconds(matches[-1].group(4)) <= seconds(matches[0].group(4)), err
    assert any(line.startswith("round 1/1: cross-validating leakage; about ") for line in lines), err
    assert any(line.startswith("round 1/1: added leakage: ") for line in lines), err


def test_the_time_left_is_said_in_whole_minutes_and_seconds() -> None:
    # Each as the progress lines say it, read back by the tests' parser.
    for s, said in ((0.4, "0 s"), (87.0, "87 s"), (89.4, "89 s"), (89.6, "1 min 30 s"), (90.0, "1 min 30 s"), (119.6, "2 min 00 s"), (155.0, "2 min 35 s"),
                    (3599.4, "59 min 59 s"), (3600.0, "1.0 h"), (-3.0, "0 s")):
        assert diagnose_module._fmt_s(s) == said, (s, diagnose_module._fmt_s(s))
        if not said.endswith(" h"):
            assert seconds(said.removesuffix(" s")) == max(0, round(s))


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


def test_an_effect_whose_gain_does_not_hold_in_its_full_fit_is_not_found(leaky_rig: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    # The accepted model is fitted again with the input noise and a larger
    # budget; on the foreign 75-minute heat run a sensor lag's screening
    # gain (BIC -9,945) ended +13.6 there and was still "found". Here the
    # leak's full fit is made to lose its gain (its residual sum of squares
    # that of the model it extends): the leak is not found, and the BIC
    # change is in the candidates' JSON.
    records = [read_record(p) for p in sorted(leaky_rig.glob("*.csv"))]
    real_fit = diagnose_module.fit
    calls: list[float] = []

    def spoiled(datasets: Any, effects: Any, **kw: Any) -> Any:
        r = real_fit(datasets, effects, **kw)
        if kw.get("max_nfev") == diagnose_module.ACCEPTED_MAX_NFEV and kw.get("input_noise", True) and "leakage" in effects:
            base = real_fit(datasets, tuple(e for e in effects if e != "leakage"), **kw)
            r = dataclasses.replace(r, rss=base.rss)
            calls.append(r.bic - base.bic)
        return r

    monkeypatch.setattr(diagnose_module, "fit", spoiled)
    d = diagnose(records, ("heat_transfer", "real_gas"), max_rounds=1, workers=1)
    assert calls and all(c > -diagnose_module.BIC_STRONG for c in calls)
    assert "leakage" not in d.found, d.found
    leak = [c for c in d.rounds[0].candidates if c.effect == "leakage"]
    assert leak and leak[0].refit_delta_bic is not None and leak[0].refit_delta_bic > -diagnose_module.BIC_STRONG
    assert any(c["refit_delta_bic"] is not None for c in summary(d)["candidates_last_round"])


@pytest.mark.parametrize("durations_s", [[0.6] * 8, [0.3, 0.6, 0.45, 0.75, 0.3, 0.6, 0.45, 0.75]], ids=["equal", "mixed"])
def test_the_time_left_counts_the_fits_still_running(durations_s: list[float], monkeypatch: pytest.MonkeyPatch) -> None:
    # Eight screening fits on four workers, each taking a known time (a
    # sleep in place of the fit): at each completion the estimate of the
    # screening time left (cross-validation and the accepted fit left out)
    # is compared with the time the batch then really took: within a factor
    # 3 (measured 2.2 x at most, equal durations' first). Counting only the
    # finished fits, the first to finish made the rate one fit per its whole
    # duration while three others were as far along: 4.2 s said where 0.6 s
    # were left (equal durations: 7 x); now 1.3 s (a fit that has run as
    # long as the finished ones took counts half done). The mixed durations
    # finish shortest first, so their estimates fall short (0.5-0.7 x while
    # half the fits are left): the fits still to come are the long ones.
    def fake_try(datasets: Any, current: Any, effects: Any, add: tuple[str, ...], **_: Any) -> Any:
        time.sleep(durations_s[effects_.index(add[0])])
        return diagnose_module.Candidate(effects=add, added_params=1, result=SimpleNamespace(stopped=False), delta_bic=0.0)  # type: ignore[arg-type]

    effects_ = list(LIBRARY)[1:1 + len(durations_s)]  # eight names the candidates' lines can carry

    monkeypatch.setattr(diagnose_module, "_try", fake_try)
    said: list[tuple[float, float]] = []  # (when, estimate of the time left)

    class Clock(diagnose_module._Clock):
        ACCEPT_FITS = 0.0

        def tell(self, what: str, fits_left: float, running_s: float | None = None) -> None:
            assert running_s is None  # no fit here times a run
            per = self.per_fit_s()
            if "fitted" in what and per is not None:
                said.append((time.perf_counter(), per * fits_left))

    clock = Clock(lambda _m: None, 1)
    with ThreadPoolExecutor(max_workers=4) as pool:
        diagnose_module._try_all([], None, (), [(e,) for e in effects_], clock, pool)  # type: ignore[arg-type]
    end = time.perf_counter()
    assert len(said) == len(durations_s)
    longest, mixed = max(durations_s), len(set(durations_s)) > 1
    for k, (when, estimate) in enumerate(said):
        truth = end - when
        if truth < longest / 4:
            # Near the end what is left is the fits' spread: no wait longer
            # than a fit promised (0.28 s said here, equal durations).
            assert estimate <= longest, (k, estimate, truth, said)
        elif not (mixed and k >= len(said) // 2):
            # (Mixed: a long fit left running alone at the tail is not known
            # to be long, 0.07 s said where 0.3 s were: not judged there.)
            assert truth / 3 <= estimate <= 3 * truth, (k, estimate, truth, said)
    assert clock.credit == 0.0


STILL_LINE = re.compile(r"^round 1/1: still fitting (.*), the (\d+) other candidates took (\S+ s)"
                        r"(?:; (\S+) screened again beside)?; then about (\S+ s) for cross-validation and the final fit$")


def test_a_fit_that_outruns_the_others_is_said_to_be_still_running(monkeypatch: pytest.MonkeyPatch) -> None:
    # The bundled heat run's round 1 in small: three screenings that end
    # at once, the first of them at the share (screened again beside), and
    # one that runs on alone (oil compliance there: 92 s where the others
    # took 4-29 s, and for a minute nothing was said). A line every
    # HEARTBEAT_S while nothing completes, naming the fit still running and
    # how long it has run, what the finished ones took and the second
    # screening beside; the lines as each fit completes are unchanged, and
    # so is the ranking.
    durations = {"friction": 0.05, "leakage": 0.05, "sensor_offset": 0.05, "oil_compliance": 1.0}

    def fake_try(datasets: Any, current: Any, effects: Any, add: tuple[str, ...], jacobian: str | None = None, max_nfev: int = 0,
                 **_: Any) -> Any:
        time.sleep(durations[add[0]] if jacobian is None else 0.4)
        at_share = add == ("friction",) and jacobian is None
        result = SimpleNamespace(model=SimpleNamespace(flexible=True), stopped=at_share)
        gain = {"friction": 900.0, "leakage": 5.0, "sensor_offset": 20.0, "oil_compliance": -3.0}[add[0]] + (100.0 if jacobian else 0.0)
        return diagnose_module.Candidate(add, 1, result, gain, 0.6 if add == ("friction",) else 0.01,  # type: ignore[arg-type]
                                         screened_by=jacobian or "broyden", ended_at_share=at_share)

    monkeypatch.setattr(diagnose_module, "_try", fake_try)
    monkeypatch.setattr(diagnose_module, "HEARTBEAT_S", 0.2)
    said: list[tuple[float, str]] = []
    clock = diagnose_module._Clock(lambda m: said.append((time.perf_counter(), m)), 1)
    clock.round = 1
    start = time.perf_counter()
    with ThreadPoolExecutor(max_workers=4) as pool:
        ranked = diagnose_module._try_all([], None, (), [(e,) for e in durations], clock, pool, ahead={})  # type: ignore[arg-type]
    assert [c.effect for c in ranked] == ["friction", "sensor_offset", "leakage", "oil_compliance"]
    assert ranked[0].delta_bic == 1_000.0  # by its second screening
    still = [(when - start, m) for when, m in said if STILL_LINE.match(m)]
    # Oil compliance alone from about 0.05 s to 1.0 s: four lines, 0.2 s apart.
    assert 3 <= len(still) <= 5, said
    for when, line in still:
        m = STILL_LINE.match(line)
        assert m is not None
        running, finished, took, again, after = m.groups()
        # Its time so far, whole seconds (0 s, then 1 s), never more than has passed.
        assert re.fullmatch(r"oil_compliance \((\d+) s so far\)", running), line
        assert int(re.findall(r"\d+", running)[0]) <= round(when) + 1, line
        assert finished == "3" and took == "0 s", line
        assert again in (None, "friction"), line
        assert after.endswith(" s"), line
    # The second screening is said while it runs (0.05-0.45 s), not after.
    assert any(m.group(4) == "friction" for _, line in still if (m := STILL_LINE.match(line))), said
    assert not any(when > 0.6 and "screened again beside" in line for when, line in still), still
    # Every completion's line as before: one each, counted 1..4.
    done = [m for _, m in said if " fitted, BIC change " in m]
    assert [int(re.findall(r"candidate (\d+)/4", m)[0]) for m in done] == [1, 2, 3, 4], said
    assert "(oil_compliance)" in done[-1]


def test_a_running_fit_takes_the_finished_ones_time_per_run_at_its_own_runs_cost() -> None:
    left = diagnose_module.screening_left_s
    # Nothing to weigh by without a cost on both sides.
    assert left([], [(1.0, 0.1)]) is None
    assert left([(2.0, None)], [(1.0, 0.1)]) is None
    assert left([(2.0, 0.1)], [(1.0, None)]) is None
    # The finished fits' median duration per run (40, 60 and 300: 60) at
    # each running fit's cost, less what it has run; the longest.
    assert left([(4.0, 0.1), (6.0, 0.1), (30.0, 0.1)], [(10.0, 0.5), (1.0, 0.1)]) == pytest.approx(20.0)
    assert left([(4.0, 0.1), (6.0, 0.1)], [(0.0, 0.2)]) == pytest.approx(10.0)  # median of 40 and 60
    # Past its due: nothing, never less.
    assert left([(4.0, 0.1)], [(100.0, 0.1)]) == 0.0


def test_the_time_left_weighs_a_running_fit_by_what_its_runs_cost(monkeypatch: pytest.MonkeyPatch) -> None:
    # The bundled heat run's round in small: three screenings whose runs
    # are cheap and one whose runs cost ten times theirs (oil compliance's
    # stiff oil there: 1.9 s a run against 0.12 s), each making 10-20 runs
    # (a sleep in place of the fit; the fit times its first run for
    # on_first_run). At each completion before the long one ends, the
    # screening time said left is within a factor 2 of what it then took;
    # counting the running fit as the finished ones' mean (running_credit
    # alone) said under a third of it (stop 76: 15 s said where 119 s were
    # on the heat run).
    cost = {"friction": 0.01, "leakage": 0.01, "sensor_offset": 0.01, "oil_compliance": 0.1}
    runs = {"friction": 10, "leakage": 15, "sensor_offset": 20, "oil_compliance": 15}

    def fake_try(datasets: Any, current: Any, effects: Any, add: tuple[str, ...], on_first_run: Any = None, **_: Any) -> Any:
        on_first_run(cost[add[0]])
        time.sleep(cost[add[0]] * runs[add[0]])
        return diagnose_module.Candidate(effects=add, added_params=1, result=SimpleNamespace(stopped=False), delta_bic=0.0)  # type: ignore[arg-type]

    monkeypatch.setattr(diagnose_module, "_try", fake_try)
    said: list[tuple[float, float, float | None]] = []  # (when, by the rate alone, by the runs' cost)

    class Clock(diagnose_module._Clock):
        ACCEPT_FITS = 0.0

        def tell(self, what: str, fits_left: float, running_s: float | None = None) -> None:
            per = self.per_fit_s()
            if "fitted" in what and per is not None:
                said.append((time.perf_counter(), per * fits_left, running_s))

    clock = Clock(lambda _m: None, 1)
    with ThreadPoolExecutor(max_workers=4) as pool:
        diagnose_module._try_all([], None, (), [(e,) for e in cost], clock, pool)  # type: ignore[arg-type]
    end = time.perf_counter()
    assert len(said) == 4
    for when, by_rate, by_cost in said[:-1]:
        truth = end - when
        assert by_cost is not None and truth / 2 <= max(by_rate, by_cost) <= 2 * truth, said
    # The first completion's (0.1 s in, 1.4 s left): by the rate alone far short.
    first_when, first_by_rate, _ = said[0]
    assert first_by_rate < (end - first_when) / 3, said
    # The last: nothing running, nothing by cost.
    assert said[-1][2] is None


def test_a_screening_ended_at_the_share_tells_the_tail_by_its_own_runs_cost(monkeypatch: pytest.MonkeyPatch) -> None:
    # _try_all notes each candidate's first run (fit's on_first_run) with
    # its screening: the tail of one ended at the share is told in its runs
    # (stop 81), however short its first screening was (it started from the
    # Jacobian of the model it extends).
    cost = {"friction": 0.05, "leakage": 0.2}

    def fake_try(datasets: Any, current: Any, effects: Any, add: tuple[str, ...], on_first_run: Any = None, **_: Any) -> Any:
        on_first_run(cost[add[0]])
        result = SimpleNamespace(model=SimpleNamespace(flexible=True), stopped=add == ("friction",))
        return diagnose_module.Candidate(add, 1, result, 900.0 if add == ("friction",) else 50.0, 0.9,  # type: ignore[arg-type]
                                         ended_at_share=add == ("friction",))

    monkeypatch.setattr(diagnose_module, "_try", fake_try)
    clock = diagnose_module._Clock(lambda _m: None, 1)
    with ThreadPoolExecutor(max_workers=2) as pool:
        diagnose_module._try_all([], None, (), [(e,) for e in cost], clock, pool)  # type: ignore[arg-type]
    assert clock.gained[("friction",)][3] == 0.05 and clock.gained[("leakage",)][3] == 0.2
    assert clock.tail_s(("friction",), rescreened=True) == pytest.approx(clock.TAIL_AFTER_SHARE_RUNS * 0.05)
    assert clock.tail_s(("friction",)) == pytest.approx((clock.TAIL_AFTER_SHARE_RUNS + clock.RESCREEN_RUNS) * 0.05)


def test_a_running_fit_counts_half_when_it_has_run_as_long_as_the_finished_ones_took() -> None:
    assert diagnose_module.running_credit([], [1.0]) == 0.0
    assert diagnose_module.running_credit([2.0], []) == 0.0
    assert diagnose_module.running_credit([2.0, 4.0], [0.0, 3.0, 9.0]) == pytest.approx(0.0 + 0.5 + 0.75)


def test_the_winners_finite_difference_screening_starts_while_the_last_fits_run(monkeypatch: pytest.MonkeyPatch) -> None:
    # A flexible Broyden screening that ended at AHEAD_SHARE of the excess
    # (diagnose.enough_explained) is screened again at once, beside the
    # fits still running, and ranked by that second screening. Stand-in
    # fits: the sensor offset's finishes first, with a gain _accept would
    # weigh but a fifth of the excess explained (it ran to its end: no
    # second screening, a fit still running may explain the rest);
    # friction's next, ended at the share; the leak's waits until
    # friction's second screening has begun (a timeout there is the
    # failure).
    import threading

    began = threading.Event()
    leak_started = threading.Event()  # so that every fit has started when the others finish
    offset_told = threading.Event()
    calls: list[tuple[tuple[str, ...], str | None]] = []

    def candidate(add: tuple[str, ...], delta_bic: float, explained: float, how: str, at_share: bool = False) -> Any:
        result = SimpleNamespace(model=SimpleNamespace(flexible=True), stopped=at_share)
        return diagnose_module.Candidate(add, 1, result, delta_bic, explained, screened_by=how, ended_at_share=at_share)  # type: ignore[arg-type]

    again = diagnose_module.RESCREEN[0]

    def fake_try(datasets: Any, current: Any, effects: Any, add: tuple[str, ...], jacobian: str | None = None, max_nfev: int = 0,
                 **_: Any) -> Any:
        calls.append((add, jacobian))
        if jacobian == again:
            assert max_nfev == diagnose_module.RESCREEN[1]
            began.set()
            return candidate(add, 9_000.0, 0.95, again)
        if add == ("leakage",):
            leak_started.set()
            assert began.wait(60.0), "friction's second screening did not start while the leak's fit ran"
            return candidate(add, 20.0, 0.001, "broyden")
        assert leak_started.wait(60.0)
        if add == ("sensor_offset",):
            return candidate(add, 5_000.0, 0.2, "broyden")
        assert offset_told.wait(60.0)  # the round has taken the offset's in (and not screened it again)
        return candidate(add, 4_000.0, diagnose_module.AHEAD_SHARE, "broyden", at_share=True)

    def say(message: str) -> None:
        if "(sensor_offset) fitted" in message:
            offset_told.set()

    monkeypatch.setattr(diagnose_module, "_try", fake_try)
    clock = diagnose_module._Clock(say, 1)
    ahead: dict[tuple[str, ...], Any] = {}
    with ThreadPoolExecutor(max_workers=4) as pool:
        ranked = diagnose_module._try_all([], None, (), [("friction",), ("sensor_offset",), ("leakage",)], clock, pool,  # type: ignore[arg-type]
                                          ahead=ahead)
        # Friction ranked by its second screening (by its first, 4,000, it was below the offset).
        assert [c.effect for c in ranked] == ["friction", "sensor_offset", "leakage"]
        assert ranked[0].delta_bic == 9_000.0 and ranked[0].broyden_delta_bic == 4_000.0 and ranked[0].screened_by == again
        assert not ahead and [c for c in calls if c[1] == again] == [(("friction",), again)] and len(calls) == 4
        # _accept's confirmation then has nothing left to do.
        assert diagnose_module._confirmed([], None, (), ranked[0], clock, ahead) is ranked[0]  # type: ignore[arg-type]
    assert len(calls) == 4 and 0.2 < diagnose_module.AHEAD_SHARE < 0.7


def test_every_screening_ended_at_the_share_is_screened_again_and_ranked_by_that(monkeypatch: pytest.MonkeyPatch) -> None:
    # Two candidates whose Broyden screenings both ended at AHEAD_SHARE:
    # where each stopped says nothing of which explains more, so both are
    # screened again (in the pool, in order), and the ranking is their
    # second screenings' (here the reverse of their first; the rank is the
    # gain per parameter of the effect: friction has two, the offsets three).
    calls: list[tuple[tuple[str, ...], str | None]] = []
    again = diagnose_module.RESCREEN[0]
    second: dict[tuple[str, ...], float] = {("friction",): 7_000.0, ("sensor_offset",): 30_000.0}
    first: dict[tuple[str, ...], float] = {("friction",): 8_000.0, ("sensor_offset",): 6_000.0}

    def fake_try(datasets: Any, current: Any, effects: Any, add: tuple[str, ...], jacobian: str | None = None, max_nfev: int = 0,
                 **_: Any) -> Any:
        calls.append((add, jacobian))
        rescreen = jacobian == again
        result = SimpleNamespace(model=SimpleNamespace(flexible=True), stopped=not rescreen)
        gain = second[add] if rescreen else first[add]
        return diagnose_module.Candidate(add, 1, result, gain, 0.9 if rescreen else 0.6,  # type: ignore[arg-type]
                                         screened_by=again if rescreen else "broyden", ended_at_share=not rescreen)

    monkeypatch.setattr(diagnose_module, "_try", fake_try)
    aheads: tuple[dict[tuple[str, ...], Any] | None, ...] = ({}, None)
    for ahead in aheads:  # screened again ahead in the pool, or here
        calls.clear()
        with ThreadPoolExecutor(max_workers=2) as pool:
            ranked = diagnose_module._try_all([], None, (), list(first), diagnose_module._Clock(lambda _m: None, 1), pool,  # type: ignore[arg-type]
                                              ahead=ahead)
        assert [c.effect for c in ranked] == ["sensor_offset", "friction"]
        assert [(c.delta_bic, c.broyden_delta_bic) for c in ranked] == [(30_000.0, 6_000.0), (7_000.0, 8_000.0)]
        assert sorted(calls, key=str) == sorted([*((a, None) for a in first), *((a, again) for a in first)], key=str)
        assert all(c.ended_at_share and not c.stopped_at_null for c in ranked)


def test_the_accepted_models_full_fit_starts_with_its_cross_validation(monkeypatch: pytest.MonkeyPatch) -> None:
    # _accept starts a candidate's full fit (with the input noise) as its
    # cross-validation begins, beside it; the round then takes that fit
    # instead of fitting again. Stand-ins: the cross-validation of the
    # model with the candidate waits until the full fit has begun (a
    # timeout there is the failure); the first candidate's cross-validation
    # rejects it (its full fit leaves ``full``), the second's accepts.
    import threading

    began: dict[tuple[str, ...], threading.Event] = {("friction",): threading.Event(), ("leakage",): threading.Event()}
    fitted: list[tuple[str, ...]] = []

    def fake_full_fit(datasets: Any, current: Any, effects: Any, c: Any) -> Any:
        fitted.append(c.effects)
        began[c.effects].set()
        return SimpleNamespace(effects=c.effects)

    def fake_cv(datasets: Any, effects: Any, start: Any, pool: Any = None, held: Any = None) -> float:
        added = tuple(e for e in effects if e not in ("heat_transfer", "real_gas"))
        if not added:
            return 100.0  # the model the candidates extend
        assert began[added].wait(60.0), f"{added}'s full fit did not start beside its cross-validation"
        return 150.0 if added == ("friction",) else 50.0

    monkeypatch.setattr(diagnose_module, "_full_fit", fake_full_fit)
    monkeypatch.setattr(diagnose_module, "cross_validation", fake_cv)
    monkeypatch.setattr(diagnose_module, "_with_errors", lambda datasets, c: None)
    monkeypatch.setattr(diagnose_module, "shape_values", lambda result: {})
    monkeypatch.setattr(diagnose_module.Candidate, "shows_itself", property(lambda self: True))

    def candidate(add: tuple[str, ...], delta_bic: float) -> Any:
        # No covariances: no design effect, the gain as it is.
        result = SimpleNamespace(model=SimpleNamespace(flexible=False), values={}, stopped=False, covariance=None, covariance_iid=None, n=1000)
        return diagnose_module.Candidate(add, 1, result, delta_bic, 0.5)  # type: ignore[arg-type]

    ranked = [candidate(("friction",), 900.0), candidate(("leakage",), 800.0)]
    current = SimpleNamespace(values={}, model=SimpleNamespace(flexible=False))
    clock = diagnose_module._Clock(lambda _m: None, 1)
    full: dict[tuple[str, ...], Any] = {}
    with ThreadPoolExecutor(max_workers=4) as pool:
        accepted = diagnose_module._accept([], current, ("heat_transfer", "real_gas"), ranked, clock, pool, full=full)  # type: ignore[arg-type]
        assert accepted is ranked[1] and accepted.cv_improves and ranked[0].cv_improves is False
        assert list(full) == [("leakage",)]
        assert full[("leakage",)].result().effects == ("leakage",)
    assert sorted(fitted) == [("friction",), ("leakage",)]


def test_a_second_look_does_not_cross_validate_again(monkeypatch: pytest.MonkeyPatch) -> None:
    # _settle looks again at the candidates left when the one accepted did
    # not hold its gain in its full fit: one its cross-validation rejected
    # the first time is not cross-validated again (the same fits of the
    # same data), nor is the model they extend; one not cross-validated yet
    # is, against that model's kept value.
    calls: list[tuple[str, ...]] = []

    def fake_cv(datasets: Any, effects: Any, start: Any, pool: Any = None, held: Any = None) -> float:
        added = tuple(e for e in effects if e not in ("heat_transfer", "real_gas"))
        calls.append(added)
        return {(): 100.0, ("friction",): 150.0, ("leakage",): 50.0, ("sensor_lag",): 90.0}[added]

    nulls: list[tuple[str, ...]] = []

    def fake_null(datasets: Any, c: Any) -> float:
        nulls.append(c.effects)
        return 5.0  # below BIC_STRONG: the candidate does not show itself

    monkeypatch.setattr(diagnose_module, "_full_fit", lambda datasets, current, effects, c: SimpleNamespace(effects=c.effects))
    monkeypatch.setattr(diagnose_module, "cross_validation", fake_cv)
    monkeypatch.setattr(diagnose_module, "_with_errors", lambda datasets, c: None)
    monkeypatch.setattr(diagnose_module, "shape_values", lambda result: {})
    monkeypatch.setattr(diagnose_module, "_null_delta_bic", fake_null)
    weak = ("valve_lag",)
    monkeypatch.setattr(diagnose_module.Candidate, "shows_itself",
                        property(lambda self: self.effects != weak or (self.null_delta_bic or 0.0) > diagnose_module.BIC_STRONG))

    def candidate(add: tuple[str, ...], delta_bic: float) -> Any:
        result = SimpleNamespace(model=SimpleNamespace(flexible=False), values={}, stopped=False, covariance=None, covariance_iid=None, n=1000)
        return diagnose_module.Candidate(add, 1, result, delta_bic, 0.5)  # type: ignore[arg-type]

    friction, leakage, weakest, lag = (candidate(("friction",), 900.0), candidate(("leakage",), 800.0), candidate(weak, 700.0),
                                       candidate(("sensor_lag",), 600.0))
    current = SimpleNamespace(values={}, model=SimpleNamespace(flexible=False))
    clock = diagnose_module._Clock(lambda _m: None, 1)
    with ThreadPoolExecutor(max_workers=2) as pool:
        first = diagnose_module._accept([], current, ("heat_transfer", "real_gas"), [friction, leakage, weakest], clock, pool)  # type: ignore[arg-type]
        assert first is leakage and friction.cv_improves is False
        assert sorted(calls) == [(), ("friction",), ("leakage",)] and nulls == []
        calls.clear()
        # leakage's full fit did not hold its gain: the rest, looked at again.
        leakage.refit_delta_bic = 3.0
        again = diagnose_module._accept([], current, ("heat_transfer", "real_gas"), [friction, weakest], clock, pool)  # type: ignore[arg-type]
        assert again is None
        assert calls == [] and nulls == [weak]
        # With a candidate not cross-validated yet among the three looked at.
        second = diagnose_module._accept([], current, ("heat_transfer", "real_gas"), [friction, weakest, lag], clock, pool)  # type: ignore[arg-type]
        assert second is lag and lag.cv_before == 100.0 and lag.cv_after == 90.0
        assert calls == [("sensor_lag",)]
        assert nulls == [weak]  # its evidence at the null is not fitted again either
        # The model they extend as cross-validated before, given (the
        # singles' for the pairs, or the one refused after its full fit).
        calls.clear()
        pair = candidate(("sensor_lag", "friction"), 500.0)

        def pair_cv(datasets: Any, effects: Any, start: Any, pool: Any = None, held: Any = None) -> float:
            calls.append(tuple(e for e in effects if e not in ("heat_transfer", "real_gas")))
            return 80.0 if calls[-1] == pair.effects else 100.0

        monkeypatch.setattr(diagnose_module, "cross_validation", pair_cv)
        third = diagnose_module._accept([], current, ("heat_transfer", "real_gas"), [pair], clock, pool, cv_before=100.0)  # type: ignore[arg-type]
    assert third is pair and pair.cv_before == 100.0 and pair.cv_after == 80.0
    assert calls == [("sensor_lag", "friction")]


def test_the_rounds_tail_is_told_by_the_candidate_that_gained_not_by_the_mean_fit(monkeypatch: pytest.MonkeyPatch) -> None:
    # What follows the screenings (cross-validation and the accepted
    # model's fit) was ACCEPT_FITS of the round's mean fit: where a costly
    # candidate that is not the answer set the mean (oil compliance's stiff
    # runs on the bundled heat run) it said 86 s where 28 s were (stop 78).
    # Once a candidate gains, the tail is its own screening's time: a share
    # of a screening that ran to its end. After a first screening
    # Broyden's updates ended at the share (started from the Jacobian of the
    # model it extends, so faster than its second screening by far more on
    # the heat run than on the campaign: 21 x and 5.8 x, stop 81), its runs
    # of the model, with its second screening still to come until it ends.
    now = [100.0]
    monkeypatch.setattr(diagnose_module.time, "perf_counter", lambda: now[0])
    lines: list[str] = []
    clock = diagnose_module._Clock(lines.append, 2)
    clock.new_round(1)
    clock.first_fit_s = 10.0

    def candidate(effect: str, delta_bic: float, at_share: bool = False) -> Any:
        return diagnose_module.Candidate((effect,), 1, SimpleNamespace(), delta_bic, ended_at_share=at_share)  # type: ignore[arg-type]

    # Nothing gained yet: the mean fit's ACCEPT_FITS.
    assert clock.tail_s() is None
    assert clock.after_screenings_s() == pytest.approx(10.0 * clock.ACCEPT_FITS)
    # A costly candidate without a gain changes nothing; a cheap one that
    # gained tells the tail by its own time, whatever the others took.
    clock.screened(candidate("oil_compliance", -5.0), 90.0)
    assert clock.tail_s() is None
    clock.screened(candidate("leakage", 500.0), 4.0)
    assert clock.tail_s() == pytest.approx(clock.TAIL_SHARE * 4.0)
    clock.fits, clock.fit_wall_s = 2, 94.0
    clock.tell("candidate 2/3 (leakage) fitted", 1.0)
    assert lines[-1].endswith(f"about {diagnose_module._fmt_s(47.0 + clock.TAIL_SHARE * 4.0)} left in this round"), lines
    # The best-scored candidate that gained is the one told by.
    clock.screened(candidate("heat_buildup", 9_000.0, at_share=True), 6.0, 0.25)
    first = clock.TAIL_AFTER_SHARE_RUNS * 0.25
    rescreen = clock.RESCREEN_RUNS * 0.25
    assert clock.tail_s() == pytest.approx(first + rescreen)
    # Told by its run, not by how long its first screening took.
    clock.screened(candidate("heat_buildup", 9_000.0, at_share=True), 60.0, 0.25)
    assert clock.tail_s() == pytest.approx(first + rescreen)
    # Its second screening counted down from when it began, as
    # running_credit counts a fit: run as long as expected, half is left;
    # never nothing while it runs.
    clock.rescreen_began[("heat_buildup",)] = now[0]
    now[0] += rescreen
    assert clock.tail_s() == pytest.approx(first + rescreen / 2)
    # It runs beside the screenings still running: only their time beyond
    # its own adds to the tail.
    assert clock.beside_s() == pytest.approx(rescreen / 2)
    clock.tell("candidate 3/4 (friction) fitted", 0.0, running_s=100.0)
    assert lines[-1].endswith(f"about {diagnose_module._fmt_s(100.0 + first)} left in this round"), lines
    clock.tell("candidate 3/4 (friction) fitted", 0.0, running_s=rescreen / 4)
    assert lines[-1].endswith(f"about {diagnose_module._fmt_s(first + rescreen / 2)} left in this round"), lines
    now[0] += 1000.0
    assert first < clock.tail_s() < first + rescreen / 10
    assert clock.tail_s(("heat_buildup",), rescreened=True) == pytest.approx(first)
    assert clock.tail_s(("leakage",)) == pytest.approx(clock.TAIL_SHARE * 4.0)
    # One ended at the share whose run was not timed tells nothing: the
    # round's rate says the tail while it is the best.
    clock.screened(candidate("sensor_lag", 20_000.0, at_share=True), 5.0)
    assert clock.tail_s() is None and clock.tail_s(("sensor_lag",), rescreened=True) is None
    assert clock.after_screenings_s() == pytest.approx(clock.per_fit_s() * clock.ACCEPT_FITS)
    # Another round's candidates are new.
    clock.new_round(2)
    assert clock.round == 2 and clock.tail_s() is None and not clock.rescreen_began


def test_the_tail_said_as_each_step_of_the_acceptance_begins(monkeypatch: pytest.MonkeyPatch) -> None:
    # _accept and _settle with stand-in fits: the cross-validation's line
    # says the candidate's whole tail, the full fit's FULL_FIT_SHARE of it;
    # a candidate never screened (no time noted) falls back to the rate.
    monkeypatch.setattr(diagnose_module, "_with_errors", lambda datasets, c: None)
    monkeypatch.setattr(diagnose_module, "design_effect", lambda result, *effects: 1.0)
    monkeypatch.setattr(diagnose_module.Candidate, "shows_itself", property(lambda self: True))
    monkeypatch.setattr(diagnose_module, "cross_validation", lambda *a, **k: 90.0 if "leakage" in a[1] else 100.0)
    full = SimpleNamespace(bic=-1000.0, rss=1.0)
    monkeypatch.setattr(diagnose_module, "_full_fit", lambda *a: full)
    monkeypatch.setattr(diagnose_module, "at_own_noise", lambda result: SimpleNamespace(rss=1.0, rms_ratio=1.0))
    monkeypatch.setattr(diagnose_module, "explained_share", lambda judged, rss: 1.0)
    lines: list[str] = []
    clock = diagnose_module._Clock(lines.append, 1)
    clock.new_round(1)
    clock.first_fit_s = 1000.0  # the rate: far from the tail said
    result = SimpleNamespace(model=SimpleNamespace(flexible=False), values={}, stopped=False, covariance=None, covariance_iid=None, n=1000)
    leak = diagnose_module.Candidate(("leakage",), 1, result, 900.0, 0.9)  # type: ignore[arg-type]
    clock.screened(leak, 40.0)
    current = SimpleNamespace(values={}, model=SimpleNamespace(flexible=False), bic=0.0)
    with ThreadPoolExecutor(max_workers=2) as pool:
        accepted, _ = diagnose_module._settle([], current, SimpleNamespace(rss=2.0, rms_ratio=2.0), ("heat_transfer",), [leak], clock,  # type: ignore[arg-type]
                                              pool, {}, {})
    assert accepted is leak
    cv = [m for m in lines if "cross-validating leakage" in m]
    fitting = [m for m in lines if "fitting the model with leakage" in m]
    assert cv and cv[0].endswith(f"about {diagnose_module._fmt_s(clock.TAIL_SHARE * 40.0)} left in this round"), lines
    assert fitting and fitting[0].endswith(f"about {diagnose_module._fmt_s(clock.FULL_FIT_SHARE * clock.TAIL_SHARE * 40.0)} left in this round"), lines


def test_a_second_look_does_not_weigh_again_nor_say_a_refusal_twice(monkeypatch: pytest.MonkeyPatch) -> None:
    # A candidate whose gain, counted by its residual's design effect, was
    # refused in _settle's first look is refused again in its second
    # without its errors computed again and without a second "not
    # accepted" line (stop 77 noticed the line repeated).
    weighed: list[tuple[str, ...]] = []

    def fake_errors(datasets: Any, c: Any) -> None:
        weighed.append(c.effects)

    monkeypatch.setattr(diagnose_module, "_with_errors", fake_errors)
    monkeypatch.setattr(diagnose_module, "design_effect", lambda result, *effects: 1_000.0 if effects == ("sensor_offset",) else 1.0)
    monkeypatch.setattr(diagnose_module, "offset_delta_bic", lambda current: 500.0)
    monkeypatch.setattr(diagnose_module.Candidate, "shows_itself", property(lambda self: True))
    monkeypatch.setattr(diagnose_module, "cross_validation", lambda datasets, effects, *a, **k: 90.0 if "leakage" in effects else 100.0)
    monkeypatch.setattr(diagnose_module, "shape_values", lambda result: {})
    monkeypatch.setattr(diagnose_module, "_full_fit", lambda datasets, current, effects, c: SimpleNamespace(effects=c.effects))
    result = SimpleNamespace(model=SimpleNamespace(flexible=False), values={}, stopped=False, covariance=None, covariance_iid=None, n=1000)
    offset = diagnose_module.Candidate(("sensor_offset",), 3, result, 900.0, 0.5)  # type: ignore[arg-type]
    leak = diagnose_module.Candidate(("leakage",), 1, result, 800.0, 0.5)  # type: ignore[arg-type]
    current = SimpleNamespace(values={}, model=SimpleNamespace(flexible=False))
    lines: list[str] = []
    clock = diagnose_module._Clock(lines.append, 1)
    with ThreadPoolExecutor(max_workers=2) as pool:
        first = diagnose_module._accept([], current, ("heat_transfer", "real_gas"), [offset, leak], clock, pool)  # type: ignore[arg-type]
        assert first is leak
        assert offset.scaled_delta_bic is not None and offset.scaled_delta_bic <= diagnose_module.BIC_STRONG
        again = diagnose_module._accept([], current, ("heat_transfer", "real_gas"), [offset], clock, pool)  # type: ignore[arg-type]
    assert again is None
    assert weighed == [("sensor_offset",), ("leakage",)]
    refused = [m for m in lines if "sensor_offset not accepted" in m]
    assert len(refused) == 1, lines

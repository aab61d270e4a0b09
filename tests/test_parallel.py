"""The parallel runners: the thread count is bounded (0 = all cores, at
most 4 x the cores, a ParameterError otherwise), and Ctrl-C stops a batch
between cases instead of after all of them."""

from __future__ import annotations

import re
import signal
import subprocess
import sys
import textwrap

import pytest

import hpctl
from hpctl import _core
from hpctl.sim.run import run_many


def _max_threads() -> int:
    with pytest.raises(hpctl.ParameterError) as e:
        run_many([], threads=10**6)
    m = re.search(r"from 0 \(all (\d+) cores\) to (\d+) \(4 x the cores\)", str(e.value))
    assert m, str(e.value)
    cores, most = int(m.group(1)), int(m.group(2))
    assert most == 4 * cores
    return most


def test_thread_counts_are_bounded() -> None:
    most = _max_threads()
    assert run_many([], threads=0) == [] and run_many([], threads=most) == [] and run_many([], threads=None) == []
    for bad in (most + 1, -1, 10**30, True, 1.5, "2"):
        with pytest.raises(hpctl.ParameterError, match="threads = "):
            run_many([], threads=bad)  # type: ignore[arg-type]
        with pytest.raises(hpctl.ParameterError, match="threads = "):
            _core.closed_loop_many([], bad)  # type: ignore[arg-type]


def test_cases_must_be_a_list() -> None:
    with pytest.raises(hpctl.ParameterError, match="cases = .*: expected a list of case dicts"):
        _core.simulate_many(({},), None)  # type: ignore[arg-type]


@pytest.mark.parametrize("runner", [_core.simulate_many, _core.closed_loop_many, _core.vehicle_run_many])
def test_a_bad_case_is_named_by_its_place_in_the_list(runner: object) -> None:
    # Every parallel runner reads its list the same way (hp-py exec::parse_cases).
    with pytest.raises(hpctl.ParameterError, match=r"cases\[0\] must be a dict"):
        runner([3], None)  # type: ignore[operator]
    with pytest.raises(hpctl.ParameterError, match=r"missing key cases\[0\]\."):
        runner([{"no_such_key": 1}], None)  # type: ignore[operator]


def test_an_error_inside_a_case_gets_the_case_path() -> None:
    # The case's own check (no output times) does not know its place in
    # the list: the runner puts it in front, keeping the exception's class.
    from hpctl.sim.run import _case, characterisation_rig

    good = _case(hpctl.Unit.seed(), characterisation_rig(hpctl.Sine(0.01, 1.0)), [0.0, 0.1], spring_hard=True, damper_on=True,
                 dt_s=None, rtol=1e-6, ambient_k=None, channels=["time_s"])
    empty = dict(good, times_s=[])
    with pytest.raises(hpctl.ParameterError, match=r"^cases\[1\]: times_s is empty"):
        _core.simulate_many([good, empty], None)


def test_ctrl_c_stops_a_batch_between_cases() -> None:
    script = textwrap.dedent("""
        # A terminal delivers Ctrl-C to a process whose SIGINT is at its default;
        # a parent that ignores SIGINT (a background job of a non-interactive
        # shell, as CI may be) passes SIG_IGN on, and Python then never raises
        # KeyboardInterrupt. Start from what the user's terminal gives.
        import signal
        signal.signal(signal.SIGINT, signal.default_int_handler)
        import time
        import hpctl
        from hpctl.sim.run import Case, run_many, sdof_rig, uniform_times
        unit = hpctl.Unit.seed()
        case = Case(unit, sdof_rig(hpctl.Step(0.04)), uniform_times(200.0, 0.01))
        t0 = time.monotonic()
        run_many([case], threads=1)
        one = time.monotonic() - t0
        print(f"ready {one}", flush=True)
        t0 = time.monotonic()
        try:
            run_many([case] * 200, threads=1)
            print(f"finished {time.monotonic() - t0}", flush=True)
        except KeyboardInterrupt:
            print(f"interrupted {time.monotonic() - t0}", flush=True)
    """)
    p = subprocess.Popen([sys.executable, "-c", script], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    assert p.stdout is not None
    line = p.stdout.readline().split()
    assert line and line[0] == "ready", p.stderr.read() if p.stderr else ""
    one_case_s = float(line[1])
    # Let a few cases run, then Ctrl-C.
    try:
        p.wait(timeout=3 * one_case_s + 0.5)
    except subprocess.TimeoutExpired:
        pass
    p.send_signal(signal.SIGINT)
    out, err = p.communicate(timeout=120)
    what, elapsed = out.split()
    assert what == "interrupted", (out, err)
    # Stopped within the running case (plus the 0.1 s polling), far from
    # the 200 cases' worth.
    assert float(elapsed) < 3 * one_case_s + 0.5 + 3 * one_case_s + 1.0
    assert float(elapsed) < 0.5 * 200 * one_case_s

"""The judgement counts a rig clock's sample-time jitter as noise, and
nothing else (hpctl.identify.diagnose.judge, _jitter_counted).

A fit of hpctl's virtual rig's SDOF step at the noise is given a
measurement sampled at jittered instants (tests/foreign_rig/sensors.py's
clock, which shares no code with hpctl), or a smooth error of the same size
instead. Drawn anew on every run: HPCTL_TEST_SEED replays a draw.
"""

from __future__ import annotations

import json
import os
import secrets
from dataclasses import replace

import numpy as np
import pytest
from scipy.interpolate import CubicSpline

from foreign_rig.sensors import jittered
from hpctl.identify import diagnose as dg
from hpctl.identify.fit import FitResult, residual_vector
from hpctl.identify.signals import derivative, rate_noise

CHANNEL = "body_disp_m"


@pytest.fixture
def seed() -> int:
    return int(os.environ.get("HPCTL_TEST_SEED", secrets.randbelow(2**31)))


def measured_as(result: FitResult, measurement: np.ndarray) -> FitResult:
    """``result`` with its SDOF body measured as ``measurement``."""
    d = result.datasets[0]
    datasets = [replace(d, targets={**d.targets, CHANNEL: measurement})]
    r = residual_vector(datasets, result.sims)
    return replace(result, datasets=datasets, rss=float(r @ r))


def clock_jittered(at_noise: FitResult, jitter_s: float = 1.5e-4, seed: int = 7) -> FitResult:
    """``at_noise`` with its SDOF body measured at instants a clock of
    ``jitter_s`` scatters, the record's own noise kept."""
    d, sim = at_noise.datasets[0], at_noise.sims[0]
    assert not isinstance(sim, Exception)
    t, model = d.times_s, np.asarray(sim[CHANNEL])
    late = CubicSpline(t, model)(jittered(t, jitter_s, np.random.default_rng(seed), float(t[-1])))
    return measured_as(at_noise, late + d.targets[CHANNEL] - model)


def test_a_clock_jitter_is_counted_in_the_noise_and_said(at_noise: FitResult, seed: int) -> None:
    rng = np.random.default_rng(seed)
    # From 100 us (1.46 x the noise without it at the least in 100 draws):
    # at 60-80 us the channel read from 1.20 and 1.32 x, too near the
    # ceiling for "above the noise without it" to hold.
    jitter_s = float(np.exp(rng.uniform(np.log(1e-4), np.log(2e-4))))
    d, sim = at_noise.datasets[0], at_noise.sims[0]
    assert not isinstance(sim, Exception)
    t = d.times_s
    model = np.asarray(sim[CHANNEL])
    noise = d.targets[CHANNEL] - model  # the record's own noise, kept
    late = CubicSpline(t, model)(jittered(t, jitter_s, rng, float(t[-1])))
    result = measured_as(at_noise, late + noise)
    raw = dg.analyse(result)
    row = next(r for r in raw.rows if r.channel == CHANNEL)
    j = dg.judge(result, raw)
    context = f"seed={seed} jitter={jitter_s * 1e6:.1f} us raw={row.rms_ratio:.3f} {j.describe()}"
    # Without the jitter the channel is above the noise; counted, it is at it.
    assert row.rms_ratio > dg.NOISE_CEILING, context
    assert j.at_noise and not j.places, context
    [counted] = j.jitter
    assert (counted.record, counted.channel) == (d.name, CHANNEL) and counted.rms_ratio_without == pytest.approx(row.rms_ratio), context
    assert counted.rms_ratio <= j.worst_rms_ratio <= dg.NOISE_CEILING, context
    # The pooled residual is judged in the same weights.
    assert j.rms_ratio < result.rms_ratio, context
    # What it reads is the clock's, to the scatter of a reading that rests
    # on the step's few dozen fastest samples: 0.63-1.54 x the drawn jitter
    # in 400 draws of 60-200 us on this record (5-95 %: 0.78-1.24; 12 of
    # them more than three of the reading's own errors off, whose normal
    # formula the few samples make optimistic; 0.67-1.23 in 100 draws each
    # at 100 and 200 us with the base's noise in the weights).
    assert 0.5 <= counted.jitter_s / jitter_s <= 2.0, context
    # Said in the text and the JSON, with the ratio without it.
    assert "sample-time jitter" in j.describe() and f"{row.rms_ratio:.3g}x" in j.describe(), context
    out = j.to_json()
    assert out["jitter"][0]["jitter_s"] == counted.jitter_s and out["jitter"][0]["rms_ratio_without"] == row.rms_ratio, context
    json.dumps(out)
    # And a warning: the verdict rests on a reading of the residual itself.
    from hpctl.cli.calibrate import _diagnosis_caveats

    diag = dg.Diagnosis(("heat_transfer", "real_gas"), [], result, raw, "nothing_left", [], j)
    [warned] = [c for c in _diagnosis_caveats(diag) if c.code == "jitter_counted"]
    assert warned.details["channels"] == [f"{d.name}/{CHANNEL}"] and warned.details["rms_ratio_without"] == [row.rms_ratio], context
    assert not [c for c in _diagnosis_caveats(diag) if c.code == "residual_structured"], context
    json.dumps(warned.to_json())


def test_a_smooth_error_at_speed_is_not_counted_as_noise(at_noise: FitResult, seed: int) -> None:
    # The same excess made by the model instead (its rate squared, as a
    # damper's missed quadratic term): smooth in time, so structure remains.
    rng = np.random.default_rng(seed)
    d, sim = at_noise.datasets[0], at_noise.sims[0]
    assert not isinstance(sim, Exception)
    v = derivative(d.times_s, np.asarray(sim[CHANNEL]))
    # 8-12 x the noise at the fastest: above the ceiling over the record.
    # It was 6-10 x (3.9 x read 1.25 x once the base's noise was in the
    # weights, stop 48); with the drive's velocity no longer taken across
    # the step's corners (stop 49) the fit's own residual is smaller, and
    # over 300 draws every size below 6.9 x was judged at the noise (worst
    # channel 1.23-1.29 x: the error lives on the few fast samples, so the
    # channel's lag-1 autocorrelation stays under 0.5) and every size from
    # 6.94 x was not: the test's premise, an error the record shows, no
    # longer held for a fifth of its draws (HPCTL_TEST_SEED=2101885049).
    # What the channel's ratio cannot show there, the regimes' split does
    # (the verdict's "fast"), which the judgement does not yet judge by.
    size_m = float(rng.uniform(8.0, 12.0)) * d.sigma[CHANNEL]
    result = measured_as(at_noise, d.targets[CHANNEL] - size_m * (v / np.max(np.abs(v))) ** 2)
    j = dg.judge(result)
    context = f"seed={seed} size={size_m:.3g} m {j.describe()}"
    assert j.structure_remains and not j.jitter, context
    assert j.places[0].channel == CHANNEL, context


def test_a_jitter_too_large_for_a_clock_is_not_counted(at_noise: FitResult, monkeypatch: pytest.MonkeyPatch) -> None:
    # Counted only while a small share of the sampling interval: with the
    # share set below what is read, the channel is a place again, its text
    # still saying what the jitter would make of it.
    result = clock_jittered(at_noise)
    assert dg.judge(result).jitter
    monkeypatch.setattr(dg, "JITTER_MAX_DT_SHARE", 1e-3)
    j = dg.judge(result)
    assert j.structure_remains and not j.jitter, j.describe()
    assert j.places[0].rate_noise is not None and "sample-time jitter" in j.places[0].describe(), j.describe()


def test_a_jitter_longer_than_the_sampling_interval_is_not_said(at_noise: FitResult) -> None:
    # A channel the model barely moves (the foreign rig's large accumulator
    # behind a closed valve 6) can carry an excess that follows its tiny
    # rate's pattern: the jitter that would make it is then absurd ("2.04e+17
    # us" on a foreign classical diagnosis, stop 71). Here the clock's 150 us
    # residual is kept while the model's channel moves a billionth as much:
    # the reading is 1e9 times longer, beyond the 5 ms sampling interval, so
    # the place says nothing of a jitter (the same residual with the real
    # motion still reads one: the previous test).
    moving = clock_jittered(at_noise)  # the previous test's measurement
    d, sim = at_noise.datasets[0], at_noise.sims[0]
    assert not isinstance(sim, Exception)
    t = d.times_s
    model = np.asarray(sim[CHANNEL])
    still = 1e-9 * model
    shifted = replace(moving.datasets[0], targets={**d.targets, CHANNEL: moving.datasets[0].targets[CHANNEL] - model + still})
    result = replace(moving, datasets=[shifted], sims=[{**sim, CHANNEL: still}])
    # The same residual (to rounding), so the same rss; only the rate is tiny.
    assert np.allclose(result.residuals(0, CHANNEL), moving.residuals(0, CHANNEL), rtol=0.0, atol=1e-9 * d.sigma[CHANNEL])
    dt_s = float(np.median(np.diff(t)))
    read = rate_noise(result.residuals(0, CHANNEL), d.weight_sigma[CHANNEL], derivative(t, still))
    assert read is not None and read.jitter_s > 1e3 * dt_s  # what the hint said before
    j = dg.judge(result)
    assert j.structure_remains and not j.jitter, j.describe()
    [place] = [p for p in j.places if p.channel == CHANNEL]
    assert place.rate_noise is None and "jitter" not in place.describe() and place.to_json()["rate_noise"] is None, j.describe()


def beside_a_faster_record(result: FitResult, at_noise: FitResult, interval_s: float) -> FitResult:
    """``result`` judged with a second record of the same rig sampled every
    ``interval_s``: ``at_noise``'s unjittered step on a compressed time
    axis, its residual at the noise."""
    d, sim = at_noise.datasets[0], at_noise.sims[0]
    dt_s = float(np.median(np.diff(d.times_s)))
    fast = replace(d, record=replace(d.record, name="fast"), times_s=d.times_s * (interval_s / dt_s))
    datasets, sims = [result.datasets[0], fast], [result.sims[0], sim]
    r = residual_vector(datasets, sims)
    return replace(result, datasets=datasets, sims=sims, rss=float(r @ r), n=len(r))


def test_a_jitter_is_bounded_by_the_fastest_record_of_the_rig(at_noise: FitResult) -> None:
    # A rig's clock scatters by a time, not by a share of the interval each
    # record is logged at: the jitter counted on one record is bounded by a
    # tenth of the fastest record's interval (stop 72: the foreign control,
    # seed 9, rested "nothing left" on 500.6 us read from a 0.3 Hz sine
    # sampled every 5 ms, where the rig's clock drew 60 us). The previous
    # tests' 150 us on the 5 ms step: counted beside a record sampled every
    # 2 ms (a bound of 200 us), not beside one sampled every 1 ms (100 us),
    # where the step is a place again whose text still says the jitter.
    jittered_step = clock_jittered(at_noise)
    beside_slow = dg.judge(beside_a_faster_record(jittered_step, at_noise, 2e-3))
    assert [(c.record, c.channel) for c in beside_slow.jitter] == [(jittered_step.datasets[0].name, CHANNEL)], beside_slow.describe()
    assert not beside_slow.structure_remains, beside_slow.describe()
    beside_fast = dg.judge(beside_a_faster_record(jittered_step, at_noise, 1e-3))
    assert beside_fast.structure_remains and not beside_fast.jitter, beside_fast.describe()
    place = beside_fast.places[0]
    assert (place.channel, place.record) == (CHANNEL, jittered_step.datasets[0].name), beside_fast.describe()
    assert place.rate_noise is not None and 1e-4 < place.rate_noise.jitter_s < 2e-4, beside_fast.describe()
    assert dg.fastest_interval_s(beside_a_faster_record(jittered_step, at_noise, 1e-3).datasets) == pytest.approx(1e-3)

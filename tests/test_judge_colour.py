"""The judgement counts a noise colour the records suggest, and nothing
else (hpctl.identify.diagnose.judge, _colour_counted).

A fit of hpctl's virtual rig's SDOF step at the noise is given, on top of
the record's own noise, a correlated noise drawn with SciPy's lfilter (an
exact AR(1) in the samples: the Ornstein-Uhlenbeck process, independent of
hpctl's code), or a smooth error of the same size instead, with the
record's datasets saying the records suggest that colour. Drawn anew on
every run: HPCTL_TEST_SEED replays a draw.
"""

from __future__ import annotations

import json
import math
import os
import secrets
from dataclasses import replace

import numpy as np
import pytest
from scipy.signal import lfilter

from hpctl.identify import diagnose as dg
from hpctl.identify.fit import FitResult, residual_vector
from hpctl.identify.signals import COLOUR_HINT_EVIDENCE, NoiseColour

CHANNEL = "body_disp_m"
@pytest.fixture
def seed() -> int:
    return int(os.environ.get("HPCTL_TEST_SEED", secrets.randbelow(2**31)))


def with_colour(result: FitResult, added: np.ndarray, colour: NoiseColour | None) -> FitResult:
    """``result`` with ``added`` on its SDOF body's measurement and, if
    given, ``colour`` suggested for that channel (what the record's level
    misses of it, as prepare() computes it)."""
    d = result.datasets[0]
    hint = {} if colour is None else {CHANNEL: (colour, colour.missed_var(d.interval_s))}
    datasets = [replace(d, targets={**d.targets, CHANNEL: d.targets[CHANNEL] + added}, noise_colour_hint=hint)]
    r = residual_vector(datasets, result.sims)
    return replace(result, datasets=datasets, rss=float(r @ r))


def ou(rng: np.random.Generator, n: int, dt_s: float, corr_time_s: float, sigma: float) -> np.ndarray:
    a = math.exp(-dt_s / corr_time_s)
    e = rng.normal(0.0, sigma * math.sqrt(1.0 - a * a), n + 2000)
    return np.asarray(lfilter([1.0], [1.0, -a], e))[2000:]


def drawn(at_noise: FitResult, seed: int) -> tuple[float, float, NoiseColour]:
    """The record's own level, a correlation time of 15-40 ms and a
    correlated part of 1.2-1.5 times the level (the channel then reads
    about 1.5-1.8 x its level): the colour the records suggest (evidence between
    the hint's and the established bar)."""
    rng = np.random.default_rng(seed)
    sigma = at_noise.datasets[0].sigma[CHANNEL]
    tau = float(rng.uniform(0.015, 0.04))
    coloured = sigma * float(rng.uniform(1.2, 1.5))
    return tau, coloured, NoiseColour(CHANNEL, sigma**2, coloured**2, tau, COLOUR_HINT_EVIDENCE + 2.0)


def judged(at_noise: FitResult, added: np.ndarray, colour: NoiseColour, seed: int
           ) -> tuple[FitResult, dg.ResidualReport, dg.ResidualRow, dg.Judgement, str]:
    """``at_noise`` with ``added`` and ``colour`` suggested (:func:`with_colour`),
    its analysis, the SDOF body's row, the judgement, and the context an
    assertion prints."""
    result = with_colour(at_noise, added, colour)
    raw = dg.analyse(result)
    row = next(r for r in raw.rows if r.channel == CHANNEL)
    j = dg.judge(result, raw)
    k = colour
    return result, raw, row, j, (f"seed={seed} tau={k.corr_time_s * 1e3:.1f} ms coloured={k.coloured_var**0.5:.3g} raw={row.rms_ratio:.3f} "
                                 f"{j.describe()}")


def test_a_noise_colour_the_records_suggest_is_counted_and_said(at_noise: FitResult, seed: int) -> None:
    from hpctl.cli.calibrate import _diagnosis_caveats

    d = at_noise.datasets[0]
    tau, coloured, colour = drawn(at_noise, seed)
    noise = ou(np.random.default_rng(seed + 1), len(d.times_s), d.interval_s, tau, coloured)
    result, raw, row, j, context = judged(at_noise, noise, colour, seed)
    # Without the colour the channel is above the noise; counted, at it.
    assert row.rms_ratio > dg.NOISE_CEILING, context
    assert j.at_noise and not j.places and not j.jitter, context
    [c] = j.colours
    assert (c.record, c.channel) == (d.name, CHANNEL) and c.rms_ratio_without == pytest.approx(row.rms_ratio), context
    assert 0.85 <= c.rms_ratio <= j.worst_rms_ratio <= dg.NOISE_CEILING and j.rms_ratio < result.rms_ratio, context
    far = math.ceil(3.0 * tau / d.interval_s)
    assert c.lags[0] == 1 and far <= c.lags[1] <= 4 * far, context
    # Said in the text, the JSON and a warning.
    assert "counting a noise colour" in j.describe() and f"{row.rms_ratio:.3g}x" in j.describe(), context
    out = j.to_json()
    assert out["colours"][0]["rms_ratio_without"] == row.rms_ratio and out["colours"][0]["colour"]["corr_time_s"] == tau, context
    json.dumps(out)
    diag = dg.Diagnosis(("heat_transfer", "real_gas"), [], result, raw, "nothing_left", [], j)
    [warned] = [w for w in _diagnosis_caveats(diag) if w.code == "colour_counted"]
    assert warned.details["channels"] == [f"{d.name}/{CHANNEL}"] and warned.details["rms_ratio_without"] == [row.rms_ratio], context
    json.dumps(warned.to_json())
    # The same noise with no colour suggested: structure remains.
    plain = dg.judge(with_colour(at_noise, noise, None))
    assert not plain.at_noise and not plain.colours and plain.places[0].colour_hint is None, context


def test_a_smooth_error_is_not_counted_as_a_suggested_colour(at_noise: FitResult, seed: int) -> None:
    # The same excess made by the model instead (a slow sine, as a missed
    # spring term would leave): smooth in time, so its autocorrelation
    # three to twelve correlation times on is its own, not the colour's. Structure
    # remains, and the place says what the colour would make of it.
    d = at_noise.datasets[0]
    tau, coloured, colour = drawn(at_noise, seed)
    rng = np.random.default_rng(seed + 2)
    t = d.times_s
    error = coloured * math.sqrt(2.0) * np.sin(2.0 * math.pi * float(rng.uniform(0.5, 2.0)) * t + float(rng.uniform(0.0, 2.0 * math.pi)))
    _result, _raw, row, j, context = judged(at_noise, error, colour, seed)
    assert row.rms_ratio > dg.NOISE_CEILING, context
    assert not j.at_noise and not j.colours, context
    [place] = [p for p in j.places if p.channel == CHANNEL]
    assert place.colour_hint is not None and place.colour_hint[0] == colour, context
    assert "do not establish" in place.describe() and place.to_json()["noise_colour_hint"]["rms_ratio"] == place.colour_hint[1], context

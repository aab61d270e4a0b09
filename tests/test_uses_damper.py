"""When a fit identifies the damper (its characteristic with ``--flexible``,
its gain without): wherever the strut moves fast, or wherever a record's
force shows the template's damper above three times its noise
(:func:`hpctl.identify.dataset.uses_damper`, stop 67). Speed alone held the
damper at the template's on slow sines whose force it dominated, and the
friction took the difference (tests/test_diagnose_foreign.py has the
foreign rig's case). Records of hp-core's virtual rig: what is tested here
is the criterion, on records whose damper and noise are known."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest

from hpctl.identify.dataset import (
    DAMPER_MEASURABLE_NOISES,
    DAMPER_WORKING_SPEED_M_S,
    Dataset,
    damper_moves_fast,
    measured_datasets,
    uses_damper,
)
from hpctl.identify.fit import model_for
from hpctl.identify.virtual_rig import Noise, make_records, sweep_tests
from hpctl.model.unit import Unit

SINES = {t.name: t for t in sweep_tests()}


def dataset(name: str, force_noise_n: float = 30.0) -> Dataset:
    (rec,) = make_records(Unit.seed(), tests=[SINES[name]], noise=Noise(force_n=force_noise_n), seed=3)
    (d,) = measured_datasets([rec])
    return d


def template_force_n(d: Dataset) -> float:
    """The template's damper force at the record's 95th-percentile speed
    with valve 5 open (the sweep's state), from hp-core's curve."""
    v95 = float(np.percentile(np.abs(d.strut_vel_m_s), 95))
    return float(d.base.damper.force_n([v95], d.base.piston_area_m2, damper_on=False)[0])


def test_a_slow_sine_whose_force_shows_the_damper_identifies_it() -> None:
    d = dataset("sine_0.1hz")
    # 38 mm/s: below the speed that used to decide, the template's 360 N
    # against 30 N of noise.
    assert np.percentile(np.abs(d.strut_vel_m_s), 95) < DAMPER_WORKING_SPEED_M_S
    assert template_force_n(d) > DAMPER_MEASURABLE_NOISES * d.sigma["force_n"] > 0.0
    assert not damper_moves_fast([d]) and uses_damper([d])
    model = model_for([d], ("heat_transfer",), flexible=True)
    assert model.fit_damper and any(p.name.startswith("damper_off_") for p in model.params)
    assert "damper_gain" in {p.name for p in model_for([d], ("heat_transfer",)).params}


def test_a_sine_too_slow_for_its_noise_leaves_the_damper_held() -> None:
    d = dataset("sine_0.01hz")
    # 3.8 mm/s: the template's 30 N is under three noises of 30 N.
    assert template_force_n(d) < DAMPER_MEASURABLE_NOISES * d.sigma["force_n"]
    assert not uses_damper([d])
    assert not any(p.name.startswith("damper_") for p in model_for([d], ("heat_transfer",), flexible=True).params)
    # The same sine measured by a quieter load cell shows the damper.
    assert uses_damper([dataset("sine_0.01hz", force_noise_n=1.0)])


def test_a_fast_sine_identifies_the_damper_by_its_speed() -> None:
    d = dataset("sine_1hz")
    assert damper_moves_fast([d]) and uses_damper([d])


@pytest.mark.parametrize("case", ["no force channel", "force noise not finite"])
def test_without_a_force_noise_to_judge_by_speed_decides(case: str) -> None:
    d = dataset("sine_0.1hz")
    if case == "no force channel":
        d = replace(d, targets={c: y for c, y in d.targets.items() if c != "force_n"})
    else:
        d = replace(d, sigma={**d.sigma, "force_n": math.nan})
    assert not uses_damper([d])
    # One record that shows it is enough.
    assert uses_damper([d, dataset("sine_0.1hz")])

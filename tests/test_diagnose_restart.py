"""A screening fit that ends worse than the model it extends starts again
next to where the effect does nothing, but only from a start better than
where it ended (:func:`hpctl.identify.diagnose._try`).

Virtual-rig records without any undeclared effect, drawn anew on each run
(the seed is printed on failure, HPCTL_TEST_SEED replays it).
"""

from __future__ import annotations

import dataclasses
import os
import secrets
from collections.abc import Sequence
from typing import Any

import numpy as np
import pytest

from hpctl.identify import diagnose as dg
from hpctl.identify import virtual_rig
from hpctl.identify.dataset import Dataset, prepare
from hpctl.identify.fit import FitResult, fit, rss_at
from hpctl.model.effects import LIBRARY
from hpctl.model.unit import Unit

SEED_MODEL = ("heat_transfer", "real_gas")


@pytest.fixture
def seed() -> int:
    return int(os.environ.get("HPCTL_TEST_SEED", secrets.randbelow(2**31)))


def complete_model_data(seed: int) -> tuple[list[Dataset], FitResult]:
    rng = np.random.default_rng(seed)
    tau = virtual_rig.effect_values(["heat_transfer"], rng)["tau_s"]
    truth = virtual_rig.truth_unit([], {}, template=Unit.seed().replace(tau_s=tau))
    records = virtual_rig.make_records(truth, tests=virtual_rig.tests_for([]), seed=int(rng.integers(2**31)))
    datasets = prepare(records)
    return datasets, fit(datasets, SEED_MODEL, input_noise=False)


def null_start(effect: str, current: FitResult) -> dict[str, float]:
    nulls = {p.name: v for p in LIBRARY[effect].params if (v := p.null_start()) is not None}
    return {**current.values, **nulls}


def test_the_model_at_a_true_null_is_the_one_it_extends_and_oil_compliances_is_not(seed: int) -> None:
    datasets, current = complete_model_data(seed)
    # Sensor offsets of zero: the same model, the same residuals.
    at_null = rss_at(datasets, SEED_MODEL + ("sensor_offset",), null_start("sensor_offset", current))
    assert at_null == pytest.approx(current.rss, rel=1e-9), f"seed={seed}"
    # Oil compliance at its stiffest (3 GPa, 1 L of oil) still compresses
    # the oil enough to move the gas pressure by many times its noise
    # (measured 5,200-8,200 x the residual sum of squares on three draws).
    at_oil_null = rss_at(datasets, SEED_MODEL + ("oil_compliance",), null_start("oil_compliance", current))
    assert at_oil_null > 100 * current.rss, f"seed={seed}: {at_oil_null / current.rss}"


@pytest.mark.parametrize("effect, restarts", [("sensor_offset", True), ("oil_compliance", False)])
def test_a_screening_fit_restarts_only_from_a_better_start(effect: str, restarts: bool, seed: int, monkeypatch: pytest.MonkeyPatch) -> None:
    datasets, current = complete_model_data(seed)
    calls: list[dict[str, float] | None] = []

    def first_fit_ends_worse(ds: Sequence[Dataset], effects: Sequence[str], **kwargs: Any) -> FitResult:
        calls.append(kwargs.get("initial"))
        if len(calls) == 1:
            # A first fit that did not get back to the model it extends.
            return dataclasses.replace(current, rss=1.5 * current.rss)
        return fit(ds, effects, **kwargs)

    monkeypatch.setattr(dg, "fit", first_fit_ends_worse)
    c = dg._try(datasets, current, SEED_MODEL, (effect,))
    assert len(calls) == (2 if restarts else 1), f"seed={seed}: {calls}"
    if restarts:
        # Started at the null, and kept: it came back to the model it extends.
        assert calls[1] == null_start(effect, current)
        assert c.result.rss <= current.rss * (1 + 1e-6), f"seed={seed}: {c.result.rss} against {current.rss}"
    else:
        assert c.result.rss == 1.5 * current.rss


def test_pairs_are_tried_only_with_a_member_that_replaces_a_law() -> None:
    # Which effects replace a law of the model (not nested): the gas's two.
    assert {n for n, e in LIBRARY.items() if not e.nested} == {"heat_transfer", "real_gas"}
    singles = list(LIBRARY)
    pairs = dg.pairs_to_try(singles)
    assert ("heat_transfer", "real_gas") in pairs
    assert all(not (LIBRARY[a].nested and LIBRARY[b].nested) for a, b in pairs)
    # Every pair with a law-replacing member is there, once, in order.
    expected = [(a, b) for i, a in enumerate(singles) for b in singles[i + 1:] if not LIBRARY[a].nested or not LIBRARY[b].nested]
    assert pairs == expected and len(pairs) == len(set(pairs))
    # With the seed's laws declared, none of the candidates left pairs up.
    assert dg.pairs_to_try([e for e in LIBRARY if e not in ("heat_transfer", "real_gas")]) == []
    assert dg.pairs_to_try(["friction"]) == [] and dg.pairs_to_try([]) == []

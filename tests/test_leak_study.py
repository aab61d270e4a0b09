"""The gas-charge leak study (scripts/leak_study.py) in a short version: a
healthy unit and one charged 20 % low, 10 minutes each on a warm day, in
closed loop with the production controller and the ECU's detector
(hpctl.control.gas_charge); the journal, the report and the summary the
full study writes. The full study's numbers are in docs/controller.md."""

from __future__ import annotations

import importlib.util
import json
import sys
from pathlib import Path

import numpy as np
import pytest

from hpctl import _core
from hpctl.control import gas_charge as gc

ROOT = Path(__file__).resolve().parent.parent


@pytest.fixture(scope="module")
def study():
    spec = importlib.util.spec_from_file_location("leak_study", ROOT / "scripts" / "leak_study.py")
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    sys.modules["leak_study"] = module
    spec.loader.exec_module(module)
    return module


def test_charged_unit_holds_the_asked_share_of_gas():
    unit = gc.seed_unit_with_heat()
    low = gc.charged_unit(unit, 0.8)
    t_k = unit.static_temperature_k
    rho = _core.gas_density_kg_m3(unit.gas, unit.static_pressure_pa, t_k)
    rho_low = _core.gas_density_kg_m3(low.gas, low.static_pressure_pa, t_k)
    assert rho_low / rho == pytest.approx(0.8, rel=1e-9)
    with pytest.raises(ValueError, match="charge_ratio"):
        gc.charged_unit(unit, 0.2)


def test_short_study_flags_a_20_percent_loss_and_not_a_healthy_unit(study, tmp_path):
    hours = 600.0 / 3600.0
    specs = [
        {"id": "healthy", "study": "fleet", "day": "warm", "hours": hours, "seed": 7, "p_offset_pa": 0.0, "t_offset_k": 0.0, "charge_ratio": 1.0},
        {"id": "lost20", "study": "steps", "day": "warm", "hours": hours, "seed": 7, "p_offset_pa": 0.0, "t_offset_k": 0.0, "charge_ratio": 0.8,
         "sensors": "nominal"},
    ]  # fmt: skip
    results = gc.run([study.build(s) for s in specs], threads=2)
    config = _core.gas_charge_config()
    healthy, lost = results
    # The healthy unit: a verdict, no fault, its estimate well under the
    # threshold.
    assert np.any(healthy["settled"]) and gc.first_fault_s(healthy) is None
    assert np.max(np.abs(gc.settled_loss(healthy))) < config["loss_threshold"]
    # 20 % lost: the settled estimate within 1 % of the truth (the charge
    # set through the gas's own equation of state), flagged after the
    # detector's settling time and before the end.
    loss = gc.settled_loss(lost)
    assert loss.size and np.all(np.abs(loss - 0.2) < 0.01)
    first = gc.first_fault_s(lost)
    assert first is not None and first < 600.0
    assert gc.fault_episodes(lost) == 1

    out = tmp_path / "study"
    out.mkdir()
    with (out / "cases.jsonl").open("w") as f:
        for spec, r in zip(specs, results, strict=True):
            f.write(json.dumps(study.summarise(spec, r)) + "\n")
    summary = study.report(out)
    assert json.loads((out / "summary.json").read_text()) == json.loads(json.dumps(summary))
    assert summary["false_alarms"]["alarms"] == 0 and summary["false_alarms"]["units"] == 1
    assert summary["steps"]["0.2-nominal"]["flagged"] == 1
    assert summary["steps"]["0.2-nominal"]["time_s"][0] == pytest.approx(first)

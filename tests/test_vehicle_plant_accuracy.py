"""The fast vehicle plant (ROS2 steps with valve 6 linearly implicit, the
reference gas through its table) against the reference plant it replaced
(RK4 steps, the gas evaluated directly): the 8x8 on the mixed route,
passive and semi-active, every metric of every section.

The two plants differ by the integrator's truncation error (second order
against fourth at the same 1 ms step) and the table's (1e-9 in pressure);
the metrics the comparison reports must not move by more than 1 % (about
a tenth of the difference between the passive settings they rank)."""

from __future__ import annotations

import dataclasses
import math

import pytest

from hpctl.vehicle import comparison, route
from hpctl.vehicle.model import preset

#: Largest relative change of a metric allowed, and the absolute floor
#: below which a metric counts as zero (m/s^2, rad, s, fractions: all of
#: order one or smaller where they matter).
REL_TOL = 0.01
ABS_FLOOR = 1e-4


def _metrics(result: comparison.CaseResult) -> dict[str, float]:
    assert result.error is None, result.error
    out: dict[str, float] = {}
    for s in result.sections:
        for group in (s.ride, s.wheels, s.handling):
            for f in dataclasses.fields(group):
                out[f"{s.name}.{type(group).__name__}.{f.name}"] = float(getattr(group, f.name))
        out[f"{s.name}.safe_state_s"] = s.safe_state_s
    return out


@pytest.mark.parametrize("setting", [comparison.PASSIVE[0], comparison.PASSIVE[3], comparison.SEMI_ACTIVE], ids=lambda s: s.name)
def test_fast_plant_reproduces_the_reference_metrics_on_the_mixed_route(setting: comparison.Setting) -> None:
    case = comparison.Case(preset("8x8"), route.mixed(scale=0.25), setting)
    fast = _metrics(comparison.run_case(case))
    reference = _metrics(comparison.run_case(case, reference_plant=True))
    assert fast.keys() == reference.keys() and len(fast) > 20
    worst = 0.0
    for name, ref in reference.items():
        got = fast[name]
        assert math.isfinite(got) == math.isfinite(ref), name
        if not math.isfinite(ref):
            continue
        scale = max(abs(ref), ABS_FLOOR)
        worst = max(worst, abs(got - ref) / scale)
        assert abs(got - ref) <= REL_TOL * scale, f"{name}: fast {got!r}, reference {ref!r}"
    print(f"{setting.name}: largest relative metric change {worst:.2e}")

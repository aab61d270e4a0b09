"""A fitted damper that makes a force at no flow: seal friction the records
do not tell from it.

A hydraulic damper's force falls to zero with its flow; seal friction's
does not (it steps to about its breakaway force within its smoothing
velocity, a millimetre a second or so). The flexible model's damper
characteristic can make such a step too (a blow-off at no flow), so a
model without friction fitted to records of a seal can put the friction
into its damper and leave only noise: on the foreign rig's draw 3 (seal
friction of 315 N breakaway), its slow sines alone, the fitted damper made
246 N at 1 mm/s where the true damper makes 3 N and the true damper plus
friction 238 N, at 0.99 x the noise; a diagnosis then said "nothing left"
with no friction named (docs/foreign-rig.md, stop 67). The records cannot
tell the two apart; the fitted curve can say that it holds such a step.

:func:`force_at_no_flow` compares the fitted curve with the template's
(the record's declared damper, the flexible shapes' centre) at
:data:`NO_FLOW_SPEED_M_S` in each branch the records exercise.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from hpctl.identify.fit import FitResult

#: The strut speed at which a fitted damper's force is compared with the
#: template's, m/s: within the smoothing velocities seals are drawn with
#: on the foreign rig (0.3-3 mm/s), where a hydraulic damper makes a few
#: newtons (the seed's 16 N with valve 5 open, 60 N closed).
NO_FLOW_SPEED_M_S = 2e-3
#: How many times the records' force noise (the quietest record's) the
#: fitted force must exceed the template's by.
NO_FLOW_NOISES = 3.0
#: The effects of the library that make a force at no flow (seal friction
#: in both directions, a load cell's offset in one): what a diagnosis at
#: the noise still screens where the fitted damper holds such a force.
NO_FLOW_EFFECTS = ("friction", "sensor_offset")


@dataclass(frozen=True)
class NoFlowForce:
    """A damper branch whose fitted force at :data:`NO_FLOW_SPEED_M_S`
    exceeds the template's by more than :data:`NO_FLOW_NOISES` force
    noises."""

    #: ``on_compression``, ``off_rebound``, ... (valve 5 closed or open).
    branch: str
    #: The fitted damper's force there, N (its magnitude).
    force_n: float
    #: The template damper's, N.
    template_n: float
    #: The records' force noise it was judged by, N.
    noise_n: float

    def describe(self) -> str:
        """The branch, its force and the template's, as the warning and the report say them."""
        return f"{self.branch} {self.force_n:.0f} N (the template's {self.template_n:.0f} N)"


def force_at_no_flow(result: FitResult) -> list[NoFlowForce]:
    """The branches of ``result``'s fitted damper characteristic that make
    a force at no flow (:class:`NoFlowForce`); none where the model does not
    identify the characteristic, already has friction to put such a force
    in, or no record has a force channel with a finite noise."""
    model = result.model
    if not (model.flexible and model.fit_damper and model.damper_branches) or "friction" in model.effects:
        return []
    noises = [d.sigma["force_n"] for d in result.datasets if "force_n" in d.targets and math.isfinite(d.sigma.get("force_n", math.nan))]
    if not noises:
        return []
    noise = min(noises)
    d = result.datasets[0]
    fitted = model.unit_for(d, result.values)
    out = []
    for branch in model.damper_branches:
        state, direction = branch.split("_")
        v = [(1.0 if direction == "compression" else -1.0) * NO_FLOW_SPEED_M_S]
        force, template = (abs(float(c.force_n(v, fitted.piston_area_m2, state == "on")[0])) for c in (fitted.damper, d.base.damper))
        if force - template > NO_FLOW_NOISES * noise:
            out.append(NoFlowForce(branch, force, template, noise))
    return out

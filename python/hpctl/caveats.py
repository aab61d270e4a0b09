"""Warnings as data: what a result cannot stand behind.

A :class:`Caveat` is a typed warning (a stable ``code``, a message for
people, ``details`` for programs). The simulation, control and
identification layers return them with their results instead of printing
or raising; the command line prints them, writes them into its JSON
summaries under ``"warnings"`` and, with ``--strict``, turns any of them
into exit code 3. They are not Python :mod:`warnings`: those are for
programmers and are easily lost; these are part of the result.

The codes (:class:`Code`) are the interface: a program may match on them,
the message wording may change.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping
from dataclasses import dataclass, field
from enum import StrEnum
from typing import Union

#: A JSON-compatible detail value.
Detail = Union[str, int, float, bool, None, list[float], list[str], list[int]]


class Code(StrEnum):
    """Why a result is not one to stand behind without reading on."""

    #: The strut ran into an end stop: the end-stop model (a stiff spring)
    #: decided the response, not the unit.
    END_STOP = "end_stop"
    #: A gas state left the range the equation of state was validated on.
    EOS_RANGE = "eos_range"
    #: The strut moved faster than the unit's rated speed.
    RATED_SPEED = "rated_speed"
    #: The integration step asked for was not the one taken.
    STEP_REPLACED = "step_replaced"
    #: A force-displacement loop that gives out energy where physics says
    #: it can only absorb it (numerical error, or a model used far outside
    #: its range).
    ENERGY_BALANCE = "energy_balance"
    #: The oil in the strut cavitated (its pressure reached the vapour
    #: pressure): the gas no longer follows the strut.
    CAVITATION = "cavitation"
    #: A case of a batch (sweep) failed; the others are reported.
    CASE_FAILED = "case_failed"
    #: The controller entered its safe state after power-on.
    SAFE_STATE = "safe_state"
    #: The controller's configuration does not describe the simulated unit.
    CONFIG_NOT_DERIVED = "config_not_derived"
    #: The ride-height sequencer was blocked while a request was pending.
    SEQUENCER_BLOCKED = "sequencer_blocked"
    #: A ride-height request was not reached.
    TARGET_MISSED = "target_missed"
    #: The fit's optimiser stopped without converging.
    NOT_CONVERGED = "not_converged"
    #: The residual is more than noise: the model misses something.
    RESIDUAL_STRUCTURED = "residual_structured"
    #: A channel above its noise was judged at it by counting a sample-time
    #: jitter read from its own residual: the verdict rests on that reading.
    JITTER_COUNTED = "jitter_counted"
    #: A channel above its noise was judged at it by counting a correlated
    #: part of its noise that its records' levels suggest without
    #: establishing it: the verdict rests on that colour.
    COLOUR_COUNTED = "colour_counted"
    #: A channel's noise level was read from differences that may still
    #: hold the signal (no order held noise only, and no other record of
    #: the channel had a level that did): it may be too high, so its RMS /
    #: noise too small and "at the noise" too lenient.
    NOISE_UNCHECKED = "noise_unchecked"
    #: A fitted parameter ended on a bound of its fit range, or within two
    #: standard errors of it: the data ask for a value the model's range
    #: does not hold, and the standard error (a Gaussian's) does not
    #: describe an estimate cut off by a bound.
    PARAM_AT_BOUND = "param_at_bound"
    #: Two fitted parameters the records tell apart only through the
    #: shapes the model assumes (their estimates' correlation near +-1):
    #: their own errors understate what the records leave open; a quantity
    #: derived from both (their product) is what the records determine
    #: best, its error resting on the damper's shapes and priors too.
    CONFOUNDED = "confounded"
    #: The identified damper characteristic makes a force at no flow, as
    #: seal friction does and a hydraulic damper does not: the records do
    #: not tell them apart (:mod:`hpctl.identify.no_flow`).
    DAMPER_FORCE_AT_NO_FLOW = "damper_force_at_no_flow"
    #: A fitted parameter whose standard error (a linearisation at the
    #: optimum) is known to understate what the records leave open: its
    #: profile interval (``hpctl fit --profile``) is the honest band.
    PROFILE_BAND = "profile_band"
    #: A side of a profile interval the records did not bound: the cost
    #: had not risen by sigmas^2 at the fit range's end, or at the farthest
    #: value its points searched. The interval is open there.
    PROFILE_OPEN = "profile_open"
    #: A wheel left the ground (its tyre force reached zero): the vehicle
    #: results there depend on the lift-off model.
    WHEEL_LIFT_OFF = "wheel_lift_off"
    #: The vehicle went beyond the handling model's validated range (the
    #: linear tyre's lateral acceleration limit).
    HANDLING_RANGE = "handling_range"
    #: CAN frames of a log failed the ECU's checks (CRC, alive counter,
    #: length, ranges) and were left out of the decoded tables.
    CAN_FRAMES_REJECTED = "can_frames_rejected"
    #: A CAN log holds identifiers the CAN database does not know.
    CAN_UNKNOWN_IDS = "can_unknown_ids"


@dataclass(frozen=True)
class Caveat:
    """One warning: ``code`` (a :class:`Code`), a sentence for people and
    ``details`` (JSON-compatible, SI units, unit-suffixed keys)."""

    code: Code
    message: str
    details: Mapping[str, Detail] = field(default_factory=dict)

    def to_json(self) -> dict[str, object]:
        return {"code": str(self.code), "message": self.message, "details": {k: _finite(v) for k, v in self.details.items()}}


def _finite(v: Detail) -> Detail:
    # JSON has no NaN or infinity: a missing value is null.
    if isinstance(v, float) and not math.isfinite(v):
        return None
    return v


def to_json(caveats: Iterable[Caveat]) -> list[dict[str, object]]:
    """The ``"warnings"`` list of a JSON summary."""
    return [c.to_json() for c in caveats]

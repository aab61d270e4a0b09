"""Where each logged valve switch fell between its two samples.

A record's flag columns give the valves' state at each sample, so a switch
lies somewhere in the interval before the first sample that shows it. The
model places it midway (:data:`hpctl.data.records.LOGGED_SWITCH_LEAD`),
which is right on average for a valve driver that runs apart from the
data system. Where the two share a clock, the switches fall on the sample
times themselves and the sample-time jitter decides which sample logs each
one: midway is then half an interval early or late at every switch. On the
foreign rig (5 ms samples) that left 130-270 kPa in the small accumulator's
pressure for 20 ms after each switch of valve 6, which a larger, smoother
orifice partly made up for (docs/foreign-rig.md).

This module estimates each switch's place from the data: the model is run
with every switch near the start, in the middle and near the end of its
interval, the residual from each switch to the next is compared,
and a parabola through the three gives the switch's place (a nuisance
parameter per switch, inside its interval). The model itself places a
switch between two outputs by an output inserted at the switch (the core
switches valves at the first output that has the new state), removed from
the results again (:func:`timeline`).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import replace
from typing import TypedDict

import numpy as np
from numpy.typing import NDArray

from hpctl.identify.dataset import Dataset

FloatArray = NDArray[np.float64]

#: The places tried, as shares of the interval before the sample that
#: shows the switch (0: the switch at that sample): three about a centre,
#: the first round about the middle, each later round about the last
#: round's place, closer. A parabola through three costs far apart is a
#: rough model of a cost that need not be symmetric (a valve opening on a
#: pressure difference): with one round, switches placed at 0.15 on the
#: virtual rig came out at 0.05 (the first probe) where they opened it.
ROUND_SPANS = (0.45, 0.15, 0.05)
#: The probes stay this far inside the interval: an output inserted at
#: its end would coincide with a sample.
EDGE = 0.01
#: The first round's probes.
PROBE_LEADS = (0.5 - ROUND_SPANS[0], 0.5, 0.5 + ROUND_SPANS[0])


def switch_samples(d: Dataset) -> NDArray[np.int64]:
    """The samples that are the first to show a valve switch (either flag)."""
    hard, on = np.asarray(d.spring_hard, bool), np.asarray(d.damper_on, bool)
    if hard.ndim == 0 or on.ndim == 0 or len(hard) < 2:
        return np.zeros(0, np.int64)
    changed = (hard[1:] != hard[:-1]) | (on[1:] != on[:-1])
    return np.asarray(np.flatnonzero(changed) + 1, np.int64)


class SwitchPlace(TypedDict):
    """Where the fit placed one logged valve switch (JSON)."""

    #: The first sample that shows the new state, s.
    sample_s: float
    #: The share of the interval before that sample by which the switch
    #: precedes it (0: at the sample).
    place: float
    #: The switch's time, s.
    switched_at_s: float


def places(datasets: Sequence[Dataset]) -> dict[str, list[SwitchPlace]]:
    """Per record with placed switches, where each one went (for the
    reports and ``--json``)."""
    out: dict[str, list[SwitchPlace]] = {}
    for d in datasets:
        ks = switch_samples(d)
        if not ks.size or d.switch_leads.size != ks.size:
            continue
        t = d.times_s
        out[d.name] = [SwitchPlace(sample_s=float(t[k]), place=float(lead), switched_at_s=float(t[k] - lead * (t[k] - t[k - 1])))
                       for k, lead in zip(ks, d.switch_leads)]
    return out


def timeline(d: Dataset, leads: FloatArray | None = None) -> tuple[FloatArray, NDArray[np.bool_], NDArray[np.bool_], NDArray[np.bool_]] | None:
    """The output times and valve states that put each switch of ``d`` at
    its lead (``leads``, one per :func:`switch_samples`, else the dataset's
    own :attr:`Dataset.switch_leads`), and the mask of the record's own
    samples among them; None where there are no leads (the model then
    places every switch midway) or no switches. The core is then run with
    a lead of 0: each switch at the first output that shows it."""
    leads = d.switch_leads if leads is None else leads
    if leads.size == 0:  # every run of a record without places: nothing to look at
        return None
    ks = switch_samples(d)
    if ks.size == 0:
        return None
    if leads.size != ks.size:
        raise ValueError(f"switch leads: {leads.size} given for {ks.size} switches of {d.name}")
    t = d.times_s
    hard = np.broadcast_to(np.asarray(d.spring_hard, bool), t.shape)
    on = np.broadcast_to(np.asarray(d.damper_on, bool), t.shape)
    insert = leads > 0.0
    k = ks[insert]
    at = t[k] - leads[insert] * (t[k] - t[k - 1])
    # np.insert puts each new output before sample k, with sample k's (the
    # new) valve state.
    times = np.insert(t, k, at)
    keep = np.insert(np.ones(len(t), bool), k, False)
    return times, np.insert(hard, k, hard[k]), np.insert(on, k, on[k]), keep


def window(k: int, next_k: int) -> slice:
    """The samples whose residual judges the place of the switch first
    shown at sample ``k``: up to the next switch (at ``next_k``). Not only
    the valve's transient: closing valve 6 a few ms early or late traps a
    different amount of gas and oil in the small accumulator, which stays
    in its pressure until the valve opens again (with the first 25 ms
    alone, on FOREIGN_RIG_SEED=20's switching record, the closings' places
    came out near midway and the refit's residual rose, 1.325 -> 1.354 x
    the noise; with the whole segment it fell to 1.086)."""
    return slice(k, next_k)


def best_lead(costs: Sequence[float], leads: Sequence[float] = PROBE_LEADS) -> float:
    """The place of a switch from its window's cost at the three probe
    leads: the vertex of the parabola through them where it opens upward,
    kept inside the probes' span; else the cheapest probe."""
    (x0, x1, x2), (y0, y1, y2) = leads, costs
    if not all(np.isfinite((y0, y1, y2))):
        return float(leads[int(np.nanargmin(np.where(np.isfinite(costs), costs, np.nan)))]) if np.isfinite(costs).any() else 0.5
    # Divided differences: y = y0 + a (x - x0) + c (x - x0)(x - x1).
    a = (y1 - y0) / (x1 - x0)
    c = ((y2 - y1) / (x2 - x1) - a) / (x2 - x0)
    if c > 0.0:
        vertex = 0.5 * (x0 + x1) - a / (2.0 * c)
        return float(np.clip(vertex, x0, x2))
    return float(leads[int(np.argmin((y0, y1, y2)))])


def _probes(centre: FloatArray, span: float) -> tuple[FloatArray, FloatArray, FloatArray]:
    """Three places per switch: ``centre`` and ``span`` either side, the
    centre moved so that all three keep :data:`EDGE` inside the interval."""
    c = np.clip(centre, EDGE + span, 1.0 - EDGE - span)
    return c - span, c, c + span


def estimate_leads(
    datasets: Sequence[Dataset],
    simulate: Callable[[Sequence[Dataset]], Sequence[dict[str, FloatArray] | Exception]],
    spans: Sequence[float] = ROUND_SPANS,
) -> list[Dataset]:
    """The datasets with each switch's place estimated
    (:attr:`Dataset.switch_leads`): ``simulate`` runs the fitted model on a
    list of datasets (their switches where their leads put them). Per
    round of :data:`ROUND_SPANS`, every other switch is probed (three runs)
    while the others stay where they are, then the rest: a switch's
    segment remembers the switch before it (the gas's temperature, over
    seconds), so probing both at once mixed the two (on the virtual rig, a
    closing at 0.15 came out at 0.65, its segment's cost 30 above the true
    place's). Only the records that switch are run. Datasets without
    switches come back as they are. The rounds start from the
    datasets' own places where they have them (a later pass, ``spans``
    the closer rounds), else midway."""
    switches = [switch_samples(d) for d in datasets]
    moving = [i for i, ks in enumerate(switches) if ks.size]
    leads = {i: datasets[i].switch_leads.copy() if datasets[i].switch_leads.size == switches[i].size else np.full(switches[i].size, 0.5)
             for i in moving}
    for span in spans:
        for parity in (0, 1):
            probes = {}
            for i in moving:
                lo, mid, hi = _probes(leads[i], span)
                mine = np.arange(switches[i].size) % 2 == parity
                probes[i] = [np.where(mine, p, leads[i]) for p in (lo, mid, hi)]
            runs = [simulate([replace(datasets[i], switch_leads=probes[i][j]) for i in moving]) for j in range(3)]
            for n, i in enumerate(moving):
                d, ks = datasets[i], switches[i]
                bounds = [*ks[1:], len(d.times_s)]
                for s in range(parity, ks.size, 2):
                    w = window(int(ks[s]), int(bounds[s]))
                    costs = []
                    for run in runs:
                        sim = run[n]
                        if isinstance(sim, Exception):
                            costs.append(np.inf)
                            continue
                        costs.append(float(sum(np.sum(((sim[c][w] - y[w]) / d.weight_sigma[c][w]) ** 2) for c, y in d.targets.items())))
                    leads[i][s] = best_lead(costs, tuple(float(p[s]) for p in probes[i]))
    return [replace(d, switch_leads=leads[i]) if i in leads else d for i, d in enumerate(datasets)]


def extrapolated_leads(placed: Sequence[Dataset], settled: Sequence[Dataset], previous_move: FloatArray | None) -> tuple[list[Dataset], FloatArray, bool]:
    """The places to fit at after a pass of fitting and placing again that
    moved them from ``placed`` to ``settled``; that pass's move (every
    switch's, in order); whether the places were extrapolated. Where the move is the
    previous one shrunk by a steady ratio rho (aligned within 25 degrees,
    rho in (0, 0.9)), the passes converge linearly to where they would end
    after many more: Aitken's extrapolation puts the places there,
    ``settled + move rho / (1 - rho)``, within the interval's edges. The
    caller fits and places again from there, so an extrapolation too far is
    corrected, not kept.

    The places and the valve's parameters trade: a switch placed late is
    met by a valve opening faster. On the foreign rig's valve-lag case
    (seed 11, a 17.6 ms valve, short sweep) the passes moved the openings
    0.61 -> 0.71 -> 0.79 -> 0.85 of their intervals, each move three
    quarters of the one before, and stopped at the pass limit with the
    valve's time constant 2 % short and 1.41 x the noise left, while at the
    true places (0.99) the residual sum of squares is 1,456 lower."""
    move = np.concatenate([s.switch_leads - p.switch_leads for s, p in zip(settled, placed) if s.switch_leads.size])
    out = list(settled)
    if previous_move is None or previous_move.shape != move.shape:
        return out, move, False
    pp, mp = float(previous_move @ previous_move), float(move @ previous_move)
    mm = float(move @ move)
    if pp == 0.0 or mm == 0.0:
        return out, move, False
    rho = mp / pp
    if not (0.0 < rho < 0.9 and mp / np.sqrt(pp * mm) >= np.cos(np.radians(25.0))):
        return out, move, False
    return moved_leads(settled, move * rho / (1.0 - rho)), move, True


def moved_leads(datasets: Sequence[Dataset], move: FloatArray) -> list[Dataset]:
    """The datasets with their switches' places moved by ``move`` (every
    placed switch's, in the datasets' order), kept within the intervals'
    edges (:data:`EDGE`)."""
    out, k = [], 0
    for d in datasets:
        n = d.switch_leads.size
        out.append(replace(d, switch_leads=np.clip(d.switch_leads + move[k:k + n], EDGE, 1.0 - EDGE)) if n else d)
        k += n
    return out

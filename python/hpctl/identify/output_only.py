"""Jacobian columns without runs: parameters that change a record's outputs
but not its state.

The seal friction is the simplest case: on the characterisation rig it is
a force on the prescribed piston, ``F_friction(v)``, added to the strut
force, which nothing integrates unless its heat warms the oil
(:data:`FRICTION_COUPLED`); a friction parameter's column is the change of
hp-core's friction law at the base run's velocities. The damper's needs
more care:

On the characterisation rig the actuator prescribes the strut's motion, so
the flow through the damper is the displaced oil ``A v``, whatever the
damper. With incompressible oil and no void, the damper's pressure drop
then enters only the strut pressure and the force (hp-core's
``Unit::evaluate_terms``: ``p_strut = p_S + dp(A v)``, ``F = A (p_strut -
p_amb) + ...``); the gas, its wall, the valves and the step sizes never see
it. A damper-shape parameter's finite-difference column on such a record is
therefore the force's change ``A (dp'(q) - dp(q))`` at the base run's own
flows, computed from hp-core's curve (``_core.damper_pressure_drop_pa``)
in milliseconds instead of one run of the record per column (on the
bundled campaign's 700 s heat piece, 16 runs of 19 ms for every Jacobian).

The damper reaches the state once it can shape the flow or heat anything:
oil compliance (the strut pressure a state), heat build-up (its power warms
the oil), valve lag (valve 5's opening a state whose share we would have to
know) and a lagging transducer (the force filtered after the run) are left
to full runs, and so is any record whose strut pressure could fall to the
oil's vapour pressure anywhere between its samples, at the base values or
the perturbed ones (:func:`cannot_cavitate`): there the void's volume is a
state the damper sets. ``tests/test_fit_output_only.py`` checks the
columns against full runs on every record type.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence

import numpy as np
from numpy.typing import NDArray

from hpctl import _core
from hpctl._coretypes import DamperDict
from hpctl.errors import bad_argument
from hpctl.identify.dataset import Dataset
from hpctl.model.effects import DAMPER_BRANCHES, DAMPER_SHAPE, FRICTION_SHAPE, LIBRARY
from hpctl.model.unit import Damper, DamperCurve, Unit
from hpctl.sim.run import CharacterisationRig, Sampled

FloatArray = NDArray[np.float64]

#: Effects with which the damper's pressure drop reaches more than the
#: force output (module docstring).
STATE_COUPLED = ("oil_compliance", "heat_buildup", "valve_lag", "sensor_lag")
#: Effects with which the seal friction reaches more than the force output:
#: its power warms the oil node; a lagging transducer filters the force
#: after the run. (The oil's compliance and the valves' lag do not: the
#: friction is a force on the prescribed piston only.)
FRICTION_COUPLED = ("heat_buildup", "sensor_lag")
#: How far below its lowest sample the gas pressure is assumed to dip
#: between samples, as a share of it, when ruling out cavitation: between
#: two samples the gas follows the displacement's cubic, whose own overshoot
#: is a small part of the stroke.
GAS_DIP = 0.1
#: The channels a base run must give for the columns.
CHANNELS = ("force_n", "damper_force_n", "flow_damper_m3_s", "p_gas_true_pa", "friction_force_n", "vel_m_s")
#: Largest mismatch between a sample's damper force and the curve's at its
#: flow, relative to the strut pressure's force: the rounding of
#: ``A ((p_S + dp) - p_S)``. A larger one means the force was not the
#: curve's (a void, a valve between states): no columns from it.
MATCH_RTOL = 1e-9

_SHAPE_NAMES = frozenset(p.name for b in DAMPER_BRANCHES for p in DAMPER_SHAPE[b])
_FRICTION_NAMES = frozenset(p.name for p in (*LIBRARY["friction"].params, *FRICTION_SHAPE))


def _prescribed(d: Dataset) -> bool:
    return (
        d.record.kind == "characterisation" and isinstance(d.rig, CharacterisationRig) and isinstance(d.rig.strut, Sampled) and d.rig.strut.vel_m_s is not None
    )


def applies(effects: Sequence[str], d: Dataset) -> bool:
    """Whether damper-shape columns of ``d`` can come from its outputs: a
    characterisation record and a model without :data:`STATE_COUPLED`
    effects."""
    return _prescribed(d) and not set(effects) & set(STATE_COUPLED)


def friction_applies(effects: Sequence[str], d: Dataset) -> bool:
    """Whether friction columns of ``d`` can come from its outputs: a
    characterisation record and a model without :data:`FRICTION_COUPLED`
    effects."""
    return _prescribed(d) and not set(effects) & set(FRICTION_COUPLED)


def is_shape(name: str) -> bool:
    """Whether ``name`` is a damper-shape parameter (:data:`hpctl.model.effects.DAMPER_SHAPE`)."""
    return name in _SHAPE_NAMES


def is_friction(name: str) -> bool:
    """Whether ``name`` is a parameter of the seal friction (the effect's
    and the flexible model's :data:`hpctl.model.effects.FRICTION_SHAPE`)."""
    return name in _FRICTION_NAMES


def extreme_flows_m3_s(d: Dataset, area_m2: float) -> tuple[float, float]:
    """The lowest and highest flow out of the strut anywhere on ``d``'s
    drive, m^3/s: hp-core's cubic Hermite through the samples and their
    velocities (``Motion::SampledVelocity``), whose velocity is a quadratic
    on each interval; its extremes are at the ends or the vertex."""
    drive = d.rig.strut if isinstance(d.rig, CharacterisationRig) else None
    if not isinstance(drive, Sampled) or drive.vel_m_s is None:
        raise bad_argument("d.rig", type(d.rig).__name__, "a characterisation rig driven by samples and their velocities (prepare() makes one)")
    t, x, v = drive.time_s, drive.disp_m, drive.vel_m_s
    h = np.diff(t)
    s = np.diff(x) / h
    m0, m1 = v[:-1], v[1:]
    # dx/dt(u) = a u^2 + b u + m0 on u in [0, 1].
    a = 3.0 * (m0 + m1) - 6.0 * s
    b = 6.0 * s - 4.0 * m0 - 2.0 * m1
    with np.errstate(divide="ignore", invalid="ignore"):
        u = np.where(a != 0.0, -b / (2.0 * a), 0.0)
    u = np.clip(u, 0.0, 1.0)
    vertex = (a * u + b) * u + m0
    lowest = float(min(v.min(), vertex.min(initial=np.inf)))
    highest = float(max(v.max(), vertex.max(initial=-np.inf)))
    return area_m2 * lowest, area_m2 * highest


def cannot_cavitate(d: Dataset, dampers: Sequence[Damper], base: Mapping[str, FloatArray], area_m2: float, vapour_pa: float) -> bool:
    """Whether the strut pressure stays above the oil's vapour pressure
    everywhere on ``d`` with every one of ``dampers``: at the drive's
    fastest rebound (:func:`extreme_flows_m3_s`) with valve 5 in each
    state, over the gas pressure's lowest sample less :data:`GAS_DIP`.
    The pressure drop rises with the flow (hp-core validates every curve
    monotone), so that is the strut pressure's lowest anywhere."""
    lowest_q, _ = extreme_flows_m3_s(d, area_m2)
    p_gas = (1.0 - GAS_DIP) * float(np.min(base["p_gas_true_pa"]))
    q = np.array([min(lowest_q, 0.0)])
    # Each curve that flow reaches once: the Jacobian's dampers differ from
    # the base run's in one branch each, so most share their rebound
    # curves (hp-core picks the compression curves at no flow).
    branches = ("on_compression", "off_compression") if q[0] >= 0.0 else ("on_rebound", "off_rebound")
    seen: set[tuple[DamperCurve, DamperCurve]] = set()
    for damper in dampers:
        curves = (getattr(damper, branches[0]), getattr(damper, branches[1]))
        if curves in seen:
            continue
        seen.add(curves)
        for bypass in (0.0, 1.0):
            if not p_gas + float(_core.damper_pressure_drop_pa(damper.to_dict(), q, bypass)[0]) > vapour_pa:
                return False
    return True


def force_changes_n(d: Dataset, base: Mapping[str, FloatArray], damper: Damper, dampers: Sequence[Damper], area_m2: float) -> list[FloatArray] | None:
    """The force's change at each output sample of the base run ``base``
    (made with ``damper``) when its damper is each of ``dampers``, N; None
    where some sample's damper force is not the curve's at its flow in
    either state of valve 5 (:data:`MATCH_RTOL`)."""
    changes = damper_columns(base, damper, area_m2)
    return None if changes is None else changes(dampers)


def damper_columns(base: Mapping[str, FloatArray], damper: Damper, area_m2: float) -> Callable[[Sequence[Damper]], list[FloatArray]] | None:
    """:func:`force_changes_n` in two halves: here whether the base run's
    damper force is its curve's (None where not), and the function that
    gives the changes for a sequence of dampers. The Jacobian knows from the
    first which columns need no run, and computes the second while the
    others run (:func:`hpctl.identify.fit.fit`'s ``fd_jac``)."""
    q = np.asarray(base["flow_damper_m3_s"], float)
    seen = np.asarray(base["damper_force_n"], float)
    scale = MATCH_RTOL * area_m2 * np.maximum(np.abs(np.asarray(base["p_gas_true_pa"], float)), 1.0) + MATCH_RTOL * np.abs(seen)
    drops = [_core.damper_pressure_drop_pa(damper.to_dict(), q, bypass) for bypass in (0.0, 1.0)]
    miss = [np.abs(area_m2 * dp - seen) for dp in drops]
    # Valve 5's state at each sample: the one whose curve gives the force
    # (at no flow both do, and both give the same change there).
    closed = miss[0] <= miss[1]
    if not np.all(np.where(closed, miss[0], miss[1]) <= scale):
        return None
    before = np.where(closed, drops[0], drops[1])
    # The samples of each branch, as hp-core picks it (valve 5's state, and
    # compression at no flow). A sample's drop is its branch's curve's alone,
    # so a damper changes the force only where its changed curves are
    # taken, and there alone it is evaluated (the Jacobian's dampers each
    # change one branch; every sample's drop for every damper was 0.38 s of
    # the bundled campaign's fit, stop 63): the same numbers, the others'
    # change exactly zero as before.
    compression = q >= 0.0
    where = {"on_compression": closed & compression, "on_rebound": closed & ~compression,
             "off_compression": ~closed & compression, "off_rebound": ~closed & ~compression}
    # Each branch's samples, flows and drops picked once here, not once per
    # damper asked (the Jacobian asks every iteration, for each of its
    # damper columns, on the main thread beside the runs: the bundled
    # campaign's fit asked for 2,064 dampers, 0.401 -> 0.351 s; stop 64).
    branches = [(branch, idx, q[idx], before[idx], 0.0 if branch.startswith("on_") else 1.0)
                for branch, mask in where.items() if (idx := np.flatnonzero(mask)).size]

    def changes(dampers: Sequence[Damper]) -> list[FloatArray]:
        out = []
        for other in dampers:
            change = np.zeros_like(q)
            curve: DamperDict | None = None
            for branch, idx, q_branch, before_branch, bypass in branches:
                if getattr(other, branch) == getattr(damper, branch):
                    continue
                curve = other.to_dict() if curve is None else curve
                change[idx] = area_m2 * (_core.damper_pressure_drop_pa(curve, q_branch, bypass) - before_branch)
            out.append(change)
        return out

    return changes


def friction_changes_n(base: Mapping[str, FloatArray], unit: Unit, units: Sequence[Unit]) -> list[FloatArray] | None:
    """The force's change at each output sample of the base run ``base``
    (made with ``unit``) when its friction is each of ``units``', N, at the
    run's own velocities (hp-core's ``Friction::force_n``,
    ``_core.friction_force_n``); None where the run's friction force is not
    ``unit``'s at them."""
    changes = friction_columns(base, unit)
    return None if changes is None else changes(units)


def friction_columns(base: Mapping[str, FloatArray], unit: Unit) -> Callable[[Sequence[Unit]], list[FloatArray]] | None:
    """:func:`friction_changes_n` in two halves, as :func:`damper_columns`."""
    v = np.asarray(base["vel_m_s"], float)
    before = _core.friction_force_n(unit.to_dict(), v)
    seen = np.asarray(base["friction_force_n"], float)
    if not np.all(np.abs(before - seen) <= MATCH_RTOL * np.maximum(np.abs(seen), 1.0)):
        return None

    def changes(units: Sequence[Unit]) -> list[FloatArray]:
        return [_core.friction_force_n(other.to_dict(), v) - before for other in units]

    return changes

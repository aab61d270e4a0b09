"""What a run cannot stand behind, found in its channels: end-stop contact,
gas states outside the validated range of the equation of state, strut
speeds beyond the unit's rating, a step size not taken, a loop that makes
energy. Each check returns :class:`~hpctl.caveats.Caveat` objects; nothing
here prints or raises.

The ranges come from where they are defined: the stroke and the rated
speed from the unit, the validated range of each gas model from the Rust
core (``_core.gas_validated_range``). The checks look at the output
samples: an excursion shorter than the output interval can pass unseen,
so the command line samples fast runs densely.
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np
from numpy.typing import NDArray

from hpctl import _core
from hpctl.caveats import Caveat, Code
from hpctl.model.unit import Unit

FloatArray = NDArray[np.float64]


def validated_range(gas: str) -> tuple[tuple[float, float], tuple[float, float]]:
    """((p_min, p_max) Pa, (t_min, t_max) K) where ``gas`` was validated."""
    r = _core.gas_validated_range(gas)
    return (float(r["pressure_pa"][0]), float(r["pressure_pa"][1])), (float(r["temperature_k"][0]), float(r["temperature_k"][1]))


def _first_time(t: FloatArray | None, mask: NDArray[np.bool_]) -> float | None:
    if t is None or not mask.any():
        return None
    return float(t[int(np.argmax(mask))])


def _at(t_s: float | None) -> str:
    return "" if t_s is None else f" (first at t = {t_s:.4g} s)"


def end_stop(unit: Unit, channels: Mapping[str, FloatArray], run: str) -> list[Caveat]:
    """Strut compression (``disp_m``) beyond either end of the stroke."""
    if "disp_m" not in channels:
        return []
    x = np.asarray(channels["disp_m"], dtype=float)
    t = channels.get("time_s")
    out = []
    for side, over, stroke in (
        ("compression", x - unit.stroke_compression_m, unit.stroke_compression_m),
        ("extension", -unit.stroke_extension_m - x, unit.stroke_extension_m),
    ):
        hit = over > 0
        if hit.any():
            first = _first_time(t, hit)
            out.append(Caveat(
                Code.END_STOP,
                f"{run}: the strut ran {1e3 * float(over.max()):.1f} mm into its {side} end stop (stroke {1e3 * stroke:g} mm){_at(first)}; "
                "the end-stop model, not the unit, decided the response there",
                {"run": run, "side": side, "max_over_travel_m": float(over.max()), "stroke_m": stroke, "first_time_s": first},
            ))
    return out


#: The gas channels checked, by preference: the true state where the run
#: has it, else what a transducer reported (records).
_PRESSURES = (("p_gas_true_pa", "p_gas_pa"), ("p_gas2_true_pa", "p_gas2_pa"))
_TEMPERATURES = (("t_gas_k",), ("t_gas2_k",))


def eos_range(gas: str, channels: Mapping[str, FloatArray], run: str) -> list[Caveat]:
    """Gas pressures and temperatures outside the range where the gas
    model ``gas`` was validated (``hp_core::gas::validated_range``)."""
    (p_lo, p_hi), (t_lo, t_hi) = validated_range(gas)
    t = channels.get("time_s")
    out = []
    for names, (lo, hi), unit, scale in (
        *((n, (p_lo, p_hi), "MPa", 1e-6) for n in _PRESSURES),
        *((n, (t_lo, t_hi), "K", 1.0) for n in _TEMPERATURES),
    ):
        name = next((n for n in names if n in channels), None)
        if name is None:
            continue
        y = np.asarray(channels[name], dtype=float)
        outside = (y < lo) | (y > hi) | ~np.isfinite(y)
        if not outside.any():
            continue
        worst = float(y[outside][np.argmax(np.abs(y[outside] - 0.5 * (lo + hi)))])
        first = _first_time(t, outside)
        out.append(Caveat(
            Code.EOS_RANGE,
            f"{run}: {name} reached {worst * scale:.4g} {unit}, outside the range [{lo * scale:g}, {hi * scale:g}] {unit} "
            f"where the {gas} equation of state was validated{_at(first)}",
            {"run": run, "channel": name, "value": worst, "min": lo, "max": hi, "gas": gas, "first_time_s": first},
        ))
    return out


def rated_speed(unit: Unit, channels: Mapping[str, FloatArray], run: str) -> list[Caveat]:
    """Strut speed (``vel_m_s``, or the derivative of ``disp_m``) beyond
    the unit's rated speed."""
    if "vel_m_s" in channels:
        v = np.abs(np.asarray(channels["vel_m_s"], dtype=float))
    elif "disp_m" in channels and "time_s" in channels and len(channels["time_s"]) > 2:
        v = np.abs(np.gradient(np.asarray(channels["disp_m"], dtype=float), np.asarray(channels["time_s"], dtype=float)))
    else:
        return []
    fast = v > unit.rated_speed_m_s
    if not fast.any():
        return []
    first = _first_time(channels.get("time_s"), fast)
    return [Caveat(
        Code.RATED_SPEED,
        f"{run}: the strut moved at up to {float(v.max()):.3g} m/s, beyond the unit's rated {unit.rated_speed_m_s:g} m/s{_at(first)}; "
        "the damper curves are extrapolated there",
        {"run": run, "max_speed_m_s": float(v.max()), "rated_speed_m_s": unit.rated_speed_m_s, "first_time_s": first},
    )]


def channels(unit: Unit, data: Mapping[str, FloatArray], run: str) -> list[Caveat]:
    """Every check on a run's channels (or a record's columns)."""
    return end_stop(unit, data, run) + eos_range(unit.gas, data, run) + rated_speed(unit, data, run)


def step_size(requested_dt_s: float | None, rtol: float | None, times_s: FloatArray, run: str) -> list[Caveat]:
    """Fixed steps (``rtol`` None) land on every output time: where the
    outputs are closer than the step asked for, the steps taken are the
    output interval instead. Say so rather than report the requested step.
    (Error-controlled steps may span output times: the outputs come from
    the dense output, and the step asked for is only an upper bound.)"""
    t = np.asarray(times_s, dtype=float)
    if rtol is not None or requested_dt_s is None or t.size < 2:
        return []
    used = float(np.min(np.diff(t)))
    if requested_dt_s <= used * (1 + 1e-9):
        return []
    return [Caveat(
        Code.STEP_REPLACED,
        f"{run}: the step asked for, {requested_dt_s:g} s, is longer than the output interval; steps of {used:.4g} s were taken",
        {"run": run, "requested_dt_s": requested_dt_s, "used_dt_s": used},
    )]


def loop_energy(area_j: float, scale_j: float, run: str, what: str) -> list[Caveat]:
    """A loop that should absorb energy over a cycle (a gas exchanging heat
    with walls at one temperature absorbs work, by the second law) but
    gives it out by more than rounding (``1e-6 scale_j``, the scale being
    force range x stroke)."""
    if not area_j < -1e-6 * abs(scale_j):
        return []
    return [Caveat(
        Code.ENERGY_BALANCE,
        f"{run}: the {what} loop area is {area_j:.4g} J < 0: over a cycle it gave out energy, which it cannot "
        "(numerical error: the step or the output sampling is too coarse for the excitation, or the model is far outside its range)",
        {"run": run, "loop": what, "area_j": area_j},
    )]


def failed_cases(errors: Mapping[str, str], what: str) -> list[Caveat]:
    """One caveat per failed case of a batch, with the reason."""
    return [Caveat(Code.CASE_FAILED, f"{what} {name} failed: {reason}", {"case": name, "error": reason}) for name, reason in errors.items()]

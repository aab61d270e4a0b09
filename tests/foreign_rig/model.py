"""The foreign rig's plant: the strut, its oil, the damper, two gas springs
and the thermal network, on the characterisation rig (prescribed strut
compression) or the SDOF rig (a sprung mass over a moving base), integrated
with SciPy's solvers (LSODA by default: it switches between Adams and BDF as
the stiffness comes and goes; Radau and BDF work too).

Formulation (docs/foreign-rig.md has the derivations):

- Gas, per accumulator: mass m (constant, or falling by seal permeation),
  volume V from the oil it holds, temperature T from the energy equation
  ``c_v dT/dt = hA (T_w - T)/m - T (dp/dT)_rho dv/dt`` with v = V/m and a
  constant wall conductance hA (so tau = m c_v / hA moves with c_v),
  pressure and properties from CoolProp's reference nitrogen.
- Oil rigid by default: the flow out of the strut is A dx/dt and the strut
  pressure is the gas pressure plus the damper's drop at that flow. It
  cannot fall below the vapour pressure: from the instant it would (an
  event), the damper passes only what the gas pressure can drive, a vapour
  void opens in the strut, and the plant stays in that mode until the void
  has closed again (a second event). Each mode is smooth, so implicit
  solvers see smooth right-hand sides and the switching instants are exact.
- With oil compliance: the oil stored in the compliant volume is a state z,
  ``p_strut = p_vap + (beta / V_oil) z`` for z > 0, a void of -z for z < 0.
- Valve 6: a Wu orifice between the accumulators' oil sides times its
  opening fraction (a state when the valves lag).
- Force: ``(p_strut - p_atm) A`` plus seal friction and the bump stop.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray
from scipy.integrate import solve_ivp

from .damper import Damper
from .gas import Nitrogen
from .motion import Motion
from .unit import G_M_S2, Unit

FloatArray = NDArray[np.float64]

ENERGY = ("work_in_j", "damper_j", "valve6_j", "friction_j", "bump_j", "heat_gas_j", "heat_gas2_j")
# A void that opened by less than this at a numerically located onset
# counts as not opened (m^3; a cubic millimetre is 1e-9).
VOID_TOL_M3 = 1e-15


@dataclass(frozen=True)
class Segment:
    """Valve commands holding from ``start_s``: valve 6 open is the soft
    spring, valve 5 (the bypass) open is the damper off."""

    start_s: float
    valve6_open: bool
    valve5_open: bool


@dataclass
class RunResult:
    times_s: FloatArray
    channels: dict[str, FloatArray]
    energy: dict[str, FloatArray]
    n_rhs: int
    cavitation_events: list[tuple[float, str]]
    final_state: dict[str, float]


class _Memo:
    """Gas properties of one accumulator, reused while its state is unchanged
    (the isolated accumulator often sits still for a whole record)."""

    def __init__(self) -> None:
        self.gas = Nitrogen()
        self.key = (math.nan, math.nan)
        self.val = (0.0, 0.0, 0.0)

    def props(self, rho: float, t: float) -> tuple[float, float, float]:
        if rho != self.key[0] or t != self.key[1]:
            self.val = self.gas.props(rho, t)
            self.key = (rho, t)
        return self.val


class Plant:
    """The ODE of one unit on one rig."""

    def __init__(self, unit: Unit, motion: Motion, sprung_mass_kg: float | None = None, energy: bool = False, balanced: bool = True) -> None:
        self.unit = unit
        self.motion = motion
        self.sdof = sprung_mass_kg is not None
        self.mass = sprung_mass_kg or 0.0
        self.energy = energy
        self.damper = Damper(unit.damper)
        self.gas_s, self.gas_l = _Memo(), _Memo()
        e = unit.effects
        p0, t0 = unit.static_pressure_pa, unit.static_temperature_k
        rho0 = self.gas_s.gas.density(p0, t0)
        self.m_s0 = rho0 * unit.small_acc_volume_m3
        self.m_l0 = rho0 * unit.large_acc_volume_m3
        cv0 = self.gas_s.props(rho0, t0)[2]
        tau = unit.tau_s
        self.isothermal = tau == 0.0
        if tau == 0.0 or math.isinf(tau):
            self.ha_s = self.ha_l = 0.0
        else:
            self.ha_s = self.m_s0 * cv0 / tau
            self.ha_l = self.m_l0 * cv0 / (tau * unit.tau_large_ratio)
        if self.sdof and balanced and abs(unit.static_force_n - self.mass * G_M_S2) > 1e-6 * unit.static_force_n:
            raise ValueError(f"sprung mass {self.mass} kg does not rest at the static position of a unit carrying {unit.static_force_n / G_M_S2:.1f} kg")
        names = []
        if not self.isothermal:
            names += ["t_s", "t_l"]
        names += ["v_l"]
        if e.leakage is not None:
            names += ["m_s", "m_l"]
        names += ["z", "v_s"] if e.oil_compliance is not None else ["void"]
        if e.valve_lag is not None:
            names += ["s5", "s6"]
        if self.sdof:
            names += ["y", "vy"]
        names += ["t_oil", "t_tc", "t_tc_oil"]
        if e.heat_buildup is not None:
            names += ["t_wall"]
        if e.sensor_lag is not None:
            names += ["f_lag", "ps_lag", "pl_lag"]
        if energy:
            names += list(ENERGY)
        self.names = names
        self.index = {n: k for k, n in enumerate(names)}
        self.cmd5 = 0.0
        self.cmd6 = 0.0
        self.cavitating = False
        self.below_vapour = False  # set when the rigid, non-cavitating mode saw p_strut < p_vap
        self.n_rhs = 0

    # -- state ------------------------------------------------------------
    def initial_state(self, seg: Segment) -> FloatArray:
        u, e, i = self.unit, self.unit.effects, self.index
        y = np.zeros(len(self.names))
        t0, ta = u.static_temperature_k, u.ambient_k
        for n, v in (("t_s", t0), ("t_l", t0), ("v_l", u.large_acc_volume_m3), ("m_s", self.m_s0), ("m_l", self.m_l0),
                     ("v_s", u.small_acc_volume_m3), ("s5", float(seg.valve5_open)), ("s6", float(seg.valve6_open)),
                     ("t_oil", ta), ("t_tc", t0), ("t_tc_oil", ta), ("t_wall", ta),
                     ("f_lag", u.static_force_n), ("ps_lag", u.static_pressure_pa), ("pl_lag", u.static_pressure_pa)):
            if n in i:
                y[i[n]] = v
        if e.oil_compliance is not None:
            c = e.oil_compliance
            y[i["z"]] = (u.static_pressure_pa - u.vapour_pressure_pa) * c.oil_volume_m3 / c.bulk_modulus_pa
        return y

    def atol(self) -> FloatArray:
        scale = {"t_s": 1e-7, "t_l": 1e-7, "v_l": 1e-13, "m_s": 1e-12, "m_l": 1e-12, "z": 1e-15, "v_s": 1e-13, "void": 1e-16,
                 "s5": 1e-9, "s6": 1e-9, "y": 1e-10, "vy": 1e-9, "t_oil": 1e-6, "t_tc": 1e-6, "t_tc_oil": 1e-6, "t_wall": 1e-7,
                 "f_lag": 1e-3, "ps_lag": 1e-1, "pl_lag": 1e-1}
        return np.array([scale.get(n, 1e-4) for n in self.names])

    # -- the right-hand side ------------------------------------------------
    def evaluate(self, t: float, y: FloatArray, outputs: bool = False) -> tuple[list[float], dict[str, float] | None]:
        self.n_rhs += 1
        u, e, i = self.unit, self.unit.effects, self.index
        area, p_atm, p_vap, t_amb = u.piston_area_m2, u.ambient_pressure_pa, u.vapour_pressure_pa, u.ambient_k
        d = [0.0] * len(y)
        mot = self.motion
        if self.sdof:
            b, bd = mot.x(t), mot.v(t)
            yb, vb = y[i["y"]], y[i["vy"]]
            x, xd = b - yb, bd - vb
        else:
            b = bd = yb = 0.0
            x, xd = mot.x(t), mot.v(t)
        vl_ = e.valve_lag
        if vl_ is not None:
            s5, s6 = y[i["s5"]], y[i["s6"]]
            d[i["s5"]] = (self.cmd5 - s5) / (vl_.time_constant_s * (1.0 if self.cmd5 > s5 else vl_.close_ratio))
            d[i["s6"]] = (self.cmd6 - s6) / (vl_.time_constant_s * (1.0 if self.cmd6 > s6 else vl_.close_ratio))
            s5, s6 = min(max(s5, 0.0), 1.0), min(max(s6, 0.0), 1.0)
        else:
            s5, s6 = self.cmd5, self.cmd6
        hb = e.heat_buildup
        t_wall = y[i["t_wall"]] if hb is not None else t_amb
        t_oil = y[i["t_oil"]]
        if e.leakage is not None:
            m_s, m_l = y[i["m_s"]], y[i["m_l"]]
        else:
            m_s, m_l = self.m_s0, self.m_l0
        v_l = y[i["v_l"]]
        oc = e.oil_compliance
        void = 0.0
        if oc is not None:
            v_s = y[i["v_s"]]
        else:
            if self.cavitating:
                void = y[i["void"]]
            v_s = u.small_acc_volume_m3 + u.large_acc_volume_m3 - area * x - void - v_l
        if self.isothermal:
            t_s = t_l = t_wall
        else:
            t_s, t_l = y[i["t_s"]], y[i["t_l"]]
        p_s, dpdt_s, cv_s = self.gas_s.props(m_s / v_s, t_s)
        p_l, dpdt_l, cv_l = self.gas_l.props(m_l / v_l, t_l)
        # valve 6: Wu orifice
        dp6 = p_s - p_l
        if s6 > 0.0:
            v6 = u.valve6
            w = math.sqrt(2.0 * abs(dp6) / u.damper.oil_density_kg_m3)
            q6 = s6 * v6.cd_inf * math.tanh(2.0 * v6.diameter_m * w / (u.damper.nu_ref_m2_s * v6.lambda_crit)) * v6.area_m2 * w
            if dp6 < 0:
                q6 = -q6
        else:
            q6 = 0.0
        nu = None
        if e.oil_viscosity is not None:
            nu = u.damper.nu_ref_m2_s * math.exp(-e.oil_viscosity.coefficient_per_k * (t_oil - u.static_temperature_k))
        demand = area * xd
        if oc is not None:
            z = y[i["z"]]
            p_strut = p_vap + oc.bulk_modulus_pa / oc.oil_volume_m3 * z if z > 0 else p_vap
            q = self.damper.flow(p_strut - p_s, s5, nu)
            d[i["z"]] = demand - q
            dv_s = q6 - q
            d[i["v_s"]] = dv_s
            void = max(-z, 0.0)
        elif self.cavitating:
            p_strut = p_vap
            q = self.damper.flow(p_vap - p_s, s5, nu)
            d[i["void"]] = q - demand
            dv_s = q6 - q
        else:
            q = demand
            p_strut = p_s + self.damper.drop(q, s5, nu)
            if p_strut < p_vap:
                self.below_vapour = True
            dv_s = q6 - q
        d[i["v_l"]] = -q6
        # seal permeation
        if e.leakage is not None:
            k = 1.0 / (e.leakage.time_constant_s * (u.static_pressure_pa - p_atm))
            dm_s, dm_l = -self.m_s0 * k * (p_s - p_atm), -self.m_l0 * k * (p_l - p_atm)
            d[i["m_s"]], d[i["m_l"]] = dm_s, dm_l
        else:
            dm_s = dm_l = 0.0
        heat_s = self.ha_s * (t_s - t_wall)  # W from the gas to the wall
        heat_l = self.ha_l * (t_l - t_wall)
        if not self.isothermal:
            dvs = dv_s / m_s - v_s / (m_s * m_s) * dm_s
            dvl = -q6 / m_l - v_l / (m_l * m_l) * dm_l
            d[i["t_s"]] = -heat_s / (m_s * cv_s) - t_s / cv_s * dpdt_s * dvs
            d[i["t_l"]] = -heat_l / (m_l * cv_l) - t_l / cv_l * dpdt_l * dvl
        # seal friction (smoothed Coulomb with a Stribeck peak, viscous) and bump stop
        fr = e.friction
        if fr is not None:
            fc = fr.coulomb_n * (1.0 + fr.pressure_coefficient * (p_strut / u.static_pressure_pa - 1.0))
            fs = fc * fr.static_ratio
            r = xd / fr.stribeck_velocity_m_s
            f_fric = (fc + (fs - fc) * math.exp(-r * r)) * math.tanh(xd / fr.smoothing_velocity_m_s) + fr.viscous_n_s_per_m * xd
        else:
            f_fric = 0.0
        bs = e.bump_stop
        f_bump = p_bump = 0.0
        if bs is not None and x > bs.start_m:
            pen = x - bs.start_m
            elastic = bs.stiffness_n_per_m1_5 * pen * math.sqrt(pen)
            f_bump = elastic * (1.0 + bs.damping_rel_s_per_m * xd)
            p_bump = elastic * bs.damping_rel_s_per_m * xd * xd
        force = (p_strut - p_atm) * area + f_fric + f_bump
        if self.sdof:
            d[i["y"]] = vb
            d[i["vy"]] = force / self.mass - G_M_S2
        # thermal network: the oil takes the heat of the damper, valve 6 and the seal
        p_damper = q * (p_strut - p_s)
        p_valve6 = q6 * dp6
        p_fric = f_fric * xd
        dt_oil = t_oil - t_amb
        g_oa = u.oil_heat_capacity_j_per_k / u.oil_to_ambient_tau_100k_s * (math.sqrt(dt_oil * dt_oil + 4.0) / 100.0) ** u.oil_to_ambient_exponent
        q_oil = p_damper + p_valve6 + p_fric + p_bump - g_oa * dt_oil
        if hb is not None:
            c_w = hb.wall_heat_capacity_j_per_k
            to_wall = c_w / hb.wall_to_oil_tau_s * (t_oil - t_wall)
            q_oil -= to_wall
            d[i["t_wall"]] = (to_wall + c_w / hb.wall_to_ambient_tau_s * (t_amb - t_wall) + heat_s + heat_l) / c_w
        d[i["t_oil"]] = q_oil / u.oil_heat_capacity_j_per_k
        d[i["t_tc"]] = (t_s - y[i["t_tc"]]) / u.thermocouple_tau_s
        d[i["t_tc_oil"]] = (t_oil - y[i["t_tc_oil"]]) / u.thermocouple_tau_s
        if e.sensor_lag is not None:
            ts = e.sensor_lag.time_constant_s
            d[i["f_lag"]] = (force - y[i["f_lag"]]) / ts
            d[i["ps_lag"]] = (p_s - y[i["ps_lag"]]) / ts
            d[i["pl_lag"]] = (p_l - y[i["pl_lag"]]) / ts
        if self.energy:
            d[i["work_in_j"]] = force * xd
            d[i["damper_j"]] = p_damper
            d[i["valve6_j"]] = p_valve6
            d[i["friction_j"]] = p_fric
            d[i["bump_j"]] = p_bump
            d[i["heat_gas_j"]] = heat_s
            d[i["heat_gas2_j"]] = heat_l
        if not outputs:
            return d, None
        out = {
            "disp_m": x, "base_disp_m": b, "body_disp_m": yb, "vel_m_s": xd, "force_n": force, "p_strut_pa": p_strut,
            "p_gas_pa": p_s, "p_gas2_pa": p_l, "t_gas_k": t_s, "t_gas2_k": t_l, "t_oil_k": t_oil, "t_wall_k": t_wall,
            "t_gas_meas_k": y[i["t_tc"]], "t_oil_meas_k": y[i["t_tc_oil"]], "v_gas_m3": v_s, "v_gas2_m3": v_l,
            "void_m3": void, "flow_m3_s": q, "damper_power_w": p_damper, "friction_n": f_fric, "bump_n": f_bump,
            "mass_gas_kg": m_s, "mass_gas2_kg": m_l, "valve6_open": s6, "valve5_open": s5,
        }
        if e.sensor_lag is not None:
            out["force_n_lagged"] = y[i["f_lag"]]
            out["p_gas_pa_lagged"] = y[i["ps_lag"]]
            out["p_gas2_pa_lagged"] = y[i["pl_lag"]]
        return d, out

    def fun(self, t: float, y: FloatArray) -> list[float]:
        return self.evaluate(t, y)[0]

    # -- cavitation events (rigid oil) ---------------------------------------
    def onset(self, t: float, y: FloatArray) -> float:
        """Strut pressure over the vapour pressure in the non-cavitating mode."""
        out = self.evaluate(t, y, outputs=True)[1]
        assert out is not None
        return out["p_strut_pa"] - self.unit.vapour_pressure_pa

    def closure(self, t: float, y: FloatArray) -> float:
        return float(y[self.index["void"]]) - VOID_TOL_M3


def _event(f: Callable[[float, FloatArray], float], direction: float) -> Callable[[float, FloatArray], float]:
    def g(t: float, y: FloatArray) -> float:
        return f(t, y)

    g.terminal = True  # type: ignore[attr-defined]
    g.direction = direction  # type: ignore[attr-defined]
    return g


def simulate(
    unit: Unit,
    motion: Motion,
    sample_times_s: Sequence[float] | FloatArray,
    segments: Sequence[Segment],
    duration_s: float,
    sprung_mass_kg: float | None = None,
    energy: bool = False,
    method: str = "LSODA",
    rtol: float = 1e-8,
    balanced: bool = True,
) -> RunResult:
    """Runs the plant and returns its true channels at ``sample_times_s``
    (increasing, within [0, duration_s]); ``segments`` hold the valve
    commands (the first starts at 0). On the SDOF rig the mass must rest at
    the static position unless ``balanced`` is False."""
    plant = Plant(unit, motion, sprung_mass_kg, energy, balanced)
    ts = np.asarray(sample_times_s, dtype=float)
    if ts.size == 0 or np.any(np.diff(ts) <= 0) or ts[0] < 0 or ts[-1] > duration_s:
        raise ValueError("sample times must increase strictly within [0, duration]")
    if not segments or segments[0].start_s != 0.0:
        raise ValueError("the first valve segment must start at 0")
    bounds = sorted({0.0, duration_s, *(s.start_s for s in segments if 0 < s.start_s < duration_s), *motion.breaks(duration_s)})
    y = plant.initial_state(segments[0])
    atol = plant.atol()
    rigid = unit.effects.oil_compliance is None
    rows: list[dict[str, float]] = []
    states: list[FloatArray] = []
    events_log: list[tuple[float, str]] = []
    seg_i = 0
    taken = 0  # samples already output
    for a, b in zip(bounds[:-1], bounds[1:]):
        while seg_i + 1 < len(segments) and segments[seg_i + 1].start_s <= a:
            seg_i += 1
        plant.cmd5 = float(segments[seg_i].valve5_open)
        plant.cmd6 = float(segments[seg_i].valve6_open)
        t_cur, watch_onset = a, False
        while True:
            events = None
            if rigid and plant.cavitating:
                # closure, or (if the onset was located a hair early and the
                # void never opened) its volume going negative
                events = [_event(plant.closure, -1.0), _event(lambda t, y: float(y[plant.index["void"]]) + 1e3 * VOID_TOL_M3, -1.0)]
            elif rigid and watch_onset:
                events = [_event(plant.onset, -1.0)]
            plant.below_vapour = False
            lo = taken
            hi_all = int(np.searchsorted(ts, b, side="right" if b == bounds[-1] else "left"))
            # Samples of this span, then its end (for the state to go on from).
            t_eval = np.concatenate((ts[lo:hi_all], [b])) if (hi_all == lo or ts[hi_all - 1] < b) else ts[lo:hi_all]
            sol = solve_ivp(plant.fun, (t_cur, b), y, method=method, t_eval=t_eval, rtol=rtol, atol=atol,
                            max_step=max((b - t_cur) / 4, 1e-6), events=events)
            if not sol.success:
                raise RuntimeError(f"integration failed at t = {sol.t[-1] if sol.t.size else t_cur}: {sol.message}")
            if rigid and not plant.cavitating and events is None and plant.below_vapour:
                watch_onset = True  # the strut pressure went below the vapour pressure: locate the onset
                continue
            if sol.status == 1:
                t_end = float(sol.t_events[0][0] if sol.t_events[0].size else sol.t_events[1][0])
                y_end = (sol.y_events[0][0] if sol.t_events[0].size else sol.y_events[1][0]).copy()
            else:
                t_end, y_end = b, sol.y[:, -1].copy()
            n_out = min(len(sol.t), hi_all - lo)  # sol.t is a prefix of t_eval
            for k in range(n_out):
                rows.append(plant.evaluate(float(sol.t[k]), sol.y[:, k], outputs=True)[1] or {})
                states.append(sol.y[:, k].copy())
            taken = lo + n_out
            y = y_end
            if sol.status == 1:  # an event: switch mode
                plant.cavitating = not plant.cavitating
                events_log.append((t_end, "onset" if plant.cavitating else "closure"))
                y[plant.index["void"]] = 0.0
                t_cur, watch_onset = t_end, False
                if t_cur >= b:
                    break
                continue
            break
    if taken != len(ts):
        raise RuntimeError(f"{len(ts) - taken} samples were not reached")
    channels = {k: np.array([r[k] for r in rows]) for k in rows[0]}
    st = np.array(states)
    en = {k: st[:, plant.index[k]] for k in ENERGY} if energy else {}
    return RunResult(ts, channels, en, plant.n_rhs, events_log, {n: float(v) for n, v in zip(plant.names, y)})

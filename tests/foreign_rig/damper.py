"""The damper as hydraulic components, not as a force-velocity curve.

Between the strut and accumulator S the oil passes, in series,

- the line (hose and ports): a turbulent loss ``rho/2 zeta (Q/A_line)^2``;
- the valve block, in parallel:
  - the damper pack, one set of passages per direction: a laminar bleed
    (conductance ``G``, proportional to 1/viscosity), a fixed orifice and a
    washer held on its seat by a preloaded (Belleville) spring, which lifts
    when the pressure drop passes its cracking pressure: its flow area grows
    with the excess pressure over the spring rate until the washer reaches
    its stop (a smooth ramp-and-saturate);
  - the bypass, solenoid valve 5, an orifice times its opening fraction
    (1 = open = damper "off").

Every orifice uses Wu's laminar-to-turbulent discharge law,
``Cd = Cd_inf tanh(2 lambda / lambda_crit)`` with the flow number
``lambda = (D_h / nu) sqrt(2 |dp| / rho)`` (Wu, Burton, Schoenau 2002), so
flow is linear in the pressure drop near zero and goes as its square root
once turbulent. All flows are odd and strictly increasing in the pressure
drop; the strut force follows by inverting them (tables on a fine grid, or
Newton where the valve is moving or the oil viscosity changes).

Sign: positive flow is compression (strut to accumulator), positive
pressure drop is strut pressure minus gas-side pressure.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

FloatArray = NDArray[np.float64]


@dataclass(frozen=True)
class Orifice:
    """A sharp-edged orifice: area, hydraulic diameter, discharge coefficient."""

    area_m2: float
    diameter_m: float
    cd_inf: float = 0.7
    lambda_crit: float = 100.0

    def flow(self, dp: FloatArray | float, rho: float, nu: float, area_m2: FloatArray | float | None = None) -> FloatArray:
        a = self.area_m2 if area_m2 is None else area_m2
        u = np.sqrt(2.0 * np.abs(dp) / rho)
        lam = self.diameter_m / nu * u
        return np.sign(dp) * self.cd_inf * np.tanh(2.0 * lam / self.lambda_crit) * a * u


@dataclass(frozen=True)
class BlowOff:
    """A spring-loaded washer: closed below ``crack_pa``; above it the flow
    area grows by ``area_per_pa`` per pascal until ``max_area_m2``.
    ``smooth_pa`` rounds the opening and the stop (seat and stop contact
    are not knife edges)."""

    crack_pa: float
    area_per_pa: float
    max_area_m2: float
    seat_diameter_m: float
    smooth_pa: float = 2e5

    def area(self, dp_mag: FloatArray | float) -> FloatArray:
        # Smooth ramp (hyperbola) then smooth saturation: monotone in dp.
        e = (np.asarray(dp_mag) - self.crack_pa) / self.smooth_pa
        ramp = 0.5 * (e + np.sqrt(e * e + 1.0)) * self.smooth_pa * self.area_per_pa
        r = ramp / self.max_area_m2
        sat_w = self.smooth_pa * self.area_per_pa / self.max_area_m2
        sat = 1.0 - 0.5 * ((1.0 - r) + np.sqrt((1.0 - r) ** 2 + sat_w**2))
        return np.maximum(sat, 0.0) * self.max_area_m2


@dataclass(frozen=True)
class Passages:
    """One direction of the damper pack."""

    bleed_m3_per_s_pa: float  # laminar bleed conductance at the reference viscosity
    orifice: Orifice
    blowoff: BlowOff

    def flow(self, dp_mag: FloatArray | float, rho: float, nu: float, nu_ref: float) -> FloatArray:
        """Flow magnitude at pressure-drop magnitude ``dp_mag`` (>= 0)."""
        q_bleed = self.bleed_m3_per_s_pa * (nu_ref / nu) * np.asarray(dp_mag)
        q_orifice = self.orifice.flow(dp_mag, rho, nu)
        # The lifted washer is an annular orifice with the seat as its
        # hydraulic length scale: same discharge law, its own diameter.
        seat = Orifice(0.0, self.blowoff.seat_diameter_m, self.orifice.cd_inf, self.orifice.lambda_crit)
        q_valve = seat.flow(dp_mag, rho, nu, area_m2=self.blowoff.area(dp_mag))
        return q_bleed + q_orifice + q_valve


@dataclass(frozen=True)
class DamperPack:
    """The valve block: the pack's two directions and the bypass (valve 5),
    itself a softer, symmetric set of passages (bleed, orifice, washer)
    opened by the solenoid."""

    compression: Passages
    rebound: Passages
    bypass: Passages
    line_zeta: float = 3.0
    line_area_m2: float = 1.13e-4  # 12 mm hose
    oil_density_kg_m3: float = 870.0
    # Kinematic viscosity at the reference temperature (ISO VG 32 near 20 C).
    nu_ref_m2_s: float = 8.0e-5

    def valve_flow(self, dp: FloatArray | float, bypass_open: float, nu: float | None = None) -> FloatArray:
        """Flow through the valve block (pack and bypass) at signed pressure drop ``dp``."""
        nu = self.nu_ref_m2_s if nu is None else nu
        rho, ref = self.oil_density_kg_m3, self.nu_ref_m2_s
        dp = np.asarray(dp, dtype=float)
        mag = np.abs(dp)
        pack = np.where(dp >= 0, self.compression.flow(mag, rho, nu, ref), -self.rebound.flow(mag, rho, nu, ref))
        if bypass_open > 0:
            pack = pack + np.sign(dp) * self.bypass.flow(mag, rho, nu, ref) * bypass_open
        return pack

    def line_drop(self, q: FloatArray | float) -> FloatArray:
        q = np.asarray(q, dtype=float)
        return 0.5 * self.oil_density_kg_m3 * self.line_zeta * q * np.abs(q) / self.line_area_m2**2


# Pressure-drop grid of the inversion tables: uniform in asinh(dp / 1 kPa)
# from -200 MPa to 200 MPa, fine enough that linear interpolation is exact
# to about 1e-6 of the value (checked in the tests against Newton).
_TABLE_POINTS = 24001
_TABLE_SCALE_PA = 1e3
_TABLE_MAX_PA = 2e8


@dataclass
class DamperTable:
    """Flow <-> total pressure drop (line + valve block) of one fixed valve
    opening, as monotone tables."""

    dp_total: FloatArray
    q: FloatArray

    def drop(self, q: float) -> float:
        return float(np.interp(q, self.q, self.dp_total))

    def flow(self, dp_total: float) -> float:
        return float(np.interp(dp_total, self.dp_total, self.q))


def scalar_valve_flow(pack: DamperPack) -> Callable[[float, float, float], float]:
    """``valve_flow`` for one float, in plain ``math`` (the ODE's inner loop
    calls it where the tables do not apply); the tests check it against the
    vectorised form."""
    rho, ref = pack.oil_density_kg_m3, pack.nu_ref_m2_s

    def passages(p: Passages) -> Callable[[float, float], float]:
        g, o, v = p.bleed_m3_per_s_pa, p.orifice, p.blowoff
        k_o = 2.0 * o.diameter_m / o.lambda_crit
        k_v = 2.0 * v.seat_diameter_m / o.lambda_crit
        crack, sm, gain, amax = v.crack_pa, v.smooth_pa, v.area_per_pa, v.max_area_m2
        sat_w2 = (sm * gain / amax) ** 2

        def flow(mag: float, nu: float) -> float:
            u = math.sqrt(2.0 * mag / rho)
            e = (mag - crack) / sm
            r = 0.5 * (e + math.sqrt(e * e + 1.0)) * sm * gain / amax
            area = max(1.0 - 0.5 * ((1.0 - r) + math.sqrt((1.0 - r) ** 2 + sat_w2)), 0.0) * amax
            return (g * (ref / nu) * mag + o.cd_inf * math.tanh(k_o * u / nu) * o.area_m2 * u
                    + o.cd_inf * math.tanh(k_v * u / nu) * area * u)

        return flow

    comp, reb, byp = passages(pack.compression), passages(pack.rebound), passages(pack.bypass)

    def valve_flow(dp: float, bypass_open: float, nu: float) -> float:
        mag = abs(dp)
        q = comp(mag, nu) if dp >= 0 else reb(mag, nu)
        if bypass_open > 0:
            q += bypass_open * byp(mag, nu)
        return q if dp >= 0 else -q

    return valve_flow


@dataclass
class Damper:
    """The damper with its inversion tables (built once per valve state)."""

    pack: DamperPack
    _tables: dict[float, DamperTable] = field(default_factory=dict)
    _scalar: Callable[[float, float, float], float] | None = None

    def table(self, bypass_open: float) -> DamperTable:
        t = self._tables.get(bypass_open)
        if t is None:
            g = np.linspace(-math.asinh(_TABLE_MAX_PA / _TABLE_SCALE_PA), math.asinh(_TABLE_MAX_PA / _TABLE_SCALE_PA), _TABLE_POINTS)
            dp_v = np.sinh(g) * _TABLE_SCALE_PA
            q = self.pack.valve_flow(dp_v, bypass_open)
            t = DamperTable(dp_v + self.pack.line_drop(q), q)
            self._tables[bypass_open] = t
        return t

    def _flow_fn(self) -> Callable[[float, float, float], float]:
        if self._scalar is None:
            self._scalar = scalar_valve_flow(self.pack)
        return self._scalar

    def _line(self, q: float) -> float:
        p = self.pack
        return 0.5 * p.oil_density_kg_m3 * p.line_zeta * q * abs(q) / p.line_area_m2**2

    def drop(self, q: float, bypass_open: float, nu: float | None = None) -> float:
        """Total pressure drop (strut minus gas side) at flow ``q``."""
        if nu is None and bypass_open in (0.0, 1.0):
            return self.table(bypass_open).drop(q)
        f = self._flow_fn()
        n = self.pack.nu_ref_m2_s if nu is None else nu
        line = self._line(q)
        guess = self.table(1.0 if bypass_open >= 0.5 else 0.0).drop(q) - line
        return _solve_monotone(lambda d: f(d, bypass_open, n) - q, guess) + line

    def flow(self, dp_total: float, bypass_open: float, nu: float | None = None) -> float:
        """Flow at total pressure drop ``dp_total``."""
        if nu is None and bypass_open in (0.0, 1.0):
            return self.table(bypass_open).flow(dp_total)
        f = self._flow_fn()
        n = self.pack.nu_ref_m2_s if nu is None else nu
        q0 = self.table(1.0 if bypass_open >= 0.5 else 0.0).flow(dp_total)
        dp_v = _solve_monotone(lambda d: d + self._line(f(d, bypass_open, n)) - dp_total, dp_total - self._line(q0))
        return f(dp_v, bypass_open, n)


def _solve_monotone(func: Callable[[float], float], x0: float, tol_rel: float = 1e-12) -> float:
    """Root of an increasing scalar function: bracket from ``x0``, then
    regula falsi with the Illinois modification."""
    f0 = func(x0)
    if f0 == 0.0:
        return x0
    step = max(abs(x0) * 0.02, 10.0)
    lo, hi, flo, fhi = x0, x0, f0, f0
    for _ in range(200):
        if f0 > 0:
            lo = lo - step
            flo = func(lo)
            if flo <= 0:
                break
        else:
            hi = hi + step
            fhi = func(hi)
            if fhi >= 0:
                break
        step *= 2.0
    else:
        raise ArithmeticError("no bracket for the damper inversion")
    side = 0
    for _ in range(200):
        x = (lo * fhi - hi * flo) / (fhi - flo) if fhi != flo else 0.5 * (lo + hi)
        fx = func(x)
        if abs(hi - lo) <= tol_rel * max(abs(x), 1.0) or fx == 0.0:
            return x
        if fx > 0:
            hi, fhi = x, fx
            if side == 1:
                flo *= 0.5
            side = 1
        else:
            lo, flo = x, fx
            if side == -1:
                fhi *= 0.5
            side = -1
    return 0.5 * (lo + hi)


def default_pack() -> DamperPack:
    """The foreign rig's nominal damper: about 9 kN at 0.25 m/s in
    compression with the damper on (A = 2e-3 m^2), rebound about 1.4 times
    stiffer, and "off" (bypass open) half of "on" in compression from 0.25
    to 1 m/s, as the seed reports."""
    return DamperPack(
        compression=Passages(4.0e-11, Orifice(1.0e-6, 1.2e-3), BlowOff(2.5e6, 1.5e-12, 4.0e-5, 2.0e-3, 3e5)),
        rebound=Passages(3.0e-11, Orifice(0.8e-6, 1.0e-3), BlowOff(4.5e6, 1.2e-12, 3.0e-5, 2.0e-3, 3e5)),
        bypass=Passages(5.0e-11, Orifice(1.0e-6, 2.0e-3), BlowOff(0.8e6, 2.5e-12, 4.0e-5, 2.5e-3, 2e5)),
    )

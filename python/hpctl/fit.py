"""Fitting the model to rig records, with the Rust simulator in the loop.

Each record is simulated with its own measured excitation (strut or base
displacement, smoothed), its valve states and its static state; the
residuals of the measured channels, each divided by that channel's noise
level estimated from the data itself, are minimised by SciPy's trust-region
least squares. The Jacobian's columns are simulated in parallel in Rust.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray
from scipy.optimize import least_squares
from scipy.signal import savgol_coeffs, savgol_filter

from hpctl import metrics
from hpctl.effects import CHARGE, DAMPER_GAIN, LIBRARY, OIL_VOLUME_M3, Param, build_unit, model_params
from hpctl.errors import HpctlError, RecordError
from hpctl.records import RigRecord
from hpctl.sim import Case, Sampled, characterisation_rig, run_many, sdof_rig
from hpctl.unit import Unit

FloatArray = NDArray[np.float64]

# Measured channels compared with the model, per record kind.
OUTPUTS = {"characterisation": ("force_n", "p_gas_pa", "p_gas2_pa"), "sdof": ("body_disp_m", "p_gas_pa", "p_gas2_pa")}


def noise_sigma(y: FloatArray) -> float:
    """Noise level of a sampled signal from its fourth differences: white
    noise of variance s^2 gives differences of variance 70 s^2, while a
    signal smooth on the sampling scale contributes almost nothing (its
    fourth difference scales with the fourth power of the sampling step).
    The median absolute deviation keeps steps and spikes out."""
    d4 = np.diff(np.asarray(y, float), 4)
    if d4.size == 0:
        return 0.0
    mad = float(np.median(np.abs(d4 - np.median(d4))))
    return mad / 0.6745 / math.sqrt(70.0)


@dataclass
class Dataset:
    """One record prepared for fitting."""

    record: RigRecord
    base: Unit
    rig: dict[str, Any]
    times_s: FloatArray
    spring_hard: NDArray[np.bool_]
    damper_on: NDArray[np.bool_]
    targets: dict[str, FloatArray]
    sigma: dict[str, float]
    ambient_k: float
    max_dt_s: float
    # Per-sample standard deviation of each channel's residual: the
    # channel's own noise plus the input displacement's noise carried
    # through the local sensitivity (the effective-variance method).
    weight_sigma: dict[str, FloatArray] = field(default_factory=dict)
    # The strut's compression (base minus body on the SDOF rig), smoothed,
    # and its rate: what the residual analysis and the reports plot against.
    strut_disp_m: FloatArray = field(default_factory=lambda: np.zeros(0))
    strut_vel_m_s: FloatArray = field(default_factory=lambda: np.zeros(0))

    @property
    def name(self) -> str:
        return self.record.name


def base_unit(record: RigRecord, template: Unit | None = None) -> Unit:
    """The unit a record describes: its piston area, gas volumes and static
    state; what the record does not say (damper curves, valve 6, stroke)
    from ``template`` (the built-in unit by default)."""
    t = template or Unit.seed()
    return t.replace(
        piston_area_m2=record.unit.piston_area_m2,
        small_volume_m3=record.unit.small_acc_volume_m3,
        large_volume_m3=record.unit.large_acc_volume_m3,
        static_pressure_pa=record.static.pressure_pa,
        static_temperature_k=record.static.temperature_k,
    )


SMOOTH_WINDOW, SMOOTH_ORDER = 11, 3
# How much of the input's white noise survives the smoothing (standard deviation).
SMOOTH_NOISE_GAIN = float(np.sqrt(np.sum(savgol_coeffs(SMOOTH_WINDOW, SMOOTH_ORDER) ** 2)))


def _smooth(t: FloatArray, x: FloatArray) -> FloatArray:
    """The measured displacement with its noise filtered (Savitzky-Golay,
    cubic, 11 samples): the model is driven by it, and a noisy input would
    become a noisy velocity for the damper and friction. Where the signal
    has features sharper than the window (a step, or a sine sampled a few
    times per cycle), the filter would move it by more than its noise: there
    the raw samples are kept, so smoothing never distorts the excitation."""
    x = np.asarray(x, float)
    if len(x) < 2 * SMOOTH_WINDOW:
        return x
    smooth = np.asarray(savgol_filter(x, SMOOTH_WINDOW, SMOOTH_ORDER))
    distorted = np.abs(smooth - x) > 4.0 * max(noise_sigma(x), 1e-12)
    # Keep the raw samples around distortions too (the filter's reach).
    distorted = np.convolve(distorted.astype(float), np.ones(SMOOTH_WINDOW), "same") > 0
    return np.where(distorted, x, smooth)


def local_sensitivities(x: FloatArray, v: FloatArray, y: FloatArray, window: int = 21) -> tuple[FloatArray, FloatArray]:
    """dy/dx and dy/dv along a trajectory: the least-squares coefficients
    of ``y ~ a + b x + c v`` in a sliding window (well defined through
    turning points, where x alone would barely change)."""
    n = len(x)
    w = min(window, n)
    k = np.ones(w) / w

    def mean(a: FloatArray) -> FloatArray:
        return np.asarray(np.convolve(a, k, "same"))

    mx, mv, my = mean(x), mean(v), mean(y)
    sxx, svv, sxv = mean(x * x) - mx * mx, mean(v * v) - mv * mv, mean(x * v) - mx * mv
    sxy, svy = mean(x * y) - mx * my, mean(v * y) - mv * my
    det = sxx * svv - sxv * sxv
    ok = det > 1e-12 * np.maximum(sxx * svv, 1e-300)
    safe = np.where(ok, det, 1.0)
    b = np.where(ok, (sxy * svv - svy * sxv) / safe, np.where(sxx > 0, sxy / np.where(sxx > 0, sxx, 1.0), 0.0))
    c = np.where(ok, (svy * sxx - sxy * sxv) / safe, 0.0)
    half = w // 2
    if n > 2 * half + 1:
        for arr in (b, c):
            arr[:half], arr[n - half:] = arr[half], arr[n - half - 1]
    return np.asarray(b), np.asarray(c)


FIVE_POINT = np.array([1.0, -8.0, 0.0, 8.0, -1.0]) / 12.0


def derivative(t: FloatArray, x: FloatArray) -> FloatArray:
    """dx/dt at the samples, fourth-order accurate: the derivative of the
    quartic through each sample and its two neighbours on either side
    (irregular spacing allowed); second order at the two ends."""
    n = len(x)
    out = np.gradient(x, t, edge_order=2) if n >= 3 else np.gradient(x, t) if n == 2 else np.zeros(n)
    if n < 5:
        return np.asarray(out)
    i = np.arange(2, n - 2)
    nodes = np.stack([t[i + k] for k in (-2, -1, 0, 1, 2)])  # 5 x m
    tc = t[i]
    weights = np.zeros_like(nodes)
    for j in range(5):
        if j == 2:
            weights[j] = sum(1.0 / (tc - nodes[m]) for m in range(5) if m != 2)
            continue
        num = np.ones_like(tc)
        den = np.ones_like(tc)
        for m in range(5):
            if m != j:
                den *= nodes[j] - nodes[m]
            if m not in (j, 2):
                num *= tc - nodes[m]
        weights[j] = num / den
    out[2:n - 2] = np.sum(weights * np.stack([x[i + k] for k in (-2, -1, 0, 1, 2)]), axis=0)
    return np.asarray(out)


def _velocity_noise_gain(dt_s: float) -> float:
    """Standard deviation of the velocity the model sees (the five-point
    derivative of the smoothed input, the interpolation's tangents) per
    unit of white input noise."""
    coeffs = savgol_coeffs(SMOOTH_WINDOW, SMOOTH_ORDER)
    return float(np.sqrt(np.sum((np.convolve(coeffs, FIVE_POINT) / dt_s) ** 2)))


def prepare(records: Sequence[RigRecord], template: Unit | None = None) -> list[Dataset]:
    """Checks that the records can be fitted and prepares them."""
    if not records:
        raise HpctlError("no records to fit")
    out = []
    for rec in records:
        t = np.asarray(rec["time_s"], float)
        x_in = rec["base_disp_m"] if rec.kind == "sdof" else rec["disp_m"]
        xs = _smooth(t, x_in)
        vs = derivative(t, xs)
        motion = Sampled(t, xs, vs)
        if rec.kind == "sdof":
            if rec.sprung_mass_kg is None:
                raise RecordError(f"{rec.name}: SDOF record without [sdof] sprung_mass_kg")
            rig = sdof_rig(motion, rec.sprung_mass_kg)
        else:
            rig = characterisation_rig(motion)
        targets = {c: np.asarray(rec[c], float) for c in OUTPUTS[rec.kind] if c in rec}
        sigma: dict[str, float] = {}
        weight_sigma: dict[str, FloatArray] = {}
        x_raw_noise = noise_sigma(x_in)
        x_noise = x_raw_noise * SMOOTH_NOISE_GAIN
        v_noise = x_raw_noise * _velocity_noise_gain(float(np.median(np.diff(t))))
        for c, y in targets.items():
            floor = 1e-4 * max(float(np.ptp(y)), 1e-12)
            sigma[c] = max(noise_sigma(y), floor)
            # An SDOF body filters the base's noise through its dynamics;
            # on the characterisation rig the outputs follow the input's
            # position (gas) and velocity (damper, friction) at once.
            if rec.kind == "sdof":
                carried2: Any = 0.0
            else:
                b, cv = local_sensitivities(xs, vs, _smooth(t, y))
                carried2 = (b * x_noise) ** 2 + (cv * v_noise) ** 2
            weight_sigma[c] = np.sqrt(sigma[c] ** 2 + carried2) * np.ones(len(t))
        hard, on = rec.spring_hard(), rec.damper_on()
        # With valve 6 open its orifice is the fastest dynamics (about a
        # millisecond); otherwise the gas, whose thermal time constant is
        # seconds. Steps also never span more than one sample interval.
        max_dt = 1e-3 if bool((~hard).any()) else 0.02
        strut = _smooth(t, rec["base_disp_m"] - rec["body_disp_m"]) if rec.kind == "sdof" else xs
        out.append(Dataset(rec, base_unit(rec, template), rig, t, hard, on, targets, sigma, rec.static.ambient_k, max_dt, weight_sigma,
                           strut, derivative(t, strut) if rec.kind == "sdof" else vs))
    return out


def uses_damper(datasets: Sequence[Dataset]) -> bool:
    """Whether the damper does measurable work in the records (strut speeds
    above 0.05 m/s), so that its gain can be identified."""
    return any(np.percentile(np.abs(d.strut_vel_m_s), 95) > 0.05 for d in datasets)


@dataclass
class Model:
    """A model structure: the effects it has and the parameters it fits."""

    effects: tuple[str, ...]
    fit_damper: bool

    @property
    def params(self) -> list[Param]:
        ps = model_params(self.effects) + [CHARGE]
        if self.fit_damper:
            ps.append(DAMPER_GAIN)
        return ps

    def unit_for(self, d: Dataset, values: Mapping[str, float]) -> Unit:
        base = d.base.replace(static_pressure_pa=d.base.static_pressure_pa * values.get("charge_scale", 1.0))
        if "damper_gain" in values:
            base = base.replace(damper=base.damper.scaled(values["damper_gain"]))
        return build_unit(base, self.effects, values)

    def max_dt_s(self, d: Dataset, values: Mapping[str, float]) -> float:
        """A step small enough for the fastest dynamics the model has."""
        dt = d.max_dt_s
        # RK4 is stable up to 2.8 time constants and accurate to well
        # within the noise at one.
        if "valve_time_constant_s" in values:
            dt = min(dt, values["valve_time_constant_s"])
        if "oil_bulk_modulus_pa" in values:
            area = d.base.piston_area_m2
            c1 = min(c.bleed_pa_s_per_m3 for c in vars(d.base.damper).values()) * area**2 * values.get("damper_gain", 1.0)
            tau_c = OIL_VOLUME_M3 * c1 / (values["oil_bulk_modulus_pa"] * area**2)
            dt = min(dt, tau_c)
        return max(dt, 2e-5)


def _case(model: Model, d: Dataset, values: Mapping[str, float]) -> Case:
    channels = ["time_s", "disp_m", "force_n", "p_gas_pa", "p_gas2_pa", "body_disp_m", "t_gas_k", "damper_force_n", "friction_force_n"]
    return Case(model.unit_for(d, values), d.rig, d.times_s, spring_hard=d.spring_hard, damper_on=d.damper_on,
                dt_s=model.max_dt_s(d, values), ambient_k=d.ambient_k, channels=channels)


def values_from_x(params: Sequence[Param], x: Sequence[float] | FloatArray) -> dict[str, float]:
    return {p.name: p.from_x(float(xi)) for p, xi in zip(params, x)}


def apply_sensor_lag(t: FloatArray, y: FloatArray, tau_s: float, y_rest: float | None = None) -> FloatArray:
    """A first-order lag of time constant ``tau_s`` applied to samples ``y``
    at times ``t``, exact for a signal linear between samples (first-order
    hold): what the transducer reports. It starts settled at ``y_rest``
    (the value at rest before the motion; ``y[0]`` by default), as the
    unit's sensor state does."""
    out = np.empty_like(y)
    h = np.diff(t)
    a = np.exp(-h / tau_s)
    ramp = (tau_s / h) * (1.0 - a)
    acc = float(y[0] if y_rest is None else y_rest)
    out[0] = acc
    for k in range(1, len(y)):
        acc = a[k - 1] * acc + y[k] - a[k - 1] * y[k - 1] - (y[k] - y[k - 1]) * ramp[k - 1]
        out[k] = acc
    return out


LAGGED = ("force_n", "p_gas_pa", "p_gas2_pa")


def simulate_all(model: Model, datasets: Sequence[Dataset], value_sets: Sequence[Mapping[str, float]]) -> list[list[dict[str, FloatArray] | Exception]]:
    """Simulates every dataset for every parameter set, in parallel."""
    cases = [_case(model, d, v) for v in value_sets for d in datasets]
    flat = run_many(cases)
    n = len(datasets)
    out: list[list[dict[str, FloatArray] | Exception]] = []
    for i, values in enumerate(value_sets):
        row: list[dict[str, FloatArray] | Exception] = []
        for d, r in zip(datasets, flat[i * n:(i + 1) * n]):
            if isinstance(r, Exception):
                row.append(r)
                continue
            ch = dict(r.channels)
            if "sensor_time_constant_s" in values:
                for c in LAGGED:
                    # At rest the force has no damper or friction part.
                    rest = ch[c][0] - (ch["damper_force_n"][0] + ch["friction_force_n"][0] if c == "force_n" else 0.0)
                    ch[c] = apply_sensor_lag(d.times_s, ch[c], values["sensor_time_constant_s"], rest)
            row.append(ch)
        out.append(row)
    return out


FAILED_RESIDUAL = 1e3  # per sample, in noise units: a simulation that failed is a very bad fit


def fold_mask(d: Dataset, fold: int, blocks: int = 10) -> NDArray[np.bool_]:
    """Samples of cross-validation fold ``fold`` (0 or 1): alternate
    contiguous blocks of the record, so both folds span the whole test."""
    n = len(d.times_s)
    block = np.minimum(np.arange(n) * blocks // max(n, 1), blocks - 1)
    return np.asarray(block % 2 == fold)


def residual_vector(
    datasets: Sequence[Dataset], sims: Sequence[dict[str, FloatArray] | Exception], fold: int | None = None
) -> FloatArray:
    """Residuals in noise units; only the samples of ``fold`` if given."""
    parts = []
    for d, sim in zip(datasets, sims):
        m = np.ones(len(d.times_s), bool) if fold is None else fold_mask(d, fold)
        for c, y in d.targets.items():
            if isinstance(sim, Exception):
                parts.append(np.full(int(m.sum()), FAILED_RESIDUAL))
            else:
                parts.append(((sim[c] - y) / d.weight_sigma[c])[m])
    return np.concatenate(parts)


@dataclass
class ChannelStats:
    record: str
    channel: str
    rms: float
    nrms: float
    max_abs: float
    noise: float
    loop_area_measured_j: float | None = None
    loop_area_error_j: float | None = None


@dataclass
class FitResult:
    """A fitted model: parameters with standard errors, residual statistics."""

    model: Model
    values: dict[str, float]
    stderr: dict[str, float]
    rss: float
    n: int
    stats: list[ChannelStats]
    sims: list[dict[str, FloatArray] | Exception]
    datasets: list[Dataset] = field(repr=False)
    success: bool = True
    message: str = ""

    @property
    def k(self) -> int:
        return len(self.model.params)

    @property
    def bic(self) -> float:
        """Bayesian information criterion (Gaussian residuals, variance fitted)."""
        return self.n * math.log(self.rss / self.n) + self.k * math.log(self.n)

    @property
    def rms_ratio(self) -> float:
        """Residual RMS over the noise level, pooled (1 = only noise left)."""
        return math.sqrt(self.rss / self.n)

    def residuals(self, d_index: int, channel: str) -> FloatArray:
        d = self.datasets[d_index]
        sim = self.sims[d_index]
        if isinstance(sim, Exception):
            return np.full(len(d.times_s), np.nan)
        return np.asarray(sim[channel] - d.targets[channel])


def _stats(datasets: Sequence[Dataset], sims: Sequence[dict[str, FloatArray] | Exception]) -> list[ChannelStats]:
    out = []
    for d, sim in zip(datasets, sims):
        for c, y in d.targets.items():
            if isinstance(sim, Exception):
                out.append(ChannelStats(d.name, c, math.inf, math.inf, math.inf, d.sigma[c]))
                continue
            r = sim[c] - y
            rng = float(np.ptp(y)) or 1.0
            st = ChannelStats(d.name, c, float(np.sqrt(np.mean(r**2))), float(np.sqrt(np.mean(r**2)) / rng), float(np.max(np.abs(r))), d.sigma[c])
            f = d.record.test.frequency_hz
            if c == "force_n" and d.record.test.excitation == "sine" and f and f * (d.times_s[-1] - d.times_s[0]) >= 1.0:
                m = metrics.last_cycle(d.times_s, f)
                x = d.record["disp_m"][m]
                st.loop_area_measured_j = metrics.loop_area_j(x, y[m])
                st.loop_area_error_j = metrics.loop_area_j(x, sim[c][m]) - st.loop_area_measured_j
            out.append(st)
    return out


def fit(
    datasets: Sequence[Dataset],
    effects: Sequence[str],
    *,
    initial: Mapping[str, float] | None = None,
    fit_damper: bool | None = None,
    max_nfev: int = 60,
    fold: int | None = None,
) -> FitResult:
    """Fits a model with ``effects`` to the datasets, starting from
    ``initial`` values where given (warm start), else the library defaults;
    to the samples of one cross-validation ``fold`` only, if given."""
    model = Model(tuple(n for n in LIBRARY if n in effects), uses_damper(datasets) if fit_damper is None else fit_damper)
    params = model.params
    start = dict(initial or {})
    x0 = np.array([p.to_x(min(max(start.get(p.name, p.initial), p.lower), p.upper)) for p in params])
    lo = np.array([p.x_bounds()[0] for p in params])
    hi = np.array([p.x_bounds()[1] for p in params])
    cache: dict[bytes, FloatArray] = {}

    def fun(x: FloatArray) -> FloatArray:
        key = x.tobytes()
        if key not in cache:
            sims = simulate_all(model, datasets, [values_from_x(params, x)])[0]
            cache[key] = residual_vector(datasets, sims, fold)
        return cache[key]

    def jac(x: FloatArray) -> FloatArray:
        f0 = fun(x)
        steps = []
        xs = []
        for i in range(len(x)):
            h = 1e-4 * max(1.0, abs(x[i])) if params[i].log else 1e-4 * max(abs(x[i]), 1e-2)
            xi = x.copy()
            # Step inwards at a bound.
            xi[i] = x[i] + h if x[i] + h <= hi[i] else x[i] - h
            steps.append(xi[i] - x[i])
            xs.append(xi)
        sims = simulate_all(model, datasets, [values_from_x(params, xi) for xi in xs])
        cols = [(residual_vector(datasets, s, fold) - f0) / h for s, h in zip(sims, steps)]
        return np.column_stack(cols) if cols else np.zeros((len(f0), 0))

    if params:
        sol = least_squares(fun, x0, jac=jac, bounds=(lo, hi), method="trf", x_scale=1.0, max_nfev=max_nfev, xtol=1e-8, ftol=1e-8)
        x, success, message, jmat = sol.x, bool(sol.success), str(sol.message), sol.jac
    else:
        x, success, message, jmat = x0, True, "nothing to fit", np.zeros((0, 0))
    values = values_from_x(params, x)
    sims = simulate_all(model, datasets, [values])[0]
    r = residual_vector(datasets, sims, fold)
    rss = float(r @ r)
    stderr = _stderr(params, x, jmat, rss, len(r))
    return FitResult(model, values, stderr, rss, len(r), _stats(datasets, sims), sims, list(datasets), success, message)


def _stderr(params: Sequence[Param], x: FloatArray, jmat: FloatArray, rss: float, n: int) -> dict[str, float]:
    """Standard errors from the Jacobian at the optimum (residual variance
    scaled), mapped through the log transform where there is one."""
    k = len(params)
    if k == 0:
        return {}
    s2 = rss / max(n - k, 1)
    try:
        cov = np.linalg.inv(jmat.T @ jmat) * s2
        sx = np.sqrt(np.clip(np.diag(cov), 0, None))
    except np.linalg.LinAlgError:
        sx = np.full(k, np.inf)
    out = {}
    for p, xi, si in zip(params, x, sx):
        value = p.from_x(float(xi))
        out[p.name] = float(value * math.log(10) * si) if p.log else float(p.scale * si)
    return out


def predict(result: FitResult, datasets: Sequence[Dataset], fold: int | None = None) -> tuple[float, int]:
    """RSS (noise units) and sample count of ``result``'s model and
    parameters on other data (other datasets, or another fold): the
    cross-validation error."""
    sims = simulate_all(result.model, datasets, [result.values])[0]
    r = residual_vector(datasets, sims, fold)
    return float(r @ r), len(r)

"""Properties of the controller's valve logic for arbitrary input sequences
(hypothesis, through the bindings), thousands of examples each.

Each example is a configuration (the timers and margins that shape the
behaviour, short enough for a few hundred periods to exercise them) and a
sequence of periods. Hypothesis draws the structure: the configuration,
the pressure levels and swings, requests, manoeuvres, driver modes, step
sizes, and the faults (NaN, infinities, out-of-range values at chosen
periods and fields, groups going stale, link faults, invalid step sizes);
a seeded generator fills in the signals between. The checks restate the
documented rules (docs/controller.md) independently of the code.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st
from numpy.typing import NDArray

from hpctl.control.controller import (
    TRIGGERS,
    Controller,
    DamperMode,
    Diag,
    DriveMode,
    DriverMode,
    InputGroup,
    SequencerState,
    SpringMode,
    seed_config,
)

DT_MAX_S = 0.005
GROUPS = [InputGroup.PRESSURES, InputGroup.STRUT, InputGroup.BODY, InputGroup.VEHICLE, InputGroup.STEERING, InputGroup.TEMPERATURE, InputGroup.DRIVER]
TIMEOUT_KEYS = ["pressures_s", "strut_s", "body_s", "vehicle_s", "steering_s", "temperature_s", "driver_s"]
#: Numeric input fields, the group each belongs to.
FIELDS = {
    "p_gas_pa": InputGroup.PRESSURES,
    "p_gas2_pa": InputGroup.PRESSURES,
    "strut_disp_m": InputGroup.STRUT,
    "body_acc_m_s2": InputGroup.BODY,
    "speed_m_s": InputGroup.VEHICLE,
    "lat_acc_m_s2": InputGroup.VEHICLE,
    "long_acc_m_s2": InputGroup.VEHICLE,
    "steer_angle_rad": InputGroup.STEERING,
    "steer_rate_rad_s": InputGroup.STEERING,
    "t_gas_k": InputGroup.TEMPERATURE,
    "ride_height_request_m": InputGroup.DRIVER,
}
BAD_VALUES = [math.nan, math.inf, -math.inf, 1e9, -1e9, 1e300]
BAD_DTS = [math.nan, 0.0, -1e-3, 1.0, math.inf, 1e-7]
SEED = seed_config()


@dataclass(frozen=True)
class Knobs:
    """What hypothesis draws for one example."""

    seed: int
    periods: int
    recovery_s: float
    hold_s: float
    resume_s: float
    margin_pa: float
    valve5_interval_s: float
    valve6_off_s: float
    timeouts_s: tuple[float, ...]
    pressure_factor: float
    swing_pa: float
    large_offset_pa: float
    requests_m: tuple[float, ...]
    dynamics: float
    driver_modes: tuple[int, ...]
    dt_pattern: int
    faults: tuple[tuple[float, int, int], ...]
    stale: tuple[tuple[int, float, float], ...]
    bad_dts: tuple[tuple[float, int], ...]
    link_faults: tuple[float, ...]
    hot: bool


def config_of(k: Knobs) -> dict[str, Any]:
    c = {name: dict(block) for name, block in SEED.items()}
    c["monitor"]["timeouts"] = dict(zip(TIMEOUT_KEYS, k.timeouts_s))
    c["monitor"]["dt_max_s"] = DT_MAX_S
    c["monitor"]["recovery_s"] = k.recovery_s
    c["mode"]["handling_hold_s"] = k.hold_s
    c["ride_height"].update(resume_s=k.resume_s, valve6_margin_pa=k.margin_pa, valve6_min_off_s=k.valve6_off_s,
                            load_pressure_tau_s=0.2, load_settle_s=min(k.resume_s, 0.2))
    c["damper"]["valve5_min_interval_s"] = k.valve5_interval_s
    if k.hot:
        c["unit"]["static_temperature_k"] = 330.0
    return c


def _segments(rng: np.random.Generator, n: int, values: tuple[Any, ...]) -> NDArray[Any]:
    """``values`` in consecutive segments of random lengths."""
    cuts = np.sort(rng.integers(0, n, size=len(values) - 1))
    out = np.empty(n, dtype=np.asarray(values).dtype)
    for v, lo, hi in zip(values, np.concatenate([[0], cuts]), np.concatenate([cuts, [n]])):
        out[lo:hi] = v
    return out


def _smooth(rng: np.random.Generator, t: NDArray[np.float64], amplitude: float, f_max_hz: float) -> NDArray[np.float64]:
    """A sum of three sines up to ``f_max_hz``, peak about ``amplitude``."""
    out = np.zeros_like(t)
    for _ in range(3):
        out += amplitude / 3 * np.sin(2 * np.pi * rng.uniform(0.2, f_max_hz) * t + rng.uniform(0, 2 * np.pi))
    return out


def sequence(k: Knobs, config: dict[str, Any]) -> tuple[dict[str, NDArray[Any]], NDArray[np.float64]]:
    """The inputs and step sizes of one example."""
    rng = np.random.default_rng(k.seed)
    n = k.periods
    dt = {0: np.full(n, 1e-3), 1: rng.choice([0.5e-3, 1e-3, 2e-3, DT_MAX_S], size=n), 2: rng.uniform(1e-6, DT_MAX_S, size=n)}[k.dt_pattern]
    for at, which in k.bad_dts:
        dt[int(at * (n - 1))] = BAD_DTS[which]
    valid = np.isfinite(dt) & (dt >= 1e-6) & (dt <= DT_MAX_S)
    # Signals move on the controller's clock (invalid steps advance nothing),
    # slower than the documented rate limits.
    t = np.cumsum(np.where(valid, np.floor(np.where(valid, dt, 0.0) * 1e6 + 0.5) * 1e-6, 0.0))
    p0 = k.pressure_factor * config["unit"]["static_pressure_pa"]
    d = k.dynamics
    inputs: dict[str, NDArray[Any]] = {
        "p_gas_pa": p0 + _smooth(rng, t, k.swing_pa, 8.0),
        "p_gas2_pa": p0 + k.large_offset_pa + _smooth(rng, t, 0.2 * k.swing_pa, 2.0),
        "strut_disp_m": _smooth(rng, t, 0.03, 5.0),
        "body_acc_m_s2": rng.normal(0.0, 3.0, size=n),
        "speed_m_s": np.clip(18.0 + _smooth(rng, t, 20.0 * d, 0.5), -5.0, 60.0),
        "lat_acc_m_s2": _smooth(rng, t, 5.0 * d, 1.0),
        "long_acc_m_s2": _smooth(rng, t, 5.0 * d, 1.0),
        "steer_angle_rad": _smooth(rng, t, 1.5 * d, 1.0),
        "steer_rate_rad_s": _smooth(rng, t, 4.0 * d, 2.0),
        "brake_pressed": _segments(rng, n, tuple(bool(b) for b in rng.random(4) < 0.3 * d)),
        "t_gas_k": config["unit"]["static_temperature_k"] + _smooth(rng, t, 0.5, 0.2),
        "driver_mode": _segments(rng, n, tuple(np.int64(m) for m in k.driver_modes)),
        "ride_height_request_m": _segments(rng, n, k.requests_m),
        "fresh": np.full(n, int(InputGroup.ALL), dtype=np.int64),
        "link_fault": np.zeros(n, dtype=bool),
    }
    for at, field, which in k.faults:
        name = list(FIELDS)[field]
        inputs[name][int(at * (n - 1))] = BAD_VALUES[which]
    for group, start, length in k.stale:
        lo = int(start * (n - 1))
        inputs["fresh"][lo : lo + int(length * n)] &= ~int(GROUPS[group])
    for at in k.link_faults:
        inputs["link_fault"][int(at * (n - 1))] = True
    return inputs, dt


@st.composite
def knobs(draw: st.DrawFn) -> Knobs:
    n = draw(st.integers(50, 800))
    return Knobs(
        seed=draw(st.integers(0, 2**32 - 1)),
        periods=n,
        recovery_s=draw(st.sampled_from([0.0, 0.005, 0.02, 0.1])),
        hold_s=draw(st.floats(0.0, 0.2)),
        resume_s=draw(st.floats(0.0, 0.05)),
        margin_pa=draw(st.sampled_from([0.0, 0.2e6, 1e6]) | st.floats(0.0, 1e6)),
        valve5_interval_s=draw(st.floats(0.0, 0.02)),
        valve6_off_s=draw(st.floats(0.0, 0.02)),
        timeouts_s=tuple(draw(st.lists(st.floats(DT_MAX_S, 0.05), min_size=7, max_size=7))),
        pressure_factor=draw(st.floats(0.8, 1.2)),
        swing_pa=draw(st.floats(0.0, 4e6)),
        large_offset_pa=draw(st.floats(-2e6, 2e6)),
        requests_m=tuple(draw(st.lists(st.sampled_from([0.0, -0.03, 0.03, -0.08, 0.001]) | st.floats(-0.08, 0.08), min_size=1, max_size=3))),
        dynamics=draw(st.sampled_from([0.0, 0.2, 1.0])),
        driver_modes=tuple(draw(st.lists(st.sampled_from([0, 0, 0, 1, 2]), min_size=1, max_size=3))),
        dt_pattern=draw(st.sampled_from([0, 0, 1, 2])),
        faults=tuple(draw(st.lists(st.tuples(st.floats(0, 1), st.integers(0, len(FIELDS) - 1), st.integers(0, len(BAD_VALUES) - 1)), max_size=3))),
        stale=tuple(draw(st.lists(st.tuples(st.integers(0, 6), st.floats(0, 1), st.floats(0, 0.3)), max_size=2))),
        bad_dts=tuple(draw(st.lists(st.tuples(st.floats(0, 1), st.integers(0, len(BAD_DTS) - 1)), max_size=2))),
        link_faults=tuple(draw(st.lists(st.floats(0, 1), max_size=1))),
        hot=draw(st.booleans()),
    )


def random_knobs(rng: np.random.Generator) -> Knobs:
    """Knobs from a seeded generator, for the coverage check."""
    n = int(rng.integers(50, 800))
    return Knobs(
        seed=int(rng.integers(2**32)), periods=n, recovery_s=float(rng.choice([0.0, 0.005, 0.02, 0.1])), hold_s=float(rng.uniform(0, 0.2)),
        resume_s=float(rng.uniform(0, 0.05)), margin_pa=float(rng.uniform(0, 1e6)), valve5_interval_s=float(rng.uniform(0, 0.02)),
        valve6_off_s=float(rng.uniform(0, 0.02)), timeouts_s=tuple(float(x) for x in rng.uniform(DT_MAX_S, 0.05, 7)),
        pressure_factor=float(rng.uniform(0.8, 1.2)), swing_pa=float(rng.uniform(0, 4e6)), large_offset_pa=float(rng.uniform(-2e6, 2e6)),
        requests_m=tuple(float(x) for x in rng.choice([0.0, -0.03, 0.03, -0.08], size=int(rng.integers(1, 4)))),
        dynamics=float(rng.choice([0.0, 0.2, 1.0])), driver_modes=tuple(int(x) for x in rng.choice([0, 0, 0, 1, 2], size=int(rng.integers(1, 4)))),
        dt_pattern=int(rng.choice([0, 0, 1, 2])),
        faults=tuple((float(rng.random()), int(rng.integers(len(FIELDS))), int(rng.integers(len(BAD_VALUES)))) for _ in range(int(rng.integers(0, 4)))),
        stale=tuple((int(rng.integers(7)), float(rng.random()), float(rng.uniform(0, 0.3))) for _ in range(int(rng.integers(0, 3)))),
        bad_dts=tuple((float(rng.random()), int(rng.integers(len(BAD_DTS)))) for _ in range(int(rng.integers(0, 3)))),
        link_faults=tuple(float(rng.random()) for _ in range(int(rng.integers(0, 2)))), hot=bool(rng.random() < 0.5),
    )


@dataclass(frozen=True)
class Example:
    config: dict[str, Any]
    inputs: dict[str, NDArray[Any]]
    dt_s: NDArray[np.float64]
    outputs: dict[str, NDArray[Any]]


def run(k: Knobs) -> Example:
    config = config_of(k)
    inputs, dt = sequence(k, config)
    return Example(config, inputs, dt, Controller(config).step_many(inputs, dt))


# --- the documented rules, restated -----------------------------------------


def dt_us(ex: Example) -> NDArray[np.int64]:
    """The controller clock: valid steps advance by dt rounded to whole
    microseconds, invalid ones (not finite, < 1 us, > dt_max) by nothing."""
    dt = ex.dt_s
    valid = np.isfinite(dt) & (dt >= 1e-6) & (dt <= ex.config["monitor"]["dt_max_s"])
    return np.where(valid, np.floor(np.where(valid, dt, 0.0) * 1e6 + 0.5), -1).astype(np.int64)


def us(seconds: float) -> int:
    """A configured duration in whole microseconds (rounded half up)."""
    return math.floor(seconds * 1e6 + 0.5)


def value_faults(ex: Example) -> NDArray[np.bool_]:
    """A value NaN, infinite or outside its documented (inclusive) range."""
    m, u, i = ex.config["monitor"], ex.config["unit"], ex.inputs

    def outside(x: NDArray[np.float64], lo: float, hi: float) -> NDArray[np.bool_]:
        return ~(np.isfinite(x) & (x >= lo) & (x <= hi))

    bad = outside(i["p_gas_pa"], m["pressure_min_pa"], m["pressure_max_pa"]) | outside(i["p_gas2_pa"], m["pressure_min_pa"], m["pressure_max_pa"])
    bad |= outside(i["strut_disp_m"], -(u["stroke_extension_m"] + m["disp_margin_m"]), u["stroke_compression_m"] + m["disp_margin_m"])
    bad |= outside(i["body_acc_m_s2"], -m["body_acc_max_m_s2"], m["body_acc_max_m_s2"])
    bad |= outside(i["speed_m_s"], m["speed_min_m_s"], m["speed_max_m_s"])
    for name in ("lat_acc_m_s2", "long_acc_m_s2"):
        bad |= outside(i[name], -m["vehicle_acc_max_m_s2"], m["vehicle_acc_max_m_s2"])
    bad |= outside(i["steer_angle_rad"], -m["steer_angle_max_rad"], m["steer_angle_max_rad"])
    bad |= outside(i["steer_rate_rad_s"], -m["steer_rate_max_rad_s"], m["steer_rate_max_rad_s"])
    bad |= outside(i["t_gas_k"], m["temperature_min_k"], m["temperature_max_k"])
    bad |= ~np.isfinite(i["ride_height_request_m"])
    return bad


def stale(ex: Example) -> NDArray[np.bool_]:
    """Some group without a fresh value for longer than its timeout (a
    fresh flag counts only in a period with a valid step)."""
    step_us = dt_us(ex)
    valid = step_us >= 0
    clock = np.cumsum(np.where(valid, step_us, 0))
    out = np.zeros(step_us.size, dtype=bool)
    for group, key in zip(GROUPS, TIMEOUT_KEYS):
        fresh = ((ex.inputs["fresh"] & int(group)) != 0) & valid
        last = np.maximum.accumulate(np.where(fresh, clock, -1))
        age = np.where(last >= 0, clock - last, np.iinfo(np.int64).max)
        out |= age > us(ex.config["monitor"]["timeouts"][key])
    return out


def faults(ex: Example) -> NDArray[np.bool_]:
    """Every documented cause of the safe state in a period."""
    return value_faults(ex) | stale(ex) | ex.inputs["link_fault"] | (dt_us(ex) < 0)


def expected_safe(ex: Example) -> NDArray[np.bool_]:
    """Safe in a faulty period and until the inputs have been good for the
    recovery time (power-on counts as a fault)."""
    fault = faults(ex)
    good = np.cumsum(np.where(fault, 0, dt_us(ex)))
    good -= np.maximum.accumulate(np.where(fault, good, 0))
    return fault | (good < us(ex.config["monitor"]["recovery_s"]))


def is_safe_state(o: dict[str, NDArray[Any]]) -> NDArray[np.bool_]:
    """The documented safe state: both valves de-energised, Handling, hard
    spring, high damping, sequencer blocked, flagged."""
    return (
        ~o["valve5_open"] & ~o["valve6_open"] & (o["drive_mode"] == DriveMode.HANDLING) & (o["spring_mode"] == SpringMode.HARD)
        & (o["damper_mode"] == DamperMode.HIGH) & (o["sequencer"] == SequencerState.BLOCKED) & ((o["diag"] & Diag.SAFE_STATE) != 0)
    )


def trigger_inputs(ex: Example) -> NDArray[np.bool_]:
    """Periods whose inputs exceed a Handling entry threshold (by 0.1 %,
    clear of single-precision rounding) for the driver mode in force."""
    c, i = ex.config["mode"], ex.inputs
    over = 1.001
    speed = np.clip(np.abs(np.nan_to_num(i["speed_m_s"], nan=0.0)), 0.0, 1e6)
    with np.errstate(invalid="ignore"):
        predicted = speed**2 * np.abs(i["steer_angle_rad"]) / (c["steering_ratio"] * c["wheelbase_m"])
    lateral = np.maximum(np.abs(i["lat_acc_m_s2"]), predicted) > over * c["lat_acc_enter_m_s2"]
    longitudinal = np.abs(i["long_acc_m_s2"]) > over * c["long_acc_enter_m_s2"]
    steer = (np.abs(i["steer_rate_rad_s"]) > over * c["steer_rate_enter_rad_s"]) & (speed > over * c["steer_min_speed_m_s"])
    brake = i["brake_pressed"] & (speed > over * c["brake_min_speed_m_s"])
    fast = speed > over * c["speed_enter_m_s"]
    mode = i["driver_mode"]
    with np.errstate(invalid="ignore"):
        return (lateral | longitudinal) | ((mode == DriverMode.AUTO) & (steer | brake | fast)) | (mode == DriverMode.SPORT)


# --- properties ---------------------------------------------------------------

SETTINGS = settings(max_examples=2000, deadline=None)


@SETTINGS
@given(knobs())
def test_valve6_opens_only_when_the_pressures_point_the_right_way(k: Knobs) -> None:
    ex = run(k)
    o, i = ex.outputs, ex.inputs
    margin = ex.config["ride_height"]["valve6_margin_pa"]
    seq = o["sequencer"]
    is_open = o["valve6_open"]
    lowering = is_open & (seq == SequencerState.LOWERING)
    raising = is_open & (seq == SequencerState.RAISING)
    assert np.all(i["p_gas_pa"][lowering] - i["p_gas2_pa"][lowering] > margin)
    assert np.all(i["p_gas2_pa"][raising] - i["p_gas_pa"][raising] > margin)
    # Otherwise open only as the soft spring.
    assert np.all(seq[is_open & ~lowering & ~raising] == SequencerState.IDLE)


@SETTINGS
@given(knobs())
def test_ride_never_returns_sooner_than_the_hold(k: Knobs) -> None:
    ex = run(k)
    hold_us = us(ex.config["mode"]["handling_hold_s"])
    clock = np.cumsum(np.maximum(dt_us(ex), 0))
    mode = ex.outputs["drive_mode"]
    ride = mode == DriveMode.RIDE
    # Not sooner than the hold after Handling was entered ...
    entered = np.flatnonzero((mode[1:] == DriveMode.HANDLING) & (mode[:-1] == DriveMode.RIDE)) + 1
    returned = np.flatnonzero((mode[1:] == DriveMode.RIDE) & (mode[:-1] == DriveMode.HANDLING)) + 1
    for r in returned:
        before = entered[entered < r]
        if before.size:
            assert clock[r] - clock[before[-1]] >= hold_us
    # ... nor after any period whose inputs trigger Handling or fault.
    events = np.flatnonzero(trigger_inputs(ex) | faults(ex))
    if events.size:
        last_event = np.maximum.accumulate(np.where(np.isin(np.arange(mode.size), events), np.arange(mode.size), -1))
        after_event = ride & (last_event >= 0)
        since = clock[after_event] - clock[last_event[after_event]]
        assert np.all(since >= hold_us), (since.min(), hold_us)
        assert not np.any(ride[events])


@SETTINGS
@given(knobs())
def test_bad_or_stale_inputs_give_the_safe_state_in_the_same_period(k: Knobs) -> None:
    ex = run(k)
    actual = is_safe_state(ex.outputs)
    flagged = (ex.outputs["diag"] & Diag.SAFE_STATE) != 0
    # NaN/inf/out-of-range/stale inputs, link faults and bad step sizes:
    # the safe state in that very period.
    fault = faults(ex)
    assert np.all(actual[fault])
    # And exactly the documented rule, recovery included.
    expected = expected_safe(ex)
    assert np.array_equal(actual, expected), np.flatnonzero(actual != expected)[:5]
    assert np.array_equal(flagged, expected)
    assert np.array_equal((ex.outputs["diag"] & Diag.RECOVERING) != 0, expected & ~fault)


DEFINED_DIAG = 0
for _flag in Diag:
    DEFINED_DIAG |= int(_flag)


@SETTINGS
@given(knobs())
def test_outputs_are_always_valid(k: Knobs) -> None:
    ex = run(k)
    o = ex.outputs
    u = ex.config["unit"]
    for name in ("ride_height_m", "p_gas2_target_pa", "p_load_pa", "strut_vel_m_s", "body_vel_m_s"):
        assert o[name].dtype == np.float64 and np.all(np.isfinite(o[name])), name
    assert o["valve5_open"].dtype == np.bool_ and o["valve6_open"].dtype == np.bool_
    assert set(np.unique(o["drive_mode"])) <= {0, 1} and set(np.unique(o["spring_mode"])) <= {0, 1}
    assert set(np.unique(o["damper_mode"])) <= {0, 1} and set(np.unique(o["sequencer"])) <= set(range(5))
    assert np.all((o["diag"].astype(np.int64) & ~DEFINED_DIAG) == 0)
    assert np.all((o["ride_height_m"] >= -u["stroke_compression_m"] - 1e-6) & (o["ride_height_m"] <= u["stroke_extension_m"] + 1e-6))
    # The load pressure is the configured one or a mean of valid p_S
    # samples corrected by at most |a| = g/2.
    m = ex.config["monitor"]
    assert np.all(o["p_load_pa"] >= 0.999 * min(m["pressure_min_pa"] / 1.5, u["static_pressure_pa"]))
    assert np.all(o["p_load_pa"] <= 1.001 * max(m["pressure_max_pa"] / 0.5, u["static_pressure_pa"]))
    assert np.all(o["p_gas2_target_pa"] >= 0)
    # Consistency: each valve matches its reported mode; Handling and the
    # safe state close both; valve 6 is open only as the soft spring or
    # for sequencing.
    assert np.array_equal(o["valve5_open"], o["damper_mode"] == DamperMode.LOW)
    handling = o["drive_mode"] == DriveMode.HANDLING
    assert np.all(~o["valve5_open"][handling]) and np.all(o["spring_mode"][handling] == SpringMode.HARD)
    safe = (o["diag"] & Diag.SAFE_STATE) != 0
    assert np.all(~o["valve5_open"][safe] & ~o["valve6_open"][safe])
    assert np.array_equal(o["spring_mode"] == SpringMode.SOFT, o["sequencer"] == SequencerState.IDLE)
    assert np.all(np.isin(o["sequencer"][o["valve6_open"]], [SequencerState.IDLE, SequencerState.LOWERING, SequencerState.RAISING]))
    # Trigger flags only in Handling.
    assert np.all(handling[(o["diag"] & int(TRIGGERS)) != 0])


@SETTINGS
@given(knobs())
def test_the_controller_is_deterministic(k: Knobs) -> None:
    config = config_of(k)
    inputs, dt = sequence(k, config)
    first = Controller(config).step_many(inputs, dt)
    c = Controller(config)
    half = k.periods // 2
    # Run something else first, then reset: power-on again.
    c.step_many({name: v[:half] for name, v in inputs.items()}, dt[:half])
    c.reset()
    second = c.step_many(inputs, dt)
    assert first.keys() == second.keys()
    for name in first:
        assert first[name].dtype == second[name].dtype
        assert np.array_equal(first[name], second[name]), name
        assert first[name].tobytes() == second[name].tobytes(), name


def test_the_generated_sequences_exercise_every_behaviour() -> None:
    """The sequences reach what the properties are about, so the properties
    are not vacuously true: sequencing pulses both ways, mode changes both
    ways, valve 5 opening, faults and recovery."""
    rng = np.random.default_rng(2024)
    seen = dict.fromkeys(["lowering open", "raising open", "to handling", "to ride", "valve 5 opens", "fault", "recovered"], 0)
    for _ in range(300):
        ex = run(random_knobs(rng))
        o = ex.outputs
        seq, v6 = o["sequencer"], o["valve6_open"]
        mode, v5 = o["drive_mode"], o["valve5_open"]
        safe = (o["diag"] & Diag.SAFE_STATE) != 0
        seen["lowering open"] += int(np.count_nonzero(v6 & (seq == SequencerState.LOWERING)))
        seen["raising open"] += int(np.count_nonzero(v6 & (seq == SequencerState.RAISING)))
        seen["to handling"] += int(np.count_nonzero((mode[1:] == DriveMode.HANDLING) & (mode[:-1] == DriveMode.RIDE)))
        seen["to ride"] += int(np.count_nonzero((mode[1:] == DriveMode.RIDE) & (mode[:-1] == DriveMode.HANDLING)))
        seen["valve 5 opens"] += int(np.count_nonzero(v5[1:] & ~v5[:-1]))
        seen["fault"] += int(np.count_nonzero(faults(ex)[1:] & ~safe[:-1]))
        seen["recovered"] += int(np.count_nonzero(safe[:-1] & ~safe[1:]))
    assert all(n >= 50 for n in seen.values()), seen

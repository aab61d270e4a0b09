"""The plain-dict forms the Rust core (``hpctl._core``) reads and returns,
as TypedDicts: the one place their keys are written down for the type
checker (the stub ``_core.pyi`` imports them from here)."""

from __future__ import annotations

from typing import Any, Literal, NotRequired, TypedDict, Union

import numpy as np
from numpy.typing import NDArray


class DamperCurveDict(TypedDict):
    bleed_pa_s_per_m3: float
    orifice_pa_s2_per_m6: float
    blowoff_pa: float
    blowoff_slope_pa_s_per_m3: float
    blowoff_knee: float


class DamperDict(TypedDict):
    on_compression: DamperCurveDict
    on_rebound: DamperCurveDict
    off_compression: DamperCurveDict
    off_rebound: DamperCurveDict


class FrictionDict(TypedDict):
    coulomb_n: float
    viscous_n_s_per_m: float
    smoothing_velocity_m_s: float
    stribeck_ratio: float
    stribeck_velocity_m_s: float


class OilComplianceDict(TypedDict):
    bulk_modulus_pa: float
    oil_volume_m3: float


class OilNodeDict(TypedDict):
    heat_capacity_j_per_k: float
    oil_to_ambient_tau_s: float
    wall_to_oil_tau_s: float
    wall_to_ambient_tau_s: float


class TimeConstantDict(TypedDict):
    time_constant_s: float


class SensorDict(TypedDict):
    force_offset_n: float
    pressure_offset_pa: float
    time_constant_s: float


class EffectsDict(TypedDict, total=False):
    friction: FrictionDict
    oil_compliance: OilComplianceDict
    oil_node: OilNodeDict
    leakage: TimeConstantDict
    valve_lag: TimeConstantDict
    sensor: SensorDict


class UnitDict(TypedDict):
    piston_area_m2: float
    small_acc_volume_m3: float
    large_acc_volume_m3: float
    static_pressure_pa: float
    static_temperature_k: float
    gas: str
    tau_s: float
    valve6_flow_area_m2: float
    valve6_transition_pa: float
    damper: DamperDict
    oil_density_kg_m3: float
    vapour_pressure_pa: float
    ambient_pressure_pa: float
    stroke_compression_m: float
    stroke_extension_m: float
    end_stop_stiffness_n_per_m: float
    end_stop_damping_n_s_per_m: float
    rated_speed_m_s: float
    effects: NotRequired[EffectsDict]
    polytropic_exponent: NotRequired[float | None]


class HoldDict(TypedDict):
    kind: Literal["hold"]
    disp_m: float


class SineDict(TypedDict):
    kind: Literal["sine"]
    amplitude_m: float
    frequency_hz: float
    offset_m: float


class StepDict(TypedDict):
    kind: Literal["step"]
    height_m: float
    start_s: float
    rise_s: float


class StepsDict(TypedDict):
    kind: Literal["steps"]
    increment_m: float
    count: int
    ramp_s: float
    dwell_s: float


class SampledDict(TypedDict):
    kind: Literal["sampled"]
    time_s: NDArray[np.float64]
    disp_m: NDArray[np.float64]
    vel_m_s: NotRequired[NDArray[np.float64]]

MotionDict = Union[HoldDict, SineDict, StepDict, StepsDict, SampledDict]


class CharacterisationRigDict(TypedDict):
    kind: Literal["characterisation"]
    strut: MotionDict


class SdofRigDict(TypedDict):
    kind: Literal["sdof"]
    sprung_mass_kg: float
    base: MotionDict

RigDict = Union[CharacterisationRigDict, SdofRigDict]


class CaseDict(TypedDict):
    unit: UnitDict
    rig: RigDict
    times_s: NDArray[np.float64]
    dt_s: float
    ambient_k: float
    spring_hard: bool | list[bool]
    damper_on: bool | list[bool]
    channels: list[str] | None
    # Error-controlled steps to this relative tolerance (None: fixed RK4
    # steps of dt_s); steps_s replays recorded step end times;
    # record_steps adds them to the result as step_end_s.
    rtol: float | None
    steps_s: NDArray[np.float64] | None
    record_steps: bool

#: Channel name (CHANNELS) -> values at the output times.
Channels = dict[str, NDArray[np.float64]]


class GasPropsDict(TypedDict):
    p_pa: NDArray[np.float64]
    dp_dt_pa_per_k: NDArray[np.float64]
    dp_drho_pa_m3_per_kg: NDArray[np.float64]
    cv_j_per_kg_k: NDArray[np.float64]


class ValidatedRangeDict(TypedDict):
    """Where a gas model was validated (``_core.gas_validated_range``)."""

    pressure_pa: tuple[float, float]
    temperature_k: tuple[float, float]


class ClosedLoopDict(TypedDict):
    plant: Channels
    inputs: dict[str, NDArray[Any]]
    outputs: dict[str, NDArray[Any]]


# --- the gas-charge detector's drives (hp-py leak.rs) ---------------------------


class GasChargeConfigDict(TypedDict):
    """hp_ctrl::gas_charge::GasChargeConfig."""

    tau_s: float
    settle_s: float
    loss_threshold: float
    loss_hysteresis: float
    confirm_s: float
    loss_significant: float
    healthy_sigma: float


class GasChargeDriveDict(TypedDict):
    """One gas-charge drive: per record (``record_dt_s``) the detector's
    verdict at its end, the plant's temperatures and what the controller did."""

    time_s: NDArray[np.float64]
    charge_ratio: NDArray[np.float64]
    confidence: NDArray[np.float64]
    t_gas_k: NDArray[np.float64]
    t_gas2_k: NDArray[np.float64]
    t_gas_read_k: NDArray[np.float64]
    t_oil_k: NDArray[np.float64]
    disp_m: NDArray[np.float64]
    p_gas_pa: NDArray[np.float64]
    v_gas_m3: NDArray[np.float64]
    v_gas2_m3: NDArray[np.float64]
    speed_m_s: NDArray[np.float64]
    sampled: NDArray[np.float64]
    valve6_open: NDArray[np.float64]
    safe: NDArray[np.float64]
    settled: NDArray[np.bool_]
    fault: NDArray[np.bool_]


# --- the vehicles (hp-vehicle) -------------------------------------------------


class VehicleBodyDict(TypedDict):
    mass_kg: float
    roll_inertia_kg_m2: float
    pitch_inertia_kg_m2: float
    yaw_inertia_kg_m2: float
    cg_height_m: float
    roll_centre_height_m: float


class AxleDict(TypedDict):
    x_m: float
    track_m: float
    unsprung_mass_kg: float
    wheel_radius_m: float
    tyre_stiffness_n_per_m: float
    tyre_damping_n_s_per_m: float
    cornering_stiffness_n_per_rad: float
    steer_ratio: float
    unit: UnitDict


class SeatDict(TypedDict):
    x_m: float
    y_m: float
    height_m: float


class VehicleDict(TypedDict):
    body: VehicleBodyDict
    axles: list[AxleDict]
    steering_ratio: float
    seat: SeatDict


class RoadDict(TypedDict):
    """Two tracks on one distance grid."""

    start_m: float
    dx_m: float
    left_m: NDArray[np.float64]
    right_m: NDArray[np.float64]


class PassiveSuspensionDict(TypedDict):
    kind: Literal["passive"]
    spring_hard: bool
    damper_on: bool


class SemiActiveSuspensionDict(TypedDict):
    kind: Literal["semi_active"]
    config: dict[str, Any] | None


SuspensionDict = Union[PassiveSuspensionDict, SemiActiveSuspensionDict]


class VehicleStaticsDict(TypedDict):
    static_load_n: NDArray[np.float64]
    static_disp_m: NDArray[np.float64]
    tyre_static_deflection_m: NDArray[np.float64]
    x_m: NDArray[np.float64]
    y_m: NDArray[np.float64]
    total_mass_kg: float


class VehicleRunDict(TypedDict):
    """1-D arrays per period (``VEHICLE_CHANNELS``); (periods, wheels)
    arrays per wheel (``VEHICLE_CORNER_CHANNELS``) and per controller
    (``VEHICLE_CONTROLLER_CHANNELS``, semi-active runs only)."""

    vehicle: dict[str, NDArray[np.float64]]
    corners: dict[str, NDArray[np.float64]]
    controller: dict[str, NDArray[np.float64]]

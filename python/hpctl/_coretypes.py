"""The plain-dict forms the Rust core (``hpctl._core``) reads and returns,
as TypedDicts: the one place their keys are written down for the type
checker (the stub ``_core.pyi`` imports them from here)."""

from __future__ import annotations

from typing import Any, Literal, NotRequired, TypedDict, Union

import numpy as np
from numpy.typing import NDArray

# The effects' dict forms are generated with their classes from the core's
# tables (scripts/gen_effect_params.py).
from hpctl._effect_params import EffectsDict as EffectsDict
from hpctl._effect_params import FrictionDict as FrictionDict
from hpctl._effect_params import LeakageDict as LeakageDict
from hpctl._effect_params import OilComplianceDict as OilComplianceDict
from hpctl._effect_params import OilNodeDict as OilNodeDict
from hpctl._effect_params import SensorDict as SensorDict
from hpctl._effect_params import ValveLagDict as ValveLagDict
from hpctl._effect_params import WallConductanceDict as WallConductanceDict


class DamperCurveDict(TypedDict):
    bleed_pa_s_per_m3: float
    orifice_pa_s2_per_m6: float
    blowoff_pa: float
    blowoff_slope_pa_s_per_m3: float
    blowoff_knee: float
    blowoff2_pa: float
    blowoff2_slope_pa_s_per_m3: float
    bleed_parallel_m3_per_s_pa: float


class DamperDict(TypedDict):
    on_compression: DamperCurveDict
    on_rebound: DamperCurveDict
    off_compression: DamperCurveDict
    off_rebound: DamperCurveDict


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
    # The reference gas evaluated through the process's table (pressure
    # within 1.3e-8 of the direct equation; other gases: direct).
    gas_table: bool
    # Each valve switch this fraction of the interval before the first
    # output with the new valves (0: at it; 0.5: midway), in [0, 1).
    switch_lead: float

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


# --- the controller (hp-ctrl through hp-py ctrl.rs) ------------------------------
# The keys are the field names of hp_ctrl's config structs (hp-py's `block!`
# lists); tests/test_typing.py checks these TypedDicts against what the
# extension returns, key for key.


class CtrlUnitConfigDict(TypedDict):
    """hp_ctrl::gas_table::UnitConfig."""

    piston_area_m2: float
    small_acc_volume_m3: float
    large_acc_volume_m3: float
    static_pressure_pa: float
    static_temperature_k: float
    stroke_compression_m: float
    stroke_extension_m: float
    gas: str


class GroupTimeoutsDict(TypedDict):
    """hp_ctrl::monitor::GroupTimeouts."""

    pressures_s: float
    strut_s: float
    body_s: float
    vehicle_s: float
    steering_s: float
    temperature_s: float
    driver_s: float


class MonitorConfigDict(TypedDict):
    """hp_ctrl::monitor::MonitorConfig."""

    pressure_min_pa: float
    pressure_max_pa: float
    temperature_min_k: float
    temperature_max_k: float
    disp_margin_m: float
    body_acc_max_m_s2: float
    vehicle_acc_max_m_s2: float
    speed_min_m_s: float
    speed_max_m_s: float
    steer_angle_max_rad: float
    steer_rate_max_rad_s: float
    pressure_rate_max_pa_s: float
    disp_rate_max_m_s: float
    temperature_rate_max_k_s: float
    recovery_s: float
    dt_max_s: float
    timeouts: GroupTimeoutsDict


class EstimatorConfigDict(TypedDict):
    """hp_ctrl::estimator::EstimatorConfig."""

    strut_velocity_tau_s: float
    body_velocity_tau_s: float
    body_acc_bias_tau_s: float


class ModeConfigDict(TypedDict):
    """hp_ctrl::mode::ModeConfig."""

    lat_acc_enter_m_s2: float
    lat_acc_exit_m_s2: float
    steering_ratio: float
    wheelbase_m: float
    steer_rate_enter_rad_s: float
    steer_rate_exit_rad_s: float
    steer_min_speed_m_s: float
    long_acc_enter_m_s2: float
    long_acc_exit_m_s2: float
    brake_min_speed_m_s: float
    speed_enter_m_s: float
    speed_exit_m_s: float
    handling_hold_s: float


class DamperConfigDict(TypedDict):
    """hp_ctrl::damper::DamperConfig."""

    skyhook_deadband_m2_s2: float
    valve5_min_interval_s: float


class RideHeightConfigDict(TypedDict):
    """hp_ctrl::ride_height::RideHeightConfig."""

    request_max_m: float
    request_deadband_m: float
    tolerance_m: float
    valve6_margin_pa: float
    valve6_min_off_s: float
    block_lat_acc_m_s2: float
    block_long_acc_m_s2: float
    resume_s: float
    load_pressure_tau_s: float
    load_settle_s: float


class ControllerConfigDict(TypedDict):
    """hp_ctrl::Config: the controller's whole configuration (every key
    required: the extension rejects missing and unknown ones)."""

    unit: CtrlUnitConfigDict
    monitor: MonitorConfigDict
    estimator: EstimatorConfigDict
    mode: ModeConfigDict
    damper: DamperConfigDict
    ride_height: RideHeightConfigDict


class ControllerInputsDict(TypedDict):
    """hp_ctrl::Inputs, one period (``Controller.step``): enums and the
    input-group mask as their numeric values."""

    p_gas_pa: float
    p_gas2_pa: float
    t_gas_k: float
    strut_disp_m: float
    body_acc_m_s2: float
    speed_m_s: float
    lat_acc_m_s2: float
    long_acc_m_s2: float
    steer_angle_rad: float
    steer_rate_rad_s: float
    brake_pressed: bool
    driver_mode: int
    ride_height_request_m: float
    fresh: int
    link_fault: bool


class ControllerOutputsDict(TypedDict):
    """hp_ctrl::Outputs, one period: enums as their numeric values, ``diag``
    the flag word (``CTRL_DIAG_FLAGS``)."""

    valve5_open: bool
    valve6_open: bool
    drive_mode: int
    spring_mode: int
    damper_mode: int
    sequencer: int
    diag: int
    ride_height_m: float
    p_gas2_target_pa: float
    p_load_pa: float
    strut_vel_m_s: float
    body_vel_m_s: float


#: Field name (``CTRL_INPUT_FIELDS`` / ``CTRL_SCENARIO_FIELDS``) -> one value
#: per period, in the dtype ``hpctl.control.controller.INPUT_DTYPES`` gives.
CtrlArrays = dict[str, NDArray[Any]]


class ClosedLoopCaseDict(TypedDict):
    """One case of ``closed_loop_many``: the arguments of ``closed_loop``
    (hp-py ``ctrl::closed_loop_many``; the optional ones as its defaults)."""

    unit: UnitDict
    rig: RigDict
    scenario: CtrlArrays
    dt_s: float
    ambient_k: float
    config: NotRequired[ControllerConfigDict | None]
    max_dt_s: NotRequired[float]
    channels: NotRequired[list[str] | None]
    record_every: NotRequired[int]
    t_gas_sensor_tau_s: NotRequired[float]


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


class GasChargeChangesDict(TypedDict, total=False):
    """Changes to the detector's configuration for one drive (any subset
    of :class:`GasChargeConfigDict`; the core refuses unknown keys)."""

    tau_s: float
    settle_s: float
    loss_threshold: float
    loss_hysteresis: float
    confirm_s: float
    loss_significant: float
    healthy_sigma: float


class GasChargeSegmentsDict(TypedDict):
    """A drive's piecewise-constant scenario: from ``start_s[i]`` on,
    ``speed_m_s[i]`` and ``ride_height_request_m[i]``."""

    start_s: NDArray[np.float64]
    speed_m_s: NDArray[np.float64]
    ride_height_request_m: NDArray[np.float64]


class GasChargeCaseDict(TypedDict):
    """One drive of ``gas_charge_drives`` (hp-py leak.rs ``Drive::from_py``;
    the optional ones as its defaults)."""

    unit: UnitDict
    sprung_mass_kg: float
    ambient_k: float
    base: MotionDict
    segments: GasChargeSegmentsDict
    duration_s: float
    record_dt_s: NotRequired[float]
    max_dt_s: NotRequired[float]
    t_gas_sensor_tau_s: NotRequired[float]
    t_gas_sensor_offset_k: NotRequired[float]
    gas_charge: NotRequired[GasChargeChangesDict]
    reference_plant: NotRequired[bool]


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
    v_void_m3: NDArray[np.float64]
    sample_ratio: NDArray[np.float64]
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
    config: ControllerConfigDict | None


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


class VehicleCaseDict(TypedDict):
    """One case of ``vehicle_run_many``: the arguments of ``vehicle_run``
    (hp-py ``vehicle::vehicle_run_many``; the optional ones as its defaults)."""

    vehicle: VehicleDict
    road: RoadDict
    drive: dict[str, NDArray[Any]]
    suspension: SuspensionDict
    dt_s: float
    ambient_k: float
    max_dt_s: NotRequired[float]
    record_every: NotRequired[int]
    t_gas_sensor_tau_s: NotRequired[float]


# --- the effects' parameter tables (hp-core effect_params!) -----------------------


class EffectFieldDict(TypedDict):
    """One parameter of an effect: its field in the effect's struct and dict
    form, doc, the parameter's name across hpctl, valid range, default."""

    field: str
    doc: str
    parameter: str
    range: tuple[float, float]
    default: float | None


class EffectTableDict(TypedDict):
    """One effect's parameter table (``_core.EFFECT_PARAMETERS``)."""

    key: str
    name: str
    doc: str
    fields: list[EffectFieldDict]

# Hand-kept stub of the Rust extension hpctl._core (checked by stubtest).
from collections.abc import Callable, Mapping, Sequence
from typing import Any, Literal, final

import numpy as np
from numpy.typing import NDArray

__version__: str
__all__ = [
    "HpctlError",
    "ParameterError",
    "ConvergenceError",
    "SimulationError",
    "InternalError",
    "simulate",
    "simulate_many",
    "sensor_lag",
    "static_force_n",
    "static_disp_for_load_m",
    "gas_masses_kg",
    "gas_props",
    "gas_density_kg_m3",
    "gas_validated_range",
    "seed_unit",
    "seed_sprung_mass_kg",
    "seed_oil_node",
    "CHANNELS",
    "GAS_MODELS",
    "DEFAULT_GAS",
    "DEFAULT_RTOL",
    "STANDARD_GRAVITY_M_S2",
    "PARAMETER_RANGES",
    "EFFECT_PARAMETERS",
    "load_pressure_pa",
    "damper_pressure_drop_pa",
    "friction_force_n",
    "Plant",
    "__version__",
    "Controller",
    "ctrl_seed_config",
    "ctrl_config_for_unit",
    "closed_loop",
    "closed_loop_many",
    "CTRL_DIAG_FLAGS",
    "CTRL_INPUT_GROUPS",
    "CTRL_DRIVER_MODES",
    "CTRL_DRIVE_MODES",
    "CTRL_SPRING_MODES",
    "CTRL_DAMPER_MODES",
    "CTRL_SEQUENCER_STATES",
    "CTRL_INPUT_FIELDS",
    "CTRL_SCENARIO_FIELDS",
    "CanRejectError",
    "can_encode",
    "can_decode",
    "CanCounter",
    "Ecu",
    "vehicle_presets",
    "vehicle_controller_config",
    "vehicle_statics",
    "vehicle_run",
    "vehicle_run_many",
    "VehiclePlant",
    "VEHICLE_CHANNELS",
    "VEHICLE_CORNER_CHANNELS",
    "VEHICLE_CONTROLLER_CHANNELS",
    "gas_charge_drives",
    "gas_charge_config",
]

# The plain-dict forms the core reads and returns: hpctl._coretypes.
from hpctl._coretypes import (
    GasChargeCaseDict,
    GasChargeConfigDict,
    GasChargeDriveDict,
    CaseDict,
    Channels,
    ClosedLoopCaseDict,
    ClosedLoopDict,
    ControllerConfigDict,
    ControllerInputsDict,
    ControllerOutputsDict,
    DamperDict,
    CtrlArrays,
    EffectTableDict,
    GasPropsDict,
    OilNodeDict,
    RigDict,
    RoadDict,
    SuspensionDict,
    UnitDict,
    ValidatedRangeDict,
    VehicleCaseDict,
    VehicleDict,
    VehicleRunDict,
    VehicleStaticsDict,
)

CHANNELS: list[str]
GAS_MODELS: list[str]
DEFAULT_GAS: str
DEFAULT_RTOL: float
STANDARD_GRAVITY_M_S2: float
#: Every unit parameter's valid range (hp_core::ranges), inclusive.
PARAMETER_RANGES: dict[str, tuple[float, float]]
#: Every effect's parameter table (hp_core::effect_params!), in Effects order.
EFFECT_PARAMETERS: list[EffectTableDict]

class HpctlError(ValueError): ...
class ParameterError(HpctlError): ...
class ConvergenceError(HpctlError): ...
class SimulationError(HpctlError): ...
class InternalError(RuntimeError): ...

def simulate(
    unit: UnitDict,
    rig: RigDict,
    times_s: NDArray[np.float64] | Sequence[float],
    dt_s: float,
    ambient_k: float,
    spring_hard: bool | Sequence[bool],
    damper_on: bool | Sequence[bool],
    channels: Sequence[str] | None = None,
    progress: Callable[[int, int], object] | None = None,
    rtol: float | None = None,
    steps_s: Sequence[float] | NDArray[np.float64] | None = None,
    record_steps: bool = False,
    gas_table: bool = False,
    switch_lead: float = 0.0,
) -> Channels: ...
def simulate_many(cases: list[CaseDict], threads: int | None = None) -> list[Channels | HpctlError]: ...
def sensor_lag(times_s: NDArray[np.float64] | Sequence[float], values: NDArray[np.float64] | Sequence[float], time_constant_s: float, rest: float | None = None) -> NDArray[np.float64]: ...
def static_force_n(unit: UnitDict, disp_m: float, t_k: float, spring_hard: bool) -> float: ...
def static_disp_for_load_m(unit: UnitDict, load_n: float, t_k: float, spring_hard: bool) -> float: ...
def load_pressure_pa(unit: UnitDict, load_n: float) -> float: ...
def damper_pressure_drop_pa(damper: DamperDict, q_m3_s: NDArray[np.float64] | Sequence[float], bypass_open: float) -> NDArray[np.float64]: ...
def friction_force_n(unit: UnitDict, vel_m_s: NDArray[np.float64] | Sequence[float]) -> NDArray[np.float64]: ...
def gas_masses_kg(unit: UnitDict) -> tuple[float, float]: ...
def gas_props(gas: str, rho_kg_m3: NDArray[np.float64] | Sequence[float], t_k: NDArray[np.float64] | Sequence[float]) -> GasPropsDict: ...
def gas_density_kg_m3(gas: str, p_pa: float, t_k: float) -> float: ...
def gas_validated_range(gas: str) -> ValidatedRangeDict: ...
def seed_unit() -> UnitDict: ...
def seed_sprung_mass_kg() -> float: ...
def seed_oil_node() -> OilNodeDict: ...

@final
class Plant:
    def __new__(
        cls, unit: UnitDict, rig: RigDict, ambient_k: float, spring_hard: bool, damper_on: bool, max_dt_s: float = 1e-3
    ) -> Plant: ...
    @property
    def time_s(self) -> float: ...
    @property
    def static_disp_m(self) -> float: ...
    def sample(self) -> dict[str, float]: ...
    def step(self, dt_s: float, valve5_open: bool, valve6_open: bool) -> dict[str, float]: ...

# The controller (hp-ctrl): see hpctl.control and hpctl.closed_loop.
CTRL_DIAG_FLAGS: dict[str, int]
CTRL_INPUT_GROUPS: dict[str, int]
CTRL_DRIVER_MODES: list[str]
CTRL_DRIVE_MODES: list[str]
CTRL_SPRING_MODES: list[str]
CTRL_DAMPER_MODES: list[str]
CTRL_SEQUENCER_STATES: list[str]
CTRL_INPUT_FIELDS: list[str]
CTRL_SCENARIO_FIELDS: list[str]

def ctrl_seed_config() -> ControllerConfigDict: ...
def ctrl_config_for_unit(unit: UnitDict) -> ControllerConfigDict: ...
def closed_loop(
    unit: UnitDict,
    rig: RigDict,
    scenario: CtrlArrays,
    dt_s: float,
    ambient_k: float,
    config: ControllerConfigDict | None = None,
    max_dt_s: float = 1e-3,
    channels: Sequence[str] | None = None,
    record_every: int = 1,
    t_gas_sensor_tau_s: float = 1.0,
    progress: Callable[[int, int], object] | None = None,
) -> ClosedLoopDict: ...
def closed_loop_many(cases: Sequence[ClosedLoopCaseDict], threads: int | None = None) -> list[ClosedLoopDict | HpctlError]: ...
@final
class Controller:
    def __new__(cls, config: ControllerConfigDict | None = None) -> Controller: ...
    @property
    def config(self) -> ControllerConfigDict: ...
    def reset(self) -> None: ...
    def step(self, inputs: ControllerInputsDict, dt_s: float) -> ControllerOutputsDict: ...
    def step_many(self, inputs: CtrlArrays, dt_s: float | NDArray[np.float64]) -> CtrlArrays: ...

# The CAN codec and the ECU application (hp-ctrl::can): see hpctl.hil.pil and docs/can.md.
class CanRejectError(HpctlError): ...

def can_encode(name: str, counter: int, values: dict[str, float]) -> tuple[int, bytes]: ...
def can_decode(id: int, data: bytes | bytearray | memoryview, extended: bool = True) -> tuple[str, int, dict[str, float]]: ...
@final
class CanCounter:
    """One message's E2E alive-counter check (hp_ctrl::can::e2e::CounterState)."""
    def __new__(cls) -> CanCounter: ...
    def check(self, counter: int) -> Literal["next", "repeated", "skipped", "synced"]: ...
    def reset(self) -> None: ...

@final
class Ecu:
    def __new__(cls, corners: Literal[4, 8] = 4, calibration: Literal["seed", "pil"] = "seed", identity_number: int = 1) -> Ecu: ...
    @property
    def corners(self) -> int: ...
    @property
    def tx_dropped(self) -> int: ...
    @property
    def address(self) -> int: ...
    def dtcs(self) -> list[tuple[int, int, int]]: ...
    def receive(self, id: int, data: bytes | bytearray | memoryview, extended: bool = True) -> int | None: ...
    def period(self) -> list[tuple[int, bytes]]: ...

# The gas-charge detector on long drives (hp-py leak.rs): see hpctl.control.gas_charge.
def gas_charge_drives(cases: Sequence[GasChargeCaseDict], threads: int | None = None) -> list[GasChargeDriveDict | HpctlError]: ...
def gas_charge_config() -> GasChargeConfigDict: ...

# The vehicles (hp-vehicle): see hpctl.vehicle.
VEHICLE_CHANNELS: list[str]
VEHICLE_CORNER_CHANNELS: list[str]
VEHICLE_CONTROLLER_CHANNELS: list[str]

def vehicle_presets() -> dict[str, VehicleDict]: ...
def vehicle_controller_config(vehicle: VehicleDict) -> ControllerConfigDict: ...
def vehicle_statics(vehicle: VehicleDict, ambient_k: float, spring_hard: bool = True, damper_on: bool = True) -> VehicleStaticsDict: ...
def vehicle_run(
    vehicle: VehicleDict,
    road: RoadDict,
    drive: dict[str, NDArray[Any]],
    suspension: SuspensionDict,
    dt_s: float,
    ambient_k: float,
    max_dt_s: float = 1e-3,
    record_every: int = 1,
    t_gas_sensor_tau_s: float = 1.0,
    progress: Callable[[int, int], object] | None = None,
    reference_plant: bool = False,
) -> VehicleRunDict: ...
def vehicle_run_many(cases: Sequence[VehicleCaseDict], threads: int | None = None) -> list[VehicleRunDict | HpctlError]: ...
@final
class VehiclePlant:
    def __new__(
        cls,
        vehicle: VehicleDict,
        road: RoadDict,
        ambient_k: float,
        spring_hard: bool = True,
        damper_on: bool = True,
        max_dt_s: float = 1e-3,
        corner_units: Mapping[int, UnitDict] | None = None,
    ) -> VehiclePlant: ...
    @property
    def corner_count(self) -> int: ...
    @property
    def time_s(self) -> float: ...
    def sample(self) -> dict[str, float | list[float]]: ...
    def step(
        self,
        dt_s: float,
        valve5_open: Sequence[bool],
        valve6_open: Sequence[bool],
        speed_m_s: float,
        long_acc_m_s2: float = 0.0,
        steer_angle_rad: float = 0.0,
    ) -> dict[str, float | list[float]]: ...

//! The controller (hp-ctrl) from Python: its configuration as a dict, a
//! `Controller` stepped one period or many at a time, and the closed loop
//! with the plant. Thin: conversions only; NaN, infinite and stale inputs
//! are legal controller inputs (they give the safe state) and pass through
//! untouched. Only structurally wrong calls (unknown or missing keys, wrong
//! types, undefined enum values, arrays of unequal length) raise
//! `ParameterError`.

use crate::args::extract;
use crate::errors::{guard, parameter, to_py};
use crate::exec::{detached_with_progress, parse_cases, run_parallel, threads_arg};
use crate::params::{self, MotionSpec, Reader, RigSpec};
use crate::sim::{channel_values, CHANNELS};
use hp_core::rig::{Rig, RigKind};
use hp_core::unit::{Unit, Valves};
use hp_vehicle::closed_loop::{Sensors, VehicleSignals};
use hp_ctrl::{diag, input_group, Config, DriverMode, Inputs, Outputs, ParamError, Params, State};
use numpy::{IntoPyArray, PyReadonlyArray1};
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyList};

// ---------------------------------------------------------------- config

/// Reads and writes the `f64` fields of one config block from one list of
/// names, so the dict form cannot drift from the struct.
macro_rules! block {
    ($read:ident, $write:ident, $ty:ty, [$($field:ident),* $(,)?]) => {
        fn $read(r: &mut Reader<'_>, c: &mut $ty) -> PyResult<()> {
            $( c.$field = r.f64(stringify!($field))?; )*
            Ok(())
        }
        fn $write<'py>(py: Python<'py>, c: &$ty) -> PyResult<Bound<'py, PyDict>> {
            let d = PyDict::new(py);
            $( d.set_item(stringify!($field), c.$field)?; )*
            Ok(d)
        }
    };
}

block!(read_unit, write_unit, hp_ctrl::gas_table::UnitConfig, [
    piston_area_m2, small_acc_volume_m3, large_acc_volume_m3, static_pressure_pa, static_temperature_k, stroke_compression_m, stroke_extension_m,
]);
block!(read_monitor, write_monitor, hp_ctrl::monitor::MonitorConfig, [
    pressure_min_pa, pressure_max_pa, temperature_min_k, temperature_max_k, disp_margin_m, body_acc_max_m_s2,
    vehicle_acc_max_m_s2, speed_min_m_s, speed_max_m_s, steer_angle_max_rad, steer_rate_max_rad_s,
    pressure_rate_max_pa_s, disp_rate_max_m_s, temperature_rate_max_k_s, recovery_s, dt_max_s,
]);
block!(read_timeouts, write_timeouts, hp_ctrl::monitor::GroupTimeouts, [
    pressures_s, strut_s, body_s, vehicle_s, steering_s, temperature_s, driver_s,
]);
block!(read_estimator, write_estimator, hp_ctrl::estimator::EstimatorConfig, [
    strut_velocity_tau_s, body_velocity_tau_s, body_acc_bias_tau_s,
]);
block!(read_mode, write_mode, hp_ctrl::mode::ModeConfig, [
    lat_acc_enter_m_s2, lat_acc_exit_m_s2, steering_ratio, wheelbase_m, steer_rate_enter_rad_s, steer_rate_exit_rad_s,
    steer_min_speed_m_s, long_acc_enter_m_s2, long_acc_exit_m_s2, brake_min_speed_m_s, speed_enter_m_s, speed_exit_m_s,
    handling_hold_s,
]);
block!(read_damper, write_damper, hp_ctrl::damper::DamperConfig, [skyhook_deadband_m2_s2, valve5_min_interval_s]);
block!(read_ride_height, write_ride_height, hp_ctrl::ride_height::RideHeightConfig, [
    request_max_m, request_deadband_m, tolerance_m, valve6_margin_pa, valve6_min_off_s, block_lat_acc_m_s2,
    block_long_acc_m_s2, resume_s, load_pressure_tau_s, load_settle_s,
]);

/// A config dict (every key required, no unknown keys) to a [`Config`];
/// the values are checked by [`Params::new`].
fn config_from_dict(obj: &Bound<'_, PyAny>) -> PyResult<Config> {
    let mut c = Config::seed_unit();
    let mut r = Reader::new(obj, "config")?;
    let mut b = r.sub("unit")?;
    read_unit(&mut b, &mut c.unit)?;
    c.unit.gas = params::gas(&b.string("gas")?)?;
    b.finish()?;
    let mut b = r.sub("monitor")?;
    read_monitor(&mut b, &mut c.monitor)?;
    let mut t = b.sub("timeouts")?;
    read_timeouts(&mut t, &mut c.monitor.timeouts)?;
    t.finish()?;
    b.finish()?;
    let mut b = r.sub("estimator")?;
    read_estimator(&mut b, &mut c.estimator)?;
    b.finish()?;
    let mut b = r.sub("mode")?;
    read_mode(&mut b, &mut c.mode)?;
    b.finish()?;
    let mut b = r.sub("damper")?;
    read_damper(&mut b, &mut c.damper)?;
    b.finish()?;
    let mut b = r.sub("ride_height")?;
    read_ride_height(&mut b, &mut c.ride_height)?;
    b.finish()?;
    r.finish()?;
    Ok(c)
}

pub(crate) fn config_to_dict<'py>(py: Python<'py>, c: &Config) -> PyResult<Bound<'py, PyDict>> {
    let d = PyDict::new(py);
    let unit = write_unit(py, &c.unit)?;
    unit.set_item("gas", c.unit.gas.name())?;
    d.set_item("unit", unit)?;
    let monitor = write_monitor(py, &c.monitor)?;
    monitor.set_item("timeouts", write_timeouts(py, &c.monitor.timeouts)?)?;
    d.set_item("monitor", monitor)?;
    d.set_item("estimator", write_estimator(py, &c.estimator)?)?;
    d.set_item("mode", write_mode(py, &c.mode)?)?;
    d.set_item("damper", write_damper(py, &c.damper)?)?;
    d.set_item("ride_height", write_ride_height(py, &c.ride_height)?)?;
    Ok(d)
}

fn param_error(e: ParamError) -> PyErr {
    match e {
        ParamError::Gas(e) => to_py(e),
        other => parameter(format!("config: {other}")),
    }
}

/// Compiled parameters from an optional config dict (None: the seed unit).
pub(crate) fn params_from(config: Option<&Bound<'_, PyAny>>) -> PyResult<Params> {
    let config = match config {
        Some(c) if !c.is_none() => config_from_dict(c)?,
        _ => Config::seed_unit(),
    };
    Params::new(config).map_err(param_error)
}

/// The controller configuration of the seed unit, as a dict.
#[pyfunction]
pub fn ctrl_seed_config(py: Python<'_>) -> PyResult<Bound<'_, PyDict>> {
    guard(|| config_to_dict(py, &Config::seed_unit()))
}

/// The controller configuration for the plant unit `unit` (a unit dict as
/// `simulate` takes): its `unit` block derived from the unit
/// (`hp_ctrl::gas_table::UnitConfig::from_unit`), every other block the
/// default calibration. For the seed unit it equals `ctrl_seed_config()`.
#[pyfunction]
pub fn ctrl_config_for_unit<'py>(py: Python<'py>, unit: &Bound<'py, PyAny>) -> PyResult<Bound<'py, PyDict>> {
    guard(|| {
        let params = params::unit(unit)?;
        let config = Config { unit: hp_ctrl::gas_table::UnitConfig::from_unit(&params), ..Config::seed_unit() };
        Params::new(config).map_err(param_error)?;
        config_to_dict(py, &config)
    })
}

// ---------------------------------------------------------- inputs/outputs

/// A named field of an input struct, as an accessor (one list serves
/// reading and writing).
type FloatField<T> = (&'static str, fn(&mut T) -> &mut f64);
type BoolField<T> = (&'static str, fn(&mut T) -> &mut bool);

/// The value of `field` in a copy of `x`.
fn get<T: Copy, V: Copy>(x: &T, field: fn(&mut T) -> &mut V) -> V {
    let mut copy = *x;
    *field(&mut copy)
}

const INPUT_FLOATS: [FloatField<Inputs>; 11] = [
    ("p_gas_pa", |i| &mut i.p_gas_pa),
    ("p_gas2_pa", |i| &mut i.p_gas2_pa),
    ("strut_disp_m", |i| &mut i.strut_disp_m),
    ("body_acc_m_s2", |i| &mut i.body_acc_m_s2),
    ("speed_m_s", |i| &mut i.speed_m_s),
    ("lat_acc_m_s2", |i| &mut i.lat_acc_m_s2),
    ("long_acc_m_s2", |i| &mut i.long_acc_m_s2),
    ("steer_angle_rad", |i| &mut i.steer_angle_rad),
    ("steer_rate_rad_s", |i| &mut i.steer_rate_rad_s),
    ("t_gas_k", |i| &mut i.t_gas_k),
    ("ride_height_request_m", |i| &mut i.ride_height_request_m),
];
const INPUT_BOOLS: [BoolField<Inputs>; 2] = [("brake_pressed", |i| &mut i.brake_pressed), ("link_fault", |i| &mut i.link_fault)];

/// The scenario's per-period fields of the closed loop.
const VEHICLE_FLOATS: [FloatField<VehicleSignals>; 6] = [
    ("speed_m_s", |v| &mut v.speed_m_s),
    ("lat_acc_m_s2", |v| &mut v.lat_acc_m_s2),
    ("long_acc_m_s2", |v| &mut v.long_acc_m_s2),
    ("steer_angle_rad", |v| &mut v.steer_angle_rad),
    ("steer_rate_rad_s", |v| &mut v.steer_rate_rad_s),
    ("ride_height_request_m", |v| &mut v.ride_height_request_m),
];

/// Names of the enum values, indexed by their numeric value.
const DRIVER_MODES: [&str; 3] = ["auto", "comfort", "sport"];
const DRIVE_MODES: [&str; 2] = ["ride", "handling"];
const SPRING_MODES: [&str; 2] = ["hard", "soft"];
const DAMPER_MODES: [&str; 2] = ["high", "low"];
const SEQUENCER_STATES: [&str; 5] = ["idle", "lowering", "raising", "holding", "blocked"];

pub(crate) fn driver_mode(value: i64, path: &str) -> PyResult<DriverMode> {
    match value {
        0 => Ok(DriverMode::Auto),
        1 => Ok(DriverMode::Comfort),
        2 => Ok(DriverMode::Sport),
        _ => Err(parameter(format!("{path} = {value} is not a driver mode (0 auto, 1 comfort, 2 sport)"))),
    }
}

fn fresh_mask(value: i64, path: &str) -> PyResult<u16> {
    u16::try_from(value)
        .ok()
        .filter(|v| v & !input_group::ALL == 0)
        .ok_or_else(|| parameter(format!("{path} = {value} is not a set of input groups (0..={})", input_group::ALL)))
}

/// One period's inputs from a dict with every field of `Inputs`.
fn inputs_from_dict(obj: &Bound<'_, PyAny>) -> PyResult<Inputs> {
    let mut r = Reader::new(obj, "inputs")?;
    let mut i = Inputs::default();
    for (name, field) in INPUT_FLOATS {
        *field(&mut i) = extract(&r.get(name)?, &format!("inputs.{name}"), "a number")?;
    }
    for (name, field) in INPUT_BOOLS {
        *field(&mut i) = extract(&r.get(name)?, &format!("inputs.{name}"), "a bool")?;
    }
    i.driver_mode = driver_mode(extract(&r.get("driver_mode")?, "inputs.driver_mode", "an int")?, "inputs.driver_mode")?;
    i.fresh = fresh_mask(extract(&r.get("fresh")?, "inputs.fresh", "an int")?, "inputs.fresh")?;
    r.finish()?;
    Ok(i)
}

pub(crate) fn array<'py, T: numpy::Element + Copy>(r: &mut Reader<'py>, name: &str, path: &str, dtype: &str, n: &mut Option<usize>) -> PyResult<Vec<T>> {
    let v = r.get(name)?;
    let a: PyReadonlyArray1<'_, T> = extract(&v, &format!("{path}.{name}"), &format!("a 1-D numpy array of {dtype}"))?;
    let values = a.as_array().to_vec();
    match *n {
        Some(len) if len != values.len() => {
            Err(parameter(format!("{path}.{name} has {} values; the other arrays have {len}", values.len())))
        }
        _ => {
            *n = Some(values.len());
            Ok(values)
        }
    }
}

/// Periods of inputs from a dict of equally long arrays (float64, bool,
/// int64 for `driver_mode` and `fresh`).
fn inputs_from_arrays(obj: &Bound<'_, PyAny>) -> PyResult<Vec<Inputs>> {
    let mut r = Reader::new(obj, "inputs")?;
    let mut n = None;
    let floats: Vec<Vec<f64>> =
        INPUT_FLOATS.iter().map(|(name, _)| array(&mut r, name, "inputs", "float64", &mut n)).collect::<PyResult<_>>()?;
    let bools: Vec<Vec<bool>> =
        INPUT_BOOLS.iter().map(|(name, _)| array(&mut r, name, "inputs", "bool", &mut n)).collect::<PyResult<_>>()?;
    let modes: Vec<i64> = array(&mut r, "driver_mode", "inputs", "int64", &mut n)?;
    let fresh: Vec<i64> = array(&mut r, "fresh", "inputs", "int64", &mut n)?;
    r.finish()?;
    let mut out = vec![Inputs::default(); n.unwrap_or(0)];
    for (k, i) in out.iter_mut().enumerate() {
        for ((_, field), column) in INPUT_FLOATS.iter().zip(&floats) {
            *field(i) = column.get(k).copied().unwrap_or(f64::NAN);
        }
        for ((_, field), column) in INPUT_BOOLS.iter().zip(&bools) {
            *field(i) = column.get(k).copied().unwrap_or(false);
        }
        let path = format!("inputs.driver_mode[{k}]");
        i.driver_mode = driver_mode(modes.get(k).copied().unwrap_or(-1), &path)?;
        let path = format!("inputs.fresh[{k}]");
        i.fresh = fresh_mask(fresh.get(k).copied().unwrap_or(-1), &path)?;
    }
    Ok(out)
}

/// The scenario of a closed loop: `periods` values of each vehicle field.
fn vehicles_from_arrays(obj: &Bound<'_, PyAny>) -> PyResult<Vec<VehicleSignals>> {
    let mut r = Reader::new(obj, "scenario")?;
    let mut n = None;
    let floats: Vec<Vec<f64>> = VEHICLE_FLOATS
        .iter()
        .map(|(name, _)| array(&mut r, name, "scenario", "float64", &mut n))
        .collect::<PyResult<_>>()?;
    let brake: Vec<bool> = array(&mut r, "brake_pressed", "scenario", "bool", &mut n)?;
    let modes: Vec<i64> = array(&mut r, "driver_mode", "scenario", "int64", &mut n)?;
    r.finish()?;
    let mut out = vec![VehicleSignals::default(); n.unwrap_or(0)];
    for (k, v) in out.iter_mut().enumerate() {
        for ((_, field), column) in VEHICLE_FLOATS.iter().zip(&floats) {
            *field(v) = column.get(k).copied().unwrap_or(f64::NAN);
        }
        v.brake_pressed = brake.get(k).copied().unwrap_or(false);
        v.driver_mode = driver_mode(modes.get(k).copied().unwrap_or(-1), &format!("scenario.driver_mode[{k}]"))?;
    }
    Ok(out)
}

fn outputs_to_arrays<'py>(py: Python<'py>, outs: &[Outputs]) -> PyResult<Bound<'py, PyDict>> {
    let d = PyDict::new(py);
    let col_b = |f: fn(&Outputs) -> bool| outs.iter().map(f).collect::<Vec<bool>>().into_pyarray(py);
    let col_u8 = |f: fn(&Outputs) -> u8| outs.iter().map(f).collect::<Vec<u8>>().into_pyarray(py);
    let col_f = |f: fn(&Outputs) -> f64| outs.iter().map(f).collect::<Vec<f64>>().into_pyarray(py);
    d.set_item("valve5_open", col_b(|o| o.valve5_open))?;
    d.set_item("valve6_open", col_b(|o| o.valve6_open))?;
    d.set_item("drive_mode", col_u8(|o| o.drive_mode as u8))?;
    d.set_item("spring_mode", col_u8(|o| o.spring_mode as u8))?;
    d.set_item("damper_mode", col_u8(|o| o.damper_mode as u8))?;
    d.set_item("sequencer", col_u8(|o| o.sequencer as u8))?;
    d.set_item("diag", outs.iter().map(|o| o.diag).collect::<Vec<u32>>().into_pyarray(py))?;
    d.set_item("ride_height_m", col_f(|o| o.ride_height_m))?;
    d.set_item("p_gas2_target_pa", col_f(|o| o.p_gas2_target_pa))?;
    d.set_item("p_load_pa", col_f(|o| o.p_load_pa))?;
    d.set_item("strut_vel_m_s", col_f(|o| o.strut_vel_m_s))?;
    d.set_item("body_vel_m_s", col_f(|o| o.body_vel_m_s))?;
    Ok(d)
}

fn inputs_to_arrays<'py>(py: Python<'py>, inputs: &[Inputs]) -> PyResult<Bound<'py, PyDict>> {
    let d = PyDict::new(py);
    for (name, field) in INPUT_FLOATS {
        let column: Vec<f64> = inputs.iter().map(|i| get(i, field)).collect();
        d.set_item(name, column.into_pyarray(py))?;
    }
    for (name, field) in INPUT_BOOLS {
        let column: Vec<bool> = inputs.iter().map(|i| get(i, field)).collect();
        d.set_item(name, column.into_pyarray(py))?;
    }
    d.set_item("driver_mode", inputs.iter().map(|i| i.driver_mode as i64).collect::<Vec<i64>>().into_pyarray(py))?;
    d.set_item("fresh", inputs.iter().map(|i| i64::from(i.fresh)).collect::<Vec<i64>>().into_pyarray(py))?;
    Ok(d)
}

/// One period's outputs as a dict of Python scalars (enums as their
/// numeric values, see `CTRL_*_MODES`).
fn outputs_to_dict<'py>(py: Python<'py>, o: &Outputs) -> PyResult<Bound<'py, PyDict>> {
    let d = PyDict::new(py);
    d.set_item("valve5_open", o.valve5_open)?;
    d.set_item("valve6_open", o.valve6_open)?;
    d.set_item("drive_mode", o.drive_mode as u8)?;
    d.set_item("spring_mode", o.spring_mode as u8)?;
    d.set_item("damper_mode", o.damper_mode as u8)?;
    d.set_item("sequencer", o.sequencer as u8)?;
    d.set_item("diag", o.diag)?;
    d.set_item("ride_height_m", o.ride_height_m)?;
    d.set_item("p_gas2_target_pa", o.p_gas2_target_pa)?;
    d.set_item("p_load_pa", o.p_load_pa)?;
    d.set_item("strut_vel_m_s", o.strut_vel_m_s)?;
    d.set_item("body_vel_m_s", o.body_vel_m_s)?;
    Ok(d)
}

// ------------------------------------------------------------ controller

/// The controller: compiled parameters and its state, stepped one control
/// period (`step`) or many (`step_many`) at a time.
#[pyclass(module = "hpctl._core")]
pub struct Controller {
    params: Params,
    state: State,
}

#[pymethods]
impl Controller {
    /// Compiles `config` (a dict like `ctrl_seed_config()`; None: the seed
    /// unit) and starts at power-on (the safe state).
    #[new]
    #[pyo3(signature = (config=None))]
    fn new(config: Option<&Bound<'_, PyAny>>) -> PyResult<Self> {
        guard(|| Ok(Controller { params: params_from(config)?, state: State::new() }))
    }

    /// The configuration, as a dict.
    #[getter]
    fn config<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        guard(|| config_to_dict(py, self.params.config()))
    }

    /// Back to power-on (the safe state).
    fn reset(&mut self) {
        self.state = State::new();
    }

    /// One control period: `inputs` is a dict with every input field, `dt_s`
    /// the time since the previous call. Returns the outputs as a dict.
    fn step<'py>(&mut self, py: Python<'py>, inputs: &Bound<'py, PyAny>, dt_s: f64) -> PyResult<Bound<'py, PyDict>> {
        guard(|| {
            let inputs = inputs_from_dict(inputs)?;
            let out = hp_ctrl::step(&self.params, &mut self.state, &inputs, dt_s);
            outputs_to_dict(py, &out)
        })
    }

    /// Many control periods: `inputs` is a dict of equally long arrays
    /// (float64; bool for `brake_pressed`, `link_fault`; int64 for
    /// `driver_mode`, `fresh`), `dt_s` one step size or an array of them.
    /// Returns a dict of arrays of the outputs.
    fn step_many<'py>(&mut self, py: Python<'py>, inputs: &Bound<'py, PyAny>, dt_s: &Bound<'py, PyAny>) -> PyResult<Bound<'py, PyDict>> {
        guard(|| {
            let inputs = inputs_from_arrays(inputs)?;
            let dts: Vec<f64> = if let Ok(dt) = dt_s.extract::<f64>() {
                vec![dt; inputs.len()]
            } else {
                let a: PyReadonlyArray1<'_, f64> = extract(dt_s, "dt_s", "a number or a 1-D numpy array of float64")?;
                a.as_array().to_vec()
            };
            if dts.len() != inputs.len() {
                return Err(parameter(format!("dt_s has {} values; the inputs have {}", dts.len(), inputs.len())));
            }
            let outs: Vec<Outputs> =
                inputs.iter().zip(&dts).map(|(i, &dt)| hp_ctrl::step(&self.params, &mut self.state, i, dt)).collect();
            outputs_to_arrays(py, &outs)
        })
    }
}

// ----------------------------------------------------------- closed loop

/// One closed-loop run, fully owned so it can run on another thread.
struct LoopCase {
    unit: hp_core::unit::UnitParams,
    base: MotionSpec,
    sprung_mass_kg: f64,
    params: Params,
    vehicles: Vec<VehicleSignals>,
    dt_s: f64,
    ambient_k: f64,
    max_dt_s: f64,
    record_every: usize,
    channels: Vec<usize>,
    sensors: Sensors,
}

/// What a run recorded: plant channels, controller inputs and outputs.
struct LoopRecord {
    channels: Vec<Vec<f64>>,
    inputs: Vec<Inputs>,
    outputs: Vec<Outputs>,
}

impl LoopCase {
    #[allow(clippy::too_many_arguments)]
    fn from_py(
        unit: &Bound<'_, PyAny>,
        rig: &Bound<'_, PyAny>,
        scenario: &Bound<'_, PyAny>,
        dt_s: f64,
        ambient_k: f64,
        config: Option<&Bound<'_, PyAny>>,
        max_dt_s: f64,
        channels: Option<Vec<String>>,
        record_every: usize,
        t_gas_sensor_tau_s: f64,
    ) -> PyResult<LoopCase> {
        let (sprung_mass_kg, base) = match params::rig(rig)? {
            RigSpec::Sdof { sprung_mass_kg, base } => (sprung_mass_kg, base),
            RigSpec::Characterisation { .. } => {
                return Err(parameter("rig.kind must be \"sdof\" for a closed loop (a body for the controller to ride)"))
            }
        };
        if record_every == 0 {
            return Err(parameter("record_every must be at least 1"));
        }
        let channels = match channels {
            None => (0..CHANNELS.len()).collect(),
            Some(names) => names
                .iter()
                .map(|n| {
                    CHANNELS
                        .iter()
                        .position(|c| c == n)
                        .ok_or_else(|| parameter(format!("unknown channel {n:?} (known: {})", CHANNELS.join(", "))))
                })
                .collect::<PyResult<_>>()?,
        };
        Ok(LoopCase {
            unit: params::unit(unit)?,
            base,
            sprung_mass_kg,
            params: params_from(config)?,
            vehicles: vehicles_from_arrays(scenario)?,
            dt_s,
            ambient_k,
            max_dt_s,
            record_every,
            channels,
            sensors: Sensors { t_gas_tau_s: t_gas_sensor_tau_s, ..Sensors::default() },
        })
    }

    /// Runs the loop; `tick(period)` is called every period and may stop it.
    fn run(&self, mut tick: impl FnMut(usize) -> bool) -> Result<LoopRecord, hp_core::Error> {
        let unit = Unit::new(self.unit)?;
        let kind = RigKind::Sdof { sprung_mass_kg: self.sprung_mass_kg, base: self.base.motion() };
        // Power-on: the controller's safe state, both valves closed.
        let rig = Rig::new(&unit, kind, self.ambient_k, Valves::default())?;
        let n = self.vehicles.len().div_ceil(self.record_every);
        let mut out = LoopRecord {
            channels: self.channels.iter().map(|_| Vec::with_capacity(n)).collect(),
            inputs: Vec::with_capacity(n),
            outputs: Vec::with_capacity(n),
        };
        let mut state = State::new();
        let vehicles = &self.vehicles;
        hp_vehicle::closed_loop::run(
            &rig,
            &self.params,
            &self.sensors,
            &mut state,
            vehicles.len(),
            self.dt_s,
            self.max_dt_s,
            |k, _| vehicles.get(k).copied().unwrap_or_default(),
            |p| {
                if p.index % self.record_every == 0 {
                    let values = channel_values(p.sample);
                    for (column, &c) in out.channels.iter_mut().zip(&self.channels) {
                        column.push(values.get(c).copied().unwrap_or(f64::NAN));
                    }
                    out.inputs.push(*p.inputs);
                    out.outputs.push(*p.outputs);
                }
                tick(p.index)
            },
        )?;
        Ok(out)
    }

    fn to_dict<'py>(&self, py: Python<'py>, r: LoopRecord) -> PyResult<Bound<'py, PyDict>> {
        let plant = PyDict::new(py);
        for (column, &c) in r.channels.into_iter().zip(&self.channels) {
            plant.set_item(CHANNELS.get(c).copied().unwrap_or("?"), column.into_pyarray(py))?;
        }
        let d = PyDict::new(py);
        d.set_item("plant", plant)?;
        d.set_item("inputs", inputs_to_arrays(py, &r.inputs)?)?;
        d.set_item("outputs", outputs_to_arrays(py, &r.outputs)?)?;
        Ok(d)
    }
}

/// Runs the controller in closed loop with `unit` on an SDOF `rig` (see
/// `simulate`): one control period of `dt_s` per entry of the `scenario`
/// arrays (the vehicle and driver inputs: float64 `speed_m_s`,
/// `lat_acc_m_s2`, `long_acc_m_s2`, `steer_angle_rad`, `steer_rate_rad_s`,
/// `ride_height_request_m`; bool `brake_pressed`; int64 `driver_mode`).
/// The gas-temperature sensor lags L's gas by `t_gas_sensor_tau_s`.
/// Returns `{"plant": channels, "inputs": ..., "outputs": ...}`, each a
/// dict of arrays, every `record_every`-th period.
#[pyfunction]
#[pyo3(signature = (unit, rig, scenario, dt_s, ambient_k, config=None, max_dt_s=1e-3, channels=None, record_every=1, t_gas_sensor_tau_s=1.0, progress=None))]
#[allow(clippy::too_many_arguments)]
pub fn closed_loop<'py>(
    py: Python<'py>,
    unit: &Bound<'py, PyAny>,
    rig: &Bound<'py, PyAny>,
    scenario: &Bound<'py, PyAny>,
    dt_s: f64,
    ambient_k: f64,
    config: Option<&Bound<'py, PyAny>>,
    max_dt_s: f64,
    channels: Option<Vec<String>>,
    record_every: usize,
    t_gas_sensor_tau_s: f64,
    progress: Option<Py<PyAny>>,
) -> PyResult<Bound<'py, PyDict>> {
    guard(|| {
        let case =
            LoopCase::from_py(unit, rig, scenario, dt_s, ambient_k, config, max_dt_s, channels, record_every, t_gas_sensor_tau_s)?;
        let total = case.vehicles.len();
        let result = detached_with_progress(py, total, progress, |tick| case.run(tick))?;
        case.to_dict(py, result.map_err(to_py)?)
    })
}

/// Runs many closed loops in parallel on `threads` threads (all cores when
/// None). Each case is a dict with the arguments of `closed_loop` (`config`,
/// `max_dt_s`, `channels`, `record_every`, `t_gas_sensor_tau_s` optional). Returns, per case, its
/// result dict or the exception it raised.
#[pyfunction]
#[pyo3(signature = (cases, threads=None))]
pub fn closed_loop_many<'py>(py: Python<'py>, cases: &Bound<'py, PyAny>, threads: Option<&Bound<'py, PyAny>>) -> PyResult<Bound<'py, PyList>> {
    guard(|| {
        let threads = threads_arg(threads)?;
        let specs = parse_cases(cases, |r, path| {
            let config = r.get_opt("config")?;
            let max_dt_s = match r.get_opt("max_dt_s")? {
                Some(v) => extract(&v, &format!("{path}.max_dt_s"), "a number")?,
                None => 1e-3,
            };
            let channels = match r.get_opt("channels")? {
                Some(v) => Some(extract(&v, &format!("{path}.channels"), "a list of channel names")?),
                None => None,
            };
            let record_every = match r.get_opt("record_every")? {
                Some(v) => extract(&v, &format!("{path}.record_every"), "a positive int")?,
                None => 1,
            };
            let t_gas_sensor_tau_s = match r.get_opt("t_gas_sensor_tau_s")? {
                Some(v) => extract(&v, &format!("{path}.t_gas_sensor_tau_s"), "a number")?,
                None => Sensors::default().t_gas_tau_s,
            };
            LoopCase::from_py(
                &r.get("unit")?,
                &r.get("rig")?,
                &r.get("scenario")?,
                r.f64("dt_s")?,
                r.f64("ambient_k")?,
                config.as_ref(),
                max_dt_s,
                channels,
                record_every,
                t_gas_sensor_tau_s,
            )
        })?;
        run_parallel(py, &specs, threads, |c| c.run(|_| true), |c, r| c.to_dict(py, r))
    })
}

// -------------------------------------------------------------- registry

/// The diagnostic flags by name (see `docs/controller.md`).
fn diag_flags() -> Vec<(&'static str, u32)> {
    let mut flags = vec![
        ("SAFE_STATE", diag::SAFE_STATE),
        ("RECOVERING", diag::RECOVERING),
        ("BAD_DT", diag::BAD_DT),
        ("LINK_FAULT", diag::LINK_FAULT),
        ("NOT_FINITE", diag::NOT_FINITE),
        ("OUT_OF_RANGE", diag::OUT_OF_RANGE),
        ("RATE_LIMIT", diag::RATE_LIMIT),
        ("STALE", diag::STALE),
    ];
    for (_, flag_name, group) in INPUT_GROUPS {
        flags.push((flag_name, diag::group(group)));
    }
    flags.extend([
        ("REQUEST_CLAMPED", diag::REQUEST_CLAMPED),
        ("SEQUENCER_PAUSED", diag::SEQUENCER_PAUSED),
        ("HEIGHT_HOLDS_SPRING", diag::HEIGHT_HOLDS_SPRING),
        ("HEIGHT_ESTIMATE_HELD", diag::HEIGHT_ESTIMATE_HELD),
        ("TRIGGER_LATERAL", diag::TRIGGER_LATERAL),
        ("TRIGGER_STEER_RATE", diag::TRIGGER_STEER_RATE),
        ("TRIGGER_LONGITUDINAL", diag::TRIGGER_LONGITUDINAL),
        ("TRIGGER_BRAKE", diag::TRIGGER_BRAKE),
        ("TRIGGER_SPEED", diag::TRIGGER_SPEED),
        ("TRIGGER_SPORT", diag::TRIGGER_SPORT),
        ("HANDLING_HOLD", diag::HANDLING_HOLD),
    ]);
    flags
}

/// The input groups: name, name of their diag flag, bit.
const INPUT_GROUPS: [(&str, &str, u16); 7] = [
    ("PRESSURES", "GROUP_PRESSURES", input_group::PRESSURES),
    ("STRUT", "GROUP_STRUT", input_group::STRUT),
    ("BODY", "GROUP_BODY", input_group::BODY),
    ("VEHICLE", "GROUP_VEHICLE", input_group::VEHICLE),
    ("STEERING", "GROUP_STEERING", input_group::STEERING),
    ("TEMPERATURE", "GROUP_TEMPERATURE", input_group::TEMPERATURE),
    ("DRIVER", "GROUP_DRIVER", input_group::DRIVER),
];

/// Registers the controller's classes, functions and name tables.
pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    let py = m.py();
    m.add_class::<Controller>()?;
    m.add_function(wrap_pyfunction!(ctrl_seed_config, m)?)?;
    m.add_function(wrap_pyfunction!(ctrl_config_for_unit, m)?)?;
    m.add_function(wrap_pyfunction!(closed_loop, m)?)?;
    m.add_function(wrap_pyfunction!(closed_loop_many, m)?)?;
    let flags = PyDict::new(py);
    for (name, bit) in diag_flags() {
        flags.set_item(name, bit)?;
    }
    m.add("CTRL_DIAG_FLAGS", flags)?;
    let groups = PyDict::new(py);
    for (name, _, bit) in INPUT_GROUPS {
        groups.set_item(name, bit)?;
    }
    m.add("CTRL_INPUT_GROUPS", groups)?;
    m.add("CTRL_DRIVER_MODES", DRIVER_MODES.to_vec())?;
    m.add("CTRL_DRIVE_MODES", DRIVE_MODES.to_vec())?;
    m.add("CTRL_SPRING_MODES", SPRING_MODES.to_vec())?;
    m.add("CTRL_DAMPER_MODES", DAMPER_MODES.to_vec())?;
    m.add("CTRL_SEQUENCER_STATES", SEQUENCER_STATES.to_vec())?;
    m.add("CTRL_INPUT_FIELDS", INPUT_FLOATS.iter().map(|f| f.0).chain(INPUT_BOOLS.iter().map(|f| f.0)).chain(["driver_mode", "fresh"]).collect::<Vec<_>>())?;
    m.add("CTRL_SCENARIO_FIELDS", VEHICLE_FLOATS.iter().map(|f| f.0).chain(["brake_pressed", "driver_mode"]).collect::<Vec<_>>())?;
    Ok(())
}

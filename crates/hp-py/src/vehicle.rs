//! The vehicles of hp-vehicle from Python: presets as dicts, a run along a
//! road (passive or one controller per wheel) recorded as numpy arrays,
//! many runs in parallel (rayon), and a vehicle stepped one control period
//! at a time with valve commands per wheel (for processor-in-the-loop).
//! Thin: conversions only.

use crate::args::extract;
use crate::ctrl::{array, config_to_dict, driver_mode, params_from};
use crate::errors::{guard, parameter, to_py};
use crate::exec::{detached_with_progress, parse_cases, run_parallel, threads_arg};
use crate::params::{self, Reader};
use hp_core::unit::Valves;
use hp_ctrl::{Outputs, Params, State};
use hp_vehicle::closed_loop::Sensors;
use hp_vehicle::drive::{self, Driver, Suspension};
use hp_vehicle::track::{Road, Track};
use hp_vehicle::tyre::Tyre;
use hp_vehicle::vehicle::{
    Axle, Body, CornerSample, DriveInputs, Seat, StepMemory, Stepping, Vehicle, VehicleParams, VehicleSample, VehicleState, MAX_AXLES, MAX_CORNERS,
};
use hp_vehicle::presets;
use numpy::ndarray::Array2;
use numpy::IntoPyArray;
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyList};

// ------------------------------------------------------------ parameters

/// A vehicle dict (see `vehicle_presets`) to parameters; the values are
/// checked by `Vehicle::new`.
fn vehicle_params(obj: &Bound<'_, PyAny>) -> PyResult<VehicleParams> {
    let mut r = Reader::new(obj, "vehicle")?;
    let mut b = r.sub("body")?;
    let body = Body {
        mass_kg: b.f64("mass_kg")?,
        roll_inertia_kg_m2: b.f64("roll_inertia_kg_m2")?,
        pitch_inertia_kg_m2: b.f64("pitch_inertia_kg_m2")?,
        yaw_inertia_kg_m2: b.f64("yaw_inertia_kg_m2")?,
        cg_height_m: b.f64("cg_height_m")?,
        roll_centre_height_m: b.f64("roll_centre_height_m")?,
    };
    b.finish()?;
    let list = r.get("axles")?;
    let list = list.cast::<PyList>().map_err(|_| parameter("vehicle.axles must be a list of axle dicts"))?;
    if !(2..=MAX_AXLES).contains(&list.len()) {
        return Err(parameter(format!("vehicle.axles has {} axles; a vehicle has 2 to {MAX_AXLES}", list.len())));
    }
    let mut axles = Vec::with_capacity(MAX_AXLES);
    for (k, a) in list.iter().enumerate() {
        let mut ar = Reader::new(&a, &format!("vehicle.axles[{k}]"))?;
        axles.push(Axle {
            x_m: ar.f64("x_m")?,
            track_m: ar.f64("track_m")?,
            unsprung_mass_kg: ar.f64("unsprung_mass_kg")?,
            wheel_radius_m: ar.f64("wheel_radius_m")?,
            tyre: Tyre { stiffness_n_per_m: ar.f64("tyre_stiffness_n_per_m")?, damping_n_s_per_m: ar.f64("tyre_damping_n_s_per_m")? },
            cornering_stiffness_n_per_rad: ar.f64("cornering_stiffness_n_per_rad")?,
            steer_ratio: ar.f64("steer_ratio")?,
            unit: params::unit(&ar.get("unit")?)?,
        });
        ar.finish()?;
    }
    let axle_count = axles.len();
    let first = axles.first().copied().ok_or_else(|| parameter("vehicle.axles is empty"))?;
    axles.resize(MAX_AXLES, first);
    let mut s = r.sub("seat")?;
    let seat = Seat { x_m: s.f64("x_m")?, y_m: s.f64("y_m")?, height_m: s.f64("height_m")? };
    s.finish()?;
    let p = VehicleParams {
        body,
        axles: axles.try_into().map_err(|_| parameter("vehicle.axles"))?,
        axle_count,
        steering_ratio: r.f64("steering_ratio")?,
        seat,
    };
    r.finish()?;
    Ok(p)
}

fn vehicle_to_dict<'py>(py: Python<'py>, p: &VehicleParams) -> PyResult<Bound<'py, PyDict>> {
    let d = PyDict::new(py);
    let b = PyDict::new(py);
    b.set_item("mass_kg", p.body.mass_kg)?;
    b.set_item("roll_inertia_kg_m2", p.body.roll_inertia_kg_m2)?;
    b.set_item("pitch_inertia_kg_m2", p.body.pitch_inertia_kg_m2)?;
    b.set_item("yaw_inertia_kg_m2", p.body.yaw_inertia_kg_m2)?;
    b.set_item("cg_height_m", p.body.cg_height_m)?;
    b.set_item("roll_centre_height_m", p.body.roll_centre_height_m)?;
    d.set_item("body", b)?;
    let axles = PyList::empty(py);
    for a in p.axles.iter().take(p.axle_count) {
        let ad = PyDict::new(py);
        ad.set_item("x_m", a.x_m)?;
        ad.set_item("track_m", a.track_m)?;
        ad.set_item("unsprung_mass_kg", a.unsprung_mass_kg)?;
        ad.set_item("wheel_radius_m", a.wheel_radius_m)?;
        ad.set_item("tyre_stiffness_n_per_m", a.tyre.stiffness_n_per_m)?;
        ad.set_item("tyre_damping_n_s_per_m", a.tyre.damping_n_s_per_m)?;
        ad.set_item("cornering_stiffness_n_per_rad", a.cornering_stiffness_n_per_rad)?;
        ad.set_item("steer_ratio", a.steer_ratio)?;
        ad.set_item("unit", params::unit_to_dict(py, &a.unit)?)?;
        axles.append(ad)?;
    }
    d.set_item("axles", axles)?;
    d.set_item("steering_ratio", p.steering_ratio)?;
    let s = PyDict::new(py);
    s.set_item("x_m", p.seat.x_m)?;
    s.set_item("y_m", p.seat.y_m)?;
    s.set_item("height_m", p.seat.height_m)?;
    d.set_item("seat", s)?;
    Ok(d)
}

/// The built-in vehicles, by name (`4x4`, `8x8`), as dicts.
#[pyfunction]
pub fn vehicle_presets(py: Python<'_>) -> PyResult<Bound<'_, PyDict>> {
    guard(|| {
        let d = PyDict::new(py);
        d.set_item("4x4", vehicle_to_dict(py, &presets::armoured_4x4())?)?;
        d.set_item("8x8", vehicle_to_dict(py, &presets::armoured_8x8())?)?;
        Ok(d)
    })
}

/// The controller configuration for a vehicle: the seed calibration with
/// the vehicle's steering ratio and effective wheelbase.
#[pyfunction]
pub fn vehicle_controller_config<'py>(py: Python<'py>, vehicle: &Bound<'py, PyAny>) -> PyResult<Bound<'py, PyDict>> {
    guard(|| config_to_dict(py, &presets::controller_config(&vehicle_params(vehicle)?)))
}

/// Static wheel loads (N), strut compressions (m) and tyre deflections (m)
/// of a vehicle at `ambient_k` with the valves given.
#[pyfunction]
#[pyo3(signature = (vehicle, ambient_k, spring_hard=true, damper_on=true))]
pub fn vehicle_statics<'py>(py: Python<'py>, vehicle: &Bound<'py, PyAny>, ambient_k: f64, spring_hard: bool, damper_on: bool) -> PyResult<Bound<'py, PyDict>> {
    guard(|| {
        let v = Vehicle::new(vehicle_params(vehicle)?, ambient_k, Valves::from_modes(spring_hard, damper_on)).map_err(to_py)?;
        let d = PyDict::new(py);
        let col = |f: fn(&hp_vehicle::vehicle::CornerGeometry) -> f64| v.corners().iter().map(f).collect::<Vec<f64>>();
        d.set_item("static_load_n", col(|c| c.static_load_n).into_pyarray(py))?;
        d.set_item("static_disp_m", col(|c| c.static_disp_m).into_pyarray(py))?;
        d.set_item("tyre_static_deflection_m", col(|c| c.tyre_static_deflection_m).into_pyarray(py))?;
        d.set_item("x_m", col(|c| c.x_m).into_pyarray(py))?;
        d.set_item("y_m", col(|c| c.y_m).into_pyarray(py))?;
        d.set_item("total_mass_kg", v.total_mass_kg())?;
        Ok(d)
    })
}

/// A road as the two tracks on one grid.
#[derive(Debug, Clone)]
struct RoadSpec {
    start_m: f64,
    dx_m: f64,
    left_m: Vec<f64>,
    right_m: Vec<f64>,
}

impl RoadSpec {
    fn road(&self) -> Road<'_> {
        Road {
            left: Track { start_m: self.start_m, dx_m: self.dx_m, height_m: &self.left_m },
            right: Track { start_m: self.start_m, dx_m: self.dx_m, height_m: &self.right_m },
        }
    }
}

fn road_spec(obj: &Bound<'_, PyAny>) -> PyResult<RoadSpec> {
    let mut r = Reader::new(obj, "road")?;
    let spec = RoadSpec { start_m: r.f64("start_m")?, dx_m: r.f64("dx_m")?, left_m: r.vec("left_m")?, right_m: r.vec("right_m")? };
    r.finish()?;
    if spec.left_m.len() != spec.right_m.len() {
        return Err(parameter(format!("road.left_m has {} points but road.right_m has {}", spec.left_m.len(), spec.right_m.len())));
    }
    spec.road().validate().map_err(to_py)?;
    Ok(spec)
}

// --------------------------------------------------------------- channels

type Global = (&'static str, fn(&VehicleSample) -> f64);
type PerCorner = (&'static str, fn(&CornerSample) -> f64);
type PerController = (&'static str, fn(&Outputs) -> f64);

const GLOBAL: [Global; 22] = [
    ("time_s", |s| s.time_s),
    ("distance_m", |s| s.distance_m),
    ("speed_m_s", |s| s.speed_m_s),
    ("long_acc_m_s2", |s| s.long_acc_m_s2),
    ("steer_angle_rad", |s| s.steer_angle_rad),
    ("lat_acc_m_s2", |s| s.lat_acc_m_s2),
    ("yaw_rate_rad_s", |s| s.yaw_rate_rad_s),
    ("heading_rad", |s| s.heading_rad),
    ("lateral_pos_m", |s| s.lateral_pos_m),
    ("heave_m", |s| s.body.heave_m),
    ("heave_vel_m_s", |s| s.body.heave_vel_m_s),
    ("heave_acc_m_s2", |s| s.body.heave_acc_m_s2),
    ("pitch_rad", |s| s.body.pitch_rad),
    ("pitch_rate_rad_s", |s| s.body.pitch_rate_rad_s),
    ("pitch_acc_rad_s2", |s| s.body.pitch_acc_rad_s2),
    ("roll_rad", |s| s.body.roll_rad),
    ("roll_rate_rad_s", |s| s.body.roll_rate_rad_s),
    ("roll_acc_rad_s2", |s| s.body.roll_acc_rad_s2),
    ("seat_acc_x_m_s2", |s| s.seat_acc_x_m_s2),
    ("seat_acc_y_m_s2", |s| s.seat_acc_y_m_s2),
    ("seat_acc_z_m_s2", |s| s.seat_acc_z_m_s2),
    ("lat_vel_m_s", |s| s.lat_vel_m_s),
];

/// Per-wheel channels; names as in the rig records where the quantity is
/// the same (`force_n` is the transducer's reading, `p_gas_pa` S, `p_gas2_pa` L).
const CORNER: [PerCorner; 20] = [
    ("disp_m", |c| c.forces.strut.disp_m),
    ("vel_m_s", |c| c.forces.strut.vel_m_s),
    ("force_n", |c| c.forces.unit.force_n),
    ("force_true_n", |c| c.forces.unit.force_true_n),
    ("p_gas_pa", |c| c.forces.unit.p_gas_pa),
    ("p_gas2_pa", |c| c.forces.unit.p_gas2_pa),
    ("t_gas_k", |c| c.forces.unit.t_gas_k),
    ("t_gas2_k", |c| c.forces.unit.t_gas2_k),
    ("v_gas_m3", |c| c.v_gas_m3),
    ("v_gas2_m3", |c| c.v_gas2_m3),
    ("damper_force_n", |c| c.forces.unit.damper_force_n),
    ("damper_power_w", |c| c.forces.unit.damper_power_w),
    ("tyre_force_n", |c| c.forces.tyre_force_n),
    ("tyre_deflection_m", |c| c.forces.tyre_deflection_m),
    ("road_m", |c| c.road_m),
    ("wheel_disp_m", |c| c.wheel_disp_m),
    ("wheel_acc_m_s2", |c| c.wheel_acc_m_s2),
    ("body_acc_m_s2", |c| c.body_acc_m_s2),
    ("valve5_open", |c| f64::from(u8::from(c.valves.valve5_open))),
    ("valve6_open", |c| f64::from(u8::from(c.valves.valve6_open))),
];

/// Per-wheel controller outputs (semi-active runs).
const CONTROLLER: [PerController; 5] = [
    ("drive_mode", |o| f64::from(o.drive_mode as u8)),
    ("sequencer", |o| f64::from(o.sequencer as u8)),
    ("diag", |o| f64::from(o.diag)),
    ("ride_height_m", |o| o.ride_height_m),
    ("p_load_pa", |o| o.p_load_pa),
];

// ------------------------------------------------------------------- runs

/// One vehicle run, fully owned so it can run on another thread.
struct VehicleCase {
    vehicle: VehicleParams,
    road: RoadSpec,
    drivers: Vec<Driver>,
    /// None: passive with these valves.
    controller: Option<Params>,
    passive: Valves,
    dt_s: f64,
    ambient_k: f64,
    max_dt_s: f64,
    record_every: usize,
    sensors: Sensors,
    /// Run the reference plant (RK4 steps, the gas evaluated directly)
    /// instead of the fast one (ROS2 steps, the tabulated gas).
    reference_plant: bool,
}

/// What a run recorded (row-major per-wheel arrays).
struct VehicleRecord {
    corners: usize,
    rows: usize,
    global: Vec<Vec<f64>>,
    corner: Vec<Vec<f64>>,
    controller: Vec<Vec<f64>>,
}

fn drivers_from_arrays(obj: &Bound<'_, PyAny>) -> PyResult<Vec<Driver>> {
    let mut r = Reader::new(obj, "drive")?;
    let mut n = None;
    let names = ["speed_m_s", "long_acc_m_s2", "steer_angle_rad", "steer_rate_rad_s", "ride_height_request_m"];
    let floats: Vec<Vec<f64>> = names.iter().map(|name| array(&mut r, name, "drive", "float64", &mut n)).collect::<PyResult<_>>()?;
    let brake: Vec<bool> = array(&mut r, "brake_pressed", "drive", "bool", &mut n)?;
    let modes: Vec<i64> = array(&mut r, "driver_mode", "drive", "int64", &mut n)?;
    r.finish()?;
    let col = |c: usize, k: usize| floats.get(c).and_then(|v| v.get(k)).copied().unwrap_or(f64::NAN);
    (0..n.unwrap_or(0))
        .map(|k| {
            Ok(Driver {
                speed_m_s: col(0, k),
                long_acc_m_s2: col(1, k),
                steer_angle_rad: col(2, k),
                steer_rate_rad_s: col(3, k),
                ride_height_request_m: col(4, k),
                brake_pressed: brake.get(k).copied().unwrap_or(false),
                driver_mode: driver_mode(modes.get(k).copied().unwrap_or(-1), &format!("drive.driver_mode[{k}]"))?,
            })
        })
        .collect()
}

/// `{"kind": "passive", "spring_hard": bool, "damper_on": bool}` or
/// `{"kind": "semi_active", "config": dict | None}`.
fn suspension_spec(obj: &Bound<'_, PyAny>) -> PyResult<(Option<Params>, Valves)> {
    let mut r = Reader::new(obj, "suspension")?;
    let kind = r.string("kind")?;
    let out = match kind.as_str() {
        "passive" => {
            let hard = extract(&r.get("spring_hard")?, "suspension.spring_hard", "a bool")?;
            let on = extract(&r.get("damper_on")?, "suspension.damper_on", "a bool")?;
            (None, Valves::from_modes(hard, on))
        }
        "semi_active" => {
            let config = r.get_opt("config")?;
            (Some(params_from(config.as_ref())?), Valves::default())
        }
        other => return Err(parameter(format!("suspension.kind = {other:?} is not a suspension (one of: passive, semi_active)"))),
    };
    r.finish()?;
    Ok(out)
}

impl VehicleCase {
    #[allow(clippy::too_many_arguments)]
    fn from_py(
        vehicle: &Bound<'_, PyAny>,
        road: &Bound<'_, PyAny>,
        drive: &Bound<'_, PyAny>,
        suspension: &Bound<'_, PyAny>,
        dt_s: f64,
        ambient_k: f64,
        max_dt_s: f64,
        record_every: usize,
        t_gas_sensor_tau_s: f64,
    ) -> PyResult<VehicleCase> {
        if record_every == 0 {
            return Err(parameter("record_every must be at least 1"));
        }
        let (controller, passive) = suspension_spec(suspension)?;
        Ok(VehicleCase {
            vehicle: vehicle_params(vehicle)?,
            road: road_spec(road)?,
            drivers: drivers_from_arrays(drive)?,
            controller,
            passive,
            dt_s,
            ambient_k,
            max_dt_s,
            record_every,
            sensors: Sensors { t_gas_tau_s: t_gas_sensor_tau_s, ..Sensors::default() },
            reference_plant: false,
        })
    }

    fn run(&self, mut tick: impl FnMut(usize) -> bool) -> Result<VehicleRecord, hp_core::Error> {
        let suspension = match &self.controller {
            Some(p) => Suspension::SemiActive(p),
            None => Suspension::Passive(self.passive),
        };
        let mut vehicle = Vehicle::new(self.vehicle, self.ambient_k, suspension.initial_valves())?;
        if self.reference_plant {
            vehicle = vehicle.with_direct_gas().with_stepping(Stepping::Rk4);
        }
        let corners = vehicle.corner_count();
        let rows = self.drivers.len().div_ceil(self.record_every);
        let mut rec = VehicleRecord {
            corners,
            rows: 0,
            global: GLOBAL.iter().map(|_| Vec::with_capacity(rows)).collect(),
            corner: CORNER.iter().map(|_| Vec::with_capacity(rows * corners)).collect(),
            controller: if self.controller.is_some() { CONTROLLER.iter().map(|_| Vec::with_capacity(rows * corners)).collect() } else { Vec::new() },
        };
        let mut states = [State::new(); MAX_CORNERS];
        let drivers = &self.drivers;
        let road = self.road.road();
        drive::run(
            &vehicle,
            &road,
            suspension,
            &self.sensors,
            &mut states,
            drivers.len(),
            self.dt_s,
            self.max_dt_s,
            |k, _| drivers.get(k).copied().unwrap_or_default(),
            |p| {
                if p.index % self.record_every == 0 {
                    rec.rows += 1;
                    for (column, (_, f)) in rec.global.iter_mut().zip(GLOBAL.iter()) {
                        column.push(f(p.sample));
                    }
                    for (column, (_, f)) in rec.corner.iter_mut().zip(CORNER.iter()) {
                        column.extend(p.sample.corners.iter().take(corners).map(f));
                    }
                    for (column, (_, f)) in rec.controller.iter_mut().zip(CONTROLLER.iter()) {
                        column.extend(p.outputs.iter().take(corners).map(f));
                    }
                }
                tick(p.index)
            },
        )?;
        Ok(rec)
    }

    fn to_dict<'py>(&self, py: Python<'py>, r: VehicleRecord) -> PyResult<Bound<'py, PyDict>> {
        let d = PyDict::new(py);
        let shaped = |v: Vec<f64>| Array2::from_shape_vec((r.rows, r.corners), v).map_err(|e| parameter(format!("record shape: {e}")));
        let global = PyDict::new(py);
        for (column, (name, _)) in r.global.into_iter().zip(GLOBAL.iter()) {
            global.set_item(name, column.into_pyarray(py))?;
        }
        let corner = PyDict::new(py);
        for (column, (name, _)) in r.corner.into_iter().zip(CORNER.iter()) {
            corner.set_item(name, shaped(column)?.into_pyarray(py))?;
        }
        let controller = PyDict::new(py);
        for (column, (name, _)) in r.controller.into_iter().zip(CONTROLLER.iter()) {
            controller.set_item(name, shaped(column)?.into_pyarray(py))?;
        }
        d.set_item("vehicle", global)?;
        d.set_item("corners", corner)?;
        d.set_item("controller", controller)?;
        Ok(d)
    }
}

/// Drives `vehicle` along `road` (`{"start_m", "dx_m", "left_m", "right_m"}`)
/// for one control period of `dt_s` per entry of the `drive` arrays
/// (float64 `speed_m_s`, `long_acc_m_s2`, `steer_angle_rad`,
/// `steer_rate_rad_s`, `ride_height_request_m`; bool `brake_pressed`;
/// int64 `driver_mode`) with the `suspension`. Returns `{"vehicle": 1-D
/// arrays, "corners": (periods, wheels) arrays, "controller": (periods,
/// wheels) arrays (semi-active only)}` every `record_every`-th period.
/// `reference_plant` runs RK4 steps with the gas evaluated directly (what
/// the fast default, ROS2 steps on the tabulated gas, is checked against).
#[pyfunction]
#[pyo3(signature = (vehicle, road, drive, suspension, dt_s, ambient_k, max_dt_s=1e-3, record_every=1, t_gas_sensor_tau_s=1.0, progress=None, reference_plant=false))]
#[allow(clippy::too_many_arguments)]
pub fn vehicle_run<'py>(
    py: Python<'py>,
    vehicle: &Bound<'py, PyAny>,
    road: &Bound<'py, PyAny>,
    drive: &Bound<'py, PyAny>,
    suspension: &Bound<'py, PyAny>,
    dt_s: f64,
    ambient_k: f64,
    max_dt_s: f64,
    record_every: usize,
    t_gas_sensor_tau_s: f64,
    progress: Option<Py<PyAny>>,
    reference_plant: bool,
) -> PyResult<Bound<'py, PyDict>> {
    guard(|| {
        let mut case = VehicleCase::from_py(vehicle, road, drive, suspension, dt_s, ambient_k, max_dt_s, record_every, t_gas_sensor_tau_s)?;
        case.reference_plant = reference_plant;
        let total = case.drivers.len();
        let result = detached_with_progress(py, total, progress, |tick| case.run(tick))?;
        case.to_dict(py, result.map_err(to_py)?)
    })
}

/// Runs many vehicle runs in parallel on `threads` threads (all cores when
/// None). Each case is a dict with the arguments of `vehicle_run`
/// (`max_dt_s`, `record_every`, `t_gas_sensor_tau_s` optional). Returns, per
/// case, its result dict or the exception it raised.
#[pyfunction]
#[pyo3(signature = (cases, threads=None))]
pub fn vehicle_run_many<'py>(py: Python<'py>, cases: &Bound<'py, PyAny>, threads: Option<&Bound<'py, PyAny>>) -> PyResult<Bound<'py, PyList>> {
    guard(|| {
        let threads = threads_arg(threads)?;
        let specs = parse_cases(cases, |r, path| {
            let opt_f64 = |r: &mut Reader<'_>, key: &str, default: f64| -> PyResult<f64> {
                match r.get_opt(key)? {
                    Some(v) => extract(&v, &format!("{path}.{key}"), "a number"),
                    None => Ok(default),
                }
            };
            let max_dt_s = opt_f64(r, "max_dt_s", 1e-3)?;
            let tau = opt_f64(r, "t_gas_sensor_tau_s", Sensors::default().t_gas_tau_s)?;
            let record_every = match r.get_opt("record_every")? {
                Some(v) => extract(&v, &format!("{path}.record_every"), "a positive int")?,
                None => 1,
            };
            VehicleCase::from_py(
                &r.get("vehicle")?,
                &r.get("road")?,
                &r.get("drive")?,
                &r.get("suspension")?,
                r.f64("dt_s")?,
                r.f64("ambient_k")?,
                max_dt_s,
                record_every,
                tau,
            )
        })?;
        run_parallel(py, &specs, threads, |c| c.run(|_| true), |c, r| c.to_dict(py, r))
    })
}

// ----------------------------------------------------------- stepping

/// A vehicle on a road, advanced by `step` one control period at a time
/// with valve commands per wheel: the plant of a processor-in-the-loop
/// test. Samples are dicts: the vehicle channels as floats, the wheel
/// channels as lists (one value per wheel, front axle first, left first).
#[pyclass(module = "hpctl._core")]
pub struct VehiclePlant {
    vehicle: Vehicle,
    road: RoadSpec,
    state: VehicleState,
    drive: DriveInputs,
    valves: [Valves; MAX_CORNERS],
    time_s: f64,
    max_dt_s: f64,
    /// What ROS2 keeps between steps, as in the drive loop (`vehicle_run`),
    /// so that both step the same plant.
    memory: StepMemory,
}

impl VehiclePlant {
    fn sample_now(&self) -> Result<VehicleSample, hp_core::Error> {
        let road = self.road.road();
        let mut s = VehicleSample::default();
        self.vehicle.dynamics(&road, self.drive, self.valves).rate_and_sample(self.time_s, &self.state, &mut s)?;
        Ok(s)
    }

    fn to_dict<'py>(&self, py: Python<'py>, s: &VehicleSample) -> PyResult<Bound<'py, PyDict>> {
        let d = PyDict::new(py);
        for (name, f) in GLOBAL.iter() {
            d.set_item(name, f(s))?;
        }
        let n = self.vehicle.corner_count();
        for (name, f) in CORNER.iter() {
            d.set_item(name, s.corners.iter().take(n).map(f).collect::<Vec<f64>>())?;
        }
        Ok(d)
    }

    fn valves_from(&self, valve5_open: Vec<bool>, valve6_open: Vec<bool>) -> PyResult<[Valves; MAX_CORNERS]> {
        let n = self.vehicle.corner_count();
        if valve5_open.len() != n || valve6_open.len() != n {
            return Err(parameter(format!(
                "valve5_open has {} and valve6_open {} values; the vehicle has {n} wheels",
                valve5_open.len(),
                valve6_open.len()
            )));
        }
        let mut v = [Valves::default(); MAX_CORNERS];
        for ((o, a), b) in v.iter_mut().zip(valve5_open).zip(valve6_open) {
            *o = Valves { valve5_open: a, valve6_open: b };
        }
        Ok(v)
    }
}

#[pymethods]
impl VehiclePlant {
    /// Puts `vehicle` on `road` at rest in static equilibrium at
    /// `ambient_k`, every wheel's valves as given (the default, both
    /// closed, is the controller's power-on safe state). `max_dt_s` bounds
    /// the integration step inside each `step`. `corner_units` replaces
    /// single wheels' units (`{wheel index: unit dict}`, e.g. one unit with
    /// a gas leak); the others keep their axle's.
    #[new]
    #[pyo3(signature = (vehicle, road, ambient_k, spring_hard=true, damper_on=true, max_dt_s=1e-3, corner_units=None))]
    #[allow(clippy::too_many_arguments)]
    fn new(
        vehicle: &Bound<'_, PyAny>,
        road: &Bound<'_, PyAny>,
        ambient_k: f64,
        spring_hard: bool,
        damper_on: bool,
        max_dt_s: f64,
        corner_units: Option<&Bound<'_, PyAny>>,
    ) -> PyResult<Self> {
        guard(|| {
            hp_core::error::check_range("max_dt_s", max_dt_s, 1e-9, 10.0).map_err(to_py)?;
            let initial = Valves::from_modes(spring_hard, damper_on);
            let mut vehicle = Vehicle::new(vehicle_params(vehicle)?, ambient_k, initial).map_err(to_py)?;
            if let Some(units) = corner_units {
                let units = units.cast::<PyDict>().map_err(|_| parameter("corner_units must be a dict {wheel index: unit dict}"))?;
                for (key, unit) in units.iter() {
                    let i: usize = extract(&key, "corner_units key", "a wheel index (int >= 0)")?;
                    if i >= vehicle.corner_count() {
                        return Err(parameter(format!("corner_units has wheel {i}; the vehicle has wheels 0 to {}", vehicle.corner_count() - 1)));
                    }
                    vehicle = vehicle.with_corner_unit(i, params::unit(&unit)?, initial).map_err(to_py)?;
                }
            }
            let valves = [initial; MAX_CORNERS];
            let state = vehicle.initial_state(&valves).map_err(to_py)?;
            Ok(VehiclePlant { vehicle, road: road_spec(road)?, state, drive: DriveInputs::default(), valves, time_s: 0.0, max_dt_s, memory: StepMemory::new() })
        })
    }

    /// Number of wheels.
    #[getter]
    fn corner_count(&self) -> usize {
        self.vehicle.corner_count()
    }

    /// Simulated time, s.
    #[getter]
    fn time_s(&self) -> f64 {
        self.time_s
    }

    /// The observed quantities now.
    fn sample<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        guard(|| self.to_dict(py, &self.sample_now().map_err(to_py)?))
    }

    /// Holds the driver's inputs and each wheel's valves (lists, one per
    /// wheel) over `dt_s`, advances and returns the sample at the new time.
    #[allow(clippy::too_many_arguments)]
    #[pyo3(signature = (dt_s, valve5_open, valve6_open, speed_m_s, long_acc_m_s2=0.0, steer_angle_rad=0.0))]
    fn step<'py>(
        &mut self,
        py: Python<'py>,
        dt_s: f64,
        valve5_open: Vec<bool>,
        valve6_open: Vec<bool>,
        speed_m_s: f64,
        long_acc_m_s2: f64,
        steer_angle_rad: f64,
    ) -> PyResult<Bound<'py, PyDict>> {
        guard(|| {
            hp_core::error::check_range("dt_s", dt_s, 1e-9, 10.0).map_err(to_py)?;
            for (name, x) in [("speed_m_s", speed_m_s), ("long_acc_m_s2", long_acc_m_s2), ("steer_angle_rad", steer_angle_rad)] {
                hp_core::error::check_range(name, x, -1e3, 1e3).map_err(to_py)?;
            }
            self.valves = self.valves_from(valve5_open, valve6_open)?;
            self.drive = DriveInputs { speed_m_s, long_acc_m_s2, steer_angle_rad };
            let road = self.road.road();
            let d = self.vehicle.dynamics(&road, self.drive, self.valves);
            let t = self.time_s;
            let memory = &mut self.memory;
            let next = d.rate_for(t, &self.state, None, memory).and_then(|rate| d.advance_with(t, t + dt_s, &self.state, &rate, self.max_dt_s, memory));
            self.state = next.map_err(to_py)?;
            self.time_s = t + dt_s;
            self.to_dict(py, &self.sample_now().map_err(to_py)?)
        })
    }
}

/// Registers the vehicle functions, the plant class and the channel names.
pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_function(wrap_pyfunction!(vehicle_presets, m)?)?;
    m.add_function(wrap_pyfunction!(vehicle_controller_config, m)?)?;
    m.add_function(wrap_pyfunction!(vehicle_statics, m)?)?;
    m.add_function(wrap_pyfunction!(vehicle_run, m)?)?;
    m.add_function(wrap_pyfunction!(vehicle_run_many, m)?)?;
    m.add_class::<VehiclePlant>()?;
    m.add("VEHICLE_CHANNELS", GLOBAL.iter().map(|c| c.0).collect::<Vec<_>>())?;
    m.add("VEHICLE_CORNER_CHANNELS", CORNER.iter().map(|c| c.0).collect::<Vec<_>>())?;
    m.add("VEHICLE_CONTROLLER_CHANNELS", CONTROLLER.iter().map(|c| c.0).collect::<Vec<_>>())?;
    Ok(())
}

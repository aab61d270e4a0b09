//! Long drives for the gas-charge detector: one corner's unit on an SDOF
//! rig in closed loop with the production corner controller
//! (`hp_vehicle::closed_loop`), and the ECU's gas-charge detector
//! (`hp_ctrl::gas_charge`) on the same samples the vehicle step gives it.
//! Many drives run in parallel; each returns one record per `record_dt_s`.

use crate::errors::{bad_argument, guard, parameter};
use crate::exec::{run_parallel, threads_arg};
use crate::params::{self, MotionSpec, Reader};
use hp_core::rig::{Rig, RigKind};
use hp_core::unit::{Unit, Valves};
use hp_vehicle::closed_loop::{Period, Sensors, VehicleSignals};
use hp_ctrl::gas_charge::{self, GasChargeConfig, GasChargeParams, GasChargeState};
use hp_ctrl::{diag, Params, State};
use numpy::IntoPyArray;
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyList};

/// One drive, fully owned so it can run on another thread.
struct Drive {
    unit: hp_core::unit::UnitParams,
    sprung_mass_kg: f64,
    ambient_k: f64,
    base: MotionSpec,
    /// Piecewise-constant scenario: from `start_s[i]` on, `speed_m_s[i]`
    /// and `ride_height_request_m[i]`.
    start_s: Vec<f64>,
    speed_m_s: Vec<f64>,
    request_m: Vec<f64>,
    periods: usize,
    record_every: usize,
    gas: GasChargeConfig,
    max_dt_s: f64,
    sensors: Sensors,
    /// The plant's gas evaluated by the direct equation of state (the
    /// reference) rather than the tabulated one (fast).
    reference_plant: bool,
}

/// Per record: the detector's verdict at its end, the plant's gas and oil
/// temperatures, what the controller did over the record.
#[derive(Default)]
struct Record {
    time_s: Vec<f64>,
    charge_ratio: Vec<f64>,
    confidence: Vec<f64>,
    settled: Vec<bool>,
    fault: Vec<bool>,
    t_gas_k: Vec<f64>,
    t_gas2_k: Vec<f64>,
    t_gas_read_k: Vec<f64>,
    t_oil_k: Vec<f64>,
    disp_m: Vec<f64>,
    p_gas_pa: Vec<f64>,
    /// The gas volumes of S and L (their sum against the strut's
    /// `V_S0 + V_L0 - A x` shows a void in the strut).
    v_gas_m3: Vec<f64>,
    v_gas2_m3: Vec<f64>,
    /// The plant's vapour void in the strut (the oil balance's third
    /// term: gas volumes plus void are `V_S0 + V_L0 - A x`).
    v_void_m3: Vec<f64>,
    /// Mean of the record's samples of the charge ratio (what one period
    /// gives the detector), NaN if the record had none.
    sample_ratio: Vec<f64>,
    speed_m_s: Vec<f64>,
    /// Share of the record's periods with a usable sample.
    sampled: Vec<f64>,
    /// Share of the record's periods with valve 6 open.
    valve6_open: Vec<f64>,
    /// Share of the record's periods in the safe state.
    safe: Vec<f64>,
}

/// Control period, s (the ECU's).
const DT_S: f64 = 1e-3;

fn gas_config(obj: Option<Bound<'_, PyAny>>, path: &str) -> PyResult<GasChargeConfig> {
    let mut c = GasChargeConfig::default();
    if let Some(obj) = obj.filter(|o| !o.is_none()) {
        let mut r = Reader::new(&obj, path)?;
        let fields: [(&str, &mut f64); 7] = [
            ("tau_s", &mut c.tau_s),
            ("settle_s", &mut c.settle_s),
            ("loss_threshold", &mut c.loss_threshold),
            ("loss_hysteresis", &mut c.loss_hysteresis),
            ("confirm_s", &mut c.confirm_s),
            ("loss_significant", &mut c.loss_significant),
            ("healthy_sigma", &mut c.healthy_sigma),
        ];
        for (name, field) in fields {
            if r.get_opt(name)?.is_some() {
                *field = r.f64(name)?;
            }
        }
        r.finish()?;
    }
    c.validate().map_err(|e| parameter(format!("{path}: {e}")))?;
    Ok(c)
}

impl Drive {
    fn from_py(obj: &Bound<'_, PyAny>, path: &str) -> PyResult<Self> {
        let mut r = Reader::new(obj, path)?;
        let unit = params::unit(&r.get("unit")?)?;
        let sprung_mass_kg = r.f64("sprung_mass_kg")?;
        let ambient_k = r.f64("ambient_k")?;
        let base = params::motion(&r.get("base")?, &format!("{path}.base"))?;
        let mut seg = r.sub("segments")?;
        let (start_s, speed_m_s, request_m) = (seg.vec("start_s")?, seg.vec("speed_m_s")?, seg.vec("ride_height_request_m")?);
        seg.finish()?;
        if start_s.is_empty() || start_s.len() != speed_m_s.len() || start_s.len() != request_m.len() {
            return Err(parameter(format!("{path}.segments: start_s, speed_m_s and ride_height_request_m must be equally long, not empty")));
        }
        if start_s.windows(2).any(|w| !matches!(w, [a, b] if a < b)) || start_s.iter().chain(&speed_m_s).chain(&request_m).any(|x| !x.is_finite()) {
            return Err(parameter(format!("{path}.segments: finite values, start_s strictly increasing")));
        }
        let duration_s = r.f64("duration_s")?;
        let record_dt_s = match r.get_opt("record_dt_s")? {
            Some(_) => r.f64("record_dt_s")?,
            None => 1.0,
        };
        let max_dt_s = match r.get_opt("max_dt_s")? {
            Some(_) => r.f64("max_dt_s")?,
            None => DT_S,
        };
        let t_gas_tau_s = match r.get_opt("t_gas_sensor_tau_s")? {
            Some(_) => r.f64("t_gas_sensor_tau_s")?,
            None => Sensors::default().t_gas_tau_s,
        };
        let t_gas_offset_k = match r.get_opt("t_gas_sensor_offset_k")? {
            Some(_) => r.f64("t_gas_sensor_offset_k")?,
            None => 0.0,
        };
        let gas = gas_config(r.get_opt("gas_charge")?, &format!("{path}.gas_charge"))?;
        let reference_plant = match r.get_opt("reference_plant")? {
            Some(v) => v.extract::<bool>().map_err(|_| bad_argument(&format!("{path}.reference_plant"), &v, "True or False"))?,
            None => false,
        };
        r.finish()?;
        for (name, v, lo, hi) in [("duration_s", duration_s, 1.0, 1e7), ("record_dt_s", record_dt_s, DT_S, 1e4), ("max_dt_s", max_dt_s, 1e-6, DT_S)] {
            if !(v.is_finite() && (lo..=hi).contains(&v)) {
                return Err(parameter(format!("{path}.{name} = {v} must be within [{lo}, {hi}]")));
            }
        }
        Ok(Drive {
            unit,
            sprung_mass_kg,
            ambient_k,
            base,
            start_s,
            speed_m_s,
            request_m,
            periods: (duration_s / DT_S).round() as usize,
            record_every: ((record_dt_s / DT_S).round() as usize).max(1),
            gas,
            max_dt_s,
            sensors: Sensors { t_gas_tau_s, t_gas_offset_k },
            reference_plant,
        })
    }

    fn run(&self) -> Result<Record, hp_core::Error> {
        let unit = Unit::new(self.unit)?;
        let kind = RigKind::Sdof { sprung_mass_kg: self.sprung_mass_kg, base: self.base.motion() };
        // Power-on: the controller's safe state, both valves closed.
        let rig = Rig::new(&unit, kind, self.ambient_k, Valves::default())?;
        // The ECU: the production corner controller; the detector knows the
        // unit the controller was calibrated for (the nominal charge).
        let params: &Params = hp_ctrl::calibration::SEED_4.corner();
        let gas = GasChargeParams::new(&self.gas, &params.config().unit);
        let mut gas_state = GasChargeState::new();
        let mut state = State::new();
        let mut out = Record::default();
        let (mut segment, mut sampled, mut open, mut safe, mut in_record) = (0usize, 0usize, 0usize, 0usize, 0usize);
        let mut sample_sum = 0.0_f64;
        let dt_us = (DT_S * 1e6).round() as u32;
        let vehicle_at = |_, t_s: f64| {
            while self.start_s.get(segment + 1).is_some_and(|&next| t_s >= next) {
                segment += 1;
            }
            let at = |v: &Vec<f64>| v.get(segment).copied().unwrap_or(0.0);
            VehicleSignals { speed_m_s: at(&self.speed_m_s), ride_height_request_m: at(&self.request_m), ..VehicleSignals::default() }
        };
        let on_period = |p: &Period<'_>| {
            let sample = gas.corner_sample(params.large_table(), p.inputs, p.outputs.diag);
            let verdict = gas_charge::step(&gas, &mut gas_state, sample, dt_us);
            sampled += usize::from(sample.is_some());
            sample_sum += sample.map_or(0.0, f64::from);
            open += usize::from(p.outputs.valve6_open);
            safe += usize::from(p.outputs.diag & diag::SAFE_STATE != 0);
            in_record += 1;
            if in_record == self.record_every {
                in_record = 0;
                let n = self.record_every as f64;
                let u = &p.sample.unit;
                out.time_s.push((p.index + 1) as f64 * DT_S);
                out.charge_ratio.push(f64::from(verdict.charge_ratio));
                out.confidence.push(f64::from(verdict.confidence));
                out.settled.push(verdict.settled);
                out.fault.push(verdict.fault);
                out.t_gas_k.push(u.t_gas_k);
                out.t_gas2_k.push(u.t_gas2_k);
                out.t_gas_read_k.push(p.inputs.t_gas_k);
                out.t_oil_k.push(u.t_oil_k);
                out.disp_m.push(p.sample.disp_m);
                out.p_gas_pa.push(u.p_gas_pa);
                out.v_gas_m3.push(p.sample.v_gas_m3);
                out.v_gas2_m3.push(p.sample.v_gas2_m3);
                out.v_void_m3.push(p.sample.v_void_m3);
                out.sample_ratio.push(if sampled > 0 { sample_sum / sampled as f64 } else { f64::NAN });
                out.speed_m_s.push(p.inputs.speed_m_s);
                out.sampled.push(sampled as f64 / n);
                out.valve6_open.push(open as f64 / n);
                out.safe.push(safe as f64 / n);
                (sampled, open, safe, sample_sum) = (0, 0, 0, 0.0);
            }
            true
        };
        // The fast plant evaluates the same gas through the process's
        // table (pressure within 1.3e-8 of the direct equation; the direct
        // equation if the table could not be built); the reference plant
        // evaluates the equation directly. Both step RK4 at `max_dt_s`.
        let rig = match hp_vehicle::gas_table::span() {
            Some(table) if !self.reference_plant && self.unit.gas == hp_core::gas::Gas::Span => rig.with_gas_table(table)?,
            _ => rig,
        };
        hp_vehicle::closed_loop::run(&rig, params, &self.sensors, &mut state, self.periods, DT_S, self.max_dt_s, vehicle_at, on_period)?;
        Ok(out)
    }
}

fn to_dict<'py>(py: Python<'py>, r: Record) -> PyResult<Bound<'py, PyDict>> {
    let d = PyDict::new(py);
    let floats = [
        ("time_s", r.time_s),
        ("charge_ratio", r.charge_ratio),
        ("confidence", r.confidence),
        ("t_gas_k", r.t_gas_k),
        ("t_gas2_k", r.t_gas2_k),
        ("t_gas_read_k", r.t_gas_read_k),
        ("t_oil_k", r.t_oil_k),
        ("disp_m", r.disp_m),
        ("p_gas_pa", r.p_gas_pa),
        ("v_gas_m3", r.v_gas_m3),
        ("v_gas2_m3", r.v_gas2_m3),
        ("v_void_m3", r.v_void_m3),
        ("sample_ratio", r.sample_ratio),
        ("speed_m_s", r.speed_m_s),
        ("sampled", r.sampled),
        ("valve6_open", r.valve6_open),
        ("safe", r.safe),
    ];
    for (name, column) in floats {
        d.set_item(name, column.into_pyarray(py))?;
    }
    d.set_item("settled", r.settled.into_pyarray(py))?;
    d.set_item("fault", r.fault.into_pyarray(py))?;
    Ok(d)
}

/// Runs gas-charge drives in parallel on `threads` threads (all cores when
/// None): per case a dict with `unit` (the plant's unit, e.g. under-charged
/// or with the leakage effect), `sprung_mass_kg`, `ambient_k`, `base` (a
/// motion dict, the road under the wheel), `segments` (arrays `start_s`,
/// `speed_m_s`, `ride_height_request_m`: from each start on, the vehicle's
/// speed and the driver's ride-height request), `duration_s`, and optional
/// `record_dt_s` (1 s), `gas_charge` (fields of the detector's
/// configuration; default the production one), `max_dt_s`,
/// `t_gas_sensor_tau_s` (1 s), `t_gas_sensor_offset_k` (0 K: the
/// temperature sensor's calibration error; a pressure transducers' offset
/// is the unit's sensor effect), `reference_plant` (False: the plant's
/// reference gas evaluated through its table, `hp_core::gas::table`,
/// about twice as fast a drive; True: by the direct equation). The controller and the detector are the
/// ECU's production ones for the seed unit. Returns, per case, a dict of
/// arrays (one value per record) or the exception the case raised.
#[pyfunction]
#[pyo3(signature = (cases, threads=None))]
pub fn gas_charge_drives<'py>(py: Python<'py>, cases: &Bound<'py, PyAny>, threads: Option<&Bound<'py, PyAny>>) -> PyResult<Bound<'py, PyList>> {
    guard(|| {
        let threads = threads_arg(threads)?;
        let cases = cases.cast::<PyList>().map_err(|_| bad_argument("cases", cases, "a list of drive dicts"))?;
        let drives = cases.iter().enumerate().map(|(i, c)| Drive::from_py(&c, &format!("cases[{i}]"))).collect::<PyResult<Vec<_>>>()?;
        run_parallel(py, &drives, threads, Drive::run, |_, r| to_dict(py, r))
    })
}

/// The production gas-charge detector's configuration, as a dict.
#[pyfunction]
pub fn gas_charge_config(py: Python<'_>) -> PyResult<Bound<'_, PyDict>> {
    let c = GasChargeConfig::default();
    let d = PyDict::new(py);
    for (k, v) in [
        ("tau_s", c.tau_s),
        ("settle_s", c.settle_s),
        ("loss_threshold", c.loss_threshold),
        ("loss_hysteresis", c.loss_hysteresis),
        ("confirm_s", c.confirm_s),
        ("loss_significant", c.loss_significant),
        ("healthy_sigma", c.healthy_sigma),
    ] {
        d.set_item(k, v)?;
    }
    Ok(d)
}

pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_function(wrap_pyfunction!(gas_charge_drives, m)?)?;
    m.add_function(wrap_pyfunction!(gas_charge_config, m)?)?;
    Ok(())
}

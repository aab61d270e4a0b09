//! Running the rigs from Python: one run, or many in parallel (rayon).

use crate::args::{extract, f64_array};
use crate::errors::{bad_argument, guard, parameter, to_py};
use crate::exec::{detached_with_progress, parse_cases, run_parallel, threads_arg};
use crate::params::{self, RigSpec};
use hp_core::gas::EquationOfState;
use hp_core::lag::{self, Lag, LagSample, LagState};
use hp_core::rig::{run_adaptive, run_with_lead, Adaptive, Rig, RigKind, RigSample, SampleDetail, Steps};
use hp_core::unit::{Unit, UnitParams, Valves};
use numpy::IntoPyArray;
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyList};

/// The output channels, in SI units, named as in rig records where a
/// record has the quantity.
pub const CHANNELS: [&str; 31] = [
    "time_s",
    "disp_m",
    "vel_m_s",
    "force_n",
    "force_true_n",
    "p_strut_pa",
    "p_gas_pa",
    "p_gas2_pa",
    "p_gas_true_pa",
    "p_gas2_true_pa",
    "t_gas_k",
    "t_gas2_k",
    "t_wall_k",
    "t_oil_k",
    "v_gas_m3",
    "v_gas2_m3",
    "damper_force_n",
    "damper_power_w",
    "friction_force_n",
    "flow_damper_m3_s",
    "flow_valve6_m3_s",
    "e_damper_j",
    "e_friction_j",
    "e_valve6_j",
    "body_disp_m",
    "body_vel_m_s",
    "body_acc_m_s2",
    "base_disp_m",
    "cavitating",
    "spring_hard",
    "damper_on",
];

/// The channels a sample gives from the integrated state alone, without
/// evaluating the unit (see [`SampleDetail::States`]).
const STATE_CHANNELS: [&str; 13] = [
    "time_s",
    "disp_m",
    "vel_m_s",
    "v_gas_m3",
    "v_gas2_m3",
    "e_damper_j",
    "e_friction_j",
    "e_valve6_j",
    "body_disp_m",
    "body_vel_m_s",
    "base_disp_m",
    "spring_hard",
    "damper_on",
];

/// Every channel's value, in the order of [`CHANNELS`].
pub fn channel_values(s: &RigSample) -> [f64; CHANNELS.len()] {
    let u = &s.unit;
    let flag = |b: bool| if b { 1.0 } else { 0.0 };
    [
        s.time_s,
        s.disp_m,
        s.vel_m_s,
        u.force_n,
        u.force_true_n,
        u.p_strut_pa,
        u.p_gas_pa,
        u.p_gas2_pa,
        u.p_gas_true_pa,
        u.p_gas2_true_pa,
        u.t_gas_k,
        u.t_gas2_k,
        u.t_wall_k,
        u.t_oil_k,
        s.v_gas_m3,
        s.v_gas2_m3,
        u.damper_force_n,
        u.damper_power_w,
        u.friction_force_n,
        u.flow_damper_m3_s,
        u.flow_valve6_m3_s,
        s.e_damper_j,
        s.e_friction_j,
        s.e_valve6_j,
        s.body_disp_m,
        s.body_vel_m_s,
        s.body_acc_m_s2,
        s.base_disp_m,
        flag(u.cavitating),
        flag(s.valves.spring_hard()),
        flag(s.valves.damper_on()),
    ]
}

/// One simulation, fully owned so it can run on another thread.
struct Case {
    unit: UnitParams,
    rig: RigSpec,
    times_s: Vec<f64>,
    dt_s: f64,
    ambient_k: f64,
    spring_hard: Vec<bool>,
    damper_on: Vec<bool>,
    channels: Vec<usize>,
    /// Relative tolerance of the adaptive integrator; `None`: fixed-step
    /// RK4 with steps of at most `dt_s` (with a tolerance, `dt_s` caps the
    /// adaptive step).
    rtol: Option<f64>,
    /// Adaptive only: replay these step ends (from a recorded run) instead
    /// of choosing steps.
    replay_steps_s: Option<Vec<f64>>,
    /// Adaptive only: return the step ends as `step_end_s`.
    record_steps: bool,
    /// Evaluate the reference gas through the process's table
    /// ([`hp_vehicle::gas_table::span`]: pressure within 1.3e-8 of the
    /// direct equation) instead of the equation itself; other gases, or a
    /// table that could not be built, are evaluated directly.
    gas_table: bool,
    /// Where between two outputs the valves switch (hp-core's
    /// `run_with_lead`): the fraction of the interval before the first
    /// output with the new valves; 0 at that output.
    switch_lead: f64,
}

/// What a run returns: the channels' columns and, when recorded, the step ends.
type RunOutput = (Vec<Vec<f64>>, Option<Vec<f64>>);

fn bools(obj: &Bound<'_, PyAny>, name: &str, n: usize) -> PyResult<Vec<bool>> {
    let v: Vec<bool> = if let Ok(b) = obj.extract::<bool>() {
        vec![b]
    } else {
        obj.extract::<Vec<bool>>().map_err(|_| parameter(format!("{name} must be a bool or a sequence of bools")))?
    };
    if v.len() == 1 || v.len() == n {
        Ok(v)
    } else {
        Err(parameter(format!("{name} has {} values; expected 1 or one per output time ({n})", v.len())))
    }
}

fn channel_indices(channels: Option<Vec<String>>) -> PyResult<Vec<usize>> {
    match channels {
        None => Ok((0..CHANNELS.len()).collect()),
        Some(names) => names
            .iter()
            .map(|n| {
                CHANNELS.iter().position(|c| c == n).ok_or_else(|| {
                    parameter(format!("unknown channel {n:?} (known: {})", CHANNELS.join(", ")))
                })
            })
            .collect(),
    }
}

impl Case {
    #[allow(clippy::too_many_arguments)]
    fn from_py(
        unit: &Bound<'_, PyAny>,
        rig: &Bound<'_, PyAny>,
        times_s: Vec<f64>,
        dt_s: f64,
        ambient_k: f64,
        spring_hard: &Bound<'_, PyAny>,
        damper_on: &Bound<'_, PyAny>,
        channels: Option<Vec<String>>,
        rtol: Option<f64>,
        replay_steps_s: Option<Vec<f64>>,
        record_steps: bool,
        gas_table: bool,
        switch_lead: f64,
    ) -> PyResult<Case> {
        if times_s.is_empty() {
            return Err(parameter("times_s is empty; expected at least one output time"));
        }
        if rtol.is_none() && (replay_steps_s.is_some() || record_steps) {
            return Err(parameter("steps_s and record_steps need the adaptive integrator (rtol given)"));
        }
        let n = times_s.len();
        Ok(Case {
            rtol,
            replay_steps_s,
            record_steps,
            gas_table,
            switch_lead,
            unit: params::unit(unit)?,
            rig: params::rig(rig)?,
            times_s,
            dt_s,
            ambient_k,
            spring_hard: bools(spring_hard, "spring_hard", n)?,
            damper_on: bools(damper_on, "damper_on", n)?,
            channels: channel_indices(channels)?,
        })
    }

    /// Runs the case; `tick(index)` is called for every sample and may
    /// stop the run by returning false.
    fn run(&self, mut tick: impl FnMut(usize) -> bool) -> Result<RunOutput, hp_core::Error> {
        let unit = Unit::new(self.unit)?;
        let kind = match &self.rig {
            RigSpec::Characterisation { strut } => RigKind::Characterisation { strut: strut.motion() },
            RigSpec::Sdof { sprung_mass_kg, base } => RigKind::Sdof { sprung_mass_kg: *sprung_mass_kg, base: base.motion() },
        };
        let at = |v: &[bool], i: usize| v.get(i).or(v.first()).copied().unwrap_or(false);
        let valves_at = |i: usize| Valves::from_modes(at(&self.spring_hard, i), at(&self.damper_on, i));
        let rig = Rig::new(&unit, kind, self.ambient_k, valves_at(0))?;
        let rig = match hp_vehicle::gas_table::span() {
            Some(table) if self.gas_table && self.unit.gas == hp_core::gas::Gas::Span => rig.with_gas_table(table)?,
            _ => rig,
        };
        let mut out: Vec<Vec<f64>> = self.channels.iter().map(|_| Vec::with_capacity(self.times_s.len())).collect();
        let on_sample = |i: usize, s: &RigSample| {
            let values = channel_values(s);
            for (column, &c) in out.iter_mut().zip(&self.channels) {
                column.push(values.get(c).copied().unwrap_or(f64::NAN));
            }
            tick(i)
        };
        let mut ends: Vec<f64> = Vec::new();
        match self.rtol {
            None => run_with_lead(&rig, self.times_s.iter().copied(), self.dt_s, self.switch_lead, |i, _| valves_at(i), on_sample)?,
            Some(rtol) => {
                let states_only =
                    self.channels.iter().all(|&c| CHANNELS.get(c).is_some_and(|name| STATE_CHANNELS.contains(name)));
                let detail = if states_only { SampleDetail::States } else { SampleDetail::Full };
                let settings = Adaptive { rtol, max_dt_s: self.dt_s, switch_lead: self.switch_lead };
                let mut record = |t: f64| ends.push(t);
                let steps = match (&self.replay_steps_s, self.record_steps) {
                    (Some(replay), _) => Steps::Replay(replay),
                    (None, true) => Steps::Record(&mut record),
                    (None, false) => Steps::Controlled,
                };
                run_adaptive(&rig, &self.times_s, settings, detail, steps, |i, _| valves_at(i), on_sample)?;
            }
        }
        Ok((out, if self.record_steps { Some(ends) } else { None }))
    }

    fn to_dict<'py>(&self, py: Python<'py>, (columns, ends): RunOutput) -> PyResult<Bound<'py, PyDict>> {
        let d = PyDict::new(py);
        for (column, &c) in columns.into_iter().zip(&self.channels) {
            d.set_item(CHANNELS.get(c).copied().unwrap_or("?"), column.into_pyarray(py))?;
        }
        if let Some(ends) = ends {
            d.set_item("step_end_s", ends.into_pyarray(py))?;
        }
        Ok(d)
    }
}

/// Runs one rig simulation and returns its channels as numpy arrays.
///
/// With `rtol` the steps are error-controlled (relative tolerance `rtol`,
/// at most `dt_s` long, which may be infinite) and the samples come from
/// the dense output; without, fixed RK4 steps of at most `dt_s` land on
/// every output time. `record_steps` adds the adaptive steps' end times as
/// `step_end_s`; `steps_s` replays such a list without error control (a
/// run whose steps do not move when a parameter does, for
/// finite-difference derivatives). `gas_table` evaluates the reference gas
/// through the process's table (pressure within 1.3e-8 of the equation,
/// several times cheaper; other gases directly). `switch_lead` places
/// each valve switch that fraction of the interval before the first output
/// with the new valves (0: at it; 0.5: midway, for a record's logged
/// valve states), in [0, 1).
///
/// `progress(done, total)` is called about ten times a second from the
/// simulation thread; the GIL is released otherwise. Ctrl-C stops the run.
#[pyfunction]
#[pyo3(signature = (unit, rig, times_s, dt_s, ambient_k, spring_hard, damper_on, channels=None, progress=None, rtol=None, steps_s=None, record_steps=false, gas_table=false, switch_lead=0.0))]
#[allow(clippy::too_many_arguments)]
pub fn simulate<'py>(
    py: Python<'py>,
    unit: &Bound<'py, PyAny>,
    rig: &Bound<'py, PyAny>,
    times_s: &Bound<'py, PyAny>,
    dt_s: f64,
    ambient_k: f64,
    spring_hard: &Bound<'py, PyAny>,
    damper_on: &Bound<'py, PyAny>,
    channels: Option<Vec<String>>,
    progress: Option<Py<PyAny>>,
    rtol: Option<f64>,
    steps_s: Option<Vec<f64>>,
    record_steps: bool,
    gas_table: bool,
    switch_lead: f64,
) -> PyResult<Bound<'py, PyDict>> {
    guard(|| {
        let times = f64_array(times_s, "times_s")?;
        let case = Case::from_py(unit, rig, times, dt_s, ambient_k, spring_hard, damper_on, channels, rtol, steps_s, record_steps, gas_table, switch_lead)?;
        let total = case.times_s.len();
        let result = detached_with_progress(py, total, progress, |tick| case.run(tick))?;
        let columns = result.map_err(to_py)?;
        case.to_dict(py, columns)
    })
}

/// Runs many simulations in parallel on `threads` threads (all cores when
/// None). Each case is a dict with the arguments of `simulate` (`times_s`
/// as a sequence). Returns, per case, either its dict of arrays or the
/// exception that case raised, so one bad case does not lose the others.
#[pyfunction]
#[pyo3(signature = (cases, threads=None))]
pub fn simulate_many<'py>(py: Python<'py>, cases: &Bound<'py, PyAny>, threads: Option<&Bound<'py, PyAny>>) -> PyResult<Bound<'py, PyList>> {
    guard(|| {
        let threads = threads_arg(threads)?;
        let specs = parse_cases(cases, |r, path| {
            let spring_hard = r.get("spring_hard")?;
            let damper_on = r.get("damper_on")?;
            let channels = match r.get_opt("channels")? {
                Some(v) => Some(extract(&v, &format!("{path}.channels"), "a list of channel names")?),
                None => None,
            };
            let rtol = match r.get_opt("rtol")? {
                Some(v) => Some(extract(&v, &format!("{path}.rtol"), "a number or None")?),
                None => None,
            };
            let steps = if r.get_opt("steps_s")?.is_some() { Some(r.vec("steps_s")?) } else { None };
            let record = match r.get_opt("record_steps")? {
                Some(v) => extract(&v, &format!("{path}.record_steps"), "a bool")?,
                None => false,
            };
            let gas_table = match r.get_opt("gas_table")? {
                Some(v) => extract(&v, &format!("{path}.gas_table"), "a bool")?,
                None => false,
            };
            let switch_lead = match r.get_opt("switch_lead")? {
                Some(v) => extract(&v, &format!("{path}.switch_lead"), "a number")?,
                None => 0.0,
            };
            Case::from_py(
                &r.get("unit")?,
                &r.get("rig")?,
                r.vec("times_s")?,
                r.f64("dt_s")?,
                r.f64("ambient_k")?,
                &spring_hard,
                &damper_on,
                channels,
                rtol,
                steps,
                record,
                gas_table,
                switch_lead,
            )
        })?;
        run_parallel(py, &specs, threads, |c| c.run(|_| true), |c, r| c.to_dict(py, r))
    })
}

/// The transducers' first-order lag ([`hp_core::lag`]) applied to the
/// samples `values` at `times_s`, exact for a signal linear between
/// samples: what a transducer of time constant `time_constant_s` reports.
/// It starts settled at `rest` (the value at rest before the motion;
/// `values[0]` when None), as the unit's sensor state does.
#[pyfunction]
#[pyo3(signature = (times_s, values, time_constant_s, rest=None))]
pub fn sensor_lag<'py>(
    py: Python<'py>,
    times_s: &Bound<'py, PyAny>,
    values: &Bound<'py, PyAny>,
    time_constant_s: f64,
    rest: Option<f64>,
) -> PyResult<Bound<'py, numpy::PyArray1<f64>>> {
    guard(|| {
        let times = f64_array(times_s, "times_s")?;
        let x = f64_array(values, "values")?;
        if times.len() != x.len() {
            return Err(parameter(format!("values has {} samples; expected one per time in times_s ({})", x.len(), times.len())));
        }
        let lag = Lag { time_constant_s: hp_core::lag::TIME_CONSTANT_S.check(time_constant_s).map_err(to_py)? };
        for (i, w) in times.windows(2).enumerate() {
            if let [t0, t1] = *w {
                if t1 <= t0 || !t1.is_finite() || !t0.is_finite() {
                    return Err(parameter(format!("times_s[{}] = {t1} after {t0}: expected finite, increasing times", i + 1)));
                }
            }
        }
        if let Some(r) = rest.filter(|r| !r.is_finite()) {
            return Err(parameter(format!("rest = {r}: expected a finite number")));
        }
        let mut state = LagState::settled(rest.or(x.first().copied()).unwrap_or(0.0));
        let mut out = Vec::with_capacity(x.len());
        out.extend(x.first().map(|_| state.output));
        for (t, v) in times.windows(2).zip(x.windows(2)) {
            if let (&[t0, t1], &[x0, x1]) = (t, v) {
                out.push(lag::step(&lag, &mut state, &LagSample { input_prev: x0, input: x1, dt_s: t1 - t0 }));
            }
        }
        Ok(out.into_pyarray(py))
    })
}

fn valves(spring_hard: bool, damper_on: bool) -> Valves {
    Valves::from_modes(spring_hard, damper_on)
}

/// Static strut force at rest at compression `disp_m` with the gas at
/// `t_k`, N.
#[pyfunction]
pub fn static_force_n(unit: &Bound<'_, PyAny>, disp_m: f64, t_k: f64, spring_hard: bool) -> PyResult<f64> {
    guard(|| {
        let unit = Unit::new(params::unit(unit)?).map_err(to_py)?;
        unit.static_force_n(disp_m, t_k, valves(spring_hard, true)).map_err(to_py)
    })
}

/// The damper's signed pressure drop, strut minus accumulator S, Pa, at
/// each signed flow out of the strut `q_m3_s` (compression positive), with
/// valve 5 open by the fraction `bypass_open` (0 = closed = the damper on):
/// hp-core's `Damper::pressure_drop_pa`, for fitting a curve to measured
/// force and pressure without running the model
/// (`hpctl.identify.damper_start`).
#[pyfunction]
#[pyo3(signature = (damper, q_m3_s, bypass_open))]
pub fn damper_pressure_drop_pa<'py>(
    py: Python<'py>,
    damper: &Bound<'py, PyAny>,
    q_m3_s: &Bound<'py, PyAny>,
    bypass_open: f64,
) -> PyResult<Bound<'py, numpy::PyArray1<f64>>> {
    guard(|| {
        let d = params::damper(damper, "damper")?;
        d.validate().map_err(to_py)?;
        if !(0.0..=1.0).contains(&bypass_open) {
            return Err(parameter(format!("bypass_open = {bypass_open}: expected a fraction in [0, 1]")));
        }
        let q = f64_array(q_m3_s, "q_m3_s")?;
        if let Some((i, v)) = q.iter().enumerate().find(|(_, v)| !v.is_finite()) {
            return Err(parameter(format!("q_m3_s[{i}] = {v}: expected finite flows, m^3/s")));
        }
        // Without the GIL: the static damper fits of a diagnosis's
        // candidates run in threads, and this loop (a Newton inversion per
        // sample, about 20 ns each) is the part of their work that can
        // overlap another thread's Python.
        let d = hp_core::damper::PreparedDamper::new(&d);
        Ok(py.detach(|| q.iter().map(|&qi| d.pressure_drop_pa(qi, bypass_open)).collect::<Vec<f64>>()))
    })
    .map(|dp| dp.into_pyarray(py))
}

/// The unit's seal friction force, N, at each strut velocity `vel_m_s`
/// (compression positive): hp-core's `Friction::force_n`, zero for a unit
/// without friction. For Jacobian columns of friction parameters on
/// records whose motion is prescribed (`hpctl.identify.output_only`).
#[pyfunction]
pub fn friction_force_n<'py>(py: Python<'py>, unit: &Bound<'py, PyAny>, vel_m_s: &Bound<'py, PyAny>) -> PyResult<Bound<'py, numpy::PyArray1<f64>>> {
    guard(|| {
        let unit = Unit::new(params::unit(unit)?).map_err(to_py)?;
        let v = f64_array(vel_m_s, "vel_m_s")?;
        if let Some((i, x)) = v.iter().enumerate().find(|(_, x)| !x.is_finite()) {
            return Err(parameter(format!("vel_m_s[{i}] = {x}: expected finite velocities, m/s")));
        }
        let force: Vec<f64> = match unit.params().effects.friction {
            Some(f) => v.iter().map(|&x| f.force_n(x)).collect(),
            None => vec![0.0; v.len()],
        };
        Ok(force)
    })
    .map(|f| f.into_pyarray(py))
}

/// The gas pressure that carries `load_n` at rest, Pa.
#[pyfunction]
pub fn load_pressure_pa(unit: &Bound<'_, PyAny>, load_n: f64) -> PyResult<f64> {
    guard(|| Unit::new(params::unit(unit)?).map_err(to_py)?.load_pressure_pa(load_n).map_err(to_py))
}

/// Strut compression at which the unit carries `load_n` at rest with the
/// gas at `t_k`, m.
#[pyfunction]
pub fn static_disp_for_load_m(unit: &Bound<'_, PyAny>, load_n: f64, t_k: f64, spring_hard: bool) -> PyResult<f64> {
    guard(|| {
        let unit = Unit::new(params::unit(unit)?).map_err(to_py)?;
        unit.static_disp_for_load_m(load_n, t_k, valves(spring_hard, true)).map_err(to_py)
    })
}

/// Gas masses in S and L of a unit, kg.
#[pyfunction]
pub fn gas_masses_kg(unit: &Bound<'_, PyAny>) -> PyResult<(f64, f64)> {
    guard(|| Ok(Unit::new(params::unit(unit)?).map_err(to_py)?.gas_masses_kg()))
}

/// Equation-of-state properties at arrays of density and temperature:
/// `p_pa`, `dp_dt_pa_per_k`, `dp_drho_pa_m3_per_kg`, `cv_j_per_kg_k`.
/// Densities and temperatures outside the ranges the models are evaluated
/// on (`hp_core::gas`) raise `ParameterError` naming the first bad element.
#[pyfunction]
pub fn gas_props<'py>(
    py: Python<'py>,
    gas: &str,
    rho_kg_m3: &Bound<'py, PyAny>,
    t_k: &Bound<'py, PyAny>,
) -> PyResult<Bound<'py, PyDict>> {
    use hp_core::gas::{DENSITY_RANGE_KG_M3, TEMPERATURE_RANGE_K};
    guard(|| {
        let g = params::gas(gas)?;
        let (rho, t) = (f64_array(rho_kg_m3, "rho_kg_m3")?, f64_array(t_k, "t_k")?);
        if rho.len() != t.len() {
            return Err(parameter(format!("rho_kg_m3 has {} values but t_k has {}", rho.len(), t.len())));
        }
        for (name, values, (min, max)) in [("rho_kg_m3", &rho, DENSITY_RANGE_KG_M3), ("t_k", &t, TEMPERATURE_RANGE_K)] {
            if let Some((i, &v)) = values.iter().enumerate().find(|(_, &v)| !(v.is_finite() && v >= min && v <= max)) {
                let element = format!("{name}[{i}]");
                return Err(bad_argument(&element, &v.into_pyobject(py)?.into_any(), &format!("a number within [{min}, {max}]")));
            }
        }
        let props: Vec<_> = rho.iter().zip(t.iter()).map(|(&r, &tk)| g.props(r, tk)).collect();
        let d = PyDict::new(py);
        d.set_item("p_pa", props.iter().map(|p| p.p_pa).collect::<Vec<_>>().into_pyarray(py))?;
        d.set_item("dp_dt_pa_per_k", props.iter().map(|p| p.dp_dt_pa_per_k).collect::<Vec<_>>().into_pyarray(py))?;
        d.set_item("dp_drho_pa_m3_per_kg", props.iter().map(|p| p.dp_drho_pa_m3_per_kg).collect::<Vec<_>>().into_pyarray(py))?;
        d.set_item("cv_j_per_kg_k", props.iter().map(|p| p.cv_j_per_kg_k).collect::<Vec<_>>().into_pyarray(py))?;
        Ok(d)
    })
}

/// Where the gas model `gas` has been validated against the reference
/// (`hp_core::gas::validated_range`): `{"pressure_pa": (min, max),
/// "temperature_k": (min, max)}`. A simulated state outside it is not
/// wrong by construction, but unchecked: the front ends warn.
#[pyfunction]
pub fn gas_validated_range<'py>(py: Python<'py>, gas: &str) -> PyResult<Bound<'py, PyDict>> {
    guard(|| {
        let r = hp_core::gas::validated_range(params::gas(gas)?);
        let d = PyDict::new(py);
        d.set_item("pressure_pa", r.pressure_pa)?;
        d.set_item("temperature_k", r.temperature_k)?;
        Ok(d)
    })
}

/// Density at pressure `p_pa` and temperature `t_k`, kg/m^3.
#[pyfunction]
pub fn gas_density_kg_m3(gas: &str, p_pa: f64, t_k: f64) -> PyResult<f64> {
    guard(|| params::gas(gas)?.density_kg_m3(p_pa, t_k).map_err(to_py))
}

/// The built-in unit standing for the seed's (see hp-core's presets).
#[pyfunction]
pub fn seed_unit(py: Python<'_>) -> PyResult<Bound<'_, PyDict>> {
    guard(|| params::unit_to_dict(py, &hp_core::presets::seed_unit()))
}

/// The seed's lumped oil and gas-wall nodes for heat build-up.
#[pyfunction]
pub fn seed_oil_node(py: Python<'_>) -> PyResult<Bound<'_, PyDict>> {
    guard(|| {
        let n = hp_core::presets::seed_oil_node();
        let d = PyDict::new(py);
        d.set_item("heat_capacity_j_per_k", n.heat_capacity_j_per_k)?;
        d.set_item("oil_to_ambient_tau_s", n.oil_to_ambient_tau_s)?;
        d.set_item("wall_to_oil_tau_s", n.wall_to_oil_tau_s)?;
        d.set_item("wall_to_ambient_tau_s", n.wall_to_ambient_tau_s)?;
        d.set_item("wall_heat_capacity_j_per_k", n.wall_heat_capacity_j_per_k)?;
        d.set_item("oil_to_ambient_exponent", n.oil_to_ambient_exponent)?;
        Ok(d)
    })
}

/// The seed's sprung mass, kg.
#[pyfunction]
pub fn seed_sprung_mass_kg() -> f64 {
    hp_core::presets::SEED_SPRUNG_MASS_KG
}

/// Registers this module's functions.
pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_function(wrap_pyfunction!(simulate, m)?)?;
    m.add_function(wrap_pyfunction!(simulate_many, m)?)?;
    m.add_function(wrap_pyfunction!(sensor_lag, m)?)?;
    m.add_function(wrap_pyfunction!(static_force_n, m)?)?;
    m.add_function(wrap_pyfunction!(static_disp_for_load_m, m)?)?;
    m.add_function(wrap_pyfunction!(gas_masses_kg, m)?)?;
    m.add_function(wrap_pyfunction!(gas_props, m)?)?;
    m.add_function(wrap_pyfunction!(gas_density_kg_m3, m)?)?;
    m.add_function(wrap_pyfunction!(gas_validated_range, m)?)?;
    m.add_function(wrap_pyfunction!(seed_unit, m)?)?;
    m.add_function(wrap_pyfunction!(seed_sprung_mass_kg, m)?)?;
    m.add_function(wrap_pyfunction!(seed_oil_node, m)?)?;
    m.add_function(wrap_pyfunction!(load_pressure_pa, m)?)?;
    m.add_function(wrap_pyfunction!(damper_pressure_drop_pa, m)?)?;
    m.add_function(wrap_pyfunction!(friction_force_n, m)?)?;
    m.add("CHANNELS", CHANNELS.to_vec())?;
    // The gas models by name, the default (the reference equation of state) first.
    m.add("GAS_MODELS", hp_core::gas::Gas::ALL.map(|g| g.name()).to_vec())?;
    m.add("DEFAULT_GAS", hp_core::gas::Gas::default().name())?;
    // The adaptive integrator's relative tolerance unless a caller asks for another.
    m.add("DEFAULT_RTOL", hp_core::rig::DEFAULT_RTOL)?;
    m.add("STANDARD_GRAVITY_M_S2", hp_core::unit::STANDARD_GRAVITY_M_S2)?;
    let ranges = PyDict::new(m.py());
    for r in hp_core::ranges::ALL {
        ranges.set_item(r.name, (r.min, r.max))?;
    }
    // The effects' parameters: their ranges live in their own tables.
    let effects = params::effect_tables(m.py())?;
    for table in effects.iter() {
        for field in table.get_item("fields")?.try_iter()? {
            let field = field?;
            ranges.set_item(field.get_item("parameter")?, field.get_item("range")?)?;
        }
    }
    m.add("PARAMETER_RANGES", ranges)?;
    m.add("EFFECT_PARAMETERS", effects)?;
    Ok(())
}

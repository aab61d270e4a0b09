//! A plant stepped from Python one control period at a time: for closed
//! loops with a controller (host or firmware in the loop).

use crate::errors::{guard, to_py};
use crate::params::{self, RigSpec};
use crate::sim::{channel_values, CHANNELS};
use hp_core::rig::{Rig, RigKind, RigSample, RigState};
use hp_core::unit::{Unit, Valves};
use pyo3::prelude::*;
use pyo3::types::PyDict;

/// A unit on a rig, advanced by `step` with the valve commands of each
/// period. Samples are dicts of floats with the channel names of `simulate`.
#[pyclass(module = "hpctl._core")]
pub struct Plant {
    unit: Unit,
    rig: RigSpec,
    ambient_k: f64,
    static_disp_m: f64,
    valves: Valves,
    state: RigState,
    time_s: f64,
    max_dt_s: f64,
}

impl Plant {
    fn with_rig<T>(&self, f: impl FnOnce(&Rig<'_>) -> T) -> T {
        let kind = match &self.rig {
            RigSpec::Characterisation { strut } => RigKind::Characterisation { strut: strut.motion() },
            RigSpec::Sdof { sprung_mass_kg, base } => RigKind::Sdof { sprung_mass_kg: *sprung_mass_kg, base: base.motion() },
        };
        f(&Rig::resume(&self.unit, kind, self.ambient_k, self.valves, self.static_disp_m))
    }

    fn sample_now(&self) -> Result<RigSample, hp_core::Error> {
        self.with_rig(|rig| rig.sample(self.time_s, &self.state))
    }
}

fn to_dict<'py>(py: Python<'py>, s: &RigSample) -> PyResult<Bound<'py, PyDict>> {
    let d = PyDict::new(py);
    for (name, value) in CHANNELS.iter().zip(channel_values(s)) {
        d.set_item(name, value)?;
    }
    Ok(d)
}

#[pymethods]
impl Plant {
    /// Mounts `unit` on `rig` at rest (see `simulate` for the dicts), at
    /// ambient temperature `ambient_k`, with the given initial valve states.
    /// `max_dt_s` bounds the integration step inside each `step`.
    #[new]
    #[pyo3(signature = (unit, rig, ambient_k, spring_hard, damper_on, max_dt_s=1e-3))]
    fn new(unit: &Bound<'_, PyAny>, rig: &Bound<'_, PyAny>, ambient_k: f64, spring_hard: bool, damper_on: bool, max_dt_s: f64) -> PyResult<Self> {
        guard(|| {
            hp_core::error::check_range("max_dt_s", max_dt_s, 1e-9, 10.0).map_err(to_py)?;
            let unit = Unit::new(params::unit(unit)?).map_err(to_py)?;
            let spec = params::rig(rig)?;
            let valves = Valves::from_modes(spring_hard, damper_on);
            let kind = match &spec {
                RigSpec::Characterisation { strut } => RigKind::Characterisation { strut: strut.motion() },
                RigSpec::Sdof { sprung_mass_kg, base } => RigKind::Sdof { sprung_mass_kg: *sprung_mass_kg, base: base.motion() },
            };
            let (static_disp_m, state) = {
                let r = Rig::new(&unit, kind, ambient_k, valves).map_err(to_py)?;
                (r.static_disp_m(), r.initial_state().map_err(to_py)?)
            };
            Ok(Plant { unit, rig: spec, ambient_k, static_disp_m, valves, state, time_s: 0.0, max_dt_s })
        })
    }

    /// Simulated time, s.
    #[getter]
    fn time_s(&self) -> f64 {
        self.time_s
    }

    /// SDOF: strut compression at static equilibrium under the mass, m.
    #[getter]
    fn static_disp_m(&self) -> f64 {
        self.static_disp_m
    }

    /// The observed quantities now.
    fn sample<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        guard(|| to_dict(py, &self.sample_now().map_err(to_py)?))
    }

    /// Sets the valves (`valve5_open` = damper bypassed, `valve6_open` = L
    /// connected), advances by `dt_s` and returns the sample at the new time.
    fn step<'py>(&mut self, py: Python<'py>, dt_s: f64, valve5_open: bool, valve6_open: bool) -> PyResult<Bound<'py, PyDict>> {
        guard(|| {
            hp_core::error::check_range("dt_s", dt_s, 1e-9, 10.0).map_err(to_py)?;
            self.valves = Valves { valve5_open, valve6_open };
            let (t, max_dt) = (self.time_s, self.max_dt_s);
            let next = self.with_rig(|rig| {
                let (rate, _) = rig.rate_and_sample(t, &self.state)?;
                rig.advance(t, t + dt_s, &self.state, &rate, max_dt)
            });
            self.state = next.map_err(to_py)?;
            self.time_s = t + dt_s;
            to_dict(py, &self.sample_now().map_err(to_py)?)
        })
    }
}

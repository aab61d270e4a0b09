//! Python dicts to core parameter types. Strict: every key must be known
//! and every required key present; the core checks the values.

use crate::errors::parameter;
use hp_core::damper::{Damper, DamperCurve, Orifice};
use hp_core::gas::Gas;
use hp_core::motion::Motion;
use hp_core::thermal::HeatTransfer;
use hp_core::effect::{EffectParams, EffectVisitor};
use hp_core::unit::{Effects, UnitParams};
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyList};
use std::collections::BTreeSet;

/// Reads keys from a dict and remembers which were read, so that unknown
/// keys can be reported.
pub struct Reader<'py> {
    dict: Bound<'py, PyDict>,
    path: String,
    used: BTreeSet<String>,
}

impl<'py> Reader<'py> {
    pub fn new(obj: &Bound<'py, PyAny>, path: &str) -> PyResult<Self> {
        let dict = obj.cast::<PyDict>().map_err(|_| parameter(format!("{path} must be a dict")))?.clone();
        Ok(Reader { dict, path: path.to_owned(), used: BTreeSet::new() })
    }

    fn key_path(&self, key: &str) -> String {
        if self.path.is_empty() {
            key.to_owned()
        } else {
            format!("{}.{key}", self.path)
        }
    }

    pub fn get_opt(&mut self, key: &str) -> PyResult<Option<Bound<'py, PyAny>>> {
        self.used.insert(key.to_owned());
        match self.dict.get_item(key)? {
            Some(v) if !v.is_none() => Ok(Some(v)),
            _ => Ok(None),
        }
    }

    pub fn get(&mut self, key: &str) -> PyResult<Bound<'py, PyAny>> {
        let path = self.key_path(key);
        self.get_opt(key)?.ok_or_else(|| parameter(format!("missing key {path}")))
    }

    pub fn f64(&mut self, key: &str) -> PyResult<f64> {
        let path = self.key_path(key);
        let v = self.get(key)?;
        v.extract::<f64>().map_err(|_| parameter(format!("{path} must be a number in SI units, got {v}")))
    }

    pub fn string(&mut self, key: &str) -> PyResult<String> {
        let path = self.key_path(key);
        let v = self.get(key)?;
        v.extract::<String>().map_err(|_| parameter(format!("{path} must be a string, got {v}")))
    }

    pub fn sub(&mut self, key: &str) -> PyResult<Reader<'py>> {
        let path = self.key_path(key);
        Reader::new(&self.get(key)?, &path)
    }

    pub fn sub_opt(&mut self, key: &str) -> PyResult<Option<Reader<'py>>> {
        let path = self.key_path(key);
        self.get_opt(key)?.map(|v| Reader::new(&v, &path)).transpose()
    }

    pub fn vec(&mut self, key: &str) -> PyResult<Vec<f64>> {
        let path = self.key_path(key);
        let v = self.get(key)?;
        // A float64 numpy array is copied in one go; anything else element by element.
        if let Ok(array) = v.extract::<numpy::PyReadonlyArray1<'py, f64>>() {
            return Ok(array.as_slice().map(<[f64]>::to_vec).unwrap_or_else(|_| array.as_array().to_vec()));
        }
        v.extract::<Vec<f64>>().map_err(|_| parameter(format!("{path} must be a sequence of numbers")))
    }

    /// Fails on keys that were never asked for.
    pub fn finish(self) -> PyResult<()> {
        for key in self.dict.keys() {
            let key: String = key.extract().unwrap_or_else(|_| format!("{key}"));
            if !self.used.contains(&key) {
                let known: Vec<&str> = self.used.iter().map(String::as_str).collect();
                return Err(parameter(format!(
                    "unknown key {} (known keys: {})",
                    self.key_path(&key),
                    known.join(", ")
                )));
            }
        }
        Ok(())
    }
}

fn curve(r: &mut Reader<'_>, key: &str) -> PyResult<DamperCurve> {
    let mut c = r.sub(key)?;
    let curve = DamperCurve {
        bleed_pa_s_per_m3: c.f64("bleed_pa_s_per_m3")?,
        orifice_pa_s2_per_m6: c.f64("orifice_pa_s2_per_m6")?,
        blowoff_pa: c.f64("blowoff_pa")?,
        blowoff_slope_pa_s_per_m3: c.f64("blowoff_slope_pa_s_per_m3")?,
        blowoff_knee: c.f64("blowoff_knee")?,
        // The second stage came later: curves written without it have none.
        blowoff2_pa: if c.get_opt("blowoff2_pa")?.is_some() { c.f64("blowoff2_pa")? } else { 0.0 },
        blowoff2_slope_pa_s_per_m3: if c.get_opt("blowoff2_slope_pa_s_per_m3")?.is_some() { c.f64("blowoff2_slope_pa_s_per_m3")? } else { 0.0 },
        // The parallel bleed too: curves written without it have none.
        bleed_parallel_m3_per_s_pa: if c.get_opt("bleed_parallel_m3_per_s_pa")?.is_some() { c.f64("bleed_parallel_m3_per_s_pa")? } else { 0.0 },
    };
    c.finish()?;
    Ok(curve)
}

/// A damper description (`hpctl.model.unit.Damper`, as a dict), read at
/// `path` (for the messages); the core checks the values.
pub fn damper(obj: &Bound<'_, PyAny>, path: &str) -> PyResult<Damper> {
    damper_from(Reader::new(obj, path)?)
}

fn damper_from(mut d: Reader<'_>) -> PyResult<Damper> {
    let damper = Damper {
        on_compression: curve(&mut d, "on_compression")?,
        on_rebound: curve(&mut d, "on_rebound")?,
        off_compression: curve(&mut d, "off_compression")?,
        off_rebound: curve(&mut d, "off_rebound")?,
    };
    d.finish()?;
    Ok(damper)
}

/// The gas model named `name`.
pub fn gas(name: &str) -> PyResult<Gas> {
    Gas::from_name(name).ok_or_else(|| {
        let names: Vec<&str> = Gas::ALL.iter().map(|g| g.name()).collect();
        parameter(format!("gas = {name:?} is not a known model (one of: {})", names.join(", ")))
    })
}

/// A unit description (see `hpctl.unit.Unit.to_core`) to core parameters.
pub fn unit(obj: &Bound<'_, PyAny>) -> PyResult<UnitParams> {
    let mut r = Reader::new(obj, "unit")?;
    let tau_s = r.f64("tau_s")?;
    let heat = match r.get_opt("polytropic_exponent")? {
        Some(n) => {
            let n: f64 = n.extract().map_err(|_| parameter("unit.polytropic_exponent must be a number or None"))?;
            HeatTransfer::polytropic(n).map_err(crate::errors::to_py)?
        }
        None => HeatTransfer::from_tau_s(tau_s).map_err(crate::errors::to_py)?,
    };
    let gas = gas(&r.string("gas")?)?;
    let damper = damper_from(r.sub("damper")?)?;
    let effects = match r.sub_opt("effects")? {
        Some(e) => effects(e)?,
        None => Effects::default(),
    };
    let params = UnitParams {
        piston_area_m2: r.f64("piston_area_m2")?,
        small_acc_volume_m3: r.f64("small_acc_volume_m3")?,
        large_acc_volume_m3: r.f64("large_acc_volume_m3")?,
        static_pressure_pa: r.f64("static_pressure_pa")?,
        static_temperature_k: r.f64("static_temperature_k")?,
        gas,
        heat,
        valve6: Orifice { flow_area_m2: r.f64("valve6_flow_area_m2")?, transition_pa: r.f64("valve6_transition_pa")? },
        damper,
        oil_density_kg_m3: r.f64("oil_density_kg_m3")?,
        vapour_pressure_pa: r.f64("vapour_pressure_pa")?,
        ambient_pressure_pa: r.f64("ambient_pressure_pa")?,
        stroke_compression_m: r.f64("stroke_compression_m")?,
        stroke_extension_m: r.f64("stroke_extension_m")?,
        end_stop_stiffness_n_per_m: r.f64("end_stop_stiffness_n_per_m")?,
        end_stop_damping_n_s_per_m: r.f64("end_stop_damping_n_s_per_m")?,
        rated_speed_m_s: r.f64("rated_speed_m_s")?,
        effects,
    };
    r.finish()?;
    Ok(params)
}

/// Reads each effect's block, field by field, from the effect's own table
/// (hp_core::effect): no per-effect code here.
struct ReadEffects<'a, 'py> {
    dict: &'a mut Reader<'py>,
}

impl EffectVisitor for ReadEffects<'_, '_> {
    type Error = PyErr;
    fn visit<T: EffectParams>(&mut self, slot: &mut Option<T>) -> PyResult<()> {
        if let Some(mut block) = self.dict.sub_opt(T::KEY)? {
            let mut value = T::ZERO;
            for f in T::FIELDS {
                // A field with a default may be left out (a dict written
                // before the field existed still reads).
                let v = match f.default {
                    Some(d) if block.get_opt(f.field)?.is_none() => d,
                    _ => block.f64(f.field)?,
                };
                (f.set)(&mut value, v);
            }
            block.finish()?;
            *slot = Some(value);
        }
        Ok(())
    }
}

fn effects(mut e: Reader<'_>) -> PyResult<Effects> {
    let mut out = Effects::default();
    out.visit(&mut ReadEffects { dict: &mut e })?;
    e.finish()?;
    Ok(out)
}

/// Every effect's parameter table, for Python (`_core.EFFECT_PARAMETERS`):
/// per effect its key, struct name and doc, per field its name, doc,
/// parameter name, valid range and default (None: required).
pub fn effect_tables<'py>(py: Python<'py>) -> PyResult<Bound<'py, PyList>> {
    struct Export<'py> {
        py: Python<'py>,
        list: Bound<'py, PyList>,
    }
    impl EffectVisitor for Export<'_> {
        type Error = PyErr;
        fn visit<T: EffectParams>(&mut self, _slot: &mut Option<T>) -> PyResult<()> {
            let fields = PyList::empty(self.py);
            for f in T::FIELDS {
                let d = PyDict::new(self.py);
                d.set_item("field", f.field)?;
                d.set_item("doc", f.doc.trim())?;
                d.set_item("parameter", f.range.name)?;
                d.set_item("range", (f.range.min, f.range.max))?;
                d.set_item("default", f.default)?;
                fields.append(d)?;
            }
            let d = PyDict::new(self.py);
            d.set_item("key", T::KEY)?;
            d.set_item("name", T::NAME)?;
            d.set_item("doc", T::DOC.trim())?;
            d.set_item("fields", fields)?;
            self.list.append(d)
        }
    }
    let mut export = Export { py, list: PyList::empty(py) };
    Effects::default().visit(&mut export)?;
    Ok(export.list)
}

/// A motion description, owning its samples (so it can cross threads).
#[derive(Debug, Clone)]
pub enum MotionSpec {
    Fixed(Motion<'static>),
    Sampled { time_s: Vec<f64>, disp_m: Vec<f64>, vel_m_s: Option<Vec<f64>> },
}

impl MotionSpec {
    pub fn motion(&self) -> Motion<'_> {
        match self {
            MotionSpec::Fixed(m) => *m,
            MotionSpec::Sampled { time_s, disp_m, vel_m_s: None } => Motion::Sampled { time_s, disp_m },
            MotionSpec::Sampled { time_s, disp_m, vel_m_s: Some(vel_m_s) } => Motion::SampledVelocity { time_s, disp_m, vel_m_s },
        }
    }
}

pub fn motion(obj: &Bound<'_, PyAny>, path: &str) -> PyResult<MotionSpec> {
    let mut r = Reader::new(obj, path)?;
    let kind = r.string("kind")?;
    let spec = match kind.as_str() {
        "hold" => MotionSpec::Fixed(Motion::Hold { disp_m: r.f64("disp_m")? }),
        "sine" => MotionSpec::Fixed(Motion::Sine {
            amplitude_m: r.f64("amplitude_m")?,
            frequency_hz: r.f64("frequency_hz")?,
            offset_m: r.f64("offset_m")?,
        }),
        "step" => MotionSpec::Fixed(Motion::Step {
            height_m: r.f64("height_m")?,
            start_s: r.f64("start_s")?,
            rise_s: r.f64("rise_s")?,
        }),
        "steps" => {
            let count = r.f64("count")?;
            if !((1.0..=1e6).contains(&count) && count.fract() == 0.0) {
                return Err(parameter(format!("{path}.count = {count} must be a whole number in [1, 1e6]")));
            }
            MotionSpec::Fixed(Motion::Steps {
                increment_m: r.f64("increment_m")?,
                count: count as u32,
                ramp_s: r.f64("ramp_s")?,
                dwell_s: r.f64("dwell_s")?,
            })
        }
        "sampled" => {
            let vel_m_s = if r.get_opt("vel_m_s")?.is_some() { Some(r.vec("vel_m_s")?) } else { None };
            MotionSpec::Sampled { time_s: r.vec("time_s")?, disp_m: r.vec("disp_m")?, vel_m_s }
        }
        other => {
            return Err(parameter(format!(
                "{path}.kind = {other:?} is not a motion (one of: hold, sine, step, steps, sampled)"
            )))
        }
    };
    r.finish()?;
    spec.motion().validate().map_err(crate::errors::to_py)?;
    Ok(spec)
}

/// Which rig, with its excitation.
#[derive(Debug, Clone)]
pub enum RigSpec {
    Characterisation { strut: MotionSpec },
    Sdof { sprung_mass_kg: f64, base: MotionSpec },
}

pub fn rig(obj: &Bound<'_, PyAny>) -> PyResult<RigSpec> {
    let mut r = Reader::new(obj, "rig")?;
    let kind = r.string("kind")?;
    let spec = match kind.as_str() {
        "characterisation" => RigSpec::Characterisation { strut: motion(&r.get("strut")?, "rig.strut")? },
        "sdof" => RigSpec::Sdof { sprung_mass_kg: r.f64("sprung_mass_kg")?, base: motion(&r.get("base")?, "rig.base")? },
        other => {
            return Err(parameter(format!("rig.kind = {other:?} is not a rig (one of: characterisation, sdof)")))
        }
    };
    r.finish()?;
    Ok(spec)
}

/// Core parameters back to the dict form `unit` reads.
pub fn unit_to_dict<'py>(py: Python<'py>, p: &UnitParams) -> PyResult<Bound<'py, PyDict>> {
    let d = PyDict::new(py);
    let curve = |c: &DamperCurve| -> PyResult<Bound<'py, PyDict>> {
        let cd = PyDict::new(py);
        cd.set_item("bleed_pa_s_per_m3", c.bleed_pa_s_per_m3)?;
        cd.set_item("orifice_pa_s2_per_m6", c.orifice_pa_s2_per_m6)?;
        cd.set_item("blowoff_pa", c.blowoff_pa)?;
        cd.set_item("blowoff_slope_pa_s_per_m3", c.blowoff_slope_pa_s_per_m3)?;
        cd.set_item("blowoff_knee", c.blowoff_knee)?;
        cd.set_item("blowoff2_pa", c.blowoff2_pa)?;
        cd.set_item("blowoff2_slope_pa_s_per_m3", c.blowoff2_slope_pa_s_per_m3)?;
        cd.set_item("bleed_parallel_m3_per_s_pa", c.bleed_parallel_m3_per_s_pa)?;
        Ok(cd)
    };
    d.set_item("piston_area_m2", p.piston_area_m2)?;
    d.set_item("small_acc_volume_m3", p.small_acc_volume_m3)?;
    d.set_item("large_acc_volume_m3", p.large_acc_volume_m3)?;
    d.set_item("static_pressure_pa", p.static_pressure_pa)?;
    d.set_item("static_temperature_k", p.static_temperature_k)?;
    d.set_item("gas", p.gas.name())?;
    match p.heat {
        HeatTransfer::Polytropic(n) => {
            d.set_item("tau_s", f64::INFINITY)?;
            d.set_item("polytropic_exponent", n)?;
        }
        other => d.set_item("tau_s", other.tau_s())?,
    }
    d.set_item("valve6_flow_area_m2", p.valve6.flow_area_m2)?;
    d.set_item("valve6_transition_pa", p.valve6.transition_pa)?;
    let damper = PyDict::new(py);
    damper.set_item("on_compression", curve(&p.damper.on_compression)?)?;
    damper.set_item("on_rebound", curve(&p.damper.on_rebound)?)?;
    damper.set_item("off_compression", curve(&p.damper.off_compression)?)?;
    damper.set_item("off_rebound", curve(&p.damper.off_rebound)?)?;
    d.set_item("damper", damper)?;
    d.set_item("oil_density_kg_m3", p.oil_density_kg_m3)?;
    d.set_item("vapour_pressure_pa", p.vapour_pressure_pa)?;
    d.set_item("ambient_pressure_pa", p.ambient_pressure_pa)?;
    d.set_item("stroke_compression_m", p.stroke_compression_m)?;
    d.set_item("stroke_extension_m", p.stroke_extension_m)?;
    d.set_item("end_stop_stiffness_n_per_m", p.end_stop_stiffness_n_per_m)?;
    d.set_item("end_stop_damping_n_s_per_m", p.end_stop_damping_n_s_per_m)?;
    d.set_item("rated_speed_m_s", p.rated_speed_m_s)?;
    // The built-in presets carry no optional effects; `effects` stays absent.
    Ok(d)
}

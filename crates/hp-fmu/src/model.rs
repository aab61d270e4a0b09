//! What a model author writes: a table of variables ([`Var`]) and the
//! [`Model`] trait. Everything the standard asks beyond that (the C API, the
//! life cycle, value references, logging, the model description) is
//! written once, in [`crate::fmi2`] and [`crate::description`].

use core::fmt;

/// The base type of a variable (FMI 2.0 `Real`, `Integer`, `Boolean`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Kind {
    Real,
    Integer,
    Boolean,
}

/// FMI 2.0 causality.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Causality {
    /// Set before initialisation, fixed afterwards.
    Parameter,
    Input,
    Output,
}

/// An enumeration type (FMI 2.0 `SimpleType` with `Enumeration` items):
/// the variable is an `Integer` whose values are the items' values.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Enumeration {
    /// The type's name in the model description.
    pub name: &'static str,
    /// `(name, value, description)` of each item.
    pub items: &'static [(&'static str, i32, &'static str)],
}

/// One variable of a model. Its value reference is its position in the
/// model's table (unique across the three base types).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Var {
    pub name: &'static str,
    pub kind: Kind,
    pub causality: Causality,
    /// Start value (parameters and inputs); booleans 0/1. Outputs have none
    /// (they are calculated).
    pub start: f64,
    /// SI unit symbol as in [`crate::description::UNITS`] ("" for none).
    pub unit: &'static str,
    /// Inclusive valid range, checked when the value is set (NaN: open).
    pub min: f64,
    pub max: f64,
    /// For `Integer` variables of an enumeration type.
    pub enumeration: Option<&'static Enumeration>,
    pub description: &'static str,
}

impl Var {
    /// A real parameter with its valid range.
    pub const fn parameter(name: &'static str, start: f64, unit: &'static str, min: f64, max: f64, description: &'static str) -> Var {
        Var { name, kind: Kind::Real, causality: Causality::Parameter, start, unit, min, max, enumeration: None, description }
    }
    /// A real input (continuous).
    pub const fn input(name: &'static str, start: f64, unit: &'static str, description: &'static str) -> Var {
        Var { name, kind: Kind::Real, causality: Causality::Input, start, unit, min: f64::NAN, max: f64::NAN, enumeration: None, description }
    }
    /// A real output.
    pub const fn output(name: &'static str, unit: &'static str, description: &'static str) -> Var {
        Var { name, kind: Kind::Real, causality: Causality::Output, start: 0.0, unit, min: f64::NAN, max: f64::NAN, enumeration: None, description }
    }
    /// A variable of another base type.
    pub const fn typed(name: &'static str, kind: Kind, causality: Causality, start: f64, description: &'static str) -> Var {
        Var { name, kind, causality, start, unit: "", min: f64::NAN, max: f64::NAN, enumeration: None, description }
    }
    /// An integer variable of an enumeration type.
    pub const fn enumerated(name: &'static str, causality: Causality, start: i32, e: &'static Enumeration, description: &'static str) -> Var {
        Var {
            name,
            kind: Kind::Integer,
            causality,
            start: start as f64,
            unit: "",
            min: f64::NAN,
            max: f64::NAN,
            enumeration: Some(e),
            description,
        }
    }

    /// Whether `value` may be given to this variable (its range, its
    /// enumeration's values, finite for parameters).
    pub fn accepts(&self, value: f64) -> bool {
        if let Some(e) = self.enumeration {
            return e.items.iter().any(|&(_, v, _)| f64::from(v) == value);
        }
        if self.causality == Causality::Parameter && !value.is_finite() && !(value == f64::INFINITY && self.max == f64::INFINITY) {
            return false;
        }
        !(value < self.min || value > self.max)
    }
}

/// What the model description says about a model beyond its variables.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ModelInfo {
    /// `modelName` and `modelIdentifier` (the shared library's file name).
    pub identifier: &'static str,
    pub description: &'static str,
    /// The variables; value reference = index.
    pub vars: &'static [Var],
    /// `DefaultExperiment`: stop time and step size, s.
    pub default_stop_s: f64,
    pub default_step_s: f64,
}

impl ModelInfo {
    /// The variable with value reference `vr`.
    pub fn var(&self, vr: u32) -> Option<&'static Var> {
        self.vars.get(vr as usize)
    }

    /// The value reference of the variable called `name`.
    pub fn vr(&self, name: &str) -> Option<u32> {
        self.vars.iter().position(|v| v.name == name).and_then(|i| u32::try_from(i).ok())
    }

    /// A GUID that changes whenever the interface does: FNV-1a (64 bit,
    /// twice with two seeds) over the identifier and every variable's name,
    /// type, causality, unit and start value, formatted as a GUID.
    pub fn guid(&self) -> String {
        let mut text = String::from(self.identifier);
        for v in self.vars {
            text.push_str(&format!("|{}:{:?}:{:?}:{}:{:e}", v.name, v.kind, v.causality, v.unit, v.start));
        }
        let hash = |seed: u64| {
            text.bytes().fold(seed, |h, b| (h ^ u64::from(b)).wrapping_mul(0x0100_0000_01b3))
        };
        let (a, b) = (hash(0xcbf2_9ce4_8422_2325), hash(0x8422_2325_cbf2_9ce4));
        format!(
            "{{{:08x}-{:04x}-{:04x}-{:04x}-{:012x}}}",
            a >> 32,
            (a >> 16) & 0xffff,
            a & 0xffff,
            b >> 48,
            b & 0xffff_ffff_ffff
        )
    }
}

/// The current values of a model's variables, by value reference, with the
/// input derivatives a master may set (`fmi2SetRealInputDerivatives`).
#[derive(Debug, Clone, PartialEq)]
pub struct Values {
    values: Vec<f64>,
    /// First and second time derivatives of real inputs (0 unless set).
    derivatives: Vec<[f64; 2]>,
}

impl Values {
    /// Every variable at its start value.
    pub fn new(info: &ModelInfo) -> Self {
        Values { values: info.vars.iter().map(|v| v.start).collect(), derivatives: vec![[0.0; 2]; info.vars.len()] }
    }
    /// The value of variable `vr` (0 for an unknown one: models use their
    /// own table's indices, checked by their tests).
    pub fn get(&self, vr: usize) -> f64 {
        self.values.get(vr).copied().unwrap_or(0.0)
    }
    pub fn get_bool(&self, vr: usize) -> bool {
        self.get(vr) != 0.0
    }
    pub fn set(&mut self, vr: usize, value: f64) {
        if let Some(v) = self.values.get_mut(vr) {
            *v = value;
        }
    }
    pub fn set_bool(&mut self, vr: usize, value: bool) {
        self.set(vr, if value { 1.0 } else { 0.0 });
    }
    /// Derivative of `order` (1 or 2) of input `vr`.
    pub fn derivative(&self, vr: usize, order: usize) -> f64 {
        self.derivatives.get(vr).and_then(|d| d.get(order.wrapping_sub(1))).copied().unwrap_or(0.0)
    }
    pub fn set_derivative(&mut self, vr: usize, order: usize, value: f64) -> bool {
        match self.derivatives.get_mut(vr).and_then(|d| d.get_mut(order.wrapping_sub(1))) {
            Some(d) => {
                *d = value;
                true
            }
            None => false,
        }
    }
    /// Forgets the input derivatives (they hold for one step only).
    pub fn clear_derivatives(&mut self) {
        self.derivatives.iter_mut().for_each(|d| *d = [0.0; 2]);
    }
}

/// Why a model call failed: the message goes to the importer's logger with
/// `fmi2Error`.
#[derive(Debug, Clone, PartialEq)]
pub struct ModelError(pub String);

impl fmt::Display for ModelError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.0)
    }
}

impl From<hp_core::Error> for ModelError {
    fn from(e: hp_core::Error) -> Self {
        ModelError(e.to_string())
    }
}

/// A co-simulation model: built from its parameters and initial inputs,
/// asked for its outputs at the current time, advanced by steps.
pub trait Model: Sized + Clone + 'static {
    /// The model's variables and description.
    fn info() -> &'static ModelInfo;
    /// Builds the model at `time_s` from the parameters and the inputs'
    /// current values (end of initialisation).
    fn start(values: &Values, time_s: f64) -> Result<Self, ModelError>;
    /// Writes the outputs at `time_s` for the current inputs into `values`
    /// (called when an output is read after inputs changed or time moved).
    fn outputs(&mut self, values: &mut Values, time_s: f64) -> Result<(), ModelError>;
    /// Advances from `time_s` by `step_s` with the current inputs (and
    /// their derivatives).
    fn do_step(&mut self, values: &Values, time_s: f64, step_s: f64) -> Result<(), ModelError>;
    /// A warning about the state just reached, if any (logged with
    /// `fmi2Warning` and returned as the step's status): a result the
    /// model cannot stand behind.
    fn warning(&mut self, _values: &Values) -> Option<String> {
        None
    }
}

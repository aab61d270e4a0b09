//! The FMI 2.0 co-simulation C API, written once for any [`Model`].
//!
//! Every exported function catches panics (none should occur: the models
//! return errors) so that no unwinding crosses the C boundary; a caught
//! panic or a model error is reported through the importer's logger and as
//! `fmi2Error`, after which the instance only accepts `fmi2FreeInstance`,
//! `fmi2Reset` and the getters (as the standard prescribes).
//!
//! One shared library serves both FMUs: `fmi2Instantiate` picks the model
//! from the GUID of the model description it was unpacked with (each FMU's
//! `binaries/linux64/<modelIdentifier>.so` is the same library).

use crate::model::{Causality, Kind, Model, ModelError, ModelInfo, Values};
use std::ffi::{c_char, c_int, c_uint, c_void, CStr, CString};
use std::panic::{catch_unwind, AssertUnwindSafe};

pub type Status = c_int;
pub const OK: Status = 0;
pub const WARNING: Status = 1;
pub const DISCARD: Status = 2;
pub const ERROR: Status = 3;
pub const FATAL: Status = 4;

/// `fmi2CallbackLogger`: `printf`-like, the message is a format string.
pub type Logger = Option<unsafe extern "C" fn(*mut c_void, *const c_char, Status, *const c_char, *const c_char, ...)>;

/// `fmi2CallbackFunctions`.
#[repr(C)]
pub struct CallbackFunctions {
    pub logger: Logger,
    pub allocate_memory: Option<unsafe extern "C" fn(usize, usize) -> *mut c_void>,
    pub free_memory: Option<unsafe extern "C" fn(*mut c_void)>,
    pub step_finished: Option<unsafe extern "C" fn(*mut c_void, Status)>,
    pub component_environment: *mut c_void,
}

/// Where an instance is in the FMI 2.0 co-simulation life cycle.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Phase {
    Instantiated,
    Initialization,
    Stepping,
    Terminated,
    /// After `fmi2Error`: only free, reset and the getters.
    Failed,
}

/// The model-specific part of an instance, behind a trait object so one
/// library can hold several models.
pub trait Component {
    fn info(&self) -> &'static ModelInfo;
    fn values(&self) -> &Values;
    fn values_mut(&mut self) -> &mut Values;
    /// Builds the model from the parameters and initial inputs.
    fn start(&mut self, time_s: f64) -> Result<(), ModelError>;
    /// Brings the outputs up to date (no-op when they are).
    fn refresh(&mut self, time_s: f64) -> Result<(), ModelError>;
    fn mark_stale(&mut self);
    /// Drops a model built during initialisation (its parameters or
    /// initial inputs changed): the next read or the end of initialisation
    /// builds it again.
    fn forget_model(&mut self);
    fn do_step(&mut self, time_s: f64, step_s: f64) -> Result<Option<String>, ModelError>;
    fn snapshot(&self) -> Box<dyn Component>;
    fn restore(&mut self, from: &dyn Component) -> bool;
    fn reset(&mut self);
    fn as_any(&self) -> &dyn std::any::Any;
}

/// A model with its values.
#[derive(Clone)]
pub struct Core<M: Model> {
    values: Values,
    model: Option<M>,
    /// Outputs need recomputing (inputs changed, or time moved).
    stale: bool,
}

impl<M: Model> Core<M> {
    pub fn new() -> Self {
        Core { values: Values::new(M::info()), model: None, stale: true }
    }
}

impl<M: Model> Default for Core<M> {
    fn default() -> Self {
        Self::new()
    }
}

impl<M: Model> Component for Core<M> {
    fn info(&self) -> &'static ModelInfo {
        M::info()
    }
    fn values(&self) -> &Values {
        &self.values
    }
    fn values_mut(&mut self) -> &mut Values {
        &mut self.values
    }
    fn start(&mut self, time_s: f64) -> Result<(), ModelError> {
        self.model = Some(M::start(&self.values, time_s)?);
        self.stale = true;
        self.refresh(time_s)
    }
    fn refresh(&mut self, time_s: f64) -> Result<(), ModelError> {
        if !self.stale {
            return Ok(());
        }
        if self.model.is_none() {
            // Outputs asked for during initialisation: build a model from
            // what is set so far (it is built again when initialisation ends).
            self.model = Some(M::start(&self.values, time_s)?);
        }
        if let Some(m) = self.model.as_mut() {
            m.outputs(&mut self.values, time_s)?;
        }
        self.stale = false;
        Ok(())
    }
    fn mark_stale(&mut self) {
        self.stale = true;
    }
    fn forget_model(&mut self) {
        self.model = None;
        self.stale = true;
    }
    fn do_step(&mut self, time_s: f64, step_s: f64) -> Result<Option<String>, ModelError> {
        let Some(m) = self.model.as_mut() else {
            return Err(ModelError("fmi2DoStep before fmi2ExitInitializationMode".into()));
        };
        m.do_step(&self.values, time_s, step_s)?;
        self.values.clear_derivatives();
        self.stale = true;
        self.refresh(time_s + step_s)?;
        Ok(self.model.as_mut().and_then(|m| m.warning(&self.values)))
    }
    fn snapshot(&self) -> Box<dyn Component> {
        Box::new(self.clone())
    }
    fn restore(&mut self, from: &dyn Component) -> bool {
        match from.as_any().downcast_ref::<Core<M>>() {
            Some(c) => {
                *self = c.clone();
                true
            }
            None => false,
        }
    }
    fn reset(&mut self) {
        *self = Core::new();
    }
    fn as_any(&self) -> &dyn std::any::Any {
        self
    }
}

/// An FMU instance: the life cycle, the logger and the component.
pub struct Instance {
    name: CString,
    logger: Logger,
    environment: *mut c_void,
    logging_on: bool,
    pub phase: Phase,
    pub time_s: f64,
    start_time_s: f64,
    stop_time_s: Option<f64>,
    component: Box<dyn Component>,
}

/// A saved FMU state (`fmi2GetFMUstate`).
struct Saved {
    phase: Phase,
    time_s: f64,
    component: Box<dyn Component>,
}

fn c_string(s: &str) -> CString {
    CString::new(s.replace('\0', " ")).unwrap_or_default()
}

impl Instance {
    pub fn new(name: &str, component: Box<dyn Component>, logger: Logger, environment: *mut c_void, logging_on: bool) -> Self {
        Instance {
            name: c_string(name),
            logger,
            environment,
            logging_on,
            phase: Phase::Instantiated,
            time_s: 0.0,
            start_time_s: 0.0,
            stop_time_s: None,
            component,
        }
    }

    /// `fmi2SetDebugLogging`.
    pub fn set_logging(&mut self, on: bool) {
        self.logging_on = on;
    }

    /// Sends `message` to the importer's logger. Errors and warnings always
    /// go out; other messages only with debug logging on.
    pub fn log(&self, status: Status, category: &str, message: &str) {
        if status == OK && !self.logging_on {
            return;
        }
        log_to(self.logger, self.environment, &self.name, status, category, message);
    }

    /// Logs `message` as an error and moves to the failed phase.
    fn fail(&mut self, message: &str) -> Status {
        self.log(ERROR, "logStatusError", message);
        self.phase = Phase::Failed;
        ERROR
    }

    /// Logs a call that the standard does not allow now (no phase change:
    /// the instance is intact).
    fn refuse(&self, message: &str) -> Status {
        self.log(ERROR, "logStatusError", message);
        ERROR
    }

    fn info(&self) -> &'static ModelInfo {
        self.component.info()
    }

    pub fn setup_experiment(&mut self, start_s: f64, stop_s: Option<f64>) -> Status {
        if self.phase != Phase::Instantiated {
            return self.refuse("fmi2SetupExperiment is only allowed right after fmi2Instantiate");
        }
        if !start_s.is_finite() || stop_s.is_some_and(|s| !(s >= start_s)) {
            return self.refuse(&format!("fmi2SetupExperiment: start time {start_s} s, stop time {stop_s:?} s: the start must be finite and the stop not before it"));
        }
        self.start_time_s = start_s;
        self.time_s = start_s;
        self.stop_time_s = stop_s;
        OK
    }

    pub fn enter_initialization(&mut self) -> Status {
        if self.phase != Phase::Instantiated {
            return self.refuse("fmi2EnterInitializationMode is only allowed once, after fmi2Instantiate");
        }
        self.phase = Phase::Initialization;
        OK
    }

    pub fn exit_initialization(&mut self) -> Status {
        if self.phase != Phase::Initialization {
            return self.refuse("fmi2ExitInitializationMode outside initialisation mode");
        }
        match self.component.start(self.time_s) {
            Ok(()) => {
                self.phase = Phase::Stepping;
                OK
            }
            Err(e) => self.fail(&format!("initialisation failed: {e}")),
        }
    }

    pub fn terminate(&mut self) -> Status {
        if !matches!(self.phase, Phase::Stepping) {
            return self.refuse("fmi2Terminate is only allowed after initialisation");
        }
        self.phase = Phase::Terminated;
        OK
    }

    pub fn reset(&mut self) -> Status {
        self.component.reset();
        self.phase = Phase::Instantiated;
        self.time_s = self.start_time_s;
        OK
    }

    pub fn do_step(&mut self, t_s: f64, h_s: f64) -> Status {
        if self.phase != Phase::Stepping {
            return self.refuse("fmi2DoStep is only allowed after fmi2ExitInitializationMode (and before fmi2Terminate)");
        }
        if !(h_s > 0.0) || !h_s.is_finite() {
            return self.refuse(&format!("fmi2DoStep: communicationStepSize = {h_s} s must be positive and finite"));
        }
        // The master's time must be the FMU's (to rounding of repeated sums).
        let tolerance = 1e-9 * (1.0 + self.time_s.abs()) + 1e-6 * h_s;
        if !((t_s - self.time_s).abs() <= tolerance) {
            return self.refuse(&format!(
                "fmi2DoStep: currentCommunicationPoint = {t_s} s is not the FMU's time {} s",
                self.time_s
            ));
        }
        if let Some(stop) = self.stop_time_s {
            if t_s + h_s > stop + tolerance {
                return self.refuse(&format!("fmi2DoStep: the step to {} s goes past the stop time {stop} s", t_s + h_s));
            }
        }
        match self.component.do_step(self.time_s, h_s) {
            Ok(warning) => {
                self.time_s += h_s;
                match warning {
                    Some(w) => {
                        self.log(WARNING, "logStatusWarning", &format!("t = {} s: {w}", self.time_s));
                        WARNING
                    }
                    None => OK,
                }
            }
            Err(e) => self.fail(&format!("step from t = {} s by {h_s} s failed: {e}", self.time_s)),
        }
    }

    /// Checks value references and kind for a get or set.
    fn check(&self, vr: &[c_uint], kind: Kind, setting: bool) -> Result<(), String> {
        let info = self.info();
        for &r in vr {
            let Some(v) = info.var(r) else {
                return Err(format!("unknown value reference {r} ({} has {})", info.identifier, info.vars.len()));
            };
            if v.kind != kind {
                return Err(format!("{} (value reference {r}) is a {:?}, not a {kind:?}", v.name, v.kind));
            }
            if setting {
                let allowed = match v.causality {
                    Causality::Parameter => matches!(self.phase, Phase::Instantiated | Phase::Initialization),
                    Causality::Input => matches!(self.phase, Phase::Instantiated | Phase::Initialization | Phase::Stepping),
                    Causality::Output => false,
                };
                if !allowed {
                    return Err(format!("{} ({:?}) cannot be set now ({:?})", v.name, v.causality, self.phase));
                }
            }
        }
        Ok(())
    }

    /// Reads variables as f64 (for every base type).
    pub fn get(&mut self, vr: &[c_uint], kind: Kind, out: &mut [f64]) -> Status {
        if let Err(e) = self.check(vr, kind, false) {
            return self.refuse(&format!("get: {e}"));
        }
        let wants_output = vr.iter().any(|&r| self.info().var(r).is_some_and(|v| v.causality == Causality::Output));
        if wants_output && matches!(self.phase, Phase::Instantiated) {
            return self.refuse("outputs can be read from initialisation mode on");
        }
        if wants_output && matches!(self.phase, Phase::Initialization | Phase::Stepping) {
            if let Err(e) = self.component.refresh(self.time_s) {
                return self.fail(&format!("outputs at t = {} s: {e}", self.time_s));
            }
        }
        for (o, &r) in out.iter_mut().zip(vr) {
            *o = self.component.values().get(r as usize);
        }
        OK
    }

    /// Writes variables given as f64 (for every base type).
    pub fn set(&mut self, vr: &[c_uint], kind: Kind, values: &[f64]) -> Status {
        if let Err(e) = self.check(vr, kind, true) {
            return self.refuse(&format!("set: {e}"));
        }
        let info = self.info();
        for (&r, &x) in vr.iter().zip(values) {
            if let Some(v) = info.var(r) {
                if !v.accepts(x) {
                    let range = match v.enumeration {
                        Some(e) => format!("one of {:?}", e.items.iter().map(|(n, v, _)| format!("{v} ({n})")).collect::<Vec<_>>()),
                        None => format!("[{}, {}]", v.min, v.max),
                    };
                    return self.refuse(&format!("{} = {x} is outside its valid range {range}", v.name));
                }
            }
        }
        for (&r, &x) in vr.iter().zip(values) {
            self.component.values_mut().set(r as usize, x);
        }
        if self.phase == Phase::Stepping {
            self.component.mark_stale();
        } else {
            self.component.forget_model();
        }
        OK
    }

    pub fn set_input_derivatives(&mut self, vr: &[c_uint], order: &[c_int], values: &[f64]) -> Status {
        if let Err(e) = self.check(vr, Kind::Real, true) {
            return self.refuse(&format!("fmi2SetRealInputDerivatives: {e}"));
        }
        for ((&r, &n), &x) in vr.iter().zip(order).zip(values) {
            let is_input = self.info().var(r).is_some_and(|v| v.causality == Causality::Input);
            let Ok(n) = usize::try_from(n) else { return self.refuse("fmi2SetRealInputDerivatives: negative order") };
            if !is_input || !x.is_finite() || !self.component.values_mut().set_derivative(r as usize, n, x) {
                return self.refuse(&format!(
                    "fmi2SetRealInputDerivatives: value reference {r}, order {n}, value {x}: only finite derivatives of order 1 or 2 of real inputs"
                ));
            }
        }
        OK
    }

    fn save(&self) -> Saved {
        Saved { phase: self.phase, time_s: self.time_s, component: self.component.snapshot() }
    }

    fn load(&mut self, s: &Saved) -> Status {
        if !self.component.restore(s.component.as_ref()) {
            return self.refuse("fmi2SetFMUstate: the state belongs to another model");
        }
        self.phase = s.phase;
        self.time_s = s.time_s;
        OK
    }
}

/// Sends one message to `logger`. The message is the format string with
/// every `%` doubled and no arguments, so a `printf`-style logger prints it
/// as is and a logger that does not format (many importers' simple ones)
/// still shows the text.
#[allow(clippy::not_unsafe_ptr_arg_deref)] // the environment is the importer's, passed back untouched
pub fn log_to(logger: Logger, environment: *mut c_void, name: &CStr, status: Status, category: &str, message: &str) {
    if let Some(f) = logger {
        let category = c_string(category);
        let message = c_string(&message.replace('%', "%%"));
        // SAFETY: the importer gave this function as an fmi2CallbackLogger;
        // every string is NUL-terminated and outlives the call.
        unsafe { f(environment, name.as_ptr(), status, category.as_ptr(), message.as_ptr()) };
    }
}

// ------------------------------------------------------------ entry points

/// The models this library serves, by GUID.
pub type Registry = fn(guid: &str) -> Option<Box<dyn Component>>;

/// Runs `f` on the instance behind `c`, turning a panic into `fmi2Error`.
///
/// # Safety
/// `c` must be null or a pointer returned by [`instantiate`] and not freed.
pub unsafe fn with_instance(c: *mut c_void, f: impl FnOnce(&mut Instance) -> Status) -> Status {
    if c.is_null() {
        return ERROR;
    }
    // SAFETY: the caller passes a pointer from `instantiate`.
    let instance = unsafe { &mut *(c as *mut Instance) };
    match catch_unwind(AssertUnwindSafe(|| f(instance))) {
        Ok(s) => s,
        Err(_) => {
            // The instance may be inconsistent: nothing but freeing it is safe.
            instance.log(FATAL, "logStatusFatal", "internal error (a panic was caught at the FMI boundary); please report it");
            instance.phase = Phase::Failed;
            FATAL
        }
    }
}

/// A slice from a C array, empty for a null pointer or zero length.
///
/// # Safety
/// `p` must point to `n` valid elements when it is not null.
pub unsafe fn slice<'a, T>(p: *const T, n: usize) -> &'a [T] {
    if p.is_null() || n == 0 {
        &[]
    } else {
        // SAFETY: as documented.
        unsafe { std::slice::from_raw_parts(p, n) }
    }
}

/// A mutable slice from a C array.
///
/// # Safety
/// `p` must point to `n` valid elements when it is not null.
pub unsafe fn slice_mut<'a, T>(p: *mut T, n: usize) -> &'a mut [T] {
    if p.is_null() || n == 0 {
        &mut []
    } else {
        // SAFETY: as documented.
        unsafe { std::slice::from_raw_parts_mut(p, n) }
    }
}

/// A string from C, or `None` for null or invalid UTF-8.
///
/// # Safety
/// `p` must be null or a NUL-terminated string.
pub unsafe fn string(p: *const c_char) -> Option<String> {
    if p.is_null() {
        None
    } else {
        // SAFETY: as documented.
        unsafe { CStr::from_ptr(p) }.to_str().ok().map(str::to_owned)
    }
}

/// `fmi2Instantiate` for the models of `registry`.
///
/// # Safety
/// Arguments as the standard defines them.
pub unsafe fn instantiate(
    registry: Registry,
    name: *const c_char,
    fmu_type: c_int,
    guid: *const c_char,
    functions: *const CallbackFunctions,
    logging_on: c_int,
) -> *mut c_void {
    let result = catch_unwind(AssertUnwindSafe(|| {
        // SAFETY: the importer passes valid or null pointers.
        let (logger, environment) = match unsafe { functions.as_ref() } {
            Some(f) => (f.logger, f.component_environment),
            None => (None, std::ptr::null_mut()),
        };
        // SAFETY: as above.
        let name = unsafe { string(name) }.unwrap_or_else(|| "hpctl".into());
        let cname = c_string(&name);
        let fail = |message: &str| {
            log_to(logger, environment, &cname, ERROR, "logStatusError", message);
            std::ptr::null_mut()
        };
        if fmu_type != 1 {
            return fail("this FMU supports co-simulation only (fmi2CoSimulation)");
        }
        // SAFETY: as above.
        let Some(guid) = (unsafe { string(guid) }) else { return fail("no GUID given") };
        let Some(component) = registry(&guid) else {
            return fail(&format!("GUID {guid} is not one of this library's models: the binary does not match the model description"));
        };
        let instance = Instance::new(&name, component, logger, environment, logging_on != 0);
        Box::into_raw(Box::new(instance)) as *mut c_void
    }));
    result.unwrap_or(std::ptr::null_mut())
}

/// `fmi2FreeInstance`.
///
/// # Safety
/// `c` must be null or from [`instantiate`], not freed before.
pub unsafe fn free_instance(c: *mut c_void) {
    if !c.is_null() {
        // SAFETY: as documented; dropping cannot panic (plain data).
        drop(unsafe { Box::from_raw(c as *mut Instance) });
    }
}

/// `fmi2GetFMUstate`.
///
/// # Safety
/// `c` from [`instantiate`]; `state` a valid pointer.
pub unsafe fn get_state(c: *mut c_void, state: *mut *mut c_void) -> Status {
    // SAFETY: as documented.
    unsafe {
        with_instance(c, |i| {
            if state.is_null() {
                return i.refuse("fmi2GetFMUstate: null FMUstate pointer");
            }
            let saved = Box::new(i.save());
            let old = *state;
            if !old.is_null() {
                // The standard: a non-null state is overwritten in place.
                drop(Box::from_raw(old as *mut Saved));
            }
            *state = Box::into_raw(saved) as *mut c_void;
            OK
        })
    }
}

/// `fmi2SetFMUstate`.
///
/// # Safety
/// `c` from [`instantiate`]; `state` from [`get_state`].
pub unsafe fn set_state(c: *mut c_void, state: *mut c_void) -> Status {
    // SAFETY: as documented.
    unsafe {
        with_instance(c, |i| match (state as *const Saved).as_ref() {
            Some(s) => i.load(s),
            None => i.refuse("fmi2SetFMUstate: null FMUstate"),
        })
    }
}

/// `fmi2FreeFMUstate`.
///
/// # Safety
/// `state` a valid pointer to a state from [`get_state`] or null.
pub unsafe fn free_state(c: *mut c_void, state: *mut *mut c_void) -> Status {
    // SAFETY: as documented.
    unsafe {
        with_instance(c, |_| {
            if !state.is_null() && !(*state).is_null() {
                drop(Box::from_raw(*state as *mut Saved));
                *state = std::ptr::null_mut();
            }
            OK
        })
    }
}

/// Exported functions that read or write variables share this: convert
/// between the C type and f64.
///
/// # Safety
/// `c` from [`instantiate`]; `vr` and `value` arrays of `n` elements.
pub unsafe fn get_values<T: Copy>(c: *mut c_void, vr: *const c_uint, n: usize, value: *mut T, kind: Kind, convert: fn(f64) -> T) -> Status {
    // SAFETY: as documented.
    unsafe {
        with_instance(c, |i| {
            let vr = slice(vr, n);
            let out = slice_mut(value, n);
            if vr.len() != n || out.len() != n {
                return i.refuse("get: null array");
            }
            let mut buffer = vec![0.0; n];
            let status = i.get(vr, kind, &mut buffer);
            if status == OK {
                for (o, b) in out.iter_mut().zip(&buffer) {
                    *o = convert(*b);
                }
            }
            status
        })
    }
}

/// The setter counterpart of [`get_values`].
///
/// # Safety
/// As [`get_values`].
pub unsafe fn set_values<T: Copy>(c: *mut c_void, vr: *const c_uint, n: usize, value: *const T, kind: Kind, convert: fn(T) -> f64) -> Status {
    // SAFETY: as documented.
    unsafe {
        with_instance(c, |i| {
            let vr = slice(vr, n);
            let input = slice(value, n);
            if vr.len() != n || input.len() != n {
                return i.refuse("set: null array");
            }
            let buffer: Vec<f64> = input.iter().map(|&x| convert(x)).collect();
            i.set(vr, kind, &buffer)
        })
    }
}

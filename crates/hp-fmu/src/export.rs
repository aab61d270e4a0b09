//! The exported `fmi2*` symbols: thin C wrappers over [`crate::fmi2`].
//! Every body runs under `catch_unwind` (through `with_instance` or
//! `instantiate`); pointers are checked for null before use.
#![allow(non_snake_case, clippy::missing_safety_doc)]

use crate::fmi2::{self, with_instance, CallbackFunctions, Status, DISCARD, ERROR, OK};
use crate::model::Kind;
use std::ffi::{c_char, c_int, c_uint, c_void};

type Component = *mut c_void;

#[no_mangle]
pub extern "C" fn fmi2GetTypesPlatform() -> *const c_char {
    c"default".as_ptr()
}

#[no_mangle]
pub extern "C" fn fmi2GetVersion() -> *const c_char {
    c"2.0".as_ptr()
}

#[no_mangle]
pub unsafe extern "C" fn fmi2SetDebugLogging(c: Component, logging_on: c_int, _n: usize, _categories: *const *const c_char) -> Status {
    // SAFETY: c is an instance pointer (or null, refused).
    unsafe {
        with_instance(c, |i| {
            i.set_logging(logging_on != 0);
            OK
        })
    }
}

#[no_mangle]
pub unsafe extern "C" fn fmi2Instantiate(
    name: *const c_char,
    fmu_type: c_int,
    guid: *const c_char,
    _resource_location: *const c_char,
    functions: *const CallbackFunctions,
    _visible: c_int,
    logging_on: c_int,
) -> Component {
    // SAFETY: arguments as the importer passes them.
    unsafe { fmi2::instantiate(crate::registry, name, fmu_type, guid, functions, logging_on) }
}

#[no_mangle]
pub unsafe extern "C" fn fmi2FreeInstance(c: Component) {
    // SAFETY: c from fmi2Instantiate.
    unsafe { fmi2::free_instance(c) }
}

#[no_mangle]
pub unsafe extern "C" fn fmi2SetupExperiment(c: Component, _tol_defined: c_int, _tol: f64, start: f64, stop_defined: c_int, stop: f64) -> Status {
    // SAFETY: c from fmi2Instantiate.
    unsafe { with_instance(c, |i| i.setup_experiment(start, (stop_defined != 0).then_some(stop))) }
}

#[no_mangle]
pub unsafe extern "C" fn fmi2EnterInitializationMode(c: Component) -> Status {
    // SAFETY: c from fmi2Instantiate.
    unsafe { with_instance(c, |i| i.enter_initialization()) }
}

#[no_mangle]
pub unsafe extern "C" fn fmi2ExitInitializationMode(c: Component) -> Status {
    // SAFETY: c from fmi2Instantiate.
    unsafe { with_instance(c, |i| i.exit_initialization()) }
}

#[no_mangle]
pub unsafe extern "C" fn fmi2Terminate(c: Component) -> Status {
    // SAFETY: c from fmi2Instantiate.
    unsafe { with_instance(c, |i| i.terminate()) }
}

#[no_mangle]
pub unsafe extern "C" fn fmi2Reset(c: Component) -> Status {
    // SAFETY: c from fmi2Instantiate.
    unsafe { with_instance(c, |i| i.reset()) }
}

#[no_mangle]
pub unsafe extern "C" fn fmi2GetReal(c: Component, vr: *const c_uint, n: usize, value: *mut f64) -> Status {
    // SAFETY: arrays of n elements.
    unsafe { fmi2::get_values(c, vr, n, value, Kind::Real, |x| x) }
}

#[no_mangle]
pub unsafe extern "C" fn fmi2GetInteger(c: Component, vr: *const c_uint, n: usize, value: *mut c_int) -> Status {
    // SAFETY: arrays of n elements.
    unsafe { fmi2::get_values(c, vr, n, value, Kind::Integer, |x| x as c_int) }
}

#[no_mangle]
pub unsafe extern "C" fn fmi2GetBoolean(c: Component, vr: *const c_uint, n: usize, value: *mut c_int) -> Status {
    // SAFETY: arrays of n elements.
    unsafe { fmi2::get_values(c, vr, n, value, Kind::Boolean, |x| c_int::from(x != 0.0)) }
}

#[no_mangle]
pub unsafe extern "C" fn fmi2GetString(c: Component, vr: *const c_uint, n: usize, _value: *mut *const c_char) -> Status {
    // SAFETY: c from fmi2Instantiate.
    unsafe { no_strings(c, vr, n) }
}

#[no_mangle]
pub unsafe extern "C" fn fmi2SetReal(c: Component, vr: *const c_uint, n: usize, value: *const f64) -> Status {
    // SAFETY: arrays of n elements.
    unsafe { fmi2::set_values(c, vr, n, value, Kind::Real, |x| x) }
}

#[no_mangle]
pub unsafe extern "C" fn fmi2SetInteger(c: Component, vr: *const c_uint, n: usize, value: *const c_int) -> Status {
    // SAFETY: arrays of n elements.
    unsafe { fmi2::set_values(c, vr, n, value, Kind::Integer, f64::from) }
}

#[no_mangle]
pub unsafe extern "C" fn fmi2SetBoolean(c: Component, vr: *const c_uint, n: usize, value: *const c_int) -> Status {
    // SAFETY: arrays of n elements.
    unsafe { fmi2::set_values(c, vr, n, value, Kind::Boolean, |x| if x != 0 { 1.0 } else { 0.0 }) }
}

#[no_mangle]
pub unsafe extern "C" fn fmi2SetString(c: Component, vr: *const c_uint, n: usize, _value: *const *const c_char) -> Status {
    // SAFETY: c from fmi2Instantiate.
    unsafe { no_strings(c, vr, n) }
}

/// The models have no string variables.
unsafe fn no_strings(c: Component, vr: *const c_uint, n: usize) -> Status {
    // SAFETY: c from fmi2Instantiate; vr an array of n elements.
    unsafe {
        with_instance(c, |i| {
            if n == 0 {
                return OK;
            }
            let r = fmi2::slice(vr, n).first().copied().unwrap_or(0);
            i.log(ERROR, "logStatusError", &format!("value reference {r}: this model has no String variables"));
            ERROR
        })
    }
}

#[no_mangle]
pub unsafe extern "C" fn fmi2GetFMUstate(c: Component, state: *mut *mut c_void) -> Status {
    // SAFETY: as the standard defines them.
    unsafe { fmi2::get_state(c, state) }
}

#[no_mangle]
pub unsafe extern "C" fn fmi2SetFMUstate(c: Component, state: *mut c_void) -> Status {
    // SAFETY: as the standard defines them.
    unsafe { fmi2::set_state(c, state) }
}

#[no_mangle]
pub unsafe extern "C" fn fmi2FreeFMUstate(c: Component, state: *mut *mut c_void) -> Status {
    // SAFETY: as the standard defines them.
    unsafe { fmi2::free_state(c, state) }
}

/// Declared unsupported (`canSerializeFMUstate` is false).
unsafe fn unsupported(c: Component, what: &str) -> Status {
    // SAFETY: c from fmi2Instantiate.
    unsafe {
        with_instance(c, |i| {
            i.log(ERROR, "logStatusError", &format!("{what} is not supported by this FMU (see its model description)"));
            ERROR
        })
    }
}

#[no_mangle]
pub unsafe extern "C" fn fmi2SerializedFMUstateSize(c: Component, _state: *mut c_void, _size: *mut usize) -> Status {
    // SAFETY: c from fmi2Instantiate.
    unsafe { unsupported(c, "fmi2SerializedFMUstateSize") }
}

#[no_mangle]
pub unsafe extern "C" fn fmi2SerializeFMUstate(c: Component, _state: *mut c_void, _bytes: *mut c_char, _size: usize) -> Status {
    // SAFETY: c from fmi2Instantiate.
    unsafe { unsupported(c, "fmi2SerializeFMUstate") }
}

#[no_mangle]
pub unsafe extern "C" fn fmi2DeSerializeFMUstate(c: Component, _bytes: *const c_char, _size: usize, _state: *mut *mut c_void) -> Status {
    // SAFETY: c from fmi2Instantiate.
    unsafe { unsupported(c, "fmi2DeSerializeFMUstate") }
}

#[no_mangle]
pub unsafe extern "C" fn fmi2GetDirectionalDerivative(
    c: Component,
    _unknown: *const c_uint,
    _n_unknown: usize,
    _known: *const c_uint,
    _n_known: usize,
    _dv_known: *const f64,
    _dv_unknown: *mut f64,
) -> Status {
    // SAFETY: c from fmi2Instantiate.
    unsafe { unsupported(c, "fmi2GetDirectionalDerivative") }
}

#[no_mangle]
pub unsafe extern "C" fn fmi2SetRealInputDerivatives(c: Component, vr: *const c_uint, n: usize, order: *const c_int, value: *const f64) -> Status {
    // SAFETY: arrays of n elements.
    unsafe {
        with_instance(c, |i| {
            let (vr, order, value) = (fmi2::slice(vr, n), fmi2::slice(order, n), fmi2::slice(value, n));
            if vr.len() != n || order.len() != n || value.len() != n {
                return ERROR;
            }
            i.set_input_derivatives(vr, order, value)
        })
    }
}

#[no_mangle]
pub unsafe extern "C" fn fmi2GetRealOutputDerivatives(c: Component, _vr: *const c_uint, _n: usize, _order: *const c_int, _value: *mut f64) -> Status {
    // SAFETY: c from fmi2Instantiate.
    unsafe { unsupported(c, "fmi2GetRealOutputDerivatives (maxOutputDerivativeOrder is 0)") }
}

#[no_mangle]
pub unsafe extern "C" fn fmi2DoStep(c: Component, t: f64, h: f64, _no_set_prior: c_int) -> Status {
    // SAFETY: c from fmi2Instantiate.
    unsafe { with_instance(c, |i| i.do_step(t, h)) }
}

#[no_mangle]
pub unsafe extern "C" fn fmi2CancelStep(c: Component) -> Status {
    // SAFETY: c from fmi2Instantiate.
    unsafe { unsupported(c, "fmi2CancelStep (steps are synchronous)") }
}

/// `fmi2StatusKind`: 0 DoStepStatus, 1 PendingStatus, 2 LastSuccessfulTime, 3 Terminated.
#[no_mangle]
pub unsafe extern "C" fn fmi2GetStatus(c: Component, kind: c_int, value: *mut Status) -> Status {
    // SAFETY: value a valid pointer or null.
    unsafe {
        with_instance(c, |_| match (kind, value.as_mut()) {
            (0, Some(v)) => {
                *v = OK;
                OK
            }
            _ => DISCARD,
        })
    }
}

#[no_mangle]
pub unsafe extern "C" fn fmi2GetRealStatus(c: Component, kind: c_int, value: *mut f64) -> Status {
    // SAFETY: value a valid pointer or null.
    unsafe {
        with_instance(c, |i| match (kind, value.as_mut()) {
            (2, Some(v)) => {
                *v = i.time_s;
                OK
            }
            _ => DISCARD,
        })
    }
}

#[no_mangle]
pub unsafe extern "C" fn fmi2GetIntegerStatus(c: Component, _kind: c_int, _value: *mut c_int) -> Status {
    // SAFETY: c from fmi2Instantiate.
    unsafe { with_instance(c, |_| DISCARD) }
}

#[no_mangle]
pub unsafe extern "C" fn fmi2GetBooleanStatus(c: Component, kind: c_int, value: *mut c_int) -> Status {
    // SAFETY: value a valid pointer or null.
    unsafe {
        with_instance(c, |_| match (kind, value.as_mut()) {
            (3, Some(v)) => {
                *v = 0;
                OK
            }
            _ => DISCARD,
        })
    }
}

#[no_mangle]
pub unsafe extern "C" fn fmi2GetStringStatus(c: Component, _kind: c_int, _value: *mut *const c_char) -> Status {
    // SAFETY: c from fmi2Instantiate.
    unsafe { with_instance(c, |_| DISCARD) }
}

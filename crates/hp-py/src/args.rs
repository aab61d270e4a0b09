//! Arguments of the Python API that pyo3 would otherwise convert itself:
//! its conversion errors are a bare `TypeError` or `OverflowError`, not the
//! `ParameterError` (a `ValueError`) naming the argument, its value and
//! what was expected that every other bad input raises.

use crate::errors::bad_argument;
use numpy::PyReadonlyArray1;
use pyo3::buffer::PyBuffer;
use pyo3::prelude::*;
use pyo3::types::PyBool;

/// A one-dimensional array of numbers: a float64 numpy array is copied in
/// one go; any other array or sequence of real numbers is converted by
/// numpy (ints, bools, lists). Strings, objects, other shapes are refused.
pub fn f64_array(obj: &Bound<'_, PyAny>, name: &str) -> PyResult<Vec<f64>> {
    if let Ok(a) = obj.extract::<PyReadonlyArray1<'_, f64>>() {
        return Ok(a.as_slice().map(<[f64]>::to_vec).unwrap_or_else(|_| a.as_array().to_vec()));
    }
    let expected = "a one-dimensional array or sequence of real numbers";
    if obj.is_instance_of::<pyo3::types::PyString>() || obj.is_instance_of::<pyo3::types::PyBytes>() {
        return Err(bad_argument(name, obj, expected));
    }
    let np = obj.py().import("numpy")?;
    let converted = np
        .call_method1("asarray", (obj, "float64"))
        .map_err(|_| bad_argument(name, obj, expected))?;
    let a: PyReadonlyArray1<'_, f64> = converted.extract().map_err(|_| bad_argument(name, obj, expected))?;
    Ok(a.as_array().to_vec())
}

/// An integer within `[min, max]` (Python ints and numpy integers; not
/// bools, not floats, even whole ones: an identifier or a counter given
/// as 1.0 is a mistake upstream).
pub fn int_arg(obj: &Bound<'_, PyAny>, name: &str, min: i64, max: i64, what: &str) -> PyResult<i64> {
    let expected = format!("{what}: an integer within [{min}, {max}] ({min:#x}..={max:#x})");
    if obj.is_instance_of::<PyBool>() {
        return Err(bad_argument(name, obj, &expected));
    }
    match obj.extract::<i64>() {
        Ok(v) if (min..=max).contains(&v) => Ok(v),
        _ => Err(bad_argument(name, obj, &expected)),
    }
}

/// Bytes from anything with the buffer protocol of unsigned bytes:
/// `bytes`, `bytearray` (python-can's `Message.data`), `memoryview`,
/// `array('B')`, a numpy uint8 array.
pub fn bytes_arg(obj: &Bound<'_, PyAny>, name: &str) -> PyResult<Vec<u8>> {
    let expected = "bytes, a bytearray or a memoryview of unsigned bytes";
    let buffer = PyBuffer::<u8>::get(obj).map_err(|_| bad_argument(name, obj, expected))?;
    buffer.to_vec(obj.py()).map_err(|_| bad_argument(name, obj, expected))
}

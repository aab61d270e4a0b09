//! The CAN codec and the ECU application (`hp_ctrl::can`) from Python:
//! frames as `(identifier, bytes)`, signals by their DBC names. Thin: the
//! codec's own checks decide; structurally wrong calls (unknown message,
//! missing or unknown signal, a counter or identifier out of its range,
//! more than 8 bytes) raise `ParameterError`, a frame the codec rejects
//! raises `CanRejectError`.

use crate::args::{bytes_arg, int_arg};
use crate::errors::{bad_argument, guard, parameter, HpctlError};
use crate::params::Reader;
use hp_ctrl::can::ecu::{self, Link};
use hp_ctrl::can::embedded_can::{ExtendedId, Frame, Id, StandardId};
use hp_ctrl::can::{self as codec, e2e, CanFrame, Kind, Reject};
use pyo3::prelude::*;
use pyo3::types::{PyBytes, PyDict};

pyo3::create_exception!(
    _core,
    CanRejectError,
    HpctlError,
    "A CAN frame the codec rejects; args are (message, reason), the reason one of unknown_id, length, crc, repeated, skipped, range."
);

fn reason(r: Reject) -> &'static str {
    match r {
        Reject::UnknownId => "unknown_id",
        Reject::Length => "length",
        Reject::Crc => "crc",
        Reject::Repeated => "repeated",
        Reject::Skipped => "skipped",
        Reject::Range => "range",
    }
}

fn rejected(r: Reject) -> PyErr {
    CanRejectError::new_err((format!("frame rejected: {}", reason(r)), reason(r)))
}

/// Largest extended (29-bit) identifier.
const EXTENDED_ID_MAX: i64 = 0x1FFF_FFFF;

/// A frame from Python arguments: the identifier (an int), the data
/// (bytes, bytearray or memoryview) and whether the identifier is extended.
fn frame_arg(id: &Bound<'_, PyAny>, data: &Bound<'_, PyAny>, extended: bool) -> PyResult<CanFrame> {
    let max = if extended { EXTENDED_ID_MAX } else { 0x7FF };
    let what = if extended { "an extended identifier (29 bits)" } else { "a standard identifier (11 bits; extended=True for 29)" };
    let raw = int_arg(id, "id", 0, max, what)?;
    let bytes = bytes_arg(data, "data")?;
    frame_from(u32::try_from(raw).unwrap_or(u32::MAX), &bytes, extended)
}

/// A frame from its identifier (standard unless `extended`) and data.
fn frame_from(id: u32, data: &[u8], extended: bool) -> PyResult<CanFrame> {
    let id: Id = if extended {
        ExtendedId::new(id).ok_or_else(|| parameter(format!("extended id = {id:#x} must be below 0x20000000")))?.into()
    } else {
        let raw = u16::try_from(id).ok().and_then(StandardId::new);
        raw.ok_or_else(|| parameter(format!("id = {id:#x} must be a standard identifier (below 0x800)")))?.into()
    };
    CanFrame::new(id, data).ok_or_else(|| parameter(format!("data has {} bytes; a classic CAN frame carries at most 8", data.len())))
}

fn frame_to_py<'py>(py: Python<'py>, f: &CanFrame) -> (u32, Bound<'py, PyBytes>) {
    let id = match f.id() {
        Id::Standard(id) => u32::from(id.as_raw()),
        Id::Extended(id) => id.as_raw(),
    };
    (id, PyBytes::new(py, f.data()))
}

/// A signal whose values are whole numbers: a flag, an enumeration, a
/// counter or a bit set (no unit, raw = physical). Rounding a value of
/// such a signal would send another state than the caller meant.
fn is_whole(sd: &codec::messages::SignalDef) -> bool {
    sd.unit.is_empty() && sd.signal.factor == 1.0 && sd.signal.offset == 0.0
}

/// Encodes message `name` (DBC spelling) with alive counter `counter`
/// (0..=14): `values` maps every signal of the message to its physical
/// value (rounded to the nearest LSB; flags, enumerations and counts must
/// be whole numbers). Returns `(identifier, 8 bytes)`.
#[pyfunction]
fn can_encode<'py>(py: Python<'py>, name: &str, counter: &Bound<'py, PyAny>, values: &Bound<'py, PyAny>) -> PyResult<(u32, Bound<'py, PyBytes>)> {
    guard(|| {
        let kind = Kind::from_name(name).ok_or_else(|| {
            let names: Vec<&str> = Kind::ALL.iter().map(|k| k.name()).collect();
            parameter(format!("unknown message {name:?} (one of: {})", names.join(", ")))
        })?;
        let counter = int_arg(counter, "counter", 0, i64::from(e2e::COUNTER_MAX), "the alive counter")?;
        let counter = u8::try_from(counter).unwrap_or(u8::MAX);
        let mut r = Reader::new(values, "values")?;
        let mut payload = [0u8; 8];
        for sd in kind.signals() {
            let x = r.f64(sd.name)?;
            if is_whole(sd) && x.fract() != 0.0 {
                let path = format!("values.{}", sd.name);
                let shown = x.into_pyobject(py)?.into_any();
                return Err(bad_argument(&path, &shown, "a whole number (a flag, an enumeration or a count)"));
            }
            sd.signal
                .put(&mut payload, x)
                .map_err(|_| parameter(format!("values.{} = {x} is not finite or outside the signal's range", sd.name)))?;
        }
        r.finish()?;
        let msg = codec::read_payload(kind, &payload).map_err(rejected)?;
        let frame = codec::encode(&msg, counter, kind.def().source).map_err(|_| parameter(format!("{name}: a value is outside its range")))?;
        Ok(frame_to_py(py, &frame))
    })
}

/// Decodes one frame (stateless: identifier, length, CRC, counter value,
/// reserved bits and signal ranges are checked; the counter sequence is
/// the receiver's job). Returns `(message name, counter, {signal: value})`.
#[pyfunction]
#[pyo3(signature = (id, data, extended=true))]
fn can_decode<'py>(py: Python<'py>, id: &Bound<'py, PyAny>, data: &Bound<'py, PyAny>, extended: bool) -> PyResult<(&'static str, u8, Bound<'py, PyDict>)> {
    guard(|| {
        let frame = frame_arg(id, data, extended)?;
        let (msg, counter) = codec::decode(&frame).map_err(rejected)?;
        let kind = msg.kind();
        let payload = codec::encode(&msg, counter, kind.def().source).map_err(|_| parameter("decoded message does not re-encode"))?;
        let values = PyDict::new(py);
        for sd in kind.signals() {
            values.set_item(sd.name, sd.signal.get(payload.payload()).unwrap_or(f64::NAN))?;
        }
        Ok((kind.name(), counter, values))
    })
}

/// Collects what the ECU sends in one period.
#[derive(Default)]
struct Sent(Vec<CanFrame>);

impl Link for Sent {
    fn receive(&mut self) -> Option<CanFrame> {
        None
    }
    fn transmit(&mut self, frame: &CanFrame) -> bool {
        self.0.push(*frame);
        true
    }
}

/// The ECU application for 4 or 8 corners, with a built-in calibration.
enum AnyEcu {
    Four(Box<ecu::Ecu<'static, 4>>),
    Eight(Box<ecu::Ecu<'static, 8>>),
}

/// The ECU application, `hp_ctrl::can::ecu::Ecu<N>` for `corners` = 4 or
/// 8: the code the firmware runs, on the host (the reference of
/// processor-in-the-loop tests), with the calibration the firmware has
/// (`hp_ctrl::calibration`): `"seed"` (production: `hp-fw-mps2`,
/// `hp-fw-stm32f4`) or `"pil"` (the gas-charge detector in seconds:
/// `hp-fw-pil`, `hp-fw-pil8`). Power-on: every corner in its safe state,
/// every input message stale, the address claim due.
#[pyclass(module = "hpctl._core", unsendable)]
pub struct Ecu {
    ecu: AnyEcu,
}

macro_rules! with_ecu {
    ($self:expr, $e:ident => $body:expr) => {
        match &mut $self.ecu {
            AnyEcu::Four($e) => $body,
            AnyEcu::Eight($e) => $body,
        }
    };
}

#[pymethods]
impl Ecu {
    #[new]
    #[pyo3(signature = (corners=4, calibration="seed", identity_number=1))]
    fn new(corners: i64, calibration: &str, identity_number: u32) -> PyResult<Self> {
        use hp_ctrl::calibration::{PIL_4, PIL_8, SEED_4, SEED_8};
        guard(|| {
            if identity_number >= 1 << 21 {
                return Err(parameter(format!("identity_number = {identity_number} must be within [0, 2097151] (21 bits)")));
            }
            let pil = match calibration {
                "seed" => false,
                "pil" => true,
                _ => return Err(parameter(format!("calibration = {calibration:?} must be \"seed\" or \"pil\""))),
            };
            let ecu = match corners {
                4 => AnyEcu::Four(Box::new(ecu::Ecu::new(if pil { &PIL_4 } else { &SEED_4 }, identity_number))),
                8 => AnyEcu::Eight(Box::new(ecu::Ecu::new(if pil { &PIL_8 } else { &SEED_8 }, identity_number))),
                _ => return Err(parameter(format!("corners = {corners} must be 4 or 8"))),
            };
            Ok(Ecu { ecu })
        })
    }

    /// Number of corners.
    #[getter]
    fn corners(&self) -> usize {
        match &self.ecu {
            AnyEcu::Four(_) => 4,
            AnyEcu::Eight(_) => 8,
        }
    }

    /// Frames that could not be queued for sending.
    #[getter]
    fn tx_dropped(&mut self) -> u32 {
        with_ecu!(self, e => e.tx_dropped)
    }

    /// The source address the ECU holds (0xFE once it could not claim one).
    #[getter]
    fn address(&mut self) -> u8 {
        with_ecu!(self, e => e.network().address())
    }

    /// The active trouble codes as `(spn, fmi, occurrence_count)`.
    fn dtcs(&mut self) -> Vec<(u32, u8, u8)> {
        with_ecu!(self, e => e.dtcs().active().map(|d| (d.spn, d.fmi, d.occurrence_count)).collect())
    }

    /// Feeds one received frame to the ECU (a rejected frame is counted in
    /// its diagnostics, not raised). Returns the tick index if it was an
    /// accepted `HP_PilTick`, else None.
    #[pyo3(signature = (id, data, extended=true))]
    fn receive(&mut self, id: &Bound<'_, PyAny>, data: &Bound<'_, PyAny>, extended: bool) -> PyResult<Option<u16>> {
        guard(|| {
            let frame = frame_arg(id, data, extended)?;
            Ok(with_ecu!(self, e => e.receive(&frame)))
        })
    }

    /// Closes one control period: the vehicle step on what was received,
    /// and the frames the ECU sends in it, as `(identifier, bytes)` in
    /// sending order.
    fn period<'py>(&mut self, py: Python<'py>) -> PyResult<Vec<(u32, Bound<'py, PyBytes>)>> {
        guard(|| {
            let mut sent = Sent::default();
            with_ecu!(self, e => { e.period(&mut sent); });
            Ok(sent.0.iter().map(|f| frame_to_py(py, f)).collect())
        })
    }
}

/// Registers the functions, the class and the exception on the module.
pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add("CanRejectError", m.py().get_type::<CanRejectError>())?;
    m.add_function(wrap_pyfunction!(can_encode, m)?)?;
    m.add_function(wrap_pyfunction!(can_decode, m)?)?;
    m.add_class::<Ecu>()?;
    Ok(())
}

//! CAN codec: the frames of `python/hpctl/data/hpctl.dbc` (SAE J1939), the
//! ECU's own ones end-to-end protected.
//!
//! - [`messages`]: PGNs, data IDs, timing and signals of the ECU's
//!   proprietary messages (mirroring the DBC), one typed struct per
//!   message and [`Message`].
//! - [`j1939`]: NAME and address claim, requests, DM1 with the
//!   controller's faults as SPN/FMI, the transport protocol (BAM).
//! - [`e2e`]: the AUTOSAR-profile-11-style CRC-8 and alive counter.
//! - [`signal`]: fixed-point bit fields.
//! - [`rx`]: the ECU's receive side, which fills the vehicle step's inputs,
//!   marks fresh input groups and supervises the link (timeouts, reject
//!   window).
//! - [`tx`]: per-message alive counters for sending, and the ECU's output
//!   messages built from the vehicle step's outputs.
//! - [`ecu`]: the ECU application (receive, one control period, send),
//!   shared by the firmware and the host reference.
//! - [`slcan`]: SLCAN (Lawicel) text framing for the emulator link.
//! - [`frame`]: a plain [`embedded_can::Frame`] for host and emulator use.
//!
//! Every function is `no_std`, allocation-free and panic-free. Decoding
//! never trusts the frame: a standard identifier or an unknown PGN, a
//! wrong length, a wrong CRC, an invalid counter, a set reserved or unused
//! bit, or a signal outside its DBC range is a [`Reject`]. `docs/can.md`
//! describes the frames and the E2E parameters with test vectors.
//!
//! ```
//! use hp_ctrl::can::{decode, encode, Message, messages::{address, Pressures}};
//!
//! let msg = Message::CornerPressures(1, Pressures { p_gas_pa: 8.0e6, p_gas2_pa: 7.5e6 });
//! let frame = encode(&msg, 3, address::SENSORS).unwrap();
//! let (back, counter) = decode(&frame).unwrap();
//! assert_eq!((back, counter), (msg, 3));
//! ```

pub mod e2e;
pub mod ecu;
pub mod frame;
pub mod j1939;
pub mod messages;
pub mod rx;
pub mod signal;
pub mod slcan;
pub mod tx;

/// The frame traits and identifiers the codec works with, re-exported so a
/// user (the Python bindings) names the very same version.
pub use embedded_can;
pub use frame::CanFrame;
pub use messages::{Kind, Message, MessageDef};
pub use rx::{Accepted, InputDecoder, LinkParams};
pub use signal::EncodeError;
pub use tx::Transmitter;

use embedded_can::{ExtendedId, Frame, Id};

/// Why a received frame was not used. Each reason has its own counter in
/// `HP_DiagE2E`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Reject {
    /// Not an extended identifier with the PGN of a message this receiver
    /// expects.
    UnknownId,
    /// Not a data frame of exactly 8 bytes.
    Length,
    /// The CRC does not match the payload and the message's data ID.
    Crc,
    /// The alive counter did not change: a repeated frame.
    Repeated,
    /// The alive counter moved by more than one: frames lost or reordered.
    Skipped,
    /// Counter 15, a set reserved or unused bit, or a signal outside its
    /// DBC range.
    Range,
}

/// Encodes `msg` with alive counter `counter` (taken modulo 15) into a
/// protected frame from source address `source`.
pub fn encode(msg: &Message, counter: u8, source: u8) -> Result<CanFrame, EncodeError> {
    protect(msg.kind(), msg.signal_bits()?, counter, source)
}

/// [`encode`] for the ECU's sending side: only the messages the ECU sends
/// (`OutOfRange` for others), so the firmware does not link the encoding
/// of its inputs.
pub fn encode_output(msg: &Message, counter: u8, source: u8) -> Result<CanFrame, EncodeError> {
    protect(msg.kind(), msg.output_bits()?, counter, source)
}

fn protect(kind: Kind, signal_bits: u64, counter: u8, source: u8) -> Result<CanFrame, EncodeError> {
    let def = kind.def();
    let mut payload = signal_bits.to_le_bytes();
    e2e::protect(&mut payload, def.data_id, counter);
    let id = ExtendedId::new(messages::j1939_id(def.priority, def.pgn, source)).ok_or(EncodeError::OutOfRange)?;
    Ok(CanFrame::extended(id, payload))
}

/// The stateless checks of a received frame, in order: identifier (an
/// extended one with a PGN of the database, from any source address),
/// length, CRC, counter value. Returns the message kind, the payload and
/// the counter; the signals are not read yet.
pub fn check_frame<F: Frame>(frame: &F) -> Result<(Kind, [u8; 8], u8), Reject> {
    let Id::Extended(id) = frame.id() else {
        return Err(Reject::UnknownId);
    };
    let kind = Kind::from_pgn(j1939::J1939Id::of_raw(id.as_raw()).pgn).ok_or(Reject::UnknownId)?;
    if frame.is_remote_frame() || frame.dlc() != 8 {
        return Err(Reject::Length);
    }
    let payload: [u8; 8] = frame.data().try_into().map_err(|_| Reject::Length)?;
    if !e2e::crc_ok(&payload, kind.def().data_id) {
        return Err(Reject::Crc);
    }
    let counter = e2e::counter(&payload);
    if counter > e2e::COUNTER_MAX {
        return Err(Reject::Range);
    }
    Ok((kind, payload, counter))
}

/// Reads the signals of a checked payload: rejects set reserved or unused
/// bits and out-of-range values.
pub fn read_payload(kind: Kind, payload: &[u8; 8]) -> Result<Message, Reject> {
    no_stray_bits(kind, payload)?;
    Message::read(kind, payload).ok_or(Reject::Range)
}

/// [`read_payload`] for the ECU's receiver: only the messages sent to the
/// ECU (a message the ECU sends is [`Reject::Range`]), so the firmware
/// does not link the decoding of its own messages.
pub fn read_input_payload(kind: Kind, payload: &[u8; 8]) -> Result<Message, Reject> {
    no_stray_bits(kind, payload)?;
    Message::read_input(kind, payload).ok_or(Reject::Range)
}

fn no_stray_bits(kind: Kind, payload: &[u8; 8]) -> Result<(), Reject> {
    if u64::from_le_bytes(*payload) & !kind.def().defined_bits != 0 {
        return Err(Reject::Range);
    }
    Ok(())
}

/// Stateless decode of any message of the database: [`check_frame`], then
/// [`read_payload`]. The alive-counter sequence is the receiver's job
/// ([`e2e::CounterState`], [`InputDecoder`]).
pub fn decode<F: Frame>(frame: &F) -> Result<(Message, u8), Reject> {
    let (kind, payload, counter) = check_frame(frame)?;
    Ok((read_payload(kind, &payload)?, counter))
}

#[cfg(test)]
#[allow(clippy::unwrap_used, clippy::indexing_slicing, clippy::panic)] // Tests may panic.
mod tests;

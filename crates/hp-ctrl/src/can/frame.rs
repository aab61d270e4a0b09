//! A plain classic-CAN frame that implements [`embedded_can::Frame`].
//!
//! The codec works on any `embedded_can::Frame`; this one is for the places
//! that have no driver frame type of their own: the host, tests, the
//! emulator's SLCAN link.

use embedded_can::{ExtendedId, Frame, Id, StandardId};

/// Maximum data length of a classic CAN frame, bytes.
pub const MAX_DLC: usize = 8;

/// A classic CAN 2.0 frame: identifier, remote flag, DLC and up to 8 bytes.
///
/// ```
/// use embedded_can::{Frame, StandardId};
/// use hp_ctrl::can::CanFrame;
///
/// let id = StandardId::new(0x100).unwrap();
/// let frame = CanFrame::new(id, &[1, 2, 3]).unwrap();
/// assert_eq!(frame.dlc(), 3);
/// assert_eq!(frame.data(), &[1, 2, 3]);
/// assert!(CanFrame::new(id, &[0; 9]).is_none());
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct CanFrame {
    id: Id,
    remote: bool,
    dlc: u8,
    data: [u8; MAX_DLC],
}

impl CanFrame {
    /// A data frame with a standard identifier and a full 8-byte payload.
    pub fn standard(id: StandardId, data: [u8; MAX_DLC]) -> Self {
        CanFrame { id: Id::Standard(id), remote: false, dlc: MAX_DLC as u8, data }
    }

    /// A data frame with an extended (29-bit, J1939) identifier and a full
    /// 8-byte payload.
    pub fn extended(id: ExtendedId, data: [u8; MAX_DLC]) -> Self {
        CanFrame { id: Id::Extended(id), remote: false, dlc: MAX_DLC as u8, data }
    }

    /// The payload as a fixed array; bytes past the DLC are zero.
    pub fn payload(&self) -> &[u8; MAX_DLC] {
        &self.data
    }
}

impl Frame for CanFrame {
    fn new(id: impl Into<Id>, data: &[u8]) -> Option<Self> {
        let mut buf = [0u8; MAX_DLC];
        buf.get_mut(..data.len())?.copy_from_slice(data);
        Some(CanFrame { id: id.into(), remote: false, dlc: data.len() as u8, data: buf })
    }

    fn new_remote(id: impl Into<Id>, dlc: usize) -> Option<Self> {
        (dlc <= MAX_DLC).then(|| CanFrame { id: id.into(), remote: true, dlc: dlc as u8, data: [0; MAX_DLC] })
    }

    fn is_extended(&self) -> bool {
        matches!(self.id, Id::Extended(_))
    }

    fn is_remote_frame(&self) -> bool {
        self.remote
    }

    fn id(&self) -> Id {
        self.id
    }

    fn dlc(&self) -> usize {
        usize::from(self.dlc)
    }

    fn data(&self) -> &[u8] {
        if self.remote {
            return &[];
        }
        self.data.get(..usize::from(self.dlc)).unwrap_or(&[])
    }
}

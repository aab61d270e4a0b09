//! SLCAN (Lawicel) ASCII framing of classic CAN frames, as USB-CAN
//! adapters and python-can's `slcan` interface speak it.
//!
//! Lines end with `\r`. Frames: `tIIIL<data>` (standard), `TIIIIIIIIL<data>`
//! (extended), `rIIIL` / `RIIIIIIIIL` (remote), upper- or lower-case hex.
//! Commands: `O` open, `L` open listen-only, `C` close, `S0`..`S9` bit
//! rate, `sXXYY` bit timing, `V` version, `N` serial number, `F` status,
//! `Z0`/`Z1` timestamps, `M`/`m` acceptance filter. An adapter answers `\r`
//! (ok) or `\x07` (error); [`Adapter`] implements those answers.

use embedded_can::{ExtendedId, Frame, Id, StandardId};

use super::frame::CanFrame;

/// Longest line: `T` + 8 id + 1 dlc + 16 data = 26 characters.
pub const MAX_LINE: usize = 26;
/// Longest encoded frame including the `\r`.
pub const MAX_FRAME_TEXT: usize = MAX_LINE + 1;

/// Positive answer.
pub const OK: u8 = b'\r';
/// Negative answer (BEL).
pub const ERROR: u8 = 0x07;

/// One parsed line.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Command {
    Open,
    ListenOnly,
    Close,
    /// `S0`..`S9`.
    Bitrate(u8),
    /// `sXXYY`.
    BitTiming,
    Version,
    Serial,
    Status,
    /// `Z0`/`Z1`.
    Timestamps(bool),
    /// `M...`/`m...`.
    Filter,
    /// An empty line.
    Empty,
    /// A frame to send on the bus.
    Frame(CanFrame),
    /// Anything else, or a line too long or malformed.
    Invalid,
}

fn hex_digit(c: u8) -> Option<u8> {
    match c {
        b'0'..=b'9' => Some(c - b'0'),
        b'A'..=b'F' => Some(c - b'A' + 10),
        b'a'..=b'f' => Some(c - b'a' + 10),
        _ => None,
    }
}

fn hex_value(digits: &[u8]) -> Option<u32> {
    digits.iter().try_fold(0u32, |acc, &c| Some(acc.checked_mul(16)? | u32::from(hex_digit(c)?)))
}

fn parse_frame(kind: u8, rest: &[u8]) -> Option<CanFrame> {
    let extended = kind == b'T' || kind == b'R';
    let remote = kind == b'r' || kind == b'R';
    let id_len = if extended { 8 } else { 3 };
    let (id_text, rest) = (rest.get(..id_len)?, rest.get(id_len..)?);
    let (dlc_text, data_text) = rest.split_first()?;
    let raw_id = hex_value(id_text)?;
    let id: Id = if extended {
        ExtendedId::new(raw_id)?.into()
    } else {
        StandardId::new(u16::try_from(raw_id).ok()?)?.into()
    };
    let dlc = usize::from(hex_digit(*dlc_text).filter(|&d| d <= 8)?);
    if remote {
        return if data_text.is_empty() { CanFrame::new_remote(id, dlc) } else { None };
    }
    if data_text.len() != 2 * dlc {
        return None;
    }
    let mut data = [0u8; 8];
    for (byte, pair) in data.iter_mut().zip(data_text.chunks_exact(2)) {
        *byte = u8::try_from(hex_value(pair)?).ok()?;
    }
    CanFrame::new(id, data.get(..dlc)?)
}

/// Parses one line (without its `\r`).
///
/// ```
/// use embedded_can::Frame;
/// use hp_ctrl::can::slcan::{parse_line, Command};
/// let Command::Frame(f) = parse_line(b"t1002A1B2") else { panic!() };
/// assert_eq!((f.dlc(), f.data()), (2, &[0xA1, 0xB2][..]));
/// assert_eq!(parse_line(b"S6"), Command::Bitrate(6));
/// assert_eq!(parse_line(b"t10"), Command::Invalid);
/// ```
pub fn parse_line(line: &[u8]) -> Command {
    let Some((&first, rest)) = line.split_first() else {
        return Command::Empty;
    };
    match (first, rest) {
        (b'O', []) => Command::Open,
        (b'L', []) => Command::ListenOnly,
        (b'C', []) => Command::Close,
        (b'S', [d @ b'0'..=b'9']) => Command::Bitrate(d - b'0'),
        (b's', [a, b, c, d]) if [a, b, c, d].iter().all(|&&x| hex_digit(x).is_some()) => Command::BitTiming,
        (b'V', []) => Command::Version,
        (b'N', []) => Command::Serial,
        (b'F', []) => Command::Status,
        (b'Z', [b'0']) => Command::Timestamps(false),
        (b'Z', [b'1']) => Command::Timestamps(true),
        (b'M' | b'm', [_, _, _, _, _, _, _, _]) => Command::Filter,
        (b't' | b'T' | b'r' | b'R', _) => parse_frame(first, rest).map_or(Command::Invalid, Command::Frame),
        _ => Command::Invalid,
    }
}

/// Collects bytes into lines and parses each complete line.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct LineReader {
    buf: [u8; MAX_LINE],
    len: usize,
    overflow: bool,
}

impl LineReader {
    pub const fn new() -> Self {
        LineReader { buf: [0; MAX_LINE], len: 0, overflow: false }
    }

    /// Takes one byte; returns the command when `\r` ends a line. An
    /// overlong line is [`Command::Invalid`]; `\n` is ignored.
    pub fn push(&mut self, byte: u8) -> Option<Command> {
        match byte {
            b'\r' => {
                let cmd = if self.overflow { Command::Invalid } else { parse_line(self.buf.get(..self.len).unwrap_or(&[])) };
                self.len = 0;
                self.overflow = false;
                Some(cmd)
            }
            b'\n' => None,
            _ => {
                match self.buf.get_mut(self.len) {
                    Some(slot) => {
                        *slot = byte;
                        self.len += 1;
                    }
                    None => self.overflow = true,
                }
                None
            }
        }
    }
}

const HEX: &[u8; 16] = b"0123456789ABCDEF";

fn hex_char(nibble: u32) -> u8 {
    HEX.get((nibble & 0xF) as usize).copied().unwrap_or(b'0')
}

/// Writes `frame` as an SLCAN line including `\r` into `out`; returns the
/// length used.
///
/// ```
/// use embedded_can::{Frame, StandardId};
/// use hp_ctrl::can::{slcan, CanFrame};
/// let f = CanFrame::new(StandardId::new(0x210).unwrap(), &[0xDE, 0xAD]).unwrap();
/// let mut buf = [0u8; slcan::MAX_FRAME_TEXT];
/// let n = slcan::format_frame(&f, &mut buf);
/// assert_eq!(&buf[..n], b"t2102DEAD\r");
/// ```
pub fn format_frame<F: Frame>(frame: &F, out: &mut [u8; MAX_FRAME_TEXT]) -> usize {
    let (kind, id, id_len) = match (frame.id(), frame.is_remote_frame()) {
        (Id::Standard(id), false) => (b't', u32::from(id.as_raw()), 3),
        (Id::Standard(id), true) => (b'r', u32::from(id.as_raw()), 3),
        (Id::Extended(id), false) => (b'T', id.as_raw(), 8),
        (Id::Extended(id), true) => (b'R', id.as_raw(), 8),
    };
    let dlc = frame.dlc().min(8);
    let mut text = [0u8; MAX_FRAME_TEXT];
    let mut n = 0;
    let mut put = |c: u8| {
        if let Some(slot) = text.get_mut(n) {
            *slot = c;
            n += 1;
        }
    };
    put(kind);
    for shift in (0..id_len).rev() {
        put(hex_char(id >> (4 * shift)));
    }
    put(b'0' + dlc as u8);
    if !frame.is_remote_frame() {
        for &b in frame.data().iter().take(dlc) {
            put(hex_char(u32::from(b) >> 4));
            put(hex_char(u32::from(b)));
        }
    }
    put(b'\r');
    *out = text;
    n
}

/// The adapter side of the protocol: open/closed state and the answer to
/// each command.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct Adapter {
    open: bool,
    listen_only: bool,
}

/// What to do with one command.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Response {
    /// The answer to send back (without further processing).
    pub answer: &'static [u8],
    /// A frame to deliver to the bus side.
    pub frame: Option<CanFrame>,
}

impl Adapter {
    pub const fn new() -> Self {
        Adapter { open: false, listen_only: false }
    }

    /// True while the channel is open: frames flow both ways.
    pub fn is_open(&self) -> bool {
        self.open
    }

    /// Handles one command as a Lawicel adapter does.
    ///
    /// ```
    /// use hp_ctrl::can::slcan::{parse_line, Adapter};
    /// let mut a = Adapter::new();
    /// assert_eq!(a.handle(parse_line(b"S6")).answer, b"\r");
    /// assert_eq!(a.handle(parse_line(b"t1000")).answer, b"\x07"); // closed
    /// assert_eq!(a.handle(parse_line(b"O")).answer, b"\r");
    /// let r = a.handle(parse_line(b"t1000"));
    /// assert_eq!(r.answer, b"z\r");
    /// assert!(r.frame.is_some());
    /// ```
    pub fn handle(&mut self, cmd: Command) -> Response {
        const BEL: &[u8] = &[ERROR];
        const CR: &[u8] = &[OK];
        let answer: &'static [u8] = match cmd {
            Command::Open | Command::ListenOnly if !self.open => {
                self.open = true;
                self.listen_only = cmd == Command::ListenOnly;
                CR
            }
            Command::Close if self.open => {
                self.open = false;
                CR
            }
            Command::Bitrate(_) | Command::BitTiming | Command::Timestamps(_) if !self.open => CR,
            Command::Version => b"V1013\r",
            Command::Serial => b"NHP01\r",
            Command::Status => b"F00\r",
            Command::Filter | Command::Empty => CR,
            Command::Frame(f) if self.open && !self.listen_only => {
                let answer: &'static [u8] = if f.is_extended() { b"Z\r" } else { b"z\r" };
                return Response { answer, frame: Some(f) };
            }
            _ => BEL,
        };
        Response { answer, frame: None }
    }
}

#[cfg(test)]
#[allow(clippy::unwrap_used, clippy::indexing_slicing, clippy::panic)] // Tests may panic.
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn reader_lines(bytes: &[u8]) -> heapless::Vec<Command, 16> {
        let mut r = LineReader::new();
        bytes.iter().filter_map(|&b| r.push(b)).collect()
    }

    #[test]
    fn python_can_open_sequence() {
        // python-can's slcan Bus(bitrate=500000) sends C, S6, "", O.
        let mut a = Adapter::new();
        let answers: heapless::Vec<&[u8], 4> = reader_lines(b"C\rS6\r\rO\r").iter().map(|&c| a.handle(c).answer).collect();
        assert_eq!(answers.as_slice(), [b"\x07".as_slice(), b"\r", b"\r", b"\r"]);
        assert!(a.is_open());
        assert_eq!(a.handle(Command::Bitrate(6)).answer, b"\x07", "no bit rate change while open");
        assert_eq!(a.handle(Command::Close).answer, b"\r");
    }

    #[test]
    fn frames_parse_in_both_cases_and_reject_malformed() {
        let Command::Frame(f) = parse_line(b"T1ABCDEF08abcdef0123456789") else { panic!() };
        assert!(f.is_extended());
        assert_eq!(f.data(), &[0xAB, 0xCD, 0xEF, 0x01, 0x23, 0x45, 0x67, 0x89]);
        for bad in [&b"t8000"[..], b"t1009", b"t1001", b"t10010G", b"t1001000", b"T200000000", b"r1001AA", b"x"] {
            assert_eq!(parse_line(bad), Command::Invalid, "{:?}", core::str::from_utf8(bad));
        }
        let Command::Frame(r) = parse_line(b"r1238") else { panic!() };
        assert!(r.is_remote_frame() && r.dlc() == 8);
    }

    #[test]
    fn overlong_line_is_invalid_and_reader_recovers() {
        let mut bytes = [b'A'; 40];
        bytes[39] = b'\r';
        let mut r = LineReader::new();
        let cmds: heapless::Vec<Command, 2> = bytes.iter().chain(b"O\r").filter_map(|&b| r.push(b)).collect();
        assert_eq!(cmds.as_slice(), [Command::Invalid, Command::Open]);
    }

    proptest! {
        #[test]
        fn format_then_parse_round_trips(id in 0u32..0x2000_0000, ext: bool, remote: bool, data in prop::collection::vec(any::<u8>(), 0..=8)) {
            let id: Id = if ext { ExtendedId::new(id).unwrap().into() } else { StandardId::new((id & 0x7FF) as u16).unwrap().into() };
            let f = if remote { CanFrame::new_remote(id, data.len()).unwrap() } else { CanFrame::new(id, &data).unwrap() };
            let mut buf = [0u8; MAX_FRAME_TEXT];
            let n = format_frame(&f, &mut buf);
            prop_assert_eq!(buf[n - 1], b'\r');
            prop_assert_eq!(parse_line(&buf[..n - 1]), Command::Frame(f));
        }

        #[test]
        fn arbitrary_bytes_never_panic(bytes in prop::collection::vec(any::<u8>(), 0..200)) {
            let mut r = LineReader::new();
            let mut a = Adapter::new();
            for b in bytes {
                if let Some(cmd) = r.push(b) {
                    let resp = a.handle(cmd);
                    prop_assert!(!resp.answer.is_empty());
                }
            }
        }
    }
}

//! The EtherCAT frame: a 2-byte header, then datagrams one after the other (ETG.1000.4, "Frame
//! structure" and "EtherCAT frame header").
//!
//! | bits of the little-endian header word | field |
//! |---|---|
//! | 0..11 | length of the datagrams that follow, in bytes |
//! | 11 | reserved |
//! | 12..16 | type: 1 = EtherCAT datagrams (DLPDU); 4 network variables, 5 mailbox gateway |
//!
//! Each datagram says in its own header whether another follows ("more" bit): [`Frame::check_datagrams`]
//! walks that chain and proves that every datagram lies inside the declared length, so a slave can
//! refuse a broken frame before it touches anything.

use super::datagram::{self, Datagram};
use super::{enum_with_unknown, le, Error};
use core::ops::Range;

/// Length of the header.
pub const HEADER_LEN: usize = 2;

/// The largest datagram region a header can declare (11 bits).
pub const MAX_LENGTH: usize = 0x07FF;

enum_with_unknown! {
    /// The frame type (header bits 12..16).
    pub enum FrameType(u8) {
        /// EtherCAT datagrams, the only type a slave processes.
        Datagrams = 1,
        /// Network variables (publisher/subscriber).
        NetworkVariables = 4,
        /// Mailbox gateway.
        Mailbox = 5,
    }
}

/// A read/write view of an EtherCAT frame (the Ethernet payload). Accessors panic if the buffer is
/// shorter than the header plus its declared length; [`Frame::new_checked`] rules that out.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Frame<T: AsRef<[u8]>> {
    buffer: T,
}

impl<T: AsRef<[u8]>> Frame<T> {
    /// Wraps a buffer without checking it.
    pub const fn new_unchecked(buffer: T) -> Frame<T> {
        Frame { buffer }
    }

    /// Wraps a buffer after [`Frame::check_len`].
    pub fn new_checked(buffer: T) -> Result<Frame<T>, Error> {
        let frame = Frame::new_unchecked(buffer);
        frame.check_len()?;
        Ok(frame)
    }

    /// Ensures that no accessor will panic: the header is there and the declared length fits the buffer
    /// (bytes beyond it, Ethernet padding, are allowed).
    pub fn check_len(&self) -> Result<(), Error> {
        let b = self.buffer.as_ref();
        if b.len() < HEADER_LEN || b.len() < HEADER_LEN + usize::from(le::u16(b, 0) & 0x07FF) {
            Err(Error::Truncated)
        } else {
            Ok(())
        }
    }

    /// The underlying buffer.
    pub fn into_inner(self) -> T {
        self.buffer
    }

    /// Length of the datagram region.
    pub fn length(&self) -> u16 {
        le::u16(self.buffer.as_ref(), 0) & 0x07FF
    }

    /// The frame type.
    pub fn frame_type(&self) -> FrameType {
        FrameType::from((le::u16(self.buffer.as_ref(), 0) >> 12) as u8)
    }

    /// The datagram region (what the length declares).
    pub fn datagrams(&self) -> &[u8] {
        &self.buffer.as_ref()[HEADER_LEN..HEADER_LEN + usize::from(self.length())]
    }

    /// Walks the datagram chain: every datagram must lie inside the declared length, and the last one
    /// (more bit clear) must be reached. Returns the number of datagrams. What follows the last datagram
    /// inside the declared length is ignored, as an ESC stops at the datagram without "more".
    pub fn check_datagrams(&self) -> Result<usize, Error> {
        let region = self.datagrams();
        let mut at = 0;
        let mut count = 0;
        loop {
            let d = Datagram::new_checked(region.get(at..).ok_or(Error::Truncated)?)?;
            count += 1;
            at += d.total_len();
            if !d.more() {
                return Ok(count);
            }
        }
    }

    /// The byte ranges (within [`Frame::datagrams`]) of the datagrams, in order. Only meaningful after
    /// [`Frame::check_datagrams`]; on a broken chain it stops where the chain breaks.
    pub fn spans(&self) -> Spans<'_> {
        Spans { region: self.datagrams(), at: 0, done: false }
    }
}

impl<T: AsRef<[u8]> + AsMut<[u8]>> Frame<T> {
    /// Sets the length and the type.
    pub fn set_header(&mut self, length: u16, frame_type: FrameType) {
        let word = (length & 0x07FF) | (u16::from(u8::from(frame_type) & 0x0F) << 12);
        le::set_u16(self.buffer.as_mut(), 0, word);
    }

    /// The datagram region, mutably.
    pub fn datagrams_mut(&mut self) -> &mut [u8] {
        let end = HEADER_LEN + usize::from(self.length());
        &mut self.buffer.as_mut()[HEADER_LEN..end]
    }
}

/// Iterator over the datagrams' byte ranges (see [`Frame::spans`]).
#[derive(Debug, Clone)]
pub struct Spans<'a> {
    region: &'a [u8],
    at: usize,
    done: bool,
}

impl Iterator for Spans<'_> {
    type Item = Range<usize>;

    fn next(&mut self) -> Option<Range<usize>> {
        if self.done {
            return None;
        }
        let d = self.region.get(self.at..).and_then(|b| Datagram::new_checked(b).ok());
        let Some(d) = d else {
            self.done = true;
            return None;
        };
        let span = self.at..self.at + d.total_len();
        self.done = !d.more();
        self.at = span.end;
        Some(span)
    }
}

/// The header as values.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Repr {
    /// Length of the datagram region.
    pub length: u16,
    /// Frame type.
    pub frame_type: FrameType,
}

impl Repr {
    /// Reads the header of a view (checked: the declared length must fit).
    pub fn parse<T: AsRef<[u8]>>(frame: &Frame<T>) -> Result<Repr, Error> {
        frame.check_len()?;
        Ok(Repr { length: frame.length(), frame_type: frame.frame_type() })
    }

    /// Bytes the header and its datagrams need.
    pub const fn buffer_len(&self) -> usize {
        HEADER_LEN + self.length as usize
    }

    /// Writes the header.
    pub fn emit<T: AsRef<[u8]> + AsMut<[u8]>>(&self, frame: &mut Frame<T>) {
        frame.set_header(self.length, self.frame_type);
    }
}

/// The datagram length a frame of `datagram_data` data bytes in one datagram needs (header, data and
/// working counter).
pub const fn one_datagram_len(datagram_data: usize) -> usize {
    datagram::HEADER_LEN + datagram_data + datagram::WKC_LEN
}

#[cfg(test)]
mod tests {
    use super::*;

    /// An EtherCAT payload of two datagrams (made up: a one-slave session has no such frame; SOEM sends
    /// them to read several slaves at once): a BRD of register 0x0000, 2 bytes, with "more", and an FPRD
    /// of 0x0502 at station 0x1001; header length 0x1C = 2 × 14, type 1.
    static TWO: [u8; 30] = [
        0x1c, 0x10, // header: length 28, type 1
        0x07, 0x01, 0x00, 0x00, 0x00, 0x00, 0x02, 0x80, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, // BRD, more
        0x04, 0x02, 0x01, 0x10, 0x02, 0x05, 0x02, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, // FPRD
    ];

    #[test]
    fn walks_the_chain() {
        let f = Frame::new_checked(&TWO[..]).unwrap();
        assert_eq!(Repr::parse(&f).unwrap(), Repr { length: 28, frame_type: FrameType::Datagrams });
        assert_eq!(f.check_datagrams(), Ok(2));
        let spans: [Range<usize>; 2] = {
            let mut s = f.spans();
            [s.next().unwrap(), s.next().unwrap()]
        };
        assert_eq!(spans, [0..14, 14..28]);
    }

    #[test]
    fn a_chain_that_runs_out_is_refused() {
        let mut bytes = TWO;
        bytes[0] = 0x1b; // one byte less than the datagrams need
        assert_eq!(Frame::new_checked(&bytes[..]).unwrap().check_datagrams(), Err(Error::Truncated));
        let mut bytes = TWO;
        bytes[2 + 14 + 7] |= 0x80; // the last datagram says "more"
        assert_eq!(Frame::new_checked(&bytes[..]).unwrap().check_datagrams(), Err(Error::Truncated));
        assert_eq!(Frame::new_checked(&TWO[..20]), Err(Error::Truncated));
    }

    #[test]
    fn header_round_trip() {
        let mut bytes = [0u8; 2];
        Repr { length: 0x123, frame_type: FrameType::Unknown(9) }.emit(&mut Frame::new_unchecked(&mut bytes[..]));
        assert_eq!(bytes, [0x23, 0x91]);
    }
}

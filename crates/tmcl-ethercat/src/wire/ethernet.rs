//! The Ethernet II header that carries EtherCAT (IEEE 802.3; EtherType 0x88A4, ETG.1000.4 "Frame
//! structure").
//!
//! | bytes | field |
//! |---|---|
//! | 0..6 | destination MAC address |
//! | 6..12 | source MAC address |
//! | 12..14 | EtherType, big-endian |
//! | 14.. | payload (the EtherCAT frame) |
//!
//! Frames arrive without the frame check sequence (the NIC strips it) and may be shorter than Ethernet's
//! 60-byte minimum: masters send EtherCAT frames unpadded over a raw socket.

use super::Error;

/// EtherType of EtherCAT (ETG.1000.4).
pub const ETHERTYPE_ETHERCAT: u16 = 0x88A4;

/// Length of the header.
pub const HEADER_LEN: usize = 14;

/// Byte ranges of the header.
pub mod field {
    use core::ops::{Range, RangeFrom};
    /// Destination MAC address.
    pub const DESTINATION: Range<usize> = 0..6;
    /// Source MAC address.
    pub const SOURCE: Range<usize> = 6..12;
    /// EtherType, big-endian.
    pub const ETHERTYPE: Range<usize> = 12..14;
    /// The payload.
    pub const PAYLOAD: RangeFrom<usize> = 14..;
}

/// A read/write view of an Ethernet II frame. Accessors panic if the buffer is shorter than
/// [`HEADER_LEN`]; [`Frame::new_checked`] rules that out.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Frame<T: AsRef<[u8]>> {
    buffer: T,
}

impl<T: AsRef<[u8]>> Frame<T> {
    /// Wraps a buffer without checking its length.
    pub const fn new_unchecked(buffer: T) -> Frame<T> {
        Frame { buffer }
    }

    /// Wraps a buffer after [`Frame::check_len`].
    pub fn new_checked(buffer: T) -> Result<Frame<T>, Error> {
        let frame = Frame::new_unchecked(buffer);
        frame.check_len()?;
        Ok(frame)
    }

    /// Ensures that no accessor will panic.
    pub fn check_len(&self) -> Result<(), Error> {
        if self.buffer.as_ref().len() < HEADER_LEN {
            Err(Error::Truncated)
        } else {
            Ok(())
        }
    }

    /// The underlying buffer.
    pub fn into_inner(self) -> T {
        self.buffer
    }

    /// Destination address.
    pub fn destination(&self) -> [u8; 6] {
        let mut a = [0; 6];
        a.copy_from_slice(&self.buffer.as_ref()[field::DESTINATION]);
        a
    }

    /// Source address.
    pub fn source(&self) -> [u8; 6] {
        let mut a = [0; 6];
        a.copy_from_slice(&self.buffer.as_ref()[field::SOURCE]);
        a
    }

    /// EtherType.
    pub fn ethertype(&self) -> u16 {
        let b = &self.buffer.as_ref()[field::ETHERTYPE];
        u16::from_be_bytes([b[0], b[1]])
    }

    /// The payload.
    pub fn payload(&self) -> &[u8] {
        &self.buffer.as_ref()[field::PAYLOAD]
    }
}

impl<T: AsRef<[u8]> + AsMut<[u8]>> Frame<T> {
    /// Sets the destination address.
    pub fn set_destination(&mut self, a: [u8; 6]) {
        self.buffer.as_mut()[field::DESTINATION].copy_from_slice(&a);
    }

    /// Sets the source address.
    pub fn set_source(&mut self, a: [u8; 6]) {
        self.buffer.as_mut()[field::SOURCE].copy_from_slice(&a);
    }

    /// Sets the EtherType.
    pub fn set_ethertype(&mut self, t: u16) {
        self.buffer.as_mut()[field::ETHERTYPE].copy_from_slice(&t.to_be_bytes());
    }

    /// Marks the frame as processed by a slave controller: bit 1 of the source address's first byte (the
    /// "locally administered" bit) is set, as an ESC does on the frame's way back (ET1100 datasheet,
    /// "Frame processing"). Masters use it to tell their own frame from the slaves' answer.
    pub fn mark_processed(&mut self) {
        self.buffer.as_mut()[field::SOURCE.start] |= 0x02;
    }

    /// The payload, mutably.
    pub fn payload_mut(&mut self) -> &mut [u8] {
        &mut self.buffer.as_mut()[field::PAYLOAD]
    }
}

/// The header as values.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Repr {
    /// Destination address.
    pub destination: [u8; 6],
    /// Source address.
    pub source: [u8; 6],
    /// EtherType.
    pub ethertype: u16,
}

impl Repr {
    /// Reads the header of a checked view.
    pub fn parse<T: AsRef<[u8]>>(frame: &Frame<T>) -> Result<Repr, Error> {
        frame.check_len()?;
        Ok(Repr { destination: frame.destination(), source: frame.source(), ethertype: frame.ethertype() })
    }

    /// Bytes the header needs.
    pub const fn buffer_len(&self) -> usize {
        HEADER_LEN
    }

    /// Writes the header into a view of at least [`HEADER_LEN`] bytes.
    pub fn emit<T: AsRef<[u8]> + AsMut<[u8]>>(&self, frame: &mut Frame<T>) {
        frame.set_destination(self.destination);
        frame.set_source(self.source);
        frame.set_ethertype(self.ethertype);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The head of SOEM's first frame (a BWR of DL control byte 0x0103) in the recorded session
    /// `tests/data/soem-session.txt`: broadcast destination, source 01:01:01:01:01:01 (SOEM's primary
    /// MAC), EtherType 0x88A4, then the EtherCAT header (13 bytes of datagrams, type 1).
    static SOEM_HEAD: [u8; 16] =
        [0xff, 0xff, 0xff, 0xff, 0xff, 0xff, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x88, 0xa4, 0x0d, 0x10];

    #[test]
    fn deconstruct() {
        let f = Frame::new_checked(&SOEM_HEAD[..]).unwrap();
        assert_eq!(f.destination(), [0xff; 6]);
        assert_eq!(f.source(), [1; 6]);
        assert_eq!(f.ethertype(), ETHERTYPE_ETHERCAT);
        assert_eq!(f.payload(), &[0x0d, 0x10]);
    }

    #[test]
    fn construct_and_round_trip() {
        let mut bytes = [0u8; 16];
        let repr = Repr::parse(&Frame::new_checked(&SOEM_HEAD[..]).unwrap()).unwrap();
        let mut f = Frame::new_unchecked(&mut bytes[..]);
        repr.emit(&mut f);
        f.payload_mut().copy_from_slice(&[0x0d, 0x10]);
        assert_eq!(bytes, SOEM_HEAD);
        let mut f = Frame::new_unchecked(&mut bytes[..]);
        f.mark_processed();
        assert_eq!(f.source(), [3, 1, 1, 1, 1, 1]);
    }

    #[test]
    fn short_buffers_are_refused() {
        assert_eq!(Frame::new_checked(&SOEM_HEAD[..13]), Err(Error::Truncated));
    }
}

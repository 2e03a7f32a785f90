//! Framing: a message as bytes on a serial line, and back.
//!
//! # Theory of operation
//!
//! A frame is a message's postcard bytes followed by their CRC-16 (X.25, little-endian),
//! COBS-encoded, then one `0x00` delimiter. COBS (consistent overhead byte stuffing) removes
//! every zero from the body at a cost of one byte per 254, so the delimiter can only mean
//! "end of frame": a receiver that starts listening mid-frame, or loses bytes, re-synchronises
//! at the next zero. The CRC rejects a body corrupted on the line; postcard then rejects a
//! body that is not a message of the expected type.
//!
//! Every size is bounded: a message's payload is at most [`MAX_PAYLOAD`] bytes, a frame at
//! most [`MAX_FRAME`] on the line. The [`Deframer`] keeps at most that many bytes; a longer
//! run without a delimiter is discarded up to the next one and reported once as
//! [`FrameError::TooLong`]. Decoding is total: every byte sequence gives a message or a
//! [`FrameError`], and no input panics (REQ-LINK-01).

use serde::Serialize;
use serde::de::DeserializeOwned;

/// The longest message payload (postcard bytes), bytes.
pub const MAX_PAYLOAD: usize = 160;

/// The CRC's length, bytes.
pub const CRC_LEN: usize = 2;

/// The longest frame body before COBS: payload and CRC.
pub const MAX_BODY: usize = MAX_PAYLOAD + CRC_LEN;

/// The longest frame on the line: the body, COBS's overhead (one byte per 254, at least
/// one) and the delimiter.
pub const MAX_FRAME: usize = MAX_BODY + MAX_BODY / 254 + 1 + 1;

/// The frame's CRC: CRC-16/X.25 (the HDLC frame check sequence: reflected polynomial
/// `0x8408`, initial value and final XOR `0xFFFF`), bit by bit — no table in the firmware's
/// flash (a frame costs a few thousand cycles in the link's low-priority task), and no
/// dependency Kani cannot compile.
#[must_use]
pub fn crc16(bytes: &[u8]) -> u16 {
    let mut crc: u16 = 0xFFFF;
    for &byte in bytes {
        crc ^= u16::from(byte);
        for _ in 0..8 {
            let carry = crc & 1 != 0;
            crc >>= 1;
            if carry {
                crc ^= 0x8408;
            }
        }
    }
    !crc
}

/// Why bytes did not give a message.
#[derive(Clone, Copy, PartialEq, Eq, Hash, Debug)]
pub enum FrameError {
    /// An empty frame (two delimiters in a row): ignored by receivers.
    Empty,
    /// More than [`MAX_FRAME`] bytes without a delimiter.
    TooLong,
    /// The COBS encoding is broken (a code byte points past the frame's end, or a zero in the
    /// body).
    Stuffing,
    /// The body is shorter than a CRC, or its CRC does not match.
    Checksum,
    /// The body is not a message of the expected type (unknown variant, short, trailing
    /// bytes, out-of-range value).
    Message,
    /// The message does not fit in [`MAX_PAYLOAD`] bytes (a sender's error).
    Oversize,
}

/// COBS-encodes `body` into `out`; returns the encoded length (without a delimiter).
///
/// # Errors
/// [`FrameError::Oversize`] when `out` is too short.
fn stuff(body: &[u8], out: &mut [u8]) -> Result<usize, FrameError> {
    let mut code_at = 0usize;
    let mut write = 1usize;
    let mut code: u8 = 1;
    for &byte in body {
        if byte == 0 {
            *out.get_mut(code_at).ok_or(FrameError::Oversize)? = code;
            code_at = write;
            write = write.saturating_add(1);
            code = 1;
        } else {
            *out.get_mut(write).ok_or(FrameError::Oversize)? = byte;
            write = write.saturating_add(1);
            code = code.saturating_add(1);
            if code == 0xFF {
                *out.get_mut(code_at).ok_or(FrameError::Oversize)? = code;
                code_at = write;
                write = write.saturating_add(1);
                code = 1;
            }
        }
    }
    *out.get_mut(code_at).ok_or(FrameError::Oversize)? = code;
    Ok(write)
}

/// COBS-decodes `frame` (without its delimiter) into `out`; returns the body's length.
///
/// # Errors
/// [`FrameError::Stuffing`] for a zero in the frame or a code past its end,
/// [`FrameError::TooLong`] when the body does not fit `out`.
fn unstuff(frame: &[u8], out: &mut [u8]) -> Result<usize, FrameError> {
    let mut read = 0usize;
    let mut write = 0usize;
    while read < frame.len() {
        let code = *frame.get(read).ok_or(FrameError::Stuffing)?;
        if code == 0 {
            return Err(FrameError::Stuffing);
        }
        read = read.saturating_add(1);
        let run = usize::from(code).saturating_sub(1);
        let end = read.saturating_add(run);
        let data = frame.get(read..end).ok_or(FrameError::Stuffing)?;
        #[allow(
            clippy::manual_contains,
            reason = "`contains` on bytes is memchr's SIMD search, which Kani cannot model"
        )]
        let has_zero = data.iter().any(|byte| *byte == 0);
        if has_zero {
            return Err(FrameError::Stuffing);
        }
        let write_end = write.saturating_add(run);
        out.get_mut(write..write_end).ok_or(FrameError::TooLong)?.copy_from_slice(data);
        write = write_end;
        read = end;
        if code != 0xFF && read < frame.len() {
            *out.get_mut(write).ok_or(FrameError::TooLong)? = 0;
            write = write.saturating_add(1);
        }
    }
    Ok(write)
}

/// Encodes `message` as one frame, delimiter included, into `out`; returns its length.
///
/// # Errors
/// [`FrameError::Oversize`] when the message's payload exceeds [`MAX_PAYLOAD`].
pub fn encode<T: Serialize>(message: &T, out: &mut [u8; MAX_FRAME]) -> Result<usize, FrameError> {
    let mut body = [0u8; MAX_BODY];
    let payload_len = {
        let payload = body.get_mut(..MAX_PAYLOAD).ok_or(FrameError::Oversize)?;
        postcard::to_slice(message, payload).map_err(|_| FrameError::Oversize)?.len()
    };
    let crc = crc16(body.get(..payload_len).ok_or(FrameError::Oversize)?);
    let body_len = payload_len.saturating_add(CRC_LEN);
    body.get_mut(payload_len..body_len)
        .ok_or(FrameError::Oversize)?
        .copy_from_slice(&crc.to_le_bytes());
    let stuffed = stuff(body.get(..body_len).ok_or(FrameError::Oversize)?, out)?;
    *out.get_mut(stuffed).ok_or(FrameError::Oversize)? = 0;
    Ok(stuffed.saturating_add(1))
}

/// Checks one frame (its bytes without the delimiter): unstuffs it into `body` and checks
/// its CRC; returns the payload.
///
/// # Errors
/// The first check the frame fails, as a [`FrameError`].
pub fn unframe<'a>(frame: &[u8], body: &'a mut [u8; MAX_BODY]) -> Result<&'a [u8], FrameError> {
    if frame.is_empty() {
        return Err(FrameError::Empty);
    }
    // MAX_FRAME counts the delimiter, which `frame` does not hold.
    if frame.len() >= MAX_FRAME {
        return Err(FrameError::TooLong);
    }
    let body_len = unstuff(frame, body)?;
    let payload_len = body_len.checked_sub(CRC_LEN).ok_or(FrameError::Checksum)?;
    let (payload, rest) = body.split_at(payload_len);
    let (Some(low), Some(high)) = (rest.first(), rest.get(1)) else {
        return Err(FrameError::Checksum);
    };
    if crc16(payload) != u16::from_le_bytes([*low, *high]) {
        return Err(FrameError::Checksum);
    }
    Ok(payload)
}

/// Decodes one frame (its bytes without the delimiter) as a `T`: [`unframe`], then the
/// whole payload as one `T`.
///
/// # Errors
/// The first check the frame fails, as a [`FrameError`].
pub fn decode<T: DeserializeOwned>(frame: &[u8]) -> Result<T, FrameError> {
    let mut body = [0u8; MAX_BODY];
    let payload = unframe(frame, &mut body)?;
    let (message, trailing) = take_message::<T>(payload)?;
    if !trailing.is_empty() {
        return Err(FrameError::Message);
    }
    Ok(message)
}

/// Decodes the first message of a postcard `payload` (no CRC, no stuffing) and returns it
/// with the bytes after it: how the fuzz target and the proofs draw well-formed requests
/// from arbitrary bytes.
///
/// # Errors
/// [`FrameError::Message`] when the bytes do not start with a `T`.
pub fn take_message<T: DeserializeOwned>(payload: &[u8]) -> Result<(T, &[u8]), FrameError> {
    postcard::take_from_bytes::<T>(payload).map_err(|_| FrameError::Message)
}

/// Collects a byte stream into frames (see the module docs).
#[derive(Clone, Debug)]
pub struct Deframer {
    buffer: [u8; MAX_FRAME],
    len: usize,
    overflowed: bool,
}

impl Default for Deframer {
    fn default() -> Self {
        Self::new()
    }
}

impl Deframer {
    /// An empty deframer.
    #[must_use]
    pub const fn new() -> Self {
        Self { buffer: [0; MAX_FRAME], len: 0, overflowed: false }
    }

    /// Takes one byte; at a delimiter, decodes what came before it as a `T`. Returns `None`
    /// inside a frame and after an empty one.
    pub fn push<T: DeserializeOwned>(&mut self, byte: u8) -> Option<Result<T, FrameError>> {
        if byte != 0 {
            // A full buffer stays full (its length stays at its end) until the delimiter.
            match self.buffer.get_mut(self.len) {
                Some(slot) => {
                    *slot = byte;
                    self.len = self.len.saturating_add(1);
                }
                None => self.overflowed = true,
            }
            return None;
        }
        let len = core::mem::take(&mut self.len);
        if core::mem::take(&mut self.overflowed) {
            return Some(Err(FrameError::TooLong));
        }
        match decode(self.buffer.get(..len).unwrap_or(&[])) {
            Err(FrameError::Empty) => None,
            result => Some(result),
        }
    }

    /// Bytes held of a frame not yet delimited.
    #[must_use]
    pub const fn pending(&self) -> usize {
        self.len
    }
}

#[cfg(test)]
mod tests {
    #![allow(
        clippy::indexing_slicing,
        clippy::unwrap_used,
        clippy::arithmetic_side_effects,
        clippy::cast_possible_truncation,
        reason = "test code on fixed small arrays; a panic is the report"
    )]
    use super::*;

    #[test]
    fn the_crc_is_x25() {
        assert_eq!(crc16(b"123456789"), 0x906E);
    }

    #[test]
    fn a_frame_round_trips_and_has_one_zero_at_its_end() {
        let message: (u32, [u8; 8]) = (0, [0, 1, 0, 0, 255, 0, 7, 0]);
        let mut out = [0u8; MAX_FRAME];
        let len = encode(&message, &mut out).unwrap();
        assert_eq!(out[len - 1], 0);
        assert!(!out[..len - 1].contains(&0));
        assert_eq!(decode::<(u32, [u8; 8])>(&out[..len - 1]), Ok(message));
    }

    #[test]
    fn a_corrupted_byte_is_caught() {
        let mut out = [0u8; MAX_FRAME];
        let len = encode(&(12_345u32, 7u8), &mut out).unwrap();
        for at in 0..len - 1 {
            for flip in [1u8, 0x80] {
                let mut bad = out;
                bad[at] ^= flip;
                assert!(decode::<(u32, u8)>(&bad[..len - 1]).is_err(), "byte {at} ^ {flip}");
            }
        }
    }

    #[test]
    fn a_run_without_delimiter_is_dropped_and_the_next_frame_read() {
        let mut deframer = Deframer::new();
        for _ in 0..MAX_FRAME * 3 {
            assert_eq!(deframer.push::<u8>(0x55), None);
        }
        assert_eq!(deframer.push::<u8>(0), Some(Err(FrameError::TooLong)));
        let mut out = [0u8; MAX_FRAME];
        let len = encode(&9u8, &mut out).unwrap();
        let mut got = None;
        for &byte in &out[..len] {
            got = deframer.push::<u8>(byte).or(got);
        }
        assert_eq!(got, Some(Ok(9)));
    }

    #[test]
    fn the_deframer_counts_the_bytes_it_holds() {
        let mut deframer = Deframer::new();
        assert_eq!(deframer.pending(), 0);
        for (held, byte) in [7u8, 8, 9].into_iter().enumerate() {
            assert_eq!(deframer.push::<u8>(byte), None);
            assert_eq!(deframer.pending(), held + 1);
        }
        assert!(deframer.push::<u8>(0).is_some(), "a delimiter ends the frame");
        assert_eq!(deframer.pending(), 0);
    }

    #[test]
    fn a_long_body_stuffs_and_unstuffs() {
        let body: [u8; MAX_BODY] = core::array::from_fn(|i| (i % 7) as u8);
        let mut frame = [0u8; MAX_FRAME];
        let len = stuff(&body, &mut frame).unwrap();
        assert!(len < MAX_FRAME);
        let mut back = [0u8; MAX_BODY];
        assert_eq!(unstuff(&frame[..len], &mut back), Ok(MAX_BODY));
        assert_eq!(back, body);
        let ones = [1u8; MAX_BODY];
        let len = stuff(&ones, &mut frame).unwrap();
        assert_eq!(len, MAX_BODY + 1);
        // A body without zeros is COBS's worst case: with its delimiter it is the longest
        // frame, exactly.
        assert_eq!(len + 1, MAX_FRAME);
        // One byte more than the longest frame is refused for its length before it is
        // unstuffed; the longest is unstuffed (here: a misplaced zero).
        let mut long = [1u8; MAX_FRAME];
        long[1] = 0;
        assert_eq!(unframe(&long, &mut back), Err(FrameError::TooLong));
        assert_eq!(unframe(&long[..MAX_FRAME - 1], &mut back), Err(FrameError::Stuffing));
        assert_eq!(unstuff(&frame[..len], &mut back), Ok(MAX_BODY));
        assert_eq!(back, ones);
    }
}

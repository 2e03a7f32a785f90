//! The machine link's byte queues on the board: the receive ring the USART fills by DMA and
//! the transmit ring the server's frames wait in for theirs.
//!
//! # Theory of operation
//!
//! The link is served on USART2 (the NUCLEO's ST-LINK virtual COM port) at
//! [`taut_link::BAUD`] without any interrupt of its own: two DMA channels move the bytes, and
//! the control tick, after it has applied the machine's outputs, does the rest in a bounded
//! time (`hardware::link`).
//!
//! - **Receive**: a DMA channel in circular mode writes every received byte into
//!   [`RX_RING`] bytes of RAM and counts down its remaining-transfers register; the tick reads
//!   that count, and [`RxCursor::arrived`] gives the one or two spans of the ring written since
//!   the last tick. The ring holds [`RX_RING`] / 11.5 bytes a ms = 44 ms of the line: twice the
//!   longest time the tick can be held off (a flash page erase, ≈ 22 ms, stalls the CPU but
//!   not the DMA), so nothing the host sends is overwritten before it is read.
//! - **Transmit**: the server queues whole frames into a [`TxRing`] (a frame that does not fit
//!   is refused whole, never cut, and the server counts it); the tick hands the DMA one
//!   contiguous span at a time ([`TxRing::start`]) and frees it when the DMA's count reaches
//!   zero ([`TxRing::finish`]). The DMA reads only the span in flight and the server writes only
//!   outside it, so neither sees the other's bytes half-written.
//!
//! Both are plain index arithmetic with no hardware, tested on the host below; the
//! registers are in the image's `hardware::link`.

use core::ops::Range;
use taut_link::Sink;
use taut_link::message::BoardId;

/// Bytes of the receive ring (see the module docs: 44 ms of the line).
pub const RX_RING: usize = 512;

/// Where the tick last read the receive ring.
#[derive(Clone, Copy, PartialEq, Eq, Debug, Default)]
pub struct RxCursor {
    read: usize,
}

impl RxCursor {
    /// The spans of the ring written since the last call, oldest first (the second is empty
    /// unless the DMA wrapped), given the DMA's remaining-transfers count `remaining` (it counts
    /// down from [`RX_RING`] and reloads at the wrap; a value outside `1..=RX_RING` is read as
    /// the ring's start).
    pub fn arrived(&mut self, remaining: u16) -> [Range<usize>; 2] {
        let remaining = usize::from(remaining);
        let write =
            if (1..=RX_RING).contains(&remaining) { RX_RING.saturating_sub(remaining) } else { 0 };
        let read = core::mem::replace(&mut self.read, write);
        if write >= read { [read..write, 0..0] } else { [read..RX_RING, 0..write] }
    }
}

/// The transmit ring: whole frames in, contiguous spans out to the DMA (see the module docs).
#[derive(Clone, Debug)]
pub struct TxRing<const N: usize> {
    bytes: [u8; N],
    /// Where the oldest byte not yet sent starts.
    head: usize,
    /// Bytes queued, in flight included.
    len: usize,
    /// Bytes from `head` the DMA is sending.
    in_flight: usize,
}

impl<const N: usize> Default for TxRing<N> {
    fn default() -> Self {
        Self::new()
    }
}

impl<const N: usize> TxRing<N> {
    /// An empty ring.
    #[must_use]
    pub const fn new() -> Self {
        Self { bytes: [0; N], head: 0, len: 0, in_flight: 0 }
    }

    /// Bytes queued (in flight included).
    #[must_use]
    pub const fn len(&self) -> usize {
        self.len
    }

    /// Whether nothing is queued.
    #[must_use]
    pub const fn is_empty(&self) -> bool {
        self.len == 0
    }

    /// The ring's bytes (the DMA's source: a span from [`TxRing::start`] indexes it).
    #[must_use]
    pub const fn bytes(&self) -> &[u8; N] {
        &self.bytes
    }

    /// The next span to hand the DMA, if none is in flight and bytes wait: from the oldest
    /// byte to the newest or to the ring's end, whichever comes first. It stays reserved until
    /// [`TxRing::finish`].
    pub fn start(&mut self) -> Option<Range<usize>> {
        if self.in_flight > 0 || self.len == 0 {
            return None;
        }
        let span = self.len.min(N.saturating_sub(self.head));
        self.in_flight = span;
        Some(self.head..self.head.saturating_add(span))
    }

    /// The span in flight has been sent: its room is free again.
    pub fn finish(&mut self) {
        let sent = core::mem::take(&mut self.in_flight);
        self.len = self.len.saturating_sub(sent);
        self.head = self.head.saturating_add(sent).checked_rem(N).unwrap_or(0);
    }

    /// Whether a span is in flight.
    #[must_use]
    pub const fn sending(&self) -> bool {
        self.in_flight > 0
    }
}

impl<const N: usize> Sink for TxRing<N> {
    fn send(&mut self, frame: &[u8]) -> bool {
        if frame.len() > N.saturating_sub(self.len) {
            return false;
        }
        let mut at = self.head.saturating_add(self.len).checked_rem(N).unwrap_or(0);
        for &byte in frame {
            if let Some(slot) = self.bytes.get_mut(at) {
                *slot = byte;
            }
            at = if at.saturating_add(1) >= N { 0 } else { at.saturating_add(1) };
        }
        self.len = self.len.saturating_add(frame.len());
        true
    }
}

/// The firmware's version (major, minor, patch) from the package's, for the link's hello.
pub const FIRMWARE_VERSION: [u8; 3] = version(env!("CARGO_PKG_VERSION").as_bytes());

/// `major.minor.patch` as three numbers (a part above 255, or missing, reads as 0; anything
/// after the patch, such as a pre-release, is ignored).
const fn version(mut text: &[u8]) -> [u8; 3] {
    let mut parts = [0u16; 3];
    let mut part: usize = 0;
    while let [c, rest @ ..] = text {
        let value = match part {
            0 => &mut parts[0],
            1 => &mut parts[1],
            2 => &mut parts[2],
            _ => break,
        };
        if *c == b'.' {
            part = part.saturating_add(1);
        } else if c.is_ascii_digit() {
            // Saturates at 256, one past a byte: read as 0 below.
            #[allow(clippy::cast_lossless, reason = "a const fn: `u16::from` is not const")]
            let digit = c.saturating_sub(b'0') as u16;
            let next = value.saturating_mul(10).saturating_add(digit);
            *value = if next > 255 { 256 } else { next };
        } else {
            break;
        }
        text = rest;
    }
    [byte(parts[0]), byte(parts[1]), byte(parts[2])]
}

/// A version part as a byte (256, the saturated value, as 0).
const fn byte(value: u16) -> u8 {
    let [low, high] = value.to_le_bytes();
    if high > 0 { 0 } else { low }
}

/// The board's identity on the link: the MCU's 96-bit unique id (three words, RM0440
/// section 48.1), little-endian.
#[must_use]
pub fn board_id(words: [u32; 3]) -> BoardId {
    let mut id = [0u8; 12];
    for (chunk, word) in id.chunks_exact_mut(4).zip(words) {
        chunk.copy_from_slice(&word.to_le_bytes());
    }
    id
}

#[cfg(test)]
#[allow(
    clippy::cast_possible_truncation,
    reason = "unit tests: ring lengths and test bytes are small by construction"
)]
mod tests {
    use super::*;
    use std::vec::Vec;

    #[test]
    fn the_cursor_gives_what_the_dma_wrote_since_the_last_tick() {
        let mut cursor = RxCursor::default();
        // Nothing yet: the count is still the ring's length.
        assert_eq!(cursor.arrived(RX_RING as u16), [0..0, 0..0]);
        assert_eq!(cursor.arrived(RX_RING as u16 - 11), [0..11, 0..0]);
        assert_eq!(cursor.arrived(RX_RING as u16 - 11), [11..11, 0..0]);
        // Wrapped: the tail of the ring, then its start.
        assert_eq!(cursor.arrived(RX_RING as u16 - 5), [11..RX_RING, 0..5]);
        // Exactly at the end: the count reloaded to the length.
        let mut cursor = RxCursor { read: RX_RING - 3 };
        assert_eq!(cursor.arrived(RX_RING as u16), [RX_RING - 3..RX_RING, 0..0]);
        // A count that cannot be: the ring's start, nothing lost past the end.
        let mut cursor = RxCursor { read: 7 };
        assert_eq!(cursor.arrived(0), [7..RX_RING, 0..0]);
        assert_eq!(cursor.arrived(RX_RING as u16 + 1), [0..0, 0..0]);
    }

    /// The DMA's view: repeatedly start a span, copy it out, finish.
    fn drain<const N: usize>(ring: &mut TxRing<N>) -> Vec<u8> {
        let mut out = Vec::new();
        while let Some(span) = ring.start() {
            assert!(ring.sending());
            assert_eq!(ring.start(), None, "one span in flight at a time");
            out.extend_from_slice(&ring.bytes()[span]);
            ring.finish();
        }
        out
    }

    #[test]
    fn frames_come_out_whole_and_in_order_across_the_wrap() {
        let mut ring = TxRing::<16>::new();
        assert!(ring.send(&[1, 2, 3, 4, 5, 6, 7, 8, 9, 10]));
        assert_eq!(drain(&mut ring), [1, 2, 3, 4, 5, 6, 7, 8, 9, 10]);
        // The next frame wraps: two spans, the bytes in order.
        assert!(ring.send(&[11, 12, 13, 14, 15, 16, 17, 18, 19]));
        assert_eq!(ring.start(), Some(10..16));
        ring.finish();
        assert_eq!(ring.start(), Some(0..3));
        assert_eq!(&ring.bytes()[0..3], &[17, 18, 19]);
        ring.finish();
        assert!(ring.is_empty());
    }

    #[test]
    fn a_frame_that_does_not_fit_is_refused_whole() {
        let mut ring = TxRing::<8>::new();
        assert!(ring.send(&[1; 6]));
        assert!(!ring.send(&[2; 3]), "3 bytes into 2 free");
        assert_eq!(ring.len(), 6);
        assert!(ring.send(&[3; 2]));
        assert!(!ring.send(&[4]));
        assert_eq!(drain(&mut ring), [1, 1, 1, 1, 1, 1, 3, 3]);
        assert!(ring.send(&[5; 8]), "the whole ring once empty");
    }

    #[test]
    fn the_span_in_flight_is_never_written() {
        let mut ring = TxRing::<8>::new();
        assert!(ring.send(&[1, 2, 3, 4]));
        let span = ring.start().unwrap();
        assert_eq!(span, 0..4);
        assert!(ring.send(&[5, 6, 7, 8]));
        assert!(!ring.send(&[9]), "full while the span is in flight");
        assert_eq!(&ring.bytes()[span], &[1, 2, 3, 4]);
        ring.finish();
        assert_eq!(drain(&mut ring), [5, 6, 7, 8]);
    }

    #[test]
    fn random_frames_arrive_in_order_and_refusals_lose_nothing_else() {
        // A deterministic walk of sends and DMA completions.
        let mut ring = TxRing::<64>::new();
        let (mut sent, mut out) = (Vec::new(), Vec::new());
        let mut seed = 0x2545_F491_u32;
        for step in 0..20_000u32 {
            seed ^= seed << 13;
            seed ^= seed >> 17;
            seed ^= seed << 5;
            if seed.is_multiple_of(3) {
                if let Some(span) = ring.start() {
                    out.extend_from_slice(&ring.bytes()[span]);
                    ring.finish();
                }
            } else {
                let len = (seed >> 8) as usize % 40;
                let frame: Vec<u8> = (0..len).map(|i| (step as usize + i) as u8).collect();
                if ring.send(&frame) {
                    sent.extend_from_slice(&frame);
                }
            }
        }
        out.extend(drain(&mut ring));
        assert_eq!(out, sent);
    }

    #[test]
    fn the_version_is_the_package_version() {
        let expected: Vec<u8> =
            env!("CARGO_PKG_VERSION").split('.').map(|p| p.parse().unwrap()).collect();
        assert_eq!(FIRMWARE_VERSION.to_vec(), expected);
        assert_eq!(version(b"1.22.333"), [1, 22, 0]);
        assert_eq!(version(b"2.0.1-rc.1"), [2, 0, 1]);
        assert_eq!(version(b""), [0, 0, 0]);
    }

    #[test]
    fn the_board_id_is_the_unique_id_little_endian() {
        let id = board_id([0x0403_0201, 0x0807_0605, 0x0C0B_0A09]);
        assert_eq!(id, [1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12]);
    }
}

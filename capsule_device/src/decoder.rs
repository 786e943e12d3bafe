//! Finding frames in a byte stream: whatever the line delivers (garbage, a frame cut in two
//! reads, a corrupted byte), the decoder hands out every intact frame and says what it skipped,
//! and a corrupted frame costs only itself (the search resumes one byte after its sync).

use crate::crc::crc16;
use crate::frame::{Frame, FrameError, CRC_LEN, HEADER_LEN, SYNC};

/// The longest payload a frame may announce: longer is taken for a corrupted length byte.
const MAX_PAYLOAD: usize = 64;

/// One result of [`Decoder::decode`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Decoded {
    /// An intact frame and its sequence number; `lost` frames of that type's stream were
    /// missed since the previous one (sequence numbers skipped).
    Frame {
        /// The frame's sequence number.
        seq: u16,
        /// The message.
        frame: Frame,
        /// Frames missed before it (0 for the first one seen).
        lost: u16,
    },
    /// Bytes skipped, and why.
    Skipped(FrameError),
}

/// A byte-stream decoder for one direction of the line.
#[derive(Debug, Default, Clone)]
pub struct Decoder {
    buf: Vec<u8>,
    last_seq: Option<u16>,
}

impl Decoder {
    /// A decoder that has seen nothing.
    pub fn new() -> Decoder {
        Decoder::default()
    }

    /// Appends bytes as they arrived.
    pub fn push(&mut self, bytes: &[u8]) {
        self.buf.extend_from_slice(bytes);
    }

    /// Bytes waiting for the rest of their frame.
    pub fn pending(&self) -> usize {
        self.buf.len()
    }

    /// Forgets everything buffered and the sequence (after a reconnection).
    pub fn reset(&mut self) {
        self.buf.clear();
        self.last_seq = None;
    }

    /// The next frame or skip, or `None` until more bytes arrive.
    pub fn decode(&mut self) -> Option<Decoded> {
        let start = self.buf.windows(2).position(|w| w == SYNC);
        match start {
            Some(0) => {}
            Some(n) => return Some(self.skip(n, FrameError::Garbage(n))),
            None => {
                // keep a last byte that may be the first half of a sync pattern
                let keep = usize::from(self.buf.last() == Some(&SYNC[0]));
                let n = self.buf.len() - keep;
                return (n > 0).then(|| self.skip(n, FrameError::Garbage(n)));
            }
        }
        if self.buf.len() < HEADER_LEN {
            return None;
        }
        let (kind, len) = (self.buf[2], usize::from(self.buf[5]));
        if len > MAX_PAYLOAD {
            let expected = Frame::payload_len(kind).unwrap_or(0);
            return Some(self.skip(
                1,
                FrameError::WrongLength {
                    kind,
                    expected,
                    got: len,
                },
            ));
        }
        let total = HEADER_LEN + len + CRC_LEN;
        if self.buf.len() < total {
            return None;
        }
        let got = u16::from_le_bytes([self.buf[total - 2], self.buf[total - 1]]);
        let computed = crc16(&self.buf[2..total - CRC_LEN]);
        if got != computed {
            // a corrupted frame may hide the start of the next one: resume right after the sync
            return Some(self.skip(1, FrameError::BadChecksum { got, computed }));
        }
        let seq = u16::from_le_bytes([self.buf[3], self.buf[4]]);
        let parsed = Frame::parse(kind, &self.buf[HEADER_LEN..total - CRC_LEN]);
        self.buf.drain(..total);
        Some(match parsed {
            Ok(frame) => {
                let lost = self
                    .last_seq
                    .map_or(0, |last| seq.wrapping_sub(last).wrapping_sub(1));
                self.last_seq = Some(seq);
                Decoded::Frame { seq, frame, lost }
            }
            Err(e) => Decoded::Skipped(e),
        })
    }

    fn skip(&mut self, n: usize, why: FrameError) -> Decoded {
        self.buf.drain(..n);
        Decoded::Skipped(why)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::frame::{Force, Frame};

    fn force(f: f32) -> Frame {
        Frame::Force(Force {
            force_n: f,
            answers: 1,
        })
    }

    fn drain(d: &mut Decoder) -> Vec<Decoded> {
        std::iter::from_fn(|| d.decode()).collect()
    }

    fn frames(out: &[Decoded]) -> Vec<(u16, Frame, u16)> {
        out.iter()
            .filter_map(|d| match d {
                Decoded::Frame { seq, frame, lost } => Some((*seq, *frame, *lost)),
                Decoded::Skipped(_) => None,
            })
            .collect()
    }

    #[test]
    fn frames_cut_anywhere_come_out_whole() {
        let bytes: Vec<u8> = (0..5u16)
            .flat_map(|k| force(f32::from(k)).encode(k))
            .collect();
        for cut in 1..bytes.len() {
            let mut d = Decoder::new();
            d.push(&bytes[..cut]);
            let mut out = drain(&mut d);
            d.push(&bytes[cut..]);
            out.extend(drain(&mut d));
            let got = frames(&out);
            assert_eq!(got.len(), 5, "cut at {cut}: {out:?}");
            assert!(got.iter().all(|(_, _, lost)| *lost == 0));
            assert_eq!(d.pending(), 0);
        }
    }

    #[test]
    fn garbage_is_skipped_and_said() {
        let mut d = Decoder::new();
        d.push(b"boot log\r\n");
        d.push(&force(2.0).encode(9));
        let out = drain(&mut d);
        assert_eq!(out[0], Decoded::Skipped(FrameError::Garbage(10)));
        assert_eq!(frames(&out), vec![(9, force(2.0), 0)]);
    }

    #[test]
    fn a_corrupted_frame_costs_only_itself() {
        let mut bytes = force(1.0).encode(1);
        bytes[8] ^= 0x40;
        bytes.extend(force(2.0).encode(2));
        let mut d = Decoder::new();
        d.push(&bytes);
        let out = drain(&mut d);
        assert!(
            matches!(out[0], Decoded::Skipped(FrameError::BadChecksum { .. })),
            "{out:?}"
        );
        assert_eq!(frames(&out), vec![(2, force(2.0), 0)]);
    }

    #[test]
    fn missed_sequence_numbers_are_counted_across_the_wrap() {
        let mut d = Decoder::new();
        for seq in [65533u16, 65534, 1, 2] {
            d.push(&force(0.0).encode(seq));
        }
        let lost: Vec<u16> = frames(&drain(&mut d)).iter().map(|f| f.2).collect();
        // 65535 and 0 were missed
        assert_eq!(lost, vec![0, 0, 2, 0]);
    }

    #[test]
    fn no_input_makes_it_panic_or_grow() {
        // a deterministic stream of arbitrary bytes with real frames mixed in
        let mut x: u32 = 12345;
        let mut d = Decoder::new();
        let mut intact = 0;
        for round in 0..2000u16 {
            let mut chunk = Vec::new();
            for _ in 0..(x % 40) {
                x = x.wrapping_mul(1_103_515_245).wrapping_add(12345);
                chunk.push((x >> 16) as u8);
            }
            if round % 3 == 0 {
                chunk.extend(force(1.5).encode(round));
            }
            d.push(&chunk);
            intact += frames(&drain(&mut d)).len();
            assert!(
                d.pending() < HEADER_LEN + MAX_PAYLOAD + CRC_LEN,
                "{}",
                d.pending()
            );
        }
        // nearly every real frame is found (random bytes can swallow one that follows them)
        assert!(intact >= 600, "{intact} of 667");
    }
}

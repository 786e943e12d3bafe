//! The frame layout and the three messages. All numbers little endian; floats IEEE 754 binary32
//! (what a microcontroller's FPU has); SI units.
//!
//! ```text
//! offset  size  field
//! 0       2     sync 0xCA 0x95
//! 2       1     type: 0x01 hello, 0x02 measurement (device -> driver), 0x03 force (driver -> device)
//! 3       2     seq: u16, +1 per frame sent in that direction, wrapping at 65535
//! 5       1     len: payload length in bytes (fixed per type: 20, 25, 6)
//! 6       len   payload
//! 6+len   2     CRC-16/CCITT-FALSE of bytes 2 .. 6+len (type, seq, len, payload)
//! ```

use crate::crc::crc16;

/// The two bytes every frame starts with.
pub const SYNC: [u8; 2] = [0xCA, 0x95];
/// Bytes before the payload: sync, type, seq, len.
pub const HEADER_LEN: usize = 6;
/// Bytes after the payload: the CRC.
pub const CRC_LEN: usize = 2;
/// The protocol version a hello frame carries.
pub const VERSION: u8 = 1;

/// What a device measures, as the bits of [`Hello::measured`].
pub mod measured {
    /// The inner mass relative to the shell, `x1 - x2` (a displacement sensor).
    pub const RELATIVE_DISPLACEMENT: u8 = 1 << 0;
    /// The shell's position `x2` (an encoder on a wheel, an optical tracker).
    pub const CAPSULE_POSITION: u8 = 1 << 1;
    /// The inner mass's velocity.
    pub const MASS_VELOCITY: u8 = 1 << 2;
    /// The shell's velocity.
    pub const CAPSULE_VELOCITY: u8 = 1 << 3;
    /// Whether the mass touches the shell's stop (a contact switch).
    pub const CONTACT: u8 = 1 << 4;
}

/// The device introduces itself, first and whenever asked again (device -> driver).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Hello {
    /// Protocol version ([`VERSION`]).
    pub version: u8,
    /// Which quantities its measurements carry ([`measured`] bits); the rest are NaN.
    pub measured: u8,
    /// The largest force its actuator may be commanded \[N\] (the driver enforces the smaller of
    /// this and its own limit).
    pub max_force_n: f32,
    /// The largest `|x1 - x2|` before the mass hits the shell's ends \[m\] (over-travel limit).
    pub max_travel_m: f32,
    /// Its measurement rate \[Hz\].
    pub sample_rate_hz: f32,
    /// After this long without a force frame it zeroes the force itself \[s\].
    pub command_timeout_s: f32,
}

/// One measurement (device -> driver). A quantity the device does not measure is NaN.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Measurement {
    /// The device's clock when it sampled \[us\], wrapping.
    pub t_us: u32,
    /// `x1 - x2`: the inner mass relative to the shell \[m\].
    pub relative_m: f32,
    /// `x2`: the shell's position \[m\].
    pub capsule_m: f32,
    /// The mass's velocity \[m/s\] (NaN: not measured).
    pub mass_velocity: f32,
    /// The shell's velocity \[m/s\] (NaN: not measured).
    pub capsule_velocity: f32,
    /// The mean force the actuator applied on the mass over the sample period that ends with
    /// this measurement \[N\] (after its limit, lag and dead band; NaN: unknown): what acted,
    /// whenever the force frames came, so that a recording says which force moved the capsule
    /// between two measurements even where the answers were late.
    pub applied_force_n: f32,
    /// Bit 0: contact is measured; bit 1: the mass touches the stop.
    pub flags: u8,
}

/// The force to apply until the next one (driver -> device).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Force {
    /// The force \[N\].
    pub force_n: f32,
    /// The sequence number of the measurement it answers.
    pub answers: u16,
}

/// A message of the protocol.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Frame {
    /// 0x01, 20 bytes.
    Hello(Hello),
    /// 0x02, 25 bytes.
    Measurement(Measurement),
    /// 0x03, 6 bytes.
    Force(Force),
}

/// Why bytes that looked like a frame are not one.
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
pub enum FrameError {
    /// No sync pattern where a frame should start.
    #[error("{0} bytes before a sync pattern")]
    Garbage(usize),
    /// The checksum does not match the bytes.
    #[error("checksum {got:#06x}, the bytes give {computed:#06x}")]
    BadChecksum {
        /// The CRC the frame carries.
        got: u16,
        /// The CRC of its bytes.
        computed: u16,
    },
    /// A type this protocol does not have.
    #[error("unknown frame type {0:#04x}")]
    UnknownType(u8),
    /// A payload length that is not its type's.
    #[error("frame type {kind:#04x} with {got} payload bytes, not {expected}")]
    WrongLength {
        /// The frame type.
        kind: u8,
        /// Its payload length.
        expected: usize,
        /// The length the frame says.
        got: usize,
    },
}

impl Frame {
    /// The type byte.
    pub fn kind(&self) -> u8 {
        match self {
            Frame::Hello(_) => 0x01,
            Frame::Measurement(_) => 0x02,
            Frame::Force(_) => 0x03,
        }
    }

    /// The payload length of a frame type, or `None` for an unknown type.
    pub fn payload_len(kind: u8) -> Option<usize> {
        match kind {
            0x01 => Some(20),
            0x02 => Some(25),
            0x03 => Some(6),
            _ => None,
        }
    }

    /// The frame as bytes, sent with sequence number `seq`.
    pub fn encode(&self, seq: u16) -> Vec<u8> {
        let mut p = Vec::with_capacity(25);
        match self {
            Frame::Hello(h) => {
                p.extend([h.version, h.measured, 0, 0]);
                for v in [
                    h.max_force_n,
                    h.max_travel_m,
                    h.sample_rate_hz,
                    h.command_timeout_s,
                ] {
                    p.extend(v.to_le_bytes());
                }
            }
            Frame::Measurement(m) => {
                p.extend(m.t_us.to_le_bytes());
                for v in [
                    m.relative_m,
                    m.capsule_m,
                    m.mass_velocity,
                    m.capsule_velocity,
                    m.applied_force_n,
                ] {
                    p.extend(v.to_le_bytes());
                }
                p.push(m.flags);
            }
            Frame::Force(f) => {
                p.extend(f.force_n.to_le_bytes());
                p.extend(f.answers.to_le_bytes());
            }
        }
        let mut out = Vec::with_capacity(HEADER_LEN + p.len() + CRC_LEN);
        out.extend(SYNC);
        out.push(self.kind());
        out.extend(seq.to_le_bytes());
        // every payload is at most 25 bytes
        out.push(p.len() as u8);
        out.extend(&p);
        let crc = crc16(&out[2..]);
        out.extend(crc.to_le_bytes());
        out
    }

    /// The message of a type byte and its payload (checksum already checked).
    pub fn parse(kind: u8, p: &[u8]) -> Result<Frame, FrameError> {
        let expected = Frame::payload_len(kind).ok_or(FrameError::UnknownType(kind))?;
        if p.len() != expected {
            return Err(FrameError::WrongLength {
                kind,
                expected,
                got: p.len(),
            });
        }
        let f32_at = |i: usize| f32::from_le_bytes([p[i], p[i + 1], p[i + 2], p[i + 3]]);
        Ok(match kind {
            0x01 => Frame::Hello(Hello {
                version: p[0],
                measured: p[1],
                max_force_n: f32_at(4),
                max_travel_m: f32_at(8),
                sample_rate_hz: f32_at(12),
                command_timeout_s: f32_at(16),
            }),
            0x02 => Frame::Measurement(Measurement {
                t_us: u32::from_le_bytes([p[0], p[1], p[2], p[3]]),
                relative_m: f32_at(4),
                capsule_m: f32_at(8),
                mass_velocity: f32_at(12),
                capsule_velocity: f32_at(16),
                applied_force_n: f32_at(20),
                flags: p[24],
            }),
            _ => Frame::Force(Force {
                force_n: f32_at(0),
                answers: u16::from_le_bytes([p[4], p[5]]),
            }),
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    pub(crate) fn examples() -> Vec<Frame> {
        vec![
            Frame::Hello(Hello {
                version: VERSION,
                measured: measured::RELATIVE_DISPLACEMENT | measured::CAPSULE_POSITION,
                max_force_n: 10.0,
                max_travel_m: 0.004,
                sample_rate_hz: 1000.0,
                command_timeout_s: 0.1,
            }),
            Frame::Measurement(Measurement {
                t_us: 4_000_000_123,
                relative_m: -1.25e-3,
                capsule_m: 0.0123,
                mass_velocity: f32::NAN,
                capsule_velocity: f32::NAN,
                applied_force_n: 0.5,
                flags: 0,
            }),
            Frame::Force(Force {
                force_n: -3.5,
                answers: 65535,
            }),
        ]
    }

    /// Equal, NaN fields included.
    fn same(a: &Frame, b: &Frame) -> bool {
        format!("{a:?}") == format!("{b:?}")
    }

    #[test]
    fn every_frame_survives_encoding() {
        for f in examples() {
            let bytes = f.encode(7);
            assert_eq!(bytes[..2], SYNC);
            assert_eq!(bytes[2], f.kind());
            assert_eq!(u16::from_le_bytes([bytes[3], bytes[4]]), 7);
            let len = usize::from(bytes[5]);
            assert_eq!(Some(len), Frame::payload_len(f.kind()));
            assert_eq!(bytes.len(), HEADER_LEN + len + CRC_LEN);
            let back = Frame::parse(bytes[2], &bytes[HEADER_LEN..HEADER_LEN + len]);
            assert!(
                back.as_ref().is_ok_and(|b| same(b, &f)),
                "{f:?} -> {back:?}"
            );
        }
    }

    #[test]
    fn a_force_frame_byte_for_byte() {
        // what a firmware author can check their decoder against
        let bytes = Frame::Force(Force {
            force_n: 1.0,
            answers: 0x0102,
        })
        .encode(0x0304);
        let crc = crc16(&bytes[2..12]).to_le_bytes();
        assert_eq!(
            bytes,
            [0xCA, 0x95, 0x03, 0x04, 0x03, 6, 0x00, 0x00, 0x80, 0x3F, 0x02, 0x01, crc[0], crc[1]]
        );
    }

    #[test]
    fn unknown_types_and_wrong_lengths_are_named() {
        assert_eq!(Frame::parse(0x09, &[]), Err(FrameError::UnknownType(0x09)));
        assert_eq!(
            Frame::parse(0x03, &[0; 5]),
            Err(FrameError::WrongLength {
                kind: 3,
                expected: 6,
                got: 5
            })
        );
    }
}

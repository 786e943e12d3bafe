//! The capsule device protocol: what a prototype's microcontroller and the plant node's hardware
//! driver say to each other over a serial line (or UDP), as bytes, with no I/O here.
//!
//! - [`frame`]: the frame layout (sync, type, sequence number, length, payload, CRC-16), the
//!   three messages ([`frame::Hello`], [`frame::Measurement`], [`frame::Force`]) and their
//!   encoding;
//! - [`decoder`]: a byte-stream decoder that finds frames in whatever arrives (garbage, cut
//!   frames, bad checksums) and says what it skipped;
//! - [`crc`]: CRC-16/CCITT-FALSE, the checksum.
//!
//! The whole protocol, for a firmware author, is in `docs/hardware.md`.

#![warn(missing_docs)]

pub mod crc;
pub mod decoder;
pub mod frame;

pub use decoder::{Decoded, Decoder};
pub use frame::{Force, Frame, FrameError, Hello, Measurement};

//! The capsule device protocol on a real line: a serial port or a pseudo-terminal in raw mode
//! ([`tty`]) and a framed link over it with deadlines ([`link`]). I/O, no ROS: the plant node's
//! serial driver and the device emulator both stand on it.

#![warn(missing_docs)]

pub mod link;
pub mod tty;

pub use link::{Line, Link, LinkError};
pub use tty::{open_line, open_pty, Pty, BAUD_RATES};

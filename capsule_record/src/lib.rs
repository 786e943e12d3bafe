//! Recordings of capsule runs: one MCAP file per run in the ROS 2 profile, the way rosbag2
//! writes it, so that `ros2 bag`, Foxglove, `rosbags` and the `mcap` tools read it without
//! this code.
//!
//! - [`writer::RecordWriter`]: profile `ros2`; schemas `pkg/msg/Type` in `ros2msg` with every
//!   dependency appended; messages in `cdr` with the encapsulation header;
//!   `offered_qos_profiles` on every channel; a `rosbag2` metadata record; the scene as an
//!   attachment; uncompressed chunks closed every 0.5 s of log time (and on the caller's
//!   timer), so a killed run loses at most its open chunk.
//! - [`read::info`]: duration, topics, counts, mode changes and scene from the summary section
//!   (no scan); [`read::messages`] for replay.
//! - [`recover::recover`]: completes a file cut by a kill.
//!
//! No ROS, no DDS here: the recorder node feeds this crate with bytes.

pub mod cdr;
pub mod civil;
pub mod error;
pub mod read;
pub mod recover;
pub mod types;
pub mod writer;

pub use error::RecordError;
pub use read::{info, messages, RecordingInfo};
pub use recover::{recover, Recovered};
pub use writer::{ChannelId, RecordWriter, SceneRecord, WriterOptions};

#[cfg(test)]
mod tests;

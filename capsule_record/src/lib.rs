//! Recordings of capsule runs: one MCAP file per run in the ROS 2 profile, the way rosbag2
//! writes it, so that `ros2 bag`, Foxglove, `rosbags` and the `mcap` tools read it without
//! this code.
//!
//! - [`writer::RecordWriter`]: profile `ros2`; schemas `pkg/msg/Type` in `ros2msg` with every
//!   dependency appended; messages in `cdr` with the encapsulation header;
//!   `offered_qos_profiles` on every channel; a `rosbag2` metadata record; the scene as an
//!   attachment; chunks (uncompressed, zstd or lz4) closed every 0.5 s of log time (and on the caller's
//!   timer), so a killed run loses at most its open chunk.
//! - [`bag::BagWriter`]: compression and splitting into numbered files with a rosbag2
//!   `metadata.yaml` ([`metadata_yaml`]), as rosbag2 users configure recordings; the
//!   profile's names in [`profile`].
//! - [`info::info`]: duration, topics, counts, mode changes and scene from the summary section
//!   (no scan); [`messages::messages`] for replay; [`scan::scan`] reads every record of a
//!   file; `open` checks a file before reading it.
//! - [`series::series`]: the states and force commands as time series, for identification.
//! - [`sample::state_message`]: a hardware sample as the `CapsuleState` the plant publishes.
//! - [`recover::recover`]: rebuilds a damaged or cut file from every intact chunk and renames
//!   old schema blocks ([`fix_schemas`]).
//!
//! No ROS, no DDS here: the recorder node feeds this crate with bytes.

pub mod bag;
pub mod cdr;
pub mod civil;
pub mod error;
pub mod fix_schemas;
pub mod info;
pub mod messages;
pub mod metadata_yaml;
mod open;
pub mod profile;
pub mod recover;
pub mod sample;
pub mod scan;
pub mod series;
pub mod types;
pub mod writer;

pub use bag::{BagOptions, BagWriter};
pub use error::RecordError;
pub use info::{info, RecordingInfo};
pub use messages::messages;
pub use recover::{recover, Recovered};
pub use writer::{ChannelId, ChunkCompression, RecordWriter, SceneRecord, WriterOptions};

#[cfg(test)]
mod tests;

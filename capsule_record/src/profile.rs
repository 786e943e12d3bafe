//! The names of rosbag2's `ros2` MCAP profile and of capsule's own records in it: what the
//! writer writes and the readers look for.

/// Name of the attachment that holds the scene file.
pub const SCENE_ATTACHMENT: &str = "scene.toml";
/// Name of the metadata record with capsule's own facts (scene name, start time, tool).
pub const CAPSULE_METADATA: &str = "capsule";
/// Name of the metadata record rosbag2 writes.
pub const ROSBAG2_METADATA: &str = "rosbag2";
/// Channel metadata key with the publisher's QoS (rosbag2's).
pub const QOS_KEY: &str = "offered_qos_profiles";

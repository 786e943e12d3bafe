//! rosbag2's `metadata.yaml`: what a split recording's directory holds, and the text the
//! `rosbag2` metadata record of every file carries.

/// Name of the rosbag2 metadata file of a split recording.
pub const METADATA_YAML: &str = "metadata.yaml";

/// One topic as `metadata.yaml` lists it.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct BagTopic {
    /// Topic name.
    pub topic: String,
    /// ROS type (`pkg/msg/Type`).
    pub type_name: String,
    /// Offered QoS YAML (rosbag2's, numeric enums).
    pub qos_yaml: String,
    /// Messages on it.
    pub count: u64,
}

/// One file as `metadata.yaml` lists it.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct BagFile {
    /// File name relative to the bag directory.
    pub name: String,
    /// First and last log time (ns), if any message.
    pub bounds: Option<(u64, u64)>,
    /// Messages in it.
    pub messages: u64,
}

fn yaml_quote(s: &str) -> String {
    let mut out = String::from("\"");
    for c in s.chars() {
        match c {
            '"' => out.push_str("\\\""),
            '\\' => out.push_str("\\\\"),
            '\n' => out.push_str("\\n"),
            c => out.push(c),
        }
    }
    out.push('"');
    out
}

/// rosbag2's `metadata.yaml` text (version 8: per-file entries, `custom_data`, `ros_distro`;
/// QoS in the numeric form of versions <= 8). MCAP chunk compression is the storage's own
/// business: rosbag2 writes `compression_format: ""` for it, as here.
pub fn metadata_yaml(topics: &[BagTopic], files: &[BagFile], ros_distro: &str) -> String {
    let bounds = files
        .iter()
        .filter_map(|f| f.bounds)
        .reduce(|a, b| (a.0.min(b.0), a.1.max(b.1)))
        .unwrap_or((0, 0));
    let messages: u64 = files.iter().map(|f| f.messages).sum();
    let mut y =
        String::from("rosbag2_bagfile_information:\n  version: 8\n  storage_identifier: mcap\n");
    y += &format!(
        "  duration:\n    nanoseconds: {}\n  starting_time:\n    nanoseconds_since_epoch: {}\n  message_count: {messages}\n  topics_with_message_count:\n",
        bounds.1 - bounds.0,
        bounds.0
    );
    for t in topics {
        y += &format!(
            "    - topic_metadata:\n        name: {}\n        type: {}\n        serialization_format: cdr\n        offered_qos_profiles: {}\n        type_description_hash: \"\"\n      message_count: {}\n",
            t.topic,
            t.type_name,
            yaml_quote(&t.qos_yaml),
            t.count
        );
    }
    y += "  compression_format: \"\"\n  compression_mode: \"\"\n  relative_file_paths:\n";
    for f in files {
        y += &format!("    - {}\n", f.name);
    }
    y += "  files:\n";
    for f in files {
        let (a, b) = f.bounds.unwrap_or((0, 0));
        y += &format!(
            "    - path: {}\n      starting_time:\n        nanoseconds_since_epoch: {a}\n      duration:\n        nanoseconds: {}\n      message_count: {}\n",
            f.name,
            b - a,
            f.messages
        );
    }
    y += &format!("  custom_data: ~\n  ros_distro: {ros_distro}\n");
    y
}

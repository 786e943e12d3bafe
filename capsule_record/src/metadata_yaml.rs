//! rosbag2's `metadata.yaml`: what a split recording's directory holds, and the text the
//! `rosbag2` metadata record of every file carries.

use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;

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

/// rosbag2's `metadata.yaml` text (version 8: per-file entries, `custom_data`, `ros_distro`;
/// QoS in the numeric form of versions <= 8). MCAP chunk compression is the storage's own
/// business: rosbag2 writes `compression_format: ""` for it, as here.
pub fn metadata_yaml(topics: &[BagTopic], files: &[BagFile], ros_distro: &str) -> String {
    let bounds = files
        .iter()
        .filter_map(|f| f.bounds)
        .reduce(|a, b| (a.0.min(b.0), a.1.max(b.1)))
        .unwrap_or((0, 0));
    let info = BagfileInformation {
        version: 8,
        storage_identifier: "mcap",
        duration: Nanoseconds {
            nanoseconds: bounds.1 - bounds.0,
        },
        starting_time: SinceEpoch {
            nanoseconds_since_epoch: bounds.0,
        },
        message_count: files.iter().map(|f| f.messages).sum(),
        topics_with_message_count: topics
            .iter()
            .map(|t| TopicWithCount {
                topic_metadata: TopicMetadata {
                    name: &t.topic,
                    r#type: &t.type_name,
                    serialization_format: "cdr",
                    offered_qos_profiles: &t.qos_yaml,
                    type_description_hash: crate::types::type_hash(&t.type_name).unwrap_or(""),
                },
                message_count: t.count,
            })
            .collect(),
        compression_format: "",
        compression_mode: "",
        relative_file_paths: files.iter().map(|f| f.name.as_str()).collect(),
        files: files
            .iter()
            .map(|f| {
                let (a, b) = f.bounds.unwrap_or((0, 0));
                FileInformation {
                    path: &f.name,
                    starting_time: SinceEpoch {
                        nanoseconds_since_epoch: a,
                    },
                    duration: Nanoseconds { nanoseconds: b - a },
                    message_count: f.messages,
                }
            })
            .collect(),
        custom_data: None,
        ros_distro,
    };
    // plain numbers, strings and lists: serializing cannot fail
    yaml_serde::to_string(&MetadataFile {
        rosbag2_bagfile_information: info,
    })
    .unwrap_or_default()
}

/// The file names of a `metadata.yaml` text (`relative_file_paths`), in order.
pub fn relative_file_paths(text: &str) -> Result<Vec<String>, String> {
    #[derive(Deserialize)]
    struct File {
        rosbag2_bagfile_information: Paths,
    }
    #[derive(Deserialize)]
    struct Paths {
        relative_file_paths: Vec<String>,
    }
    yaml_serde::from_str::<File>(text)
        .map(|f| f.rosbag2_bagfile_information.relative_file_paths)
        .map_err(|e| e.to_string())
}

// rosbag2's `BagMetadata` as its YAML writer lays it out (rosbag2_storage's yaml.hpp), field
// by field in its order.

#[derive(Serialize)]
struct MetadataFile<'a> {
    rosbag2_bagfile_information: BagfileInformation<'a>,
}

#[derive(Serialize)]
struct BagfileInformation<'a> {
    version: u32,
    storage_identifier: &'a str,
    duration: Nanoseconds,
    starting_time: SinceEpoch,
    message_count: u64,
    topics_with_message_count: Vec<TopicWithCount<'a>>,
    compression_format: &'a str,
    compression_mode: &'a str,
    relative_file_paths: Vec<&'a str>,
    files: Vec<FileInformation<'a>>,
    /// None: `null`, as rosbag2 writes an empty map (`~`).
    custom_data: Option<BTreeMap<String, String>>,
    ros_distro: &'a str,
}

#[derive(Serialize)]
struct Nanoseconds {
    nanoseconds: u64,
}

#[derive(Serialize)]
struct SinceEpoch {
    nanoseconds_since_epoch: u64,
}

#[derive(Serialize)]
struct TopicWithCount<'a> {
    topic_metadata: TopicMetadata<'a>,
    message_count: u64,
}

#[derive(Serialize)]
struct TopicMetadata<'a> {
    name: &'a str,
    r#type: &'a str,
    serialization_format: &'a str,
    /// The QoS profiles as YAML text, in a string (rosbag2's form up to version 8).
    offered_qos_profiles: &'a str,
    type_description_hash: &'a str,
}

#[derive(Serialize)]
struct FileInformation<'a> {
    path: &'a str,
    starting_time: SinceEpoch,
    duration: Nanoseconds,
    message_count: u64,
}

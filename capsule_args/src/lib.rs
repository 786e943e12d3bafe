//! What the command lines of the offline toolkit (`capsule`) and the ROS 2 nodes share, without
//! ROS or DDS: the offline toolkit depends on this crate, not on the nodes.
//!
//! - [`ranges`]: the documented range of every numeric flag, checked at parse time
//! - [`settings`]: a node's settings declared once (flag, ROS parameter, scene key, range, help,
//!   precedence); [`plant_settings`], [`controller_settings`]: the nodes' tables, with the
//!   rows both hold in [`scale_settings`], the plant's views' in [`view_settings`]
//! - [`node_table`]: the scene file's `[node]` table, how the plant node runs the scene
//! - [`scene_file`]: reading a scene file once, the same way in every binary
//! - [`storage`]: how a recording is stored (compression, splitting), as rosbag2 users set it

#![warn(missing_docs)]

pub mod controller_settings;
pub mod node_table;
pub mod plant_settings;
pub mod ranges;
pub mod scale_settings;
pub mod scene_file;
pub mod settings;
pub mod storage;
pub mod view_settings;

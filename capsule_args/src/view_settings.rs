//! The plant's views of its state (`capsule_plant_node::views`) in its settings table: a switch
//! each, on unless its `--no-` flag is given, and their rate; read-only parameters `views.*`.

use crate::settings::{Kind, Setting};

/// joint_states.
pub const JOINT_STATES: Setting = Setting::new(
    "views.joint_states",
    "publish joint_states (sensor_msgs/JointState)",
    Kind::Switch,
)
.flag()
.inverted();
/// /tf.
pub const TF: Setting = Setting::new(
    "views.tf",
    "publish /tf (the capsule frame in odom)",
    Kind::Switch,
)
.flag()
.inverted();
/// robot_description.
pub const ROBOT_DESCRIPTION: Setting = Setting::new(
    "views.robot_description",
    "publish robot_description (URDF, transient local)",
    Kind::Switch,
)
.flag()
.inverted();
/// /diagnostics.
pub const DIAGNOSTICS: Setting = Setting::new(
    "views.diagnostics",
    "publish /diagnostics at 1 Hz",
    Kind::Switch,
)
.flag()
.inverted();
/// How often joint_states and /tf go out, at most: a rate's range, as the loop's.
pub const RATE_HZ: Setting = Setting::new(
    "views.rate_hz",
    "joint_states and /tf at most this often [Hz] (every n-th sample, n = rate / this, \
     rounded, at least 1): a viewer needs far less than the loop's 1-10 kHz, and each write \
     costs DDS a wake-up",
    Kind::Number {
        min: crate::ranges::RATE_HZ.0,
        max: crate::ranges::RATE_HZ.1,
    },
)
.flag()
.default(100.0);

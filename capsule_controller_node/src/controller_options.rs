//! How the controller node is set up besides its ROS settings, in a file of its own because
//! both middlewares' node code reads it (`controller` on DDS, `controller_zenoh` on Zenoh).

use std::time::Duration;

use capsule_ros_base::action::Introspection;
use capsule_ros_base::params::ParamTable;

use crate::controller_core::ControllerCore;

/// How the controller node is set up (besides the ROS settings).
#[derive(Debug, Clone)]
pub struct ControllerOptions {
    /// The core, configured.
    pub core: ControllerCore,
    /// Stale-state check and status period.
    pub status_period: Duration,
    /// The ROS parameters served (see [`crate::controller_params`]).
    pub params: ParamTable,
    /// Publish `/diagnostics` at 1 Hz (see [`crate::controller_diagnostics`]).
    pub diagnostics: bool,
    /// What the actions' services publish on their `_service_event` topics.
    pub action_introspection: Introspection,
}

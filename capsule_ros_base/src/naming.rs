//! A node's names as ROS 2 resolves them: private (`~/x`), relative and absolute names
//! expanded in the node's namespace, then remapped (`--remap`, `-r`). The names themselves are
//! [`capsule_msgs::names`].

use ros2_client::Name;

use crate::error::{Context as _, Result};
use crate::ros_options::RosOptions;

impl RosOptions {
    /// Expands `~/x` (private), `x` (relative) and `/x` (absolute) to a full name, no remap.
    pub fn expand(&self, name: &str) -> String {
        let ns = self.namespace.trim_end_matches('/');
        if let Some(rest) = name.strip_prefix("~/") {
            format!("{ns}/{}/{rest}", self.node_name)
        } else if name.starts_with('/') {
            name.to_string()
        } else {
            format!("{ns}/{name}")
        }
    }

    /// The full name a topic or service gets: expanded, then remapped.
    pub fn resolve_name(&self, name: &str) -> String {
        let full = self.expand(name);
        self.remaps.get(&full).cloned().unwrap_or(full)
    }

    /// The resolved name as a ros2-client [`Name`].
    pub fn ros_name(&self, name: &str) -> Result<Name> {
        let full = self.resolve_name(name);
        Name::parse(&full).with_context(|| format!("bad ROS name {full:?}"))
    }
}

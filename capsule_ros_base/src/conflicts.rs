//! Conflicts in the graph that a node says loudly: a second plant publishing the state, a
//! second controller commanding, or an endpoint of another type on one of our topics.
//!
//! Two plants on one domain cross-talk silently otherwise (issue 12: a second plant applied
//! the first one's commands on 5,876 of 5,885 samples): commands carry the stamp and seq of the
//! sample they answer, and both plants sample on the same grid, so neither can tell the other's
//! commands from its own. What a node can do is notice the other endpoint in discovery (every
//! remote endpoint, matched or not, from [`Graph::remote_endpoints`]) and say so: a warning
//! when a conflict appears, repeated every [`REPEAT`] while it lasts, and a count in the
//! node's summary.

use std::{
    collections::BTreeSet,
    sync::{
        atomic::{AtomicU64, Ordering},
        Arc,
    },
    time::Duration,
};

use rustdds::TopicDescription;
use tracing::{info, warn};

use crate::graph::{Endpoint, Graph};

/// How often a standing conflict is said again.
pub const REPEAT: Duration = Duration::from_secs(10);

/// What a node expects on one of its topics.
#[derive(Debug, Clone)]
pub struct TopicRule {
    /// ROS name, for the message.
    pub ros_name: String,
    /// DDS topic name (`rt/...`).
    pub dds_name: String,
    /// Its type's DDS name.
    pub type_name: String,
    /// Other participants allowed to publish it (with our type).
    pub max_publishers: usize,
    /// What more publishers mean, for the message.
    pub meaning: &'static str,
}

impl TopicRule {
    /// The rule for `topic` (as created on the node) under `ros_name`.
    pub fn new(
        topic: &rustdds::Topic,
        ros_name: String,
        max_publishers: usize,
        meaning: &'static str,
    ) -> Self {
        TopicRule {
            ros_name,
            dds_name: topic.name(),
            type_name: topic.get_type().name().to_string(),
            max_publishers,
            meaning,
        }
    }

    /// The conflicts on this topic among `remote` (its remote endpoints).
    pub fn conflicts(&self, remote: &[Endpoint]) -> Vec<String> {
        let mut out = Vec::new();
        for e in remote.iter().filter(|e| e.type_name != self.type_name) {
            out.push(format!(
                "a {} of type {} on {} (ours: {}): types differ, so its samples are dropped or undecodable",
                if e.writer { "publisher" } else { "subscriber" },
                e.type_name,
                self.ros_name,
                self.type_name
            ));
        }
        let publishers: BTreeSet<_> = remote
            .iter()
            .filter(|e| e.writer && e.type_name == self.type_name)
            .map(|e| e.guid.prefix)
            .collect();
        if publishers.len() > self.max_publishers {
            out.push(format!(
                "{} other participant(s) publish {} (expected at most {}): {}",
                publishers.len(),
                self.ros_name,
                self.max_publishers,
                self.meaning
            ));
        }
        out
    }
}

/// Follows `graph` and logs the conflicts of `rules` (warning when one appears, again every
/// [`REPEAT`] while it lasts, info when it clears). Returns the number of conflicts seen.
pub fn watch(graph: Graph, rules: Vec<TopicRule>) -> Arc<AtomicU64> {
    let seen = Arc::new(AtomicU64::new(0));
    let count = Arc::clone(&seen);
    tokio::spawn(async move {
        let mut changes = graph.changes();
        let mut standing: BTreeSet<String> = BTreeSet::new();
        let mut repeat = tokio::time::interval(REPEAT);
        repeat.tick().await;
        loop {
            let now: BTreeSet<String> = rules
                .iter()
                .flat_map(|r| r.conflicts(&graph.remote_endpoints(&r.dds_name)))
                .collect();
            for c in now.difference(&standing) {
                count.fetch_add(1, Ordering::Relaxed);
                warn!("GRAPH CONFLICT: {c}");
            }
            for c in standing.difference(&now) {
                info!("graph conflict gone: {c}");
            }
            standing = now;
            tokio::select! {
                r = changes.changed() => if r.is_err() { return },
                _ = repeat.tick() => {
                    for c in &standing {
                        warn!("GRAPH CONFLICT (still): {c}");
                    }
                }
            }
        }
    });
    seen
}

#[cfg(test)]
mod tests {
    use super::*;
    use rustdds::GUID;

    fn rule(max: usize) -> TopicRule {
        TopicRule {
            ros_name: "/capsule/state".into(),
            dds_name: "rt/capsule/state".into(),
            type_name: "capsule_msgs::msg::dds_::CapsuleState_".into(),
            max_publishers: max,
            meaning: "a second plant",
        }
    }

    fn endpoint(writer: bool, type_name: &str) -> Endpoint {
        Endpoint {
            guid: GUID::new_participant_guid(),
            writer,
            topic: "rt/capsule/state".into(),
            type_name: type_name.into(),
        }
    }

    #[test]
    fn extra_publishers_and_foreign_types_are_conflicts() {
        let ours = "capsule_msgs::msg::dds_::CapsuleState_";
        let reader = endpoint(false, ours);
        let writer = endpoint(true, ours);
        assert!(rule(0).conflicts(std::slice::from_ref(&reader)).is_empty());
        assert!(rule(1)
            .conflicts(&[reader.clone(), writer.clone()])
            .is_empty());
        let c = rule(0).conflicts(&[reader, writer]);
        assert_eq!(c.len(), 1);
        assert!(c[0].contains("a second plant"), "{c:?}");
        let c = rule(1).conflicts(&[endpoint(true, "std_msgs::msg::dds_::String_")]);
        assert_eq!(c.len(), 1);
        assert!(c[0].contains("std_msgs::msg::dds_::String_"), "{c:?}");
    }
}

//! The plant's DDS endpoints (state, clock, force and JointState commands, views) and the
//! logging of refused and undecodable commands, shared by the pacing loops.

use capsule_msgs::names::topics;
use capsule_msgs::std_types::{Clock, DiagnosticArray, JointState};
use capsule_msgs::{ActuatorForce, CapsuleState};
use capsule_ros_base::error::{Context as _, Result};
use capsule_ros_base::{
    conflicts::TopicRule,
    graph::Graph,
    ros::{qos, subscribe, types, RosOptions},
    throttle::Throttle,
};
use std::time::Duration;
use tracing::warn;

use super::{CommandOutcome, LoopStats, PlantOptions};

/// How long the plant waits after its subscribers matched before the first sample, and after
/// the last sample before it leaves (discovery and sending run on DDS's own thread).
pub(super) const MATCH_GRACE: Duration = Duration::from_millis(200);

/// The plant's DDS endpoints.
pub(super) struct Endpoints {
    pub(super) state_pub: ros2_client::Publisher<CapsuleState>,
    pub(super) clock_pub: ros2_client::Publisher<Clock>,
    pub(super) force_sub: ros2_client::Subscription<ActuatorForce>,
    pub(super) graph: Graph,
    /// Standard-type views (issue 10).
    pub(super) views: crate::views::PlantViews,
    /// JointState commands (`--joint-commands`), `None` when off: one branch per sample.
    pub(super) joint_sub: Option<ros2_client::Subscription<JointState>>,
}

impl Endpoints {
    /// The endpoints on `node`: state, clock and force topics, JointState commands if
    /// `opts` asks, and the views; with the graph's conflict rules for the plant's topics.
    pub(super) fn create(
        node: &mut ros2_client::Node,
        settings: &RosOptions,
        graph: &Graph,
        opts: &PlantOptions,
        rate_hz: f64,
    ) -> Result<(Endpoints, Vec<TopicRule>)> {
        let state_topic = settings.topic(node, topics::STATE, types::state(), &qos::data())?;
        let force_topic = settings.topic(node, topics::FORCE, types::force(), &qos::data())?;
        let clock_topic = settings.topic(node, topics::CLOCK, types::clock(), &qos::clock())?;
        let joint_sub = opts
            .joint_commands
            .then(|| {
                let t = settings.topic(
                    node,
                    topics::JOINT_COMMANDS,
                    types::joint_state(),
                    &qos::data(),
                )?;
                subscribe::<JointState>(node, &t, &qos::data_reader())
            })
            .transpose()?;
        let rules = vec![
            TopicRule::new(
                &state_topic,
                settings.resolve_name(topics::STATE),
                0,
                "ANOTHER PLANT: both apply every command the controller sends",
            ),
            // controllers are checked for their type only: a SIGKILLed one stays in discovery
            // until its lease ends, and its successor would look like a second one
            TopicRule::new(
                &force_topic,
                settings.resolve_name(topics::FORCE),
                usize::MAX,
                "",
            ),
        ];
        let io = Endpoints {
            state_pub: node
                .create_publisher::<CapsuleState>(&state_topic, None)
                .context("state publisher")?,
            clock_pub: node
                .create_publisher::<Clock>(&clock_topic, None)
                .context("clock publisher")?,
            force_sub: subscribe::<ActuatorForce>(node, &force_topic, &qos::data_reader())?,
            joint_sub,
            graph: graph.clone(),
            views: crate::views::Views::create(
                node,
                settings,
                graph,
                crate::views::ViewSwitches::from_table(&opts.params),
                &format!("{:?}", opts.pacing).to_ascii_lowercase(),
                rate_hz,
                opts.params.double(crate::plant_params::names::M1_KG),
            )?,
        };
        Ok((io, rules))
    }

    /// Whether /clock has a subscriber now (rclcpp's `get_subscription_count() > 0` idiom).
    pub(super) fn clock_wanted(&self) -> bool {
        self.graph.subscribers(self.clock_pub.guid()) > 0
    }

    /// Publishes a sample, then its standard-type views (if any are on); the diagnostics if
    /// they went out.
    pub(super) fn publish_state(
        &self,
        state: CapsuleState,
        stats: &LoopStats,
    ) -> Option<DiagnosticArray> {
        let copy = self.views.per_sample.is_some().then(|| state.clone());
        if let Err(e) = self.state_pub.publish(state) {
            warn!("state not sent: {e:?}");
        }
        self.views_of(copy, stats)
    }

    /// The standard-type views of a sample just published; the diagnostics if they went out.
    pub(super) fn views_of(
        &self,
        state: Option<CapsuleState>,
        stats: &LoopStats,
    ) -> Option<DiagnosticArray> {
        let (views, state) = (self.views.per_sample.as_ref()?, state?);
        let mut v = views
            .lock()
            .unwrap_or_else(std::sync::PoisonError::into_inner);
        v.on_sample(&state, stats)
    }
}

/// Logs a refused command: the first ten, then at powers of two.
pub(super) fn log_refused(
    outcome: CommandOutcome,
    cmd: &ActuatorForce,
    throttle: &mut Throttle,
    total: u32,
) {
    if throttle.tick() {
        warn!(
            "command refused ({outcome:?}): seq {} stamp {:.6} s force {} N; {total} refused so far",
            cmd.state_seq,
            cmd.header.stamp.as_secs_f64(),
            cmd.force,
        );
    }
}

/// Logs an undecodable command (e.g. a foreign type on the force topic), rate-limited: a
/// writer of the wrong type sends one per sample.
pub(super) fn log_undecodable(throttle: &mut Throttle, e: &dyn std::fmt::Debug) {
    if throttle.tick() {
        warn!(
            "undecodable command ({} so far; a writer of another type on the force topic?): {e:?}",
            throttle.seen()
        );
    }
}

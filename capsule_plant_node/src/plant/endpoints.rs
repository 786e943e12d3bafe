//! The plant's endpoints (state, clock, force and JointState commands, views) and the
//! logging of refused and undecodable commands, shared by the pacing loops. State and force go
//! over DDS or, composed with the controller in one process, over the in-process link
//! ([`crate::intra_process`]; the state's DDS copies then leave from a publisher thread).

use capsule_hardware::throttle::Throttle;
use capsule_msgs::names::topics;
use capsule_msgs::std_types::{Clock, DiagnosticArray, JointState};
use capsule_msgs::{ActuatorForce, CapsuleState};
use capsule_ros_base::error::{Context as _, Result};
use capsule_ros_base::{
    conflicts::TopicRule, endpoints::subscribe, graph::Graph, qos, ros_options::RosOptions, types,
};
use std::cell::RefCell;
use std::collections::VecDeque;
use std::sync::Arc;
use std::time::Duration;
use tracing::warn;

use crate::intra_process::{CopyCounts, DdsCopies, Link, Transport};

use super::{CommandOutcome, LoopStats, PlantOptions};

/// How long the plant waits after its subscribers matched before the first sample, and after
/// the last sample before it leaves (discovery and sending run on DDS's own thread).
pub(super) const MATCH_GRACE: Duration = Duration::from_millis(200);

/// State and force: DDS topics, or the in-process link.
pub(super) enum StateForce {
    /// Over DDS: the state's writer, the force's reader (boxed: the larger variant).
    Dds {
        state_pub: Box<ros2_client::dds::Publisher<CapsuleState>>,
        force_sub: Box<ros2_client::dds::Subscription<ActuatorForce>>,
    },
    /// In-process: each sample handed to the controller, its answer queued here with the
    /// time it came (ns, [`capsule_record::writer::now_ns`]); the state's DDS copies queued to
    /// their publisher thread.
    InProcess {
        link: Link,
        gid: ros2_client::Gid,
        answers: RefCell<VecDeque<(ActuatorForce, u64)>>,
        copies: DdsCopies<CapsuleState>,
    },
}

/// The plant's endpoints.
pub(super) struct Endpoints {
    pub(super) state_force: StateForce,
    /// The state's DDS writer (in-process: the one its copies go out on).
    pub(super) state_guid: ros2_client::dds::rustdds::GUID,
    pub(super) clock_pub: ros2_client::dds::Publisher<Clock>,
    pub(super) graph: Graph,
    /// Standard-type views (issue 10).
    pub(super) views: crate::views::PlantViews,
    /// JointState commands (`--joint-commands`), `None` when off: one branch per sample.
    pub(super) joint_sub: Option<ros2_client::dds::Subscription<JointState>>,
}

impl Endpoints {
    /// The endpoints on `node`: state, clock and force topics, JointState commands if
    /// `opts` asks, and the views; with the graph's conflict rules for the plant's topics.
    pub(super) fn create(
        node: &mut ros2_client::dds::Node,
        settings: &RosOptions,
        graph: &Graph,
        opts: &PlantOptions,
        rate_hz: f64,
        transport: Transport,
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
        let state_pub = node
            .create_publisher::<CapsuleState>(&state_topic, None)
            .context("state publisher")?;
        let state_guid = state_pub.guid();
        let state_force = match transport {
            Transport::Dds => StateForce::Dds {
                state_pub: Box::new(state_pub),
                force_sub: Box::new(subscribe::<ActuatorForce>(
                    node,
                    &force_topic,
                    &qos::data_reader(),
                )?),
            },
            Transport::InProcess(link) => StateForce::InProcess {
                link,
                gid: state_guid.into(),
                answers: RefCell::default(),
                copies: DdsCopies::start(
                    &settings.resolve_name(topics::STATE),
                    state_pub,
                    graph.clone(),
                )?,
            },
        };
        let io = Endpoints {
            state_force,
            state_guid,
            clock_pub: node
                .create_publisher::<Clock>(&clock_topic, None)
                .context("clock publisher")?,
            joint_sub,
            graph: graph.clone(),
            views: crate::views::Views::create(
                node,
                settings,
                graph,
                crate::views::ViewSwitches::from_table(&opts.params),
                &format!("{:?}", opts.pacing).to_ascii_lowercase(),
                rate_hz,
                opts.params.double(capsule_args::scale_settings::M1_KG.name),
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
        self.send_state(state);
        self.views_of(copy, stats)
    }

    /// Sends a sample (a re-send too): DDS's `publish`, or in-process the controller's answer
    /// queued and the DDS copy queued.
    pub(super) fn send_state(&self, state: CapsuleState) {
        match &self.state_force {
            StateForce::Dds { state_pub, .. } => {
                if let Err(e) = state_pub.publish(state) {
                    warn!("state not sent: {e:?}");
                }
            }
            StateForce::InProcess { .. } => self.hand_over(state),
        }
    }

    /// [`Endpoints::send_state`] for an async loop (DDS's `async_publish`).
    pub(super) async fn send_state_async(&self, state: CapsuleState) {
        match &self.state_force {
            StateForce::Dds { state_pub, .. } => {
                if let Err(e) = state_pub.async_publish(state).await {
                    warn!("state not sent: {e:?}");
                }
            }
            StateForce::InProcess { .. } => self.hand_over(state),
        }
    }

    /// In-process: the sample to the controller (its answer queued) and to the DDS copies.
    fn hand_over(&self, state: CapsuleState) {
        if let StateForce::InProcess {
            link,
            gid,
            answers,
            copies,
        } = &self.state_force
        {
            if let Some(cmd) = link.answer(&state, *gid) {
                let now = capsule_record::writer::now_ns();
                answers.borrow_mut().push_back((cmd, now));
            }
            copies.push(state);
        }
    }

    /// In-process: the next answer queued and when it came (ns); `None` over DDS.
    pub(super) fn next_answer(&self) -> Option<(ActuatorForce, u64)> {
        match &self.state_force {
            StateForce::InProcess { answers, .. } => answers.borrow_mut().pop_front(),
            StateForce::Dds { .. } => None,
        }
    }

    /// The DDS reader of commands (`None` in-process).
    pub(super) fn force_sub(&self) -> Option<&ros2_client::dds::Subscription<ActuatorForce>> {
        match &self.state_force {
            StateForce::Dds { force_sub, .. } => Some(force_sub),
            StateForce::InProcess { .. } => None,
        }
    }

    /// Remote writers matched on the force topic now (`None` in-process: no graph to ask).
    pub(super) fn force_publishers(&self) -> Option<usize> {
        self.force_sub().map(|s| self.graph.publishers(s.guid()))
    }

    /// In-process: what became of the state's DDS copies.
    pub(super) fn copies(&self) -> Option<Arc<CopyCounts>> {
        match &self.state_force {
            StateForce::InProcess { copies, .. } => Some(copies.counts()),
            StateForce::Dds { .. } => None,
        }
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

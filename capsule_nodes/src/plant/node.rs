//! The plant node on DDS: endpoints, start-up, and the run around the pacing loops.

use capsule_msgs::std_types::JointState;
use std::time::{Duration, Instant};

use capsule_msgs::names::topics;
use capsule_msgs::std_types::{Clock, DiagnosticArray};
use capsule_msgs::{ActuatorForce, CapsuleState, Time};
use capsule_ros_base::error::{Context as _, Result};
use tracing::{info, warn};

use super::pacing::{lockstep_loop, realtime_loop};
use super::{
    CommandOutcome, InPlantRecording, LoopStats, Pacing, PlantCore, PlantOptions, PlantSim,
};
use crate::recorder::{drain_into, graph_topics, Channel, GraphRecording};
use capsule_ros_base::{
    conflicts::{self, TopicRule},
    graph::Graph,
    ros::{qos, subscribe, types, RosOptions},
    throttle::Throttle,
};

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

/// Runs the plant node until `until_s` or SIGINT/SIGTERM; logs the loop statistics at the end.
pub async fn run<S: PlantSim + Send + 'static>(
    settings: RosOptions,
    core: PlantCore<S>,
    opts: PlantOptions,
) -> Result<(LoopStats, CapsuleState)> {
    if opts.joint_commands && opts.pacing == Pacing::Lockstep {
        capsule_ros_base::error::bail!("JointState commands need real-time pacing: in lock-step none answers a particular sample");
    }
    // the file first: an unwritable place is an error before anything else starts
    let recording = opts
        .record
        .as_ref()
        .map(|r| {
            GraphRecording::create(
                &r.output,
                r.scene.clone(),
                &settings,
                &r.controller_node,
                r.flush_period,
                r.bag,
            )
        })
        .transpose()?;
    let context = settings.context()?;
    let (mut node, graph) = settings.loop_node(&context)?;
    let state_topic = settings.topic(&node, topics::STATE, types::state(), &qos::data())?;
    let force_topic = settings.topic(&node, topics::FORCE, types::force(), &qos::data())?;
    let clock_topic = settings.topic(&node, topics::CLOCK, types::clock(), &qos::clock())?;
    let joint_topic = opts
        .joint_commands
        .then(|| {
            settings.topic(
                &node,
                topics::JOINT_COMMANDS,
                types::joint_state(),
                &qos::data(),
            )
        })
        .transpose()?;
    let io = Endpoints {
        state_pub: node
            .create_publisher::<CapsuleState>(&state_topic, None)
            .context("state publisher")?,
        clock_pub: node
            .create_publisher::<Clock>(&clock_topic, None)
            .context("clock publisher")?,
        force_sub: subscribe::<ActuatorForce>(&mut node, &force_topic, &qos::data_reader())?,
        joint_sub: joint_topic
            .map(|t| subscribe::<JointState>(&mut node, &t, &qos::data_reader()))
            .transpose()?,
        graph: graph.clone(),
        views: crate::views::Views::create(
            &mut node,
            &settings,
            &graph,
            crate::views::ViewSwitches::from_table(&opts.params),
            &format!("{:?}", opts.pacing).to_ascii_lowercase(),
            core.rate_hz,
            opts.params.double(crate::plant_params::names::M1_KG),
        )?,
    };
    let conflicts = conflicts::watch(
        graph.clone(),
        vec![
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
        ],
    );
    crate::emergency_stop::serve(&mut node, &settings, core.emergency_stop())?;
    // ROS parameters (read-only here): served by their own task, never by the sample loop
    let _params = capsule_ros_base::param_services::serve(
        &context,
        &mut node,
        &settings,
        opts.params.clone(),
        capsule_ros_base::params::no_rules,
        || Time::from_nanos(capsule_record::writer::now_ns() as i64),
    )?;
    let mut recording = match (recording, &opts.record) {
        (Some(rec), Some(r)) => {
            // reliable, deep: status and service events are few and must all be kept
            let deep = qos::data().history(ros2_client::qos::History::KeepLast { depth: 1000 });
            let specs = graph_topics(&r.controller_node);
            let [status_topic, event_topic] = [Channel::Status, Channel::ServiceEvent].map(|c| {
                let (name, ty, _, q) = &specs[c as usize];
                settings.topic(&node, name, ty.clone(), q)
            });
            let (status_topic, event_topic) = (status_topic?, event_topic?);
            info!("recording the graph in-process to {}", r.output.display());
            Some(InPlantRecording {
                rec,
                status_sub: subscribe(&mut node, &status_topic, &deep)?,
                event_sub: subscribe(&mut node, &event_topic, &deep)?,
                last_poll: Instant::now(),
            })
        }
        _ => None,
    };
    info!(
        "{}: {:?} at {} Hz, state {} <- force {}, clock {} (while subscribed)",
        settings.describe(),
        opts.pacing,
        core.rate_hz,
        settings.resolve_name(topics::STATE),
        settings.resolve_name(topics::FORCE),
        settings.resolve_name(topics::CLOCK),
    );
    if opts.joint_commands {
        info!(
            "taking JointState commands on {} (effort of {} = actuator force [N])",
            settings.resolve_name(topics::JOINT_COMMANDS),
            crate::joint_commands::JOINT
        );
    }

    if opts.wait_subscribers > 0 {
        let writer = io.state_pub.guid();
        if !graph
            .wait_subscribers(writer, opts.wait_subscribers, opts.startup_timeout)
            .await
        {
            capsule_ros_base::error::bail!(
                "only {} of {} subscribers matched {} within {:?}",
                graph.subscribers(writer),
                opts.wait_subscribers,
                settings.resolve_name(topics::STATE),
                opts.startup_timeout
            );
        }
        // Our writer has matched them; their readers match our writer when they process our
        // announcement, which can be a moment later, and a reader that has not yet matched
        // drops what it gets. Give them that moment, or the first samples miss the recorder.
        tokio::time::sleep(MATCH_GRACE).await;
        info!("{} subscribers matched: starting", opts.wait_subscribers);
    }
    // a device's first measurement before the first sample, so that sample is one
    let mut core = core;
    core.start(opts.startup_timeout);
    let (result, mut core, recording) = match opts.pacing {
        Pacing::Lockstep => {
            let mut core = core;
            let r = lockstep_loop(&mut core, &io, &opts, recording.as_mut()).await;
            (r, core, recording)
        }
        Pacing::Realtime => {
            let stop = std::sync::Arc::new(std::sync::atomic::AtomicBool::new(false));
            let stop_loop = stop.clone();
            let opts = opts.clone();
            let mut looping = tokio::task::spawn_blocking(move || {
                let mut core = core;
                let r = realtime_loop(&mut core, &io, &opts, &stop_loop, recording.as_mut());
                (r, core, recording)
            });
            let shutdown = capsule_ros_base::ros::shutdown_signal();
            tokio::pin!(shutdown);
            tokio::select! {
                done = &mut looping => done.context("the real-time loop panicked")?,
                sig = &mut shutdown => {
                    match sig {
                        Ok(s) => info!("{s}: shutting down"),
                        Err(e) => warn!("{}", capsule_ros_base::error::chain(&e)),
                    }
                    stop.store(true, std::sync::atomic::Ordering::Relaxed);
                    looping.await.context("the real-time loop panicked")?
                }
            }
        }
    };
    // DDS sends from its own thread: let the last sample leave before the participant goes
    tokio::time::sleep(MATCH_GRACE).await;
    core.stats.finish();
    core.stats.graph_conflicts = conflicts.load(std::sync::atomic::Ordering::Relaxed);
    let stats = core.stats.clone();
    match stats.percentiles() {
        Some((p50, p99, max)) => info!(
            "loop: {} samples ({} before the first answer), {} lost, {} answered late, latency p50 {:.3} ms p99 {:.3} ms max {:.3} ms, {} commands refused, {} saturated at {} N",
            stats.published,
            stats.before_first_answer,
            stats.unanswered,
            stats.late_answers,
            p50 * 1e3,
            p99 * 1e3,
            max * 1e3,
            core.rejected(),
            stats.saturated_commands,
            core.max_force_n()
        ),
        None => info!("loop: {} samples, no command answered", stats.published),
    }
    if let Some(r) = recording {
        let mut rec = r.rec;
        let ended = result.and_then(|()| {
            // status and service events still in flight: the controller's last ones
            drain_into(&r.status_sub, &mut rec, Channel::Status)?;
            drain_into(&r.event_sub, &mut rec, Channel::ServiceEvent)
        });
        return match ended {
            Ok(_) => {
                let report = rec.finish()?;
                let total: u64 = report.per_topic.values().sum();
                info!("recorded {total} messages to {}", report.path.display());
                Ok((stats, core.state()))
            }
            Err(e) => Err(rec.abandon(e)),
        };
    }
    result.map(|()| (stats, core.state()))
}

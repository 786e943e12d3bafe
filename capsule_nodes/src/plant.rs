//! The plant node: a simulated capsule behind the same topics a real capsule driver would use.
//!
//! [`PlantCore`] is the node's logic without DDS (unit-tested here against a stand-in model):
//! sampling at a fixed rate, the zero-order hold of the last accepted command, command
//! validation (non-finite refused and counted, older-than-accepted refused: a late command
//! never rewinds time), the stale-command watchdog (zero force after the timeout, said in the
//! log and in `CapsuleState.command_stale`), SI conversion through the scene's [`Scale`], and
//! loop statistics (command latency, steps without an answer). [`run`] wires it to ROS in one of
//! two pacings:
//!
//! - **real time**: sample `k` is published at `start + k / rate` (steady clock, on one
//!   thread that sleeps, takes the commands received meanwhile and steps); whatever command is
//!   held at the next sample drives the next step;
//! - **lock-step**: sample `k` is published and the plant waits for the command that answers
//!   seq `k` (re-sending the sample every `retransmit` until it comes), then integrates one step
//!   with it. The run is then a function of the scene and the controller only: reproducible bit
//!   for bit, as fast as the loop allows. If no answer comes within the command timeout, that
//!   step runs with zero force and the plant says so.
//!
//! Time on the wire is simulation time (starting at 0), also published on `/clock` while anyone
//! subscribes to it (a write without readers still costs DDS's thread a wake-up per sample).

use std::{
    collections::VecDeque,
    time::{Duration, Instant},
};

use anyhow::{Context as _, Result};
use capsule_msgs::{std_types::JointState, ActuatorForce, CapsuleState, Header, Time};
use futures::StreamExt;
use tracing::{info, warn};

use crate::{
    command_gate::{self, CommandGate, DEFAULT_MAX_FORCE_PF},
    conflicts::{self, TopicRule},
    graph::Graph,
    latency::LatencyHistogram,
    recorder::{drain_into, graph_topics, Channel, GraphRecording},
    ros::{names, qos, types, Clock, RosSettings},
    scale::Scale,
    throttle::Throttle,
};
use capsule_msgs::ControllerStatus;
use capsule_record::types::SetModeEvent;

/// A non-dimensional sample of the simulated plant (the simulator's snapshot, SI-free).
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct PlantSample {
    /// Non-dimensional time.
    pub tau: f64,
    /// Mass position.
    pub x1: f64,
    /// Mass velocity.
    pub y1: f64,
    /// Capsule position.
    pub x2: f64,
    /// Capsule velocity.
    pub y2: f64,
    /// Capsule sticks.
    pub stuck: bool,
    /// Mass touches the secondary spring.
    pub contact: bool,
    /// Friction force on the capsule.
    pub friction_force: f64,
    /// Contact force.
    pub contact_force: f64,
    /// Actuator force applied over the last step.
    pub actuator_force: f64,
}

/// What the node needs from a simulator: hold a force until a time, and report a sample.
pub trait PlantSim {
    /// Integrates to `tau_end` holding the non-dimensional actuator force `force`.
    fn advance(&mut self, force: f64, tau_end: f64) -> Result<()>;
    /// The current sample.
    fn sample(&self) -> PlantSample;
}

/// How the plant paces its steps.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum Pacing {
    /// One sample per `1/rate` of wall time.
    Realtime,
    /// Each step waits for the command answering the last sample.
    Lockstep,
}

/// Why a command was not taken.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum CommandOutcome {
    /// Taken; held from the next step on.
    Accepted,
    /// A repeat of the last accepted command (lock-step re-answers): ignored, not counted.
    Duplicate,
    /// Force NaN or infinite: refused and counted.
    NonFinite,
    /// Stamped before the last accepted command, or answering an old sample: refused, counted.
    Late,
    /// Answering a sample not yet published (lock-step), or stamped after the newest sample:
    /// refused, counted.
    Future,
}

/// Loop statistics: for every published sample, whether and when a command answering it
/// (same seq) arrived, also after the next sample went out.
#[derive(Debug, Clone, Default)]
pub struct LoopStats {
    /// Latencies from publishing a sample to receiving its first answer (constant memory).
    pub latencies: LatencyHistogram,
    /// Samples published.
    pub published: u64,
    /// Samples published before the first answer (discovery, controller start-up).
    pub before_first_answer: u64,
    /// Samples after the first answer that never got one: lost.
    pub unanswered: u64,
    /// Answers that arrived after the next sample was out (applied one sample late).
    pub late_answers: u64,
    /// Commands beyond the force limit, applied saturated at it.
    pub saturated_commands: u64,
    /// Graph conflicts seen (another plant, a foreign type on our topics): [`crate::conflicts`].
    pub graph_conflicts: u64,
    in_flight: VecDeque<(u64, f64, bool)>,
    answered_any: bool,
}

impl LoopStats {
    const WINDOW: usize = 4096;

    fn retire_front(&mut self) {
        if let Some((_, _, answered)) = self.in_flight.pop_front() {
            if !answered {
                self.unanswered += 1;
            }
        }
    }

    /// Notes sample `seq` published at steady time `now`.
    pub fn on_publish(&mut self, seq: u64, now: f64) {
        self.published += 1;
        self.in_flight.push_back((seq, now, false));
        while self.in_flight.len() > Self::WINDOW {
            self.retire_front();
        }
    }

    /// Notes a command answering `seq` at `now`, while sample `current` is the newest.
    pub fn on_answer(&mut self, seq: u64, now: f64, current: u64) {
        let Ok(i) = self.in_flight.binary_search_by_key(&seq, |e| e.0) else {
            return;
        };
        if self.in_flight[i].2 {
            return;
        }
        self.in_flight[i].2 = true;
        self.latencies.record(now - self.in_flight[i].1);
        if seq < current {
            self.late_answers += 1;
        }
        if !self.answered_any {
            self.answered_any = true;
            let before = self.in_flight.iter().take_while(|e| e.0 < seq).count();
            self.before_first_answer += before as u64;
            self.in_flight.drain(..before);
        }
    }

    /// Ends the run: the newest sample may still be in flight; every older one without an
    /// answer is lost (all of them count as start-up if nothing was ever answered).
    pub fn finish(&mut self) {
        self.in_flight.pop_back();
        if !self.answered_any {
            self.before_first_answer += self.in_flight.len() as u64;
            self.in_flight.clear();
        }
        while !self.in_flight.is_empty() {
            self.retire_front();
        }
    }

    /// `(p50, p99, max)` of the latencies [s] (to within [`LatencyHistogram::RELATIVE_ERROR`];
    /// max exact), `None` if none.
    pub fn percentiles(&self) -> Option<(f64, f64, f64)> {
        let l = &self.latencies;
        Some((l.quantile(0.5)?, l.quantile(0.99)?, l.max()?))
    }
}

/// The plant node's logic around a simulator.
pub struct PlantCore<S: PlantSim> {
    sim: S,
    scale: Scale,
    rate_hz: f64,
    command_timeout: f64,
    frame_id: String,
    step: u64,
    held_n: f64,
    last_accepted: Option<(i64, u64, f64)>,
    last_command_at: Option<f64>,
    stale: bool,
    rejected: u32,
    answered_current: bool,
    published_at: Option<f64>,
    gate: CommandGate,
    /// Statistics of the loop.
    pub stats: LoopStats,
}

impl<S: PlantSim> PlantCore<S> {
    /// A plant sampling at `rate_hz`, falling back to zero force after `command_timeout` [s].
    pub fn new(sim: S, scale: Scale, rate_hz: f64, command_timeout: f64) -> Self {
        PlantCore {
            sim,
            scale,
            rate_hz,
            command_timeout,
            frame_id: "odom".to_string(),
            step: 0,
            held_n: 0.0,
            last_accepted: None,
            last_command_at: None,
            stale: true,
            rejected: 0,
            answered_current: false,
            published_at: None,
            gate: CommandGate::new(DEFAULT_MAX_FORCE_PF * scale.force_n()),
            stats: LoopStats::default(),
        }
    }

    /// The same plant saturating commands at `max_force_n` [N] (finite, > 0) instead of the
    /// default [`DEFAULT_MAX_FORCE_PF`] `P_f`.
    pub fn with_max_force_n(mut self, max_force_n: f64) -> Self {
        self.gate = CommandGate::new(max_force_n);
        self
    }

    /// The force limit [N].
    pub fn max_force_n(&self) -> f64 {
        self.gate.max_force_n()
    }

    /// Seq of the current sample.
    pub fn seq(&self) -> u64 {
        self.step
    }

    /// Stamp of sample `k` in nanoseconds of sim time (`k / rate`, rounded).
    fn stamp_nanos(&self, k: u64) -> i64 {
        (k as f64 * 1e9 / self.rate_hz).round() as i64
    }

    /// Stamp of the current sample.
    pub fn stamp(&self) -> Time {
        Time::from_nanos(self.stamp_nanos(self.step))
    }

    /// Force held now [N].
    pub fn held_force(&self) -> f64 {
        if self.stale {
            0.0
        } else {
            self.held_n
        }
    }

    /// Commands refused so far.
    pub fn rejected(&self) -> u32 {
        self.rejected
    }

    /// True when the watchdog has fallen back to zero force.
    pub fn stale(&self) -> bool {
        self.stale
    }

    /// True once the current sample has been answered (lock-step).
    pub fn answered(&self) -> bool {
        self.answered_current
    }

    /// The current sample as a message (SI).
    pub fn state(&self) -> CapsuleState {
        let s = self.sim.sample();
        let l = self.scale.length_m();
        let v = self.scale.velocity_m_per_s();
        let f = self.scale.force_n();
        CapsuleState {
            header: Header {
                stamp: self.stamp(),
                frame_id: self.frame_id.clone(),
            },
            seq: self.step,
            mass_position: s.x1 * l,
            mass_velocity: s.y1 * v,
            capsule_position: s.x2 * l,
            capsule_velocity: s.y2 * v,
            in_contact: s.contact,
            stuck: s.stuck,
            friction_force: s.friction_force * f,
            contact_force: s.contact_force * f,
            actuator_force: s.actuator_force * f,
            command_stale: self.stale,
            rejected_commands: self.rejected,
        }
    }

    /// Notes that the current sample went out at steady time `now`.
    pub fn published(&mut self, now: f64) {
        if self.published_at.is_none() {
            self.published_at = Some(now);
            self.stats.on_publish(self.step, now);
        }
    }

    /// Takes a command received at steady time `now`. `lockstep` requires it to answer the
    /// current sample.
    pub fn on_command(&mut self, cmd: &ActuatorForce, now: f64, lockstep: bool) -> CommandOutcome {
        let stamp = cmd.header.stamp.to_nanos();
        if let Some((t, seq, f)) = self.last_accepted {
            if t == stamp && seq == cmd.state_seq && f.to_bits() == cmd.force.to_bits() {
                self.stats.on_answer(cmd.state_seq, now, self.step);
                return CommandOutcome::Duplicate;
            }
        }
        let outcome = if !cmd.force.is_finite() {
            CommandOutcome::NonFinite
        } else if self.last_accepted.is_some_and(|(t, _, _)| stamp < t)
            || (lockstep && cmd.state_seq < self.step)
        {
            CommandOutcome::Late
        } else if (lockstep && cmd.state_seq > self.step)
            || command_gate::from_the_future(
                stamp,
                self.stamp_nanos(self.step),
                self.stamp_nanos(1),
            )
        {
            CommandOutcome::Future
        } else {
            CommandOutcome::Accepted
        };
        if outcome != CommandOutcome::Accepted {
            self.rejected = self.rejected.saturating_add(1);
            return outcome;
        }
        self.last_accepted = Some((stamp, cmd.state_seq, cmd.force));
        self.held_n = self.gate.limit(cmd.force, cmd.state_seq);
        self.stats.saturated_commands = self.gate.saturated();
        self.last_command_at = Some(now);
        if self.stale {
            info!(
                "command received (seq {}): applying commanded force",
                cmd.state_seq
            );
        }
        self.stale = false;
        self.stats.on_answer(cmd.state_seq, now, self.step);
        if cmd.state_seq == self.step {
            self.answered_current = true;
        }
        outcome
    }

    /// Watchdog at steady time `now`: true when it just fell back to zero force.
    pub fn check_watchdog(&mut self, now: f64) -> bool {
        let fresh = self
            .last_command_at
            .is_some_and(|t| now - t <= self.command_timeout);
        if !fresh && !self.stale {
            self.stale = true;
            return true;
        }
        false
    }

    /// Forces the zero-force fallback (lock-step: no answer within the timeout).
    pub fn force_stale(&mut self) -> bool {
        let was = self.stale;
        self.stale = true;
        !was
    }

    /// Integrates one sample period with the held force and moves to the next sample.
    pub fn step(&mut self) -> Result<()> {
        let force = self.held_force() / self.scale.force_n();
        let tau_end = self.stamp_nanos(self.step + 1) as f64 * 1e-9 / self.scale.time_s();
        self.sim.advance(force, tau_end)?;
        self.step += 1;
        self.answered_current = false;
        self.published_at = None;
        Ok(())
    }
}

/// A one-line JSON summary of a run: loop statistics and the last sample (floats printed
/// round-trip exact, so two runs compare bit for bit).
pub fn summary_json(stats: &LoopStats, last: &CapsuleState, wall_s: f64) -> String {
    let (p50, p99, max) = stats
        .percentiles()
        .unwrap_or((f64::NAN, f64::NAN, f64::NAN));
    let num = |v: f64| {
        if v.is_finite() {
            format!("{v:?}")
        } else {
            "null".to_string()
        }
    };
    format!(
        concat!(
            "{{\"samples\":{},\"before_first_answer\":{},\"unanswered\":{},\"late_answers\":{},",
            "\"latency_p50_s\":{},\"latency_p99_s\":{},",
            "\"latency_max_s\":{},\"wall_s\":{},\"rejected_commands\":{},\"saturated_commands\":{},\"graph_conflicts\":{},",
            "\"last\":{{\"seq\":{},",
            "\"stamp_ns\":{},\"mass_position\":{},\"mass_velocity\":{},\"capsule_position\":{},",
            "\"capsule_velocity\":{},\"actuator_force\":{},\"command_stale\":{}}}}}"
        ),
        stats.published,
        stats.before_first_answer,
        stats.unanswered,
        stats.late_answers,
        num(p50),
        num(p99),
        num(max),
        num(wall_s),
        last.rejected_commands,
        stats.saturated_commands,
        stats.graph_conflicts,
        last.seq,
        last.header.stamp.to_nanos(),
        num(last.mass_position),
        num(last.mass_velocity),
        num(last.capsule_position),
        num(last.capsule_velocity),
        num(last.actuator_force),
        last.command_stale
    )
}

/// How the plant node runs.
#[derive(Debug, Clone)]
pub struct PlantOptions {
    /// Pacing.
    pub pacing: Pacing,
    /// Stop at this sim time [s] (`None`: run until a signal).
    pub until_s: Option<f64>,
    /// Lock-step: re-send an unanswered sample this often.
    pub retransmit: Duration,
    /// Lock-step: how long to wait for the very first command (and for the subscribers).
    pub startup_timeout: Duration,
    /// Publish the first sample only once this many subscribers matched the state topic.
    pub wait_subscribers: usize,
    /// Publish /clock with every this many samples (1: every sample).
    pub clock_every: u64,
    /// Record the graph in this process (see [`InPlantRecording`]).
    pub record: Option<InPlantRecordOptions>,
    /// The ROS parameters served (see [`crate::plant_params`]).
    pub params: crate::params::ParamTable,
    /// Also take commands as JointState on [`names::JOINT_COMMANDS`] (real-time pacing; see
    /// [`crate::joint_commands`]).
    pub joint_commands: bool,
}

/// Where and how the plant records the graph itself.
#[derive(Debug, Clone)]
pub struct InPlantRecordOptions {
    /// The file to write (must not exist).
    pub output: std::path::PathBuf,
    /// The scene, stored in the file.
    pub scene: Option<capsule_record::SceneRecord>,
    /// Name of the controller node (its status and service-event topics are recorded).
    pub controller_node: String,
    /// Close the open chunk at least this often (wall clock).
    pub flush_period: Duration,
    /// Compression and splitting.
    pub bag: capsule_record::BagOptions,
}

/// The graph recorded inside the plant: what it publishes (state, /clock) as it publishes it,
/// every command as DDS delivered it, and the controller's status and service events from
/// their own (low-rate) readers. The same file as `capsule_recorder` writes, without a
/// second process receiving every sample over the network (which costs that process, on this
/// machine, 5-10 us of kernel time per datagram).
pub struct InPlantRecording {
    rec: GraphRecording,
    status_sub: ros2_client::Subscription<ControllerStatus>,
    event_sub: ros2_client::Subscription<SetModeEvent>,
    last_poll: Instant,
}

impl InPlantRecording {
    /// Records a published state sample and, if published with it, the clock.
    fn published(&mut self, state: &CapsuleState, clock: Option<&Clock>) -> Result<()> {
        let now = capsule_record::writer::now_ns();
        if let Some(c) = clock {
            self.rec.write(Channel::Clock, c, now, now)?;
        }
        self.rec.write(Channel::State, state, now, now)
    }

    /// Records a command as DDS delivered it.
    fn received(&mut self, cmd: &ActuatorForce, info: &ros2_client::MessageInfo) -> Result<()> {
        self.rec.write_received(Channel::Force, cmd, info)
    }

    /// Every 10 ms: takes the controller's status and service events, closes the chunk when due.
    /// (A `take` on a DDS reader costs microseconds even when it is empty: not every sample.)
    fn poll(&mut self) -> Result<()> {
        if self.last_poll.elapsed() < Duration::from_millis(10) {
            return Ok(());
        }
        self.last_poll = Instant::now();
        drain_into(&self.status_sub, &mut self.rec, Channel::Status)?;
        drain_into(&self.event_sub, &mut self.rec, Channel::ServiceEvent)?;
        self.rec.flush_if_due()
    }
}

/// How long the plant waits after its subscribers matched before the first sample, and after
/// the last sample before it leaves (discovery and sending run on DDS's own thread).
const MATCH_GRACE: Duration = Duration::from_millis(200);

/// The plant's DDS endpoints.
struct Endpoints {
    state_pub: ros2_client::Publisher<CapsuleState>,
    clock_pub: ros2_client::Publisher<Clock>,
    force_sub: ros2_client::Subscription<ActuatorForce>,
    graph: Graph,
    /// Standard-type views (issue 10).
    views: crate::views::PlantViews,
    /// JointState commands (`--joint-commands`), `None` when off: one branch per sample.
    joint_sub: Option<ros2_client::Subscription<JointState>>,
}

impl Endpoints {
    /// Whether /clock has a subscriber now (rclcpp's `get_subscription_count() > 0` idiom).
    fn clock_wanted(&self) -> bool {
        self.graph.subscribers(self.clock_pub.guid()) > 0
    }

    /// Publishes a sample, then its standard-type views (if any are on).
    fn publish_state(&self, state: CapsuleState, stats: &LoopStats) {
        let copy = self.views.per_sample.is_some().then(|| state.clone());
        if let Err(e) = self.state_pub.publish(state) {
            warn!("state not sent: {e:?}");
        }
        self.views_of(copy, stats);
    }

    /// The standard-type views of a sample just published.
    fn views_of(&self, state: Option<CapsuleState>, stats: &LoopStats) {
        if let (Some(views), Some(state)) = (&self.views.per_sample, state) {
            let mut v = views
                .lock()
                .unwrap_or_else(std::sync::PoisonError::into_inner);
            v.on_sample(&state, stats);
        }
    }
}

/// Logs a refused command: the first ten, then at powers of two.
fn log_refused(outcome: CommandOutcome, cmd: &ActuatorForce, throttle: &mut Throttle, total: u32) {
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
fn log_undecodable(throttle: &mut Throttle, e: &dyn std::fmt::Debug) {
    if throttle.tick() {
        warn!(
            "undecodable command ({} so far; a writer of another type on the force topic?): {e:?}",
            throttle.seen()
        );
    }
}

/// Runs the plant node until `until_s` or SIGINT/SIGTERM; logs the loop statistics at the end.
pub async fn run<S: PlantSim + Send + 'static>(
    settings: RosSettings,
    core: PlantCore<S>,
    opts: PlantOptions,
) -> Result<(LoopStats, CapsuleState)> {
    if opts.joint_commands && opts.pacing == Pacing::Lockstep {
        anyhow::bail!("JointState commands need real-time pacing: in lock-step none answers a particular sample");
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
    let state_topic = settings.topic(&node, names::STATE, types::state(), &qos::data())?;
    let force_topic = settings.topic(&node, names::FORCE, types::force(), &qos::data())?;
    let clock_topic = settings.topic(&node, names::CLOCK, types::clock(), &qos::clock())?;
    let joint_topic = opts
        .joint_commands
        .then(|| {
            settings.topic(
                &node,
                names::JOINT_COMMANDS,
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
        force_sub: node
            .create_subscription::<ActuatorForce>(&force_topic, Some(qos::data_reader()))
            .context("force subscription")?,
        joint_sub: joint_topic
            .map(|t| node.create_subscription::<JointState>(&t, Some(qos::data_reader())))
            .transpose()
            .context("joint command subscription")?,
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
                settings.resolve_name(names::STATE),
                0,
                "ANOTHER PLANT: both apply every command the controller sends",
            ),
            // controllers are checked for their type only: a SIGKILLed one stays in discovery
            // until its lease ends, and its successor would look like a second one
            TopicRule::new(
                &force_topic,
                settings.resolve_name(names::FORCE),
                usize::MAX,
                "",
            ),
        ],
    );
    // ROS parameters (read-only here): served by their own task, never by the sample loop
    let _params = crate::param_services::serve(
        &context,
        &mut node,
        &settings,
        opts.params.clone(),
        crate::params::no_rules,
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
                status_sub: node
                    .create_subscription(&status_topic, Some(deep.clone()))
                    .context("status subscription")?,
                event_sub: node
                    .create_subscription(&event_topic, Some(deep))
                    .context("service-event subscription")?,
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
        settings.resolve_name(names::STATE),
        settings.resolve_name(names::FORCE),
        settings.resolve_name(names::CLOCK),
    );
    if opts.joint_commands {
        info!(
            "taking JointState commands on {} (effort of {} = actuator force [N])",
            settings.resolve_name(names::JOINT_COMMANDS),
            crate::joint_commands::JOINT
        );
    }

    if opts.wait_subscribers > 0 {
        let writer = io.state_pub.guid();
        if !graph
            .wait_subscribers(writer, opts.wait_subscribers, opts.startup_timeout)
            .await
        {
            anyhow::bail!(
                "only {} of {} subscribers matched {} within {:?}",
                graph.subscribers(writer),
                opts.wait_subscribers,
                settings.resolve_name(names::STATE),
                opts.startup_timeout
            );
        }
        // Our writer has matched them; their readers match our writer when they process our
        // announcement, which can be a moment later, and a reader that has not yet matched
        // drops what it gets. Give them that moment, or the first samples miss the recorder.
        tokio::time::sleep(MATCH_GRACE).await;
        info!("{} subscribers matched: starting", opts.wait_subscribers);
    }
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
            let shutdown = crate::ros::shutdown_signal();
            tokio::pin!(shutdown);
            tokio::select! {
                done = &mut looping => done.context("the real-time loop panicked")?,
                sig = &mut shutdown => {
                    match sig {
                        Ok(s) => info!("{s}: shutting down"),
                        Err(e) => warn!("{e:#}"),
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

/// The current sample and, every `clock_every`-th sample, its /clock, recorded when recording.
fn outgoing<S: PlantSim>(
    core: &PlantCore<S>,
    opts: &PlantOptions,
    rec: Option<&mut InPlantRecording>,
) -> Result<(CapsuleState, Option<Clock>)> {
    let clock = core
        .seq()
        .is_multiple_of(opts.clock_every.max(1))
        .then_some(Clock {
            clock: core.stamp(),
        });
    let state = core.state();
    if let Some(r) = rec {
        r.published(&state, clock.as_ref())?;
        r.poll()?;
    }
    Ok((state, clock))
}

/// Takes every JointState command received (see [`crate::joint_commands`]): each answers the
/// current sample and goes through [`PlantCore::on_command`] as a force command does.
fn take_joint_commands<S: PlantSim>(
    core: &mut PlantCore<S>,
    sub: &ros2_client::Subscription<JointState>,
    at: impl Fn(&ros2_client::MessageInfo) -> f64,
    refused_logged: &mut Throttle,
    bad: &mut Throttle,
) {
    loop {
        match sub.take() {
            Ok(Some((js, info))) => {
                match crate::joint_commands::to_force(&js, core.seq(), core.stamp(), &core.frame_id)
                {
                    Ok(cmd) => match core.on_command(&cmd, at(&info), false) {
                        CommandOutcome::Accepted | CommandOutcome::Duplicate => {}
                        refused => log_refused(refused, &cmd, refused_logged, core.rejected()),
                    },
                    Err(e) => {
                        if bad.tick() {
                            warn!("JointState command not taken ({} so far): {e}", bad.seen());
                        }
                    }
                }
            }
            Ok(None) => break,
            Err(e) => {
                if bad.tick() {
                    warn!(
                        "undecodable JointState command ({} so far): {e:?}",
                        bad.seen()
                    );
                }
                break;
            }
        }
    }
}

/// Real time on one thread: publish sample `k`, sleep until `start + (k+1) / rate`, take every
/// command received meanwhile, step. Commands are taken, not awaited, and the timer is this
/// thread's own sleep, so a sample costs no wake-up of another thread in this process besides
/// DDS's own (an earlier timer thread -> tokio -> DDS hand-off, with a wake-up per command,
/// cost a third of the plant's CPU at 1 kHz). Latency is measured from DDS's reception time.
fn realtime_loop<S: PlantSim>(
    core: &mut PlantCore<S>,
    io: &Endpoints,
    opts: &PlantOptions,
    stop: &std::sync::atomic::AtomicBool,
    mut rec: Option<&mut InPlantRecording>,
) -> Result<()> {
    let period = Duration::from_secs_f64(1.0 / core.rate_hz);
    let until_nanos = opts.until_s.map(|s| (s * 1e9).round() as i64);
    let start = Instant::now();
    // loop times are wall-clock seconds since the start, the clock DDS stamps receptions with
    let wall0 = capsule_record::writer::now_ns() as i64;
    let now = || (capsule_record::writer::now_ns() as i64 - wall0) as f64 * 1e-9;
    let mut refused_logged = Throttle::default();
    let mut undecodable = Throttle::default();
    let mut joint_bad = Throttle::default();
    loop {
        let stamp = core.stamp();
        let (state, clock) = outgoing(core, opts, rec.as_deref_mut())?;
        if let Some(c) = clock.filter(|_| io.clock_wanted()) {
            let _ = io.clock_pub.publish(c);
        }
        io.publish_state(state, &core.stats);
        core.published(now());
        if until_nanos.is_some_and(|u| stamp.to_nanos() >= u) {
            info!("reached the end time {:.3} s", stamp.as_secs_f64());
            return Ok(());
        }
        let due = start + period.mul_f64((core.seq() + 1) as f64);
        let wait = due.saturating_duration_since(Instant::now());
        if !wait.is_zero() {
            std::thread::sleep(wait);
        }
        if stop.load(std::sync::atomic::Ordering::Relaxed) {
            return Ok(());
        }
        loop {
            match io.force_sub.take() {
                Ok(Some((cmd, info))) => {
                    if let Some(r) = rec.as_deref_mut() {
                        r.received(&cmd, &info)?;
                    }
                    let at = info
                        .received_timestamp()
                        .map_or_else(now, |t| (t.to_nanos() - wall0) as f64 * 1e-9);
                    match core.on_command(&cmd, at, false) {
                        CommandOutcome::Accepted | CommandOutcome::Duplicate => {}
                        refused => log_refused(refused, &cmd, &mut refused_logged, core.rejected()),
                    }
                }
                Ok(None) => break,
                // the rest waits for the next sample: never spin on a reader that keeps failing
                Err(e) => {
                    log_undecodable(&mut undecodable, &e);
                    break;
                }
            }
        }
        if let Some(sub) = &io.joint_sub {
            let at = |info: &ros2_client::MessageInfo| {
                info.received_timestamp()
                    .map_or_else(now, |t| (t.to_nanos() - wall0) as f64 * 1e-9)
            };
            take_joint_commands(core, sub, at, &mut refused_logged, &mut joint_bad);
        }
        if core.check_watchdog(now()) {
            warn!(
                "no command for {:.3} s: applying zero force",
                core.command_timeout
            );
        }
        core.step()?;
    }
}

/// Lock-step: publish sample `k`, wait for the command answering it (re-sending the sample
/// every `retransmit`), step with it; zero force after the command timeout.
async fn lockstep_loop<S: PlantSim>(
    core: &mut PlantCore<S>,
    io: &Endpoints,
    opts: &PlantOptions,
    mut rec: Option<&mut InPlantRecording>,
) -> Result<()> {
    let start = Instant::now();
    let steady = move || start.elapsed().as_secs_f64();
    let commands = io.force_sub.async_stream();
    tokio::pin!(commands);
    let shutdown = crate::ros::shutdown_signal();
    tokio::pin!(shutdown);
    let until_nanos = opts.until_s.map(|s| (s * 1e9).round() as i64);
    let mut wait_started = steady();
    let mut resend = tokio::time::interval(opts.retransmit);
    resend.set_missed_tick_behavior(tokio::time::MissedTickBehavior::Delay);
    let mut ever_commanded = false;
    let mut refused_logged = Throttle::default();
    let mut undecodable = Throttle::default();
    let mut need_publish = true;
    loop {
        if need_publish {
            let (state, clock) = outgoing(core, opts, rec.as_deref_mut())?;
            if let Some(c) = clock.filter(|_| io.clock_wanted()) {
                let _ = io.clock_pub.async_publish(c).await;
            }
            let copy = io.views.per_sample.is_some().then(|| state.clone());
            if let Err(e) = io.state_pub.async_publish(state).await {
                warn!("state not sent: {e:?}");
            }
            io.views_of(copy, &core.stats);
            core.published(steady());
            need_publish = false;
            wait_started = steady();
            resend.reset();
        }
        if until_nanos.is_some_and(|u| core.stamp().to_nanos() >= u) {
            info!("reached the end time {:.3} s", core.stamp().as_secs_f64());
            return Ok(());
        }
        if core.answered() {
            core.step()?;
            need_publish = true;
            continue;
        }
        tokio::select! {
            sig = &mut shutdown => {
                match sig {
                    Ok(s) => info!("{s}: shutting down"),
                    Err(e) => warn!("{e:#}"),
                }
                return Ok(());
            }
            msg = commands.select_next_some() => match msg {
                Ok((cmd, info)) => {
                    if let Some(r) = rec.as_deref_mut() {
                        r.received(&cmd, &info)?;
                    }
                    match core.on_command(&cmd, steady(), true) {
                        CommandOutcome::Accepted => ever_commanded = true,
                        CommandOutcome::Duplicate => {}
                        refused => log_refused(refused, &cmd, &mut refused_logged, core.rejected()),
                    }
                }
                Err(e) => log_undecodable(&mut undecodable, &e),
            },
            _ = resend.tick() => {
                let waited = steady() - wait_started;
                let limit = if ever_commanded { core.command_timeout } else { opts.startup_timeout.as_secs_f64() };
                if waited > limit {
                    if core.force_stale() || !ever_commanded {
                        warn!("no command for seq {} within {:.3} s: applying zero force", core.seq(), limit);
                    }
                    ever_commanded = true;
                    core.step()?;
                    need_publish = true;
                } else {
                    let state = core.state();
                    if let Some(r) = rec.as_deref_mut() {
                        r.published(&state, None)?;
                        r.poll()?;
                    }
                    if let Err(e) = io.state_pub.async_publish(state).await {
                        warn!("state not re-sent: {e:?}");
                    }
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Stand-in model: the capsule is pinned, the mass is a unit mass under the held force
    /// only (y1' = f), integrated exactly. Enough to check the node's bookkeeping.
    struct FreeMass(PlantSample);

    impl PlantSim for FreeMass {
        fn advance(&mut self, force: f64, tau_end: f64) -> Result<()> {
            let h = tau_end - self.0.tau;
            self.0.x1 += self.0.y1 * h + 0.5 * force * h * h;
            self.0.y1 += force * h;
            self.0.tau = tau_end;
            self.0.actuator_force = force;
            Ok(())
        }
        fn sample(&self) -> PlantSample {
            self.0
        }
    }

    fn scale() -> Scale {
        Scale {
            m1_kg: 0.04,
            k1_n_per_m: 100.0,
            pf_n: 2.0,
        }
    }

    fn plant() -> PlantCore<FreeMass> {
        PlantCore::new(FreeMass(PlantSample::default()), scale(), 100.0, 0.05)
    }

    fn cmd(p: &PlantCore<FreeMass>, seq: u64, force: f64) -> ActuatorForce {
        let stamp = Time::from_nanos(p.stamp_nanos(seq));
        ActuatorForce {
            header: Header {
                stamp,
                frame_id: String::new(),
            },
            state_seq: seq,
            force,
        }
    }

    #[test]
    fn held_command_drives_the_step_in_si() -> Result<()> {
        let mut p = plant();
        p.published(0.0);
        assert_eq!(
            p.on_command(&cmd(&p, 0, 1.0), 0.001, true),
            CommandOutcome::Accepted
        );
        p.step()?;
        // 1 N on 0.04 kg for 0.01 s: v = 0.25 m/s, x = 1.25 mm
        let s = p.state();
        assert!(
            (s.mass_velocity - 0.25).abs() < 1e-12,
            "{}",
            s.mass_velocity
        );
        assert!(
            (s.mass_position - 1.25e-3).abs() < 1e-15,
            "{}",
            s.mass_position
        );
        assert!((s.actuator_force - 1.0).abs() < 1e-12);
        assert_eq!((s.seq, s.header.stamp.to_nanos()), (1, 10_000_000));
        assert!(!s.command_stale);
        Ok(())
    }

    #[test]
    fn non_finite_and_late_commands_are_refused_and_counted() -> Result<()> {
        let mut p = plant();
        p.published(0.0);
        assert_eq!(
            p.on_command(&cmd(&p, 0, f64::NAN), 0.0, false),
            CommandOutcome::NonFinite
        );
        assert_eq!(
            p.on_command(&cmd(&p, 0, f64::INFINITY), 0.0, false),
            CommandOutcome::NonFinite
        );
        assert_eq!(p.rejected(), 2);
        assert!(p.stale(), "nothing accepted yet");
        assert_eq!(
            p.on_command(&cmd(&p, 0, 0.5), 0.0, false),
            CommandOutcome::Accepted
        );
        p.step()?;
        p.step()?;
        assert_eq!(
            p.on_command(&cmd(&p, 2, 0.7), 0.02, false),
            CommandOutcome::Accepted
        );
        // an older command arriving late does not take over (time does not rewind)
        assert_eq!(
            p.on_command(&cmd(&p, 1, -3.0), 0.021, false),
            CommandOutcome::Late
        );
        assert_eq!(p.held_force(), 0.7);
        assert_eq!(
            p.on_command(&cmd(&p, 2, 0.7), 0.022, false),
            CommandOutcome::Duplicate
        );
        assert_eq!(p.rejected(), 3);
        assert_eq!(p.state().rejected_commands, 3);
        assert_eq!(p.seq(), 2, "the plant kept stepping");
        Ok(())
    }

    #[test]
    fn huge_finite_commands_are_saturated_and_the_plant_goes_on() -> Result<()> {
        // default limit: 100 P_f = 200 N at this scale
        let mut p = plant();
        assert_eq!(p.max_force_n(), 200.0);
        for (k, f) in [1e308, -1e308, 1000.0].into_iter().enumerate() {
            let k = k as u64;
            p.published(k as f64 * 0.01);
            assert_eq!(
                p.on_command(&cmd(&p, k, f), k as f64 * 0.01, false),
                CommandOutcome::Accepted
            );
            assert_eq!(p.held_force(), 200.0f64.copysign(f));
            p.step()?;
            let s = p.state();
            assert!(s.mass_position.is_finite() && s.mass_velocity.is_finite());
            assert_eq!(s.actuator_force, 200.0f64.copysign(f));
        }
        assert_eq!(p.stats.saturated_commands, 3);
        assert_eq!(p.rejected(), 0);
        let mut p = plant().with_max_force_n(0.5);
        p.published(0.0);
        p.on_command(&cmd(&p, 0, 3.0), 0.0, false);
        assert_eq!(p.held_force(), 0.5);
        Ok(())
    }

    #[test]
    fn a_command_stamped_in_the_future_is_refused_and_does_not_block_later_ones() -> Result<()> {
        let mut p = plant();
        p.published(0.0);
        assert_eq!(
            p.on_command(&cmd(&p, 0, 0.1), 0.0, false),
            CommandOutcome::Accepted
        );
        p.step()?;
        p.published(0.01);
        let mut poison = cmd(&p, 1, 5.0);
        poison.header.stamp = Time {
            sec: i32::MAX,
            nanosec: 0,
        };
        assert_eq!(p.on_command(&poison, 0.01, false), CommandOutcome::Future);
        assert_eq!(p.held_force(), 0.1);
        for k in 1..50 {
            assert_eq!(
                p.on_command(&cmd(&p, k, 0.2), k as f64 * 0.01, false),
                CommandOutcome::Accepted,
                "sample {k}"
            );
            p.step()?;
            p.published(k as f64 * 0.01 + 0.01);
        }
        assert_eq!(p.rejected(), 1);
        Ok(())
    }

    #[test]
    fn lockstep_takes_only_the_answer_to_the_current_sample() -> Result<()> {
        let mut p = plant();
        p.published(0.0);
        assert_eq!(
            p.on_command(&cmd(&p, 1, 1.0), 0.0, true),
            CommandOutcome::Future
        );
        assert!(!p.answered());
        assert_eq!(
            p.on_command(&cmd(&p, 0, 1.0), 0.0, true),
            CommandOutcome::Accepted
        );
        assert!(p.answered());
        p.step()?;
        p.published(0.01);
        assert_eq!(
            p.on_command(&cmd(&p, 0, 1.0), 0.01, true),
            CommandOutcome::Duplicate
        );
        assert!(!p.answered());
        assert_eq!(p.stats.latencies.count(), 1);
        Ok(())
    }

    #[test]
    fn watchdog_falls_back_to_zero_force_and_says_so() -> Result<()> {
        let mut p = plant();
        p.published(0.0);
        p.on_command(&cmd(&p, 0, 2.0), 0.0, false);
        assert!(!p.check_watchdog(0.04));
        assert_eq!(p.held_force(), 2.0);
        assert!(p.check_watchdog(0.06));
        assert!(!p.check_watchdog(0.07), "reported once");
        assert_eq!(p.held_force(), 0.0);
        p.step()?;
        let s = p.state();
        assert!(s.command_stale);
        assert_eq!(s.mass_velocity, 0.0);
        p.published(0.08);
        p.step()?;
        p.published(0.09);
        p.stats.finish();
        // sample 0 answered; sample 1 never (lost); sample 2 was in flight at the end
        assert_eq!(
            (
                p.stats.published,
                p.stats.unanswered,
                p.stats.before_first_answer
            ),
            (3, 1, 0)
        );
        Ok(())
    }

    #[test]
    fn stats_split_startup_lost_and_late_answers() {
        let mut st = LoopStats::default();
        for k in 0..10 {
            st.on_publish(k, k as f64);
        }
        st.on_answer(3, 3.5, 3); // first answer: 0..3 were start-up
        st.on_answer(5, 6.2, 6); // late: sample 6 already out
        st.on_answer(5, 6.3, 6); // repeat: ignored
        st.on_answer(42, 7.0, 9); // unknown seq: ignored
        st.finish(); // 9 in flight; 4, 6, 7, 8 lost
        assert_eq!(st.before_first_answer, 3);
        assert_eq!(st.late_answers, 1);
        assert_eq!(st.unanswered, 4);
        assert_eq!(st.latencies.count(), 2);
        assert_eq!(st.latencies.max(), Some(1.2));
    }

    #[test]
    fn percentiles_are_order_statistics() {
        let mut stats = LoopStats::default();
        for k in 1..=100 {
            stats.latencies.record(f64::from(k) * 1e-3);
        }
        let (p50, p99, max) = stats.percentiles().unwrap_or_default();
        let close = |a: f64, b: f64| (a - b).abs() <= b * LatencyHistogram::RELATIVE_ERROR;
        assert!(close(p50, 51e-3) && close(p99, 99e-3), "{p50} {p99}");
        assert_eq!(max, 100e-3);
        assert_eq!(LoopStats::default().percentiles(), None);
    }
}

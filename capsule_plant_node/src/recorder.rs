//! The recorder node: subscribes to every topic of the capsule graph (state, force commands,
//! controller status, `/clock`, the `set_mode` service events, `/diagnostics` and the
//! actions' feedback, status and service events, [`crate::action_readers`]) and writes them to one MCAP file
//! per run through [`capsule_record`].
//!
//! Bytes: ros2-client hands over deserialised messages, so the recorder serialises them again
//! with the codec RustDDS uses (`cdr-encoding`, little endian, XCDR1 plain structs): for these
//! fixed-layout types the bytes equal the wire bytes. Log time is DDS's reception time (wall
//! clock, as rosbag2 without `use_sim_time`); publish time is the sample's source timestamp.
//!
//! No sample is lost to the recorder's own start: it subscribes to the state last, once the
//! controller's force publisher has matched, and the launcher makes the plant wait for it
//! (`--wait-subscribers`). Chunks close every `flush_period` of wall time and every 0.5 s of
//! log time, so a SIGKILL loses at most that much; SIGINT / SIGTERM finish the file.
//!
//! Each state sample and each command is recorded once: a lock-step plant re-sends an unanswered
//! sample, and its controller answers each re-send again; the re-sends (same writer, seq and
//! stamp as the sample last recorded, and for a command the same force) are not written again,
//! so `capsule record info` counts samples, not sends.

use capsule_msgs::names::{topics, type_names};
use capsule_msgs::std_types::{Clock, DiagnosticArray};
use std::{
    collections::BTreeMap,
    path::{Path, PathBuf},
    time::Duration,
};

use capsule_msgs::{ActuatorForce, CapsuleState, ControllerStatus};
use capsule_record::{
    cdr,
    types::{OfferedQos, SetModeEvent},
    BagOptions, BagWriter, ChannelId, SceneRecord, WriterOptions,
};
use capsule_ros_base::error::{Context as _, NodeError, Result};
use ros2_client::{MessageInfo, MessageTypeName};
use serde::Serialize;
use tracing::{info, warn};

use capsule_ros_base::graph::Graph;
use capsule_ros_base::{endpoints::subscribe, qos, ros_options::RosOptions, types};

use crate::action_readers::{ActionEvent, ActionReaders, ActionSample};
use crate::take_each::take_each;

/// Relative name of the `set_mode` service-event topic (ROS 2 service introspection).
pub fn service_event_topic(controller_node: &str) -> String {
    format!("{controller_node}/set_mode/_service_event")
}

/// ROS type of the service-event topic as recorded.
pub fn service_event_type() -> MessageTypeName {
    MessageTypeName::new("capsule_msgs", "SetModeEvent")
}

/// What to record and where.
#[derive(Debug, Clone)]
pub struct RecorderOptions {
    /// Compression and splitting.
    pub bag: BagOptions,
    /// The file to write (must not exist).
    pub output: PathBuf,
    /// The scene of the run, stored in the file.
    pub scene: Option<SceneRecord>,
    /// Close the open chunk at least this often (wall clock).
    pub flush_period: Duration,
    /// How often to drain the readers.
    pub poll_period: Duration,
    /// How long to wait for the controller's force publisher before subscribing to the state.
    pub wait_publishers: Duration,
    /// Name of the controller node (its status and service-event topics are private to it).
    pub controller_node: String,
    /// Stop by itself after this long without any message (None: only on a signal).
    pub idle_stop: Option<Duration>,
    /// History depth of each reader, in samples (see [`DEFAULT_QUEUE_DEPTH`]).
    pub queue_depth: usize,
}

/// Default history depth of the recorder's readers: 2 s of samples at 10 kHz, the fastest
/// rate benchmarked (`capsule_record/bench/record_node.sh`). RustDDS keeps the last `depth`
/// samples of each topic in memory whether or not they were taken, so the depth is memory
/// held for the whole run (about 1.1 kB per sample per 1 kHz topic; 100,000 cost 110 MB at
/// 1 kHz, docs/recording.md), while losing a sample needs the drain loop (every `--poll-ms`)
/// to stall for longer than depth / rate: 2 s covers a slow flush to disk.
pub const DEFAULT_QUEUE_DEPTH: usize = 20_000;

/// History depth of the readers of the controller's status and service events (at most
/// `--queue-depth`): 2 s at the fastest status period (1 ms), 200 s at the default (100 ms).
pub const SLOW_QUEUE_DEPTH: usize = 2_000;

/// `capsule_<scene>_<UTC YYYYmmddTHHMMSS.mmmZ>.mcap`, scene reduced to `[A-Za-z0-9_-]`.
pub fn run_file_name(scene: &str, now_ns: u64) -> String {
    let clean: String = scene
        .chars()
        .map(|c| {
            if c.is_ascii_alphanumeric() || c == '-' || c == '_' {
                c
            } else {
                '_'
            }
        })
        .collect();
    let clean = if clean.is_empty() {
        "run".to_string()
    } else {
        clean
    };
    format!("capsule_{clean}_{}.mcap", utc_compact(now_ns))
}

/// `YYYYmmddTHHMMSS.mmmZ` of nanoseconds since the epoch.
pub fn utc_compact(ns: u64) -> String {
    use capsule_record::civil::{civil, Civil};
    let Civil {
        year,
        month,
        day,
        hour,
        minute,
        second,
        nanos,
    } = civil(ns);
    let ms = nanos / 1_000_000;
    format!("{year:04}{month:02}{day:02}T{hour:02}{minute:02}{second:02}.{ms:03}Z")
}

/// Where a run's recording goes: `output` if given, else `record_dir` (created if missing) /
/// [`run_file_name`]. Refused if the file exists: a recording is never overwritten.
pub fn output_path(
    record_dir: &Path,
    output: Option<&Path>,
    scene: Option<&SceneRecord>,
) -> Result<PathBuf> {
    let path = match output {
        Some(o) => o.to_path_buf(),
        None => {
            std::fs::create_dir_all(record_dir).with_context(|| {
                format!(
                    "cannot create the record directory {}",
                    record_dir.display()
                )
            })?;
            let name = scene.map(|s| s.name.as_str()).unwrap_or("run");
            record_dir.join(run_file_name(name, capsule_record::writer::now_ns()))
        }
    };
    if path.exists() {
        capsule_ros_base::error::bail!("{} exists: not overwriting a recording", path.display());
    }
    let parent = match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p,
        _ => Path::new("."),
    };
    if !parent.is_dir() {
        capsule_ros_base::error::bail!(
            "cannot record to {}: {} is not a directory",
            path.display(),
            parent.display()
        );
    }
    Ok(path)
}

/// What a recording run wrote.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct RecorderReport {
    /// The file.
    pub path: PathBuf,
    /// Messages per topic.
    pub per_topic: BTreeMap<String, u64>,
}

/// The channels of a capsule graph recording, in the order [`GraphRecording`] creates them.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Channel {
    /// `capsule/state`
    State = 0,
    /// `capsule/actuator_force`
    Force = 1,
    /// `<controller>/status`
    Status = 2,
    /// `/clock`
    Clock = 3,
    /// `<controller>/set_mode/_service_event`
    ServiceEvent = 4,
    /// `/diagnostics` (every node's, 1 Hz each: what went wrong and when)
    Diagnostics = 5,
    /// `<controller>/move/_action/feedback`
    MoveFeedback = 6,
    /// `<controller>/move/_action/status`
    MoveStatus = 7,
    /// `<controller>/switch_attractor/_action/feedback`
    SwitchFeedback = 8,
    /// `<controller>/switch_attractor/_action/status`
    SwitchStatus = 9,
    /// `<controller>/move/_action/send_goal/_service_event`
    MoveSendGoalEvent = 10,
    /// `<controller>/move/_action/get_result/_service_event`
    MoveGetResultEvent = 11,
    /// `<controller>/move/_action/cancel_goal/_service_event`
    MoveCancelGoalEvent = 12,
    /// `<controller>/switch_attractor/_action/send_goal/_service_event`
    SwitchSendGoalEvent = 13,
    /// `<controller>/switch_attractor/_action/get_result/_service_event`
    SwitchGetResultEvent = 14,
    /// `<controller>/switch_attractor/_action/cancel_goal/_service_event`
    SwitchCancelGoalEvent = 15,
}

impl Channel {
    /// The channel of an action sample's topic.
    pub fn of_action(sample: &ActionSample) -> Channel {
        match sample {
            ActionSample::MoveFeedback(_) => Channel::MoveFeedback,
            ActionSample::MoveStatus(_) => Channel::MoveStatus,
            ActionSample::SwitchFeedback(_) => Channel::SwitchFeedback,
            ActionSample::SwitchStatus(_) => Channel::SwitchStatus,
        }
    }
}

/// Takes what the action readers hold into `rec`, each sample as received; how many.
pub fn drain_actions(readers: &ActionReaders, rec: &mut GraphRecording) -> Result<usize> {
    let topics = readers.take(|sample, info| {
        let channel = Channel::of_action(&sample);
        match &sample {
            ActionSample::MoveFeedback(m) => rec.write_received(channel, m, info),
            ActionSample::SwitchFeedback(m) => rec.write_received(channel, m, info),
            ActionSample::MoveStatus(m) | ActionSample::SwitchStatus(m) => {
                rec.write_received(channel, m, info)
            }
        }
    })?;
    let events = readers.take_events(|event, info| {
        use ActionEvent::*;
        match &event {
            MoveSendGoal(e) => rec.write_received(Channel::MoveSendGoalEvent, e, info),
            MoveGetResult(e) => rec.write_received(Channel::MoveGetResultEvent, e, info),
            MoveCancelGoal(e) => rec.write_received(Channel::MoveCancelGoalEvent, e, info),
            SwitchSendGoal(e) => rec.write_received(Channel::SwitchSendGoalEvent, e, info),
            SwitchGetResult(e) => rec.write_received(Channel::SwitchGetResultEvent, e, info),
            SwitchCancelGoal(e) => rec.write_received(Channel::SwitchCancelGoalEvent, e, info),
        }
    })?;
    Ok(topics + events)
}

/// The actions' service events as a recording holds them, in [`Channel`] order after the
/// actions' topics (move's `send_goal`, `get_result`, `cancel_goal`, then the switch's):
/// relative name, ROS type (rosidl's), the QoS the controller offers
/// ([`capsule_ros_base::qos::service_events`]).
pub fn action_event_topics(controller_node: &str) -> [(String, &'static str, OfferedQos); 6] {
    let offered = OfferedQos {
        durability: capsule_record::types::Durability::TransientLocal,
        ..OfferedQos::reliable(64)
    };
    let [m, s] = crate::action_readers::action_names(controller_node);
    let event = |action: &str, service: &str, ros_type: &'static str| {
        (
            format!("{action}/_action/{service}/_service_event"),
            ros_type,
            offered,
        )
    };
    [
        event(&m, "send_goal", type_names::MOVE_SEND_GOAL_EVENT),
        event(&m, "get_result", type_names::MOVE_GET_RESULT_EVENT),
        event(&m, "cancel_goal", type_names::CANCEL_GOAL_EVENT),
        event(
            &s,
            "send_goal",
            type_names::SWITCH_ATTRACTOR_SEND_GOAL_EVENT,
        ),
        event(
            &s,
            "get_result",
            type_names::SWITCH_ATTRACTOR_GET_RESULT_EVENT,
        ),
        event(&s, "cancel_goal", type_names::CANCEL_GOAL_EVENT),
    ]
}

/// The actions' topics as a recording holds them, in [`Channel`] order after the graph's:
/// relative name, ROS type, the QoS the controller offers (rcl_action's: feedback reliable and
/// volatile, status reliable and transient local, keep last 1).
pub fn action_topics(controller_node: &str) -> [(String, &'static str, OfferedQos); 4] {
    let [feedback, status] = [
        OfferedQos::reliable(10),
        OfferedQos {
            durability: capsule_record::types::Durability::TransientLocal,
            ..OfferedQos::reliable(1)
        },
    ];
    let [m, s] = crate::action_readers::action_names(controller_node);
    [
        (
            format!("{m}/_action/feedback"),
            type_names::MOVE_FEEDBACK_MESSAGE,
            feedback,
        ),
        (
            format!("{m}/_action/status"),
            type_names::GOAL_STATUS_ARRAY,
            status,
        ),
        (
            format!("{s}/_action/feedback"),
            type_names::SWITCH_ATTRACTOR_FEEDBACK_MESSAGE,
            feedback,
        ),
        (
            format!("{s}/_action/status"),
            type_names::GOAL_STATUS_ARRAY,
            status,
        ),
    ]
}

/// The graph's topics as a recording subscribes to them, in [`Channel`] order: relative name,
/// DDS type, ROS type, the QoS the capsule nodes offer.
pub fn graph_topics(
    controller_node: &str,
) -> [(
    String,
    MessageTypeName,
    &'static str,
    ros2_client::QosProfile,
); 6] {
    [
        (
            topics::STATE.to_string(),
            types::state(),
            type_names::STATE,
            qos::data(),
        ),
        (
            topics::FORCE.to_string(),
            types::force(),
            type_names::FORCE,
            qos::data(),
        ),
        (
            format!("{controller_node}/status"),
            types::status(),
            type_names::STATUS,
            qos::data(),
        ),
        (
            topics::CLOCK.to_string(),
            types::clock(),
            type_names::CLOCK,
            qos::clock(),
        ),
        (
            service_event_topic(controller_node),
            service_event_type(),
            type_names::SET_MODE_EVENT,
            qos::service_events(),
        ),
        (
            topics::views::DIAGNOSTICS.to_string(),
            types::diagnostics(),
            type_names::DIAGNOSTIC_ARRAY,
            qos::data(),
        ),
    ]
}

/// An MCAP file of the capsule graph being written: one channel per topic (see [`Channel`]),
/// chunks closed at least every `flush_period` of wall time.
pub struct GraphRecording {
    writer: BagWriter,
    channels: Vec<(ChannelId, String, u32)>,
    flush_period: Duration,
    last_flush: std::time::Instant,
}

impl GraphRecording {
    /// Creates `path` (refused if it exists or cannot be written; a directory of numbered
    /// files when `bag` splits) with the graph's channels.
    pub fn create(
        path: &Path,
        scene: Option<SceneRecord>,
        settings: &RosOptions,
        controller_node: &str,
        flush_period: Duration,
        bag: BagOptions,
    ) -> Result<GraphRecording> {
        let mut writer = BagWriter::create(
            path,
            WriterOptions {
                scene,
                ..WriterOptions::default()
            },
            bag,
        )?;
        let mut channels = Vec::new();
        for (name, _, ros_type, _) in graph_topics(controller_node) {
            let full = settings.resolve_name(&name);
            // the QoS the capsule nodes offer (reliable, volatile, keep last)
            let depth = if ros_type == type_names::CLOCK { 1 } else { 16 };
            let id = writer.add_topic(&full, ros_type, &OfferedQos::reliable(depth))?;
            channels.push((id, full, 0));
        }
        let actions = action_topics(controller_node).into_iter();
        for (name, ros_type, offered) in actions.chain(action_event_topics(controller_node)) {
            let full = settings.resolve_name(&name);
            let id = writer.add_topic(&full, ros_type, &offered)?;
            channels.push((id, full, 0));
        }
        Ok(GraphRecording {
            writer,
            channels,
            flush_period,
            last_flush: std::time::Instant::now(),
        })
    }

    /// Writes `msg` on `channel` with log and publish times in ns since the epoch.
    pub fn write<T: Serialize>(
        &mut self,
        channel: Channel,
        msg: &T,
        log_ns: u64,
        publish_ns: u64,
    ) -> Result<()> {
        let data = cdr::encode(msg)?;
        let (id, _, seq) = &mut self.channels[channel as usize];
        *seq = seq.wrapping_add(1);
        let (id, seq) = (*id, *seq);
        self.writer.write(id, seq, log_ns, publish_ns, &data)?;
        Ok(())
    }

    /// Writes a received sample: log time = when DDS received it (not when a loop got to it,
    /// which would reorder topics by its own scheduling), publish time = its source stamp.
    pub fn write_received<T: Serialize>(
        &mut self,
        channel: Channel,
        msg: &T,
        info: &MessageInfo,
    ) -> Result<()> {
        let log = info
            .received_timestamp()
            .map(|t| t.to_nanos().max(0) as u64)
            .unwrap_or_else(capsule_record::writer::now_ns);
        let publish = info
            .source_timestamp()
            .map(|t| t.to_nanos().max(0) as u64)
            .unwrap_or(log);
        self.write(channel, msg, log, publish)
    }

    /// Closes the open chunk if `flush_period` has passed since the last time.
    pub fn flush_if_due(&mut self) -> Result<()> {
        if self.last_flush.elapsed() >= self.flush_period {
            self.writer.flush()?;
            self.last_flush = std::time::Instant::now();
        }
        Ok(())
    }

    /// Messages written per topic so far.
    pub fn per_topic(&self) -> BTreeMap<String, u64> {
        self.channels
            .iter()
            .map(|c| (c.1.clone(), c.2 as u64))
            .collect()
    }

    /// Finishes the file (summary, indexes, rosbag2 metadata).
    pub fn finish(self) -> Result<RecorderReport> {
        let per_topic = self.per_topic();
        let path = self.writer.path().to_path_buf();
        self.writer.finish()?;
        Ok(RecorderReport { path, per_topic })
    }

    /// Ends after an error: flushes what it can and says how to complete the file.
    pub fn abandon(mut self, e: NodeError) -> NodeError {
        let path = self.writer.path().to_path_buf();
        let _ = self.writer.flush();
        NodeError::Failed {
            what: format!(
                "recording to {} stopped; `capsule record recover` completes the file",
                path.display()
            ),
            source: e.into(),
        }
    }
}

/// Takes every sample `sub` holds into `rec` on `channel`; returns how many.
pub fn drain_into<M: Serialize + serde::de::DeserializeOwned + 'static>(
    sub: &ros2_client::dds::Subscription<M>,
    rec: &mut GraphRecording,
    channel: Channel,
) -> Result<usize> {
    take_each(sub, format_args!("{channel:?}"), |msg, mi| {
        rec.write_received(channel, &msg, mi).map(|()| true)
    })
}

/// What tells a re-send from a new sample: the writer, the seq and the stamp, and for a
/// command its force's bits (a lock-step controller answers each re-send of a state again).
type SampleKey = (ros2_client::Gid, u64, i64, u64);

/// Takes every sample `sub` holds into `rec` on `channel`, each once: a sample whose `key`
/// equals the one last written (a lock-step plant's re-send of an unanswered state, the
/// controller's answer to it again) is not written again; returns how many were written.
/// `last`: the key last written, kept between calls.
fn drain_once<M: Serialize + serde::de::DeserializeOwned + 'static>(
    sub: &ros2_client::dds::Subscription<M>,
    rec: &mut GraphRecording,
    channel: Channel,
    last: &std::cell::Cell<Option<SampleKey>>,
    key: impl Fn(&M, &ros2_client::MessageInfo) -> SampleKey,
) -> Result<usize> {
    take_each(sub, format_args!("{channel:?}"), |msg, mi| {
        let k = Some(key(&msg, mi));
        if last.get() == k {
            return Ok(false);
        }
        last.set(k);
        rec.write_received(channel, &msg, mi).map(|()| true)
    })
}

/// The recorder's readers, one per topic of the graph.
struct Readers {
    state: ros2_client::dds::Subscription<CapsuleState>,
    force: ros2_client::dds::Subscription<ActuatorForce>,
    status: ros2_client::dds::Subscription<ControllerStatus>,
    clock: ros2_client::dds::Subscription<Clock>,
    event: ros2_client::dds::Subscription<SetModeEvent>,
    diagnostics: ros2_client::dds::Subscription<DiagnosticArray>,
    /// The state sample and the command last recorded: their re-sends are not recorded.
    last_state: std::cell::Cell<Option<SampleKey>>,
    last_force: std::cell::Cell<Option<SampleKey>>,
    actions: ActionReaders,
}

impl Readers {
    /// Subscribes to every topic of the graph: to the state last, once the controller's force
    /// publisher has matched (or `opts.wait_publishers` has passed).
    async fn subscribe(
        settings: &RosOptions,
        context: &ros2_client::dds::Context,
        node: &mut ros2_client::dds::Node,
        graph: &Graph,
        opts: &RecorderOptions,
    ) -> Result<Self> {
        let mut topics = Vec::new();
        for (name, dds_type, _, q) in graph_topics(&opts.controller_node) {
            let topic = node
                .create_topic(&settings.ros_name(&name)?, dds_type, &q)
                .with_context(|| format!("topic {}", settings.resolve_name(&name)))?;
            topics.push(topic);
        }
        // Reader queues deep enough that a slow disk moment does not drop samples, and no
        // deeper: DDS holds them in memory all run (DEFAULT_QUEUE_DEPTH). Reliable readers:
        // with best-effort ones RustDDS's writers sent only part of the samples at 10 kHz (a
        // third of /clock went missing before it reached the kernel), although they spare the
        // acknowledgement each reliable reader sends back per sample.
        let reader_qos = qos::data().history(ros2_client::qos::History::KeepLast {
            depth: opts.queue_depth,
        });
        // the controller's status (10 Hz by default, 1 kHz at the fastest) and diagnostics: the
        // same depth would be memory that fills over hours (20,000 statuses: 33 min, 10 MB);
        // the service events keep their own transient-local QoS (`qos::service_events`)
        let slow_qos = qos::data().history(ros2_client::qos::History::KeepLast {
            depth: opts.queue_depth.min(SLOW_QUEUE_DEPTH),
        });
        let force = subscribe::<ActuatorForce>(node, &topics[1], &reader_qos)?;
        let status = subscribe::<ControllerStatus>(node, &topics[2], &slow_qos)?;
        let clock = subscribe::<Clock>(node, &topics[3], &reader_qos)?;
        let event = subscribe::<SetModeEvent>(node, &topics[4], &qos::service_events())?;
        let diagnostics = subscribe::<DiagnosticArray>(node, &topics[5], &slow_qos)?;
        let actions =
            ActionReaders::subscribe(context, node, settings, &opts.controller_node, true)?;
        if !graph
            .wait_publishers(force.guid(), 1, opts.wait_publishers)
            .await
        {
            warn!(
                "no force publisher after {:?}: recording without waiting for the controller",
                opts.wait_publishers
            );
        }
        let state = subscribe::<CapsuleState>(node, &topics[0], &reader_qos)?;
        Ok(Self {
            state,
            force,
            status,
            clock,
            event,
            diagnostics,
            last_state: std::cell::Cell::default(),
            last_force: std::cell::Cell::default(),
            actions,
        })
    }

    /// Takes what every reader holds into `sink`; how many samples (diagnostics are recorded
    /// but not counted: a controller left running publishes them every second, and the graph
    /// is idle all the same).
    fn drain(&self, sink: &mut GraphRecording) -> Result<usize> {
        drain_into(&self.diagnostics, sink, Channel::Diagnostics)?;
        let state_key = |m: &CapsuleState, mi: &ros2_client::MessageInfo| {
            (mi.publisher_gid(), m.seq, m.header.stamp.to_nanos(), 0)
        };
        let force_key = |m: &ActuatorForce, mi: &ros2_client::MessageInfo| {
            let stamp = m.header.stamp.to_nanos();
            (mi.publisher_gid(), m.state_seq, stamp, m.force.to_bits())
        };
        Ok(drain_once(
            &self.state,
            sink,
            Channel::State,
            &self.last_state,
            state_key,
        )? + drain_once(
            &self.force,
            sink,
            Channel::Force,
            &self.last_force,
            force_key,
        )? + drain_into(&self.status, sink, Channel::Status)?
            + drain_into(&self.clock, sink, Channel::Clock)?
            + drain_into(&self.event, sink, Channel::ServiceEvent)?
            + drain_actions(&self.actions, sink)?)
    }

    /// Samples still in flight when the graph stops (the plant's last one): keeps draining
    /// until the readers stay empty for 100 ms (at most 0.5 s).
    async fn drain_in_flight(&self, sink: &mut GraphRecording) -> Result<()> {
        let until = tokio::time::Instant::now() + Duration::from_millis(500);
        let mut quiet = tokio::time::Instant::now();
        loop {
            if self.drain(sink)? > 0 {
                quiet = tokio::time::Instant::now();
            }
            let now = tokio::time::Instant::now();
            if now >= until || now - quiet >= Duration::from_millis(100) {
                return Ok(());
            }
            tokio::time::sleep(Duration::from_millis(5)).await;
        }
    }

    /// Records until SIGINT / SIGTERM, or `opts.idle_stop` without a message.
    ///
    /// Polls every reader on a short timer and drains what it holds, instead of one wake-up per
    /// sample: at 10 kHz x 3 topics that is 500 wake-ups/s instead of 30 000. Log times come
    /// from DDS reception, so batching does not blur them.
    async fn record(&self, sink: &mut GraphRecording, opts: &RecorderOptions) -> Result<()> {
        let mut poll = tokio::time::interval(opts.poll_period);
        poll.set_missed_tick_behavior(tokio::time::MissedTickBehavior::Delay);
        let shutdown = capsule_ros_base::signals::shutdown_signal();
        tokio::pin!(shutdown);
        let mut last_msg = tokio::time::Instant::now();
        let mut got_any = false;
        loop {
            tokio::select! {
                sig = &mut shutdown => {
                    self.drain_in_flight(sink).await?;
                    info!("{}: finishing {}", sig?, opts.output.display());
                    return Ok(());
                }
                _ = poll.tick() => {
                    if self.drain(sink)? > 0 {
                        got_any = true;
                        last_msg = tokio::time::Instant::now();
                    }
                    sink.flush_if_due()?;
                    if let Some(idle) = opts.idle_stop {
                        if got_any && last_msg.elapsed() >= idle {
                            info!("no message for {idle:?}: finishing {}", opts.output.display());
                            return Ok(());
                        }
                    }
                }
            }
        }
    }
}

/// Runs the recorder until SIGINT / SIGTERM (or `idle_stop`), then finishes the file.
pub async fn run(settings: RosOptions, opts: RecorderOptions) -> Result<RecorderReport> {
    // the file first: an unwritable place is an error before anything else starts
    let mut sink = GraphRecording::create(
        &opts.output,
        opts.scene.clone(),
        &settings,
        &opts.controller_node,
        opts.flush_period,
        opts.bag,
    )?;
    let context = settings.context()?;
    let (mut node, graph) = settings.loop_node(&context)?;
    let readers = Readers::subscribe(&settings, &context, &mut node, &graph, &opts).await?;
    info!(
        "{}: recording {} to {}",
        settings.describe(),
        sink.per_topic().into_keys().collect::<Vec<_>>().join(", "),
        opts.output.display()
    );
    match readers.record(&mut sink, &opts).await {
        Ok(()) => sink.finish(),
        // keep what is on disk readable by `capsule record recover`
        Err(e) => Err(sink.abandon(e)),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn run_file_names_are_clear_and_safe() {
        // 2026-11-22 05:29:30.123 UTC
        let ns = 1_795_325_370_123_000_000;
        assert_eq!(
            run_file_name("control point/../x", ns),
            "capsule_control_point____x_20261122T052930.123Z.mcap"
        );
        assert_eq!(
            run_file_name("", 0),
            "capsule_run_19700101T000000.000Z.mcap"
        );
    }
}

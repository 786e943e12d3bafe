//! A live view without ROS installed: the capsule graph's topics served on a Foxglove
//! WebSocket on loopback (the `foxglove` SDK crate; Foxglove's v1 WebSocket protocol under the
//! SDK's subprotocol name `foxglove.sdk.v1`).
//!
//! The bridge is its own node (`capsule_foxglove`), in a process of its own ([`run`], the
//! `capsule_foxglove` binary: it reads the plant's state and commands over DDS like any other
//! reader, so the plant's loop does not know it exists) or on a thread of its own in
//! `capsule_container` ([`BridgeThread`]: state and commands from the in-process link,
//! [`Source::InProcess`]); the controller's status it reads over DDS in a participant of its
//! own. It serves JSON channels, each with a JSON schema:
//!
//! - the state topic (`/capsule/state`): `t`, `x1`, `x2`, `y1`, `y2`, `x1_minus_x2`,
//!   `y1_minus_y2`, `force`, ... in SI (what the paper's plots show, in metres and seconds);
//! - the controller's status (`/capsule_controller/status`): mode, gain, commands sent,
//!   progression per period, mean speed;
//! - the force commands (`/capsule/actuator_force`): `t` (the stamp of the sample answered),
//!   `state_seq`, `force` \[N\] as commanded (the state's `force` is the one applied);
//! - [`FRAME_TOPIC`]: a `foxglove.FrameTransform` of the capsule body in `odom` (the 3D panel);
//! - the controller's actions, each under its topic's name: the feedback of a goal (Move's
//!   travelled, remaining, speed and mode; SwitchAttractor's state, tries and orbit period) and
//!   the statuses of the goals (accepted, executing, succeeded, ...), read over DDS
//!   ([`capsule_plant_node::action_readers`]).
//!
//! State, frame and commands are thinned by their stamps to at most `--max-rate-hz`, and nothing is
//! encoded while no client subscribes. The server binds 127.0.0.1 only ([`check_host`]).

use capsule_msgs::names::topics;
use std::sync::mpsc::{sync_channel, Receiver};
use std::sync::{Arc, Mutex, PoisonError};
use std::{future::Future, io::Write as _, net::Ipv4Addr, time::Duration};

use capsule_msgs::{ActuatorForce, CapsuleState, ControllerStatus, Time};
use capsule_ros_base::error::{bail, Context as _, Result};
use foxglove::{ChannelBuilder, RawChannel, Schema};
use futures::StreamExt;
use serde::Serialize;
use serde_json::json;
use tracing::{info, warn};

use capsule_msgs::actions::{GoalStatus, GoalStatusArray};
use capsule_msgs::names::type_names;
use capsule_plant_node::action_readers::{ActionReaders, ActionSample};
use capsule_plant_node::intra_process::Link;
use capsule_plant_node::recorder::{action_topics, Channel};
use capsule_plant_node::views::BODY_FRAME;
use capsule_ros_base::{endpoints::subscribe, qos, ros_options::RosOptions, types};
use ros2_client::dds::Subscription;

/// Foxglove channel of the capsule body's transform (the 3D panel's frame).
pub const FRAME_TOPIC: &str = "/capsule/frame";
/// The WebSocket subprotocol the SDK's server requires: Foxglove's v1 protocol (the messages of
/// `foxglove.websocket.v1`) under the SDK's name; the Foxglove app offers it.
pub const SUBPROTOCOL: &str = "foxglove.sdk.v1";

/// How the bridge is set up (besides the ROS settings).
#[derive(Debug, Clone)]
pub struct BridgeOptions {
    /// Port to serve on (0: any free one, printed).
    pub port: u16,
    /// The controller node whose `~/status` is served.
    pub controller_node: String,
    /// Most state, frame and command messages per second (by their stamps); 0: every one.
    pub max_rate_hz: f64,
}

impl BridgeOptions {
    /// The default of [`BridgeOptions::max_rate_hz`]: enough for a plot, little to encode.
    pub const DEFAULT_MAX_RATE_HZ: f64 = 200.0;
}

/// Refuses any bind address but loopback: the live view is for this machine (forward the
/// port, e.g. `ssh -L`, to look from another one).
pub fn check_host(host: &str) -> Result<Ipv4Addr> {
    match host.trim() {
        "127.0.0.1" | "localhost" => Ok(Ipv4Addr::LOCALHOST),
        other => bail!(
            "--host {other:?}: the Foxglove server binds 127.0.0.1 only (loopback); to view from another machine forward the port (ssh -L)"
        ),
    }
}

/// The JSON schema of an object: its title, description (if any) and properties (JSON text).
macro_rules! object_schema {
    ($title:literal, $(description: $description:literal,)? $properties:literal) => {
        concat!(
            r#"{"title": ""#,
            $title,
            r#"", "#,
            $(r#""description": ""#, $description, r#"", "#,)?
            r#""type": "object", "properties": {"#,
            $properties,
            "}}"
        )
    };
}

/// JSON schema of the state channel.
pub const STATE_SCHEMA: &str = object_schema!(
    "capsule.State",
    description: "One plant sample in SI: x1 inner mass, x2 capsule (positions [m] in odom), y1, y2 their velocities [m/s]",
    r#"
  "t": {"type": "number", "description": "sample time [s] (sim time)"},
  "seq": {"type": "integer"},
  "x1": {"type": "number"}, "x2": {"type": "number"},
  "y1": {"type": "number"}, "y2": {"type": "number"},
  "x1_minus_x2": {"type": "number"}, "y1_minus_y2": {"type": "number"},
  "force": {"type": "number", "description": "actuator force applied [N]"},
  "friction": {"type": "number", "description": "friction force on the capsule [N]"},
  "contact_force": {"type": "number"},
  "in_contact": {"type": "boolean"}, "stuck": {"type": "boolean"},
  "command_stale": {"type": "boolean"}, "rejected_commands": {"type": "integer"}
"#
);

/// JSON schema of the force command channel.
pub const FORCE_SCHEMA: &str = object_schema!(
    "capsule.ActuatorForce",
    description: "A force command as the controller sent it",
    r#"
  "t": {"type": "number", "description": "stamp of the state sample it answers [s]"},
  "state_seq": {"type": "integer"},
  "force": {"type": "number", "description": "commanded force [N]"}
"#
);

/// JSON schema of the controller status channel.
pub const STATUS_SCHEMA: &str = object_schema!(
    "capsule.ControllerStatus",
    r#"
  "t": {"type": "number", "description": "status time [s] (the controller's ROS time)"},
  "mode": {"type": "integer"}, "mode_name": {"type": "string"},
  "gain": {"type": "number"}, "commanding": {"type": "boolean"},
  "commands_sent": {"type": "integer"}, "periods": {"type": "integer"},
  "progression_per_period": {"type": "number", "description": "non-dimensional"},
  "progression_per_period_m": {"type": "number"},
  "mean_speed": {"type": "number", "description": "[m/s]"},
  "efficiency": {"type": "number"},
  "drive_amplitude_si": {"type": "number"}, "drive_frequency_hz": {"type": "number"}
"#
);

/// JSON schema of the Move action's feedback channel.
pub const MOVE_FEEDBACK_SCHEMA: &str = object_schema!(
    "capsule.MoveFeedback",
    r#"
  "t": {"type": "number", "description": "when the controller sent it [s] (its DDS source time, wall clock)"},
  "goal_id": {"type": "string", "description": "hex"},
  "travelled_m": {"type": "number"}, "remaining_m": {"type": "number"},
  "speed_m_per_s": {"type": "number"}, "mode": {"type": "integer"}, "mode_name": {"type": "string"}
"#
);

/// JSON schema of the SwitchAttractor action's feedback channel.
pub const SWITCH_FEEDBACK_SCHEMA: &str = object_schema!(
    "capsule.SwitchAttractorFeedback",
    r#"
  "t": {"type": "number", "description": "when the controller sent it [s] (its DDS source time, wall clock)"},
  "goal_id": {"type": "string", "description": "hex"},
  "switch_state": {"type": "integer"}, "tries": {"type": "integer"}, "orbit_period": {"type": "integer"}
"#
);

/// JSON schema of an action's status channel (`action_msgs/msg/GoalStatusArray`).
pub const GOAL_STATUS_SCHEMA: &str = object_schema!(
    "capsule.GoalStatusArray",
    r#"
  "t": {"type": "number", "description": "when the controller sent it [s] (its DDS source time, wall clock)"},
  "goals": {"type": "array", "items": {"type": "object", "properties": {
    "goal_id": {"type": "string"}, "accepted_t": {"type": "number"},
    "status": {"type": "integer"}, "status_name": {"type": "string"}}}}
"#
);

/// JSON schema of `foxglove.FrameTransform` (Foxglove's well-known schema, JSON encoding).
pub const FRAME_SCHEMA: &str = object_schema!(
    "foxglove.FrameTransform",
    r#"
  "timestamp": {"type": "object", "properties": {"sec": {"type": "integer"}, "nsec": {"type": "integer"}}},
  "parent_frame_id": {"type": "string"},
  "child_frame_id": {"type": "string"},
  "translation": {"type": "object", "properties": {"x": {"type": "number"}, "y": {"type": "number"}, "z": {"type": "number"}}},
  "rotation": {"type": "object", "properties": {"x": {"type": "number"}, "y": {"type": "number"}, "z": {"type": "number"}, "w": {"type": "number"}}}
"#
);

/// The state sample as the state channel's JSON.
pub fn state_json(s: &CapsuleState) -> serde_json::Value {
    json!({
        "t": s.header.stamp.as_secs_f64(),
        "seq": s.seq,
        "x1": s.mass_position,
        "x2": s.capsule_position,
        "y1": s.mass_velocity,
        "y2": s.capsule_velocity,
        "x1_minus_x2": s.mass_position - s.capsule_position,
        "y1_minus_y2": s.mass_velocity - s.capsule_velocity,
        "force": s.actuator_force,
        "friction": s.friction_force,
        "contact_force": s.contact_force,
        "in_contact": s.in_contact,
        "stuck": s.stuck,
        "command_stale": s.command_stale,
        "rejected_commands": s.rejected_commands,
    })
}

/// The force command as the force channel's JSON.
pub fn force_json(c: &ActuatorForce) -> serde_json::Value {
    json!({
        "t": c.header.stamp.as_secs_f64(),
        "state_seq": c.state_seq,
        "force": c.force,
    })
}

/// The controller status as the status channel's JSON.
pub fn status_json(s: &ControllerStatus) -> serde_json::Value {
    json!({
        "t": s.header.stamp.as_secs_f64(),
        "mode": s.mode,
        "mode_name": s.mode_name,
        "gain": s.gain,
        "commanding": s.commanding,
        "commands_sent": s.commands_sent,
        "periods": s.periods,
        "progression_per_period": s.progression_per_period,
        "progression_per_period_m": s.progression_per_period_m,
        "mean_speed": s.mean_speed,
        "efficiency": s.efficiency,
        "drive_amplitude_si": s.drive_amplitude_si,
        "drive_frequency_hz": s.drive_frequency_hz,
    })
}

/// An action sample as its channel's JSON, stamped `t` \[s\].
pub fn action_json(sample: &ActionSample, t: f64) -> serde_json::Value {
    let statuses = |a: &GoalStatusArray| {
        let goals: Vec<serde_json::Value> = a
            .status_list
            .iter()
            .map(|g| {
                json!({
                    "goal_id": hex(&g.goal_info.goal_id),
                    "accepted_t": g.goal_info.stamp.as_secs_f64(),
                    "status": g.status,
                    "status_name": GoalStatus::name(g.status),
                })
            })
            .collect();
        json!({"t": t, "goals": goals})
    };
    match sample {
        ActionSample::MoveFeedback(m) => {
            let mut v = feedback_json(t, &m.goal_id, &m.feedback);
            v["mode_name"] = json!(capsule_msgs::mode_name(m.feedback.mode).unwrap_or("?"));
            v
        }
        ActionSample::SwitchFeedback(m) => feedback_json(t, &m.goal_id, &m.feedback),
        ActionSample::MoveStatus(a) | ActionSample::SwitchStatus(a) => statuses(a),
    }
}

/// A goal id in hex.
fn hex(id: &[u8; 16]) -> String {
    id.iter().map(|b| format!("{b:02x}")).collect()
}

/// A goal's feedback as its channel's JSON: `t`, the goal's id, then the feedback's fields.
fn feedback_json(t: f64, goal_id: &[u8; 16], feedback: &impl Serialize) -> serde_json::Value {
    let mut v = json!({"t": t, "goal_id": hex(goal_id)});
    // a struct of numbers is always an object
    if let (Some(out), Ok(serde_json::Value::Object(fields))) =
        (v.as_object_mut(), serde_json::to_value(feedback))
    {
        out.extend(fields);
    }
    v
}

fn stamp_json(t: Time) -> serde_json::Value {
    let n = t.to_nanos();
    json!({"sec": n.div_euclid(1_000_000_000), "nsec": n.rem_euclid(1_000_000_000)})
}

/// The capsule body in the sample's frame (`odom`) as a `foxglove.FrameTransform`.
pub fn frame_json(s: &CapsuleState) -> serde_json::Value {
    json!({
        "timestamp": stamp_json(s.header.stamp),
        "parent_frame_id": s.header.frame_id,
        "child_frame_id": BODY_FRAME,
        "translation": {"x": s.capsule_position, "y": 0.0, "z": 0.0},
        "rotation": {"x": 0.0, "y": 0.0, "z": 0.0, "w": 1.0},
    })
}

/// Passes samples at most `max_rate_hz` apart by their stamps (0: all); a stamp going back
/// (a restarted plant) starts afresh.
#[derive(Debug, Clone)]
pub struct StampThinner {
    period_ns: i64,
    last: Option<i64>,
}

impl StampThinner {
    /// A thinner to at most `max_rate_hz` (>= 0, finite: the caller validates).
    pub fn new(max_rate_hz: f64) -> Self {
        let period_ns = if max_rate_hz > 0.0 {
            (1e9 / max_rate_hz).round() as i64
        } else {
            0
        };
        StampThinner {
            period_ns,
            last: None,
        }
    }

    /// True if the sample stamped `t` goes out.
    pub fn pass(&mut self, t: Time) -> bool {
        let n = t.to_nanos();
        match self.last {
            Some(last) if n >= last && n - last < self.period_ns => false,
            _ => {
                self.last = Some(n);
                true
            }
        }
    }
}

fn channel(topic: &str, schema: &'static str) -> Result<Arc<RawChannel>> {
    let title = serde_json::from_str::<serde_json::Value>(schema)
        .ok()
        .and_then(|v| v["title"].as_str().map(str::to_string))
        .with_context(|| format!("schema of {topic} has no title"))?;
    ChannelBuilder::new(topic)
        .message_encoding("json")
        .schema(Schema::new(title, "jsonschema", schema.as_bytes()))
        .build_raw()
        .with_context(|| format!("Foxglove channel {topic}"))
}

fn log(ch: &RawChannel, value: serde_json::Value) {
    match serde_json::to_vec(&value) {
        Ok(bytes) => ch.log(&bytes),
        Err(e) => warn!("{}: not encoded: {e}", ch.topic()),
    }
}

/// Where the bridge takes the plant's state and the controller's commands from (the status is
/// always read over DDS).
#[derive(Clone)]
pub enum Source {
    /// DDS readers of the state and force topics, like any other node's.
    Dds,
    /// The in-process link of a plant and a controller composed in this process: the samples
    /// and answers the link hands over, thinned to `--max-rate-hz` on the loop's thread (a stamp
    /// compared; what passes queued without waiting) and taken every [`FEED_PERIOD`].
    InProcess(Link),
}

/// How often the bridge takes what the in-process link queued for it (polled: the loop's thread
/// never wakes the bridge's).
pub const FEED_PERIOD: Duration = Duration::from_millis(5);
/// Samples the in-process queue holds; what does not fit is not shown (a live view).
const FEED_CAPACITY: usize = 1024;

/// A state sample and the command answering it, from the in-process link.
type Fed = (CapsuleState, Option<ActuatorForce>);

/// State and force: DDS readers (boxed: the larger variant), or the in-process link's queue.
enum Feed {
    Dds {
        state_sub: Box<Subscription<CapsuleState>>,
        force_sub: Box<Subscription<ActuatorForce>>,
    },
    InProcess(Receiver<Fed>),
}

impl Feed {
    /// The feed of `source`: its readers on `node`, or a watcher on the link (which queues
    /// nothing while no client subscribes to a channel of `outputs`).
    fn create(
        source: Source,
        node: &mut ros2_client::dds::Node,
        settings: &RosOptions,
        outputs: &Outputs,
        max_rate_hz: f64,
    ) -> Result<Feed> {
        match source {
            Source::Dds => {
                let state_topic =
                    settings.topic(node, topics::STATE, types::state(), &qos::data())?;
                let force_topic =
                    settings.topic(node, topics::FORCE, types::force(), &qos::data())?;
                Ok(Feed::Dds {
                    force_sub: Box::new(subscribe(node, &force_topic, &qos::data_reader())?),
                    state_sub: Box::new(subscribe(node, &state_topic, &qos::data_reader())?),
                })
            }
            Source::InProcess(link) => {
                let (tx, rx) = sync_channel(FEED_CAPACITY);
                let thin = Mutex::new(StampThinner::new(max_rate_hz));
                let channels = [&outputs.state, &outputs.frame, &outputs.force].map(Arc::clone);
                link.watch(Box::new(move |state, answer| {
                    let pass = thin
                        .lock()
                        .unwrap_or_else(PoisonError::into_inner)
                        .pass(state.header.stamp);
                    if pass && channels.iter().any(|c| c.has_sinks()) {
                        let _ = tx.try_send((state.clone(), answer.cloned()));
                    }
                }))?;
                Ok(Feed::InProcess(rx))
            }
        }
    }
}

/// The channels and their thinning: what the bridge does with each message.
struct Outputs {
    state: Arc<RawChannel>,
    status: Arc<RawChannel>,
    frame: Arc<RawChannel>,
    force: Arc<RawChannel>,
    /// The actions' feedback and status, in [`Channel`] order (move's, then the switch's).
    actions: [Arc<RawChannel>; 4],
    thin: StampThinner,
    thin_force: StampThinner,
}

impl Outputs {
    fn state(&mut self, s: &CapsuleState) {
        let wanted = self.state.has_sinks() || self.frame.has_sinks();
        if wanted && self.thin.pass(s.header.stamp) {
            if self.state.has_sinks() {
                log(&self.state, state_json(s));
            }
            if self.frame.has_sinks() {
                log(&self.frame, frame_json(s));
            }
        }
    }

    fn force(&mut self, c: &ActuatorForce) {
        if self.force.has_sinks() && self.thin_force.pass(c.header.stamp) {
            log(&self.force, force_json(c));
        }
    }

    fn status(&mut self, s: &ControllerStatus) {
        if self.status.has_sinks() {
            log(&self.status, status_json(s));
        }
    }

    fn action(&mut self, s: &ActionSample, info: &ros2_client::MessageInfo) {
        let ch = &self.actions[Channel::of_action(s) as usize - Channel::MoveFeedback as usize];
        if ch.has_sinks() {
            let t = info
                .source_timestamp()
                .or(info.received_timestamp())
                .map_or(0.0, |t| t.to_nanos() as f64 * 1e-9);
            log(ch, action_json(s, t));
        }
    }
}

/// The bridge started: its feed and status reader (on a DDS participant of its own), its
/// channels, and its server listening.
pub struct Bridge {
    // the participant and node outlive the readers (dropped after them: fields drop in order)
    feed: Feed,
    status_sub: Subscription<ControllerStatus>,
    actions: ActionReaders,
    outputs: Outputs,
    server: foxglove::WebSocketServerHandle,
    _node: ros2_client::dds::Node,
    _context: ros2_client::dds::Context,
}

impl Bridge {
    /// Starts the bridge as the node `settings` names, in a DDS participant of its own: the
    /// feed from `source`, the status reader, the channels, then the server on 127.0.0.1 (a
    /// port taken is an error naming it).
    pub async fn start(
        settings: &RosOptions,
        opts: &BridgeOptions,
        source: Source,
    ) -> Result<Bridge> {
        let context = settings.context()?;
        let (mut node, _graph) = settings.loop_node(&context)?;
        let controller = RosOptions {
            node_name: opts.controller_node.clone(),
            ..settings.clone()
        };
        let state_name = settings.resolve_name(topics::STATE);
        let status_name = controller.resolve_name(topics::STATUS);
        let force_name = settings.resolve_name(topics::FORCE);
        let status_topic = node
            .create_topic(
                &controller.ros_name(topics::STATUS)?,
                types::status(),
                &qos::data(),
            )
            .with_context(|| format!("topic {status_name}"))?;
        let action_channel = |(name, ros_type, _): &(String, &str, _)| {
            let schema = match *ros_type {
                type_names::MOVE_FEEDBACK_MESSAGE => MOVE_FEEDBACK_SCHEMA,
                type_names::SWITCH_ATTRACTOR_FEEDBACK_MESSAGE => SWITCH_FEEDBACK_SCHEMA,
                _ => GOAL_STATUS_SCHEMA,
            };
            channel(&settings.resolve_name(name), schema)
        };
        let [a, b, c, d] = action_topics(&opts.controller_node);
        let outputs = Outputs {
            state: channel(&state_name, STATE_SCHEMA)?,
            status: channel(&status_name, STATUS_SCHEMA)?,
            frame: channel(FRAME_TOPIC, FRAME_SCHEMA)?,
            force: channel(&force_name, FORCE_SCHEMA)?,
            actions: [
                action_channel(&a)?,
                action_channel(&b)?,
                action_channel(&c)?,
                action_channel(&d)?,
            ],
            thin: StampThinner::new(opts.max_rate_hz),
            thin_force: StampThinner::new(opts.max_rate_hz),
        };
        let feed = Feed::create(source, &mut node, settings, &outputs, opts.max_rate_hz)?;
        let status_sub = subscribe(&mut node, &status_topic, &qos::data_reader())?;
        let actions =
            ActionReaders::subscribe(&context, &mut node, settings, &opts.controller_node, false)?;
        let server = foxglove::WebSocketServer::new()
            .name(capsule_msgs::names::nodes::FOXGLOVE)
            .bind(Ipv4Addr::LOCALHOST.to_string(), opts.port)
            .start()
            .await
            .with_context(|| format!("cannot serve on 127.0.0.1:{}", opts.port))?;
        let from = match feed {
            Feed::Dds { .. } => "DDS",
            Feed::InProcess(_) => "the in-process link",
        };
        info!(
            "{}: ws://127.0.0.1:{} ({SUBPROTOCOL}) serves {state_name}, {force_name} (from {from}), {status_name}, {FRAME_TOPIC}",
            settings.describe(),
            server.port()
        );
        Ok(Bridge {
            feed,
            status_sub,
            actions,
            outputs,
            server,
            _node: node,
            _context: context,
        })
    }

    /// The port the server listens on.
    pub fn port(&self) -> u16 {
        self.server.port()
    }

    /// Serves until `stop` resolves (its error is the bridge's), then closes the clients'
    /// connections.
    pub async fn serve(self, stop: impl Future<Output = Result<()>>) -> Result<()> {
        let Bridge {
            feed,
            status_sub,
            actions,
            mut outputs,
            server,
            ..
        } = self;
        let mut action_tick = tokio::time::interval(ACTION_POLL);
        let statuses = status_sub.async_stream();
        tokio::pin!(statuses, stop);
        let out = &mut outputs;
        let stopped = match &feed {
            Feed::Dds {
                state_sub,
                force_sub,
            } => {
                let states = state_sub.async_stream();
                let forces = force_sub.async_stream();
                tokio::pin!(states, forces);
                loop {
                    tokio::select! {
                        stopped = &mut stop => break stopped,
                        msg = states.select_next_some() => match msg {
                            Ok((s, _)) => out.state(&s),
                            Err(e) => warn!("bad state sample: {e:?}"),
                        },
                        msg = forces.select_next_some() => match msg {
                            Ok((c, _)) => out.force(&c),
                            Err(e) => warn!("bad force command: {e:?}"),
                        },
                        msg = statuses.select_next_some() => match msg {
                            Ok((s, _)) => out.status(&s),
                            Err(e) => warn!("bad status: {e:?}"),
                        },
                        _ = action_tick.tick() => show_actions(&actions, out),
                    }
                }
            }
            Feed::InProcess(fed) => {
                let mut tick = tokio::time::interval(FEED_PERIOD);
                loop {
                    tokio::select! {
                        stopped = &mut stop => break stopped,
                        _ = tick.tick() => {
                            for (s, c) in fed.try_iter() {
                                out.state(&s);
                                if let Some(c) = c {
                                    out.force(&c);
                                }
                            }
                        },
                        msg = statuses.select_next_some() => match msg {
                            Ok((s, _)) => out.status(&s),
                            Err(e) => warn!("bad status: {e:?}"),
                        },
                        _ = action_tick.tick() => show_actions(&actions, out),
                    }
                }
            }
        };
        // close the clients' connections before leaving
        server.stop().wait().await;
        stopped
    }
}

/// How often the bridge takes the actions' feedback and statuses (20 Hz feedback; polled, as
/// four more streams in the select would be).
const ACTION_POLL: Duration = Duration::from_millis(20);

/// Shows what the action readers hold.
fn show_actions(actions: &ActionReaders, out: &mut Outputs) {
    let shown = actions.take(|sample, info| {
        out.action(&sample, info);
        Ok(())
    });
    if let Err(e) = shown {
        warn!("action topics: {e}");
    }
}

/// Says where the bridge serves, on stdout (`capsule_foxglove: serving ws://127.0.0.1:PORT`:
/// the line scripts wait for, with port 0 the only place the port is said).
pub fn announce(port: u16) {
    println!(
        "{}: serving ws://127.0.0.1:{port}",
        capsule_msgs::names::nodes::FOXGLOVE
    );
    let _ = std::io::stdout().flush();
}

/// Runs the bridge until SIGINT/SIGTERM (the `capsule_foxglove` binary).
pub async fn run(settings: RosOptions, opts: BridgeOptions) -> Result<()> {
    let bridge = Bridge::start(&settings, &opts, Source::Dds).await?;
    announce(bridge.port());
    bridge.serve(capsule_ros_base::signals::shutdown()).await
}

/// The bridge on a thread of its own with its own runtime, in a process that runs other nodes
/// (`capsule_container`): what it does never waits on, or delays, theirs.
pub struct BridgeThread {
    port: u16,
    stop: Option<tokio::sync::oneshot::Sender<()>>,
    thread: Option<std::thread::JoinHandle<Result<()>>>,
}

impl BridgeThread {
    /// Starts the bridge ([`Bridge::start`]) on its thread and waits until it serves; an error
    /// (a port taken) leaves nothing running.
    pub async fn spawn(
        settings: RosOptions,
        opts: BridgeOptions,
        source: Source,
    ) -> Result<BridgeThread> {
        let (started_tx, started) = tokio::sync::oneshot::channel();
        let (stop, stopped) = tokio::sync::oneshot::channel::<()>();
        let thread = std::thread::Builder::new()
            .name(capsule_msgs::names::nodes::FOXGLOVE.into())
            .spawn(move || -> Result<()> {
                let rt = tokio::runtime::Builder::new_current_thread()
                    .enable_all()
                    .build()
                    .context("cannot start the bridge's runtime");
                let rt = match rt {
                    Ok(rt) => rt,
                    Err(e) => {
                        let _ = started_tx.send(Err(e));
                        return Ok(());
                    }
                };
                rt.block_on(async move {
                    let bridge = match Bridge::start(&settings, &opts, source).await {
                        Ok(b) => b,
                        Err(e) => {
                            let _ = started_tx.send(Err(e));
                            return Ok(());
                        }
                    };
                    let _ = started_tx.send(Ok(bridge.port()));
                    // stopped, or the owner gone: either way the end
                    bridge
                        .serve(async move {
                            let _ = stopped.await;
                            Ok(())
                        })
                        .await
                })
            })
            .context("cannot start the bridge's thread")?;
        let started = started.await;
        match started {
            Ok(Ok(port)) => Ok(BridgeThread {
                port,
                stop: Some(stop),
                thread: Some(thread),
            }),
            Ok(Err(e)) => {
                let _ = thread.join();
                Err(e)
            }
            Err(_) => {
                let _ = thread.join();
                bail!("the bridge's thread ended before it served (it panicked)")
            }
        }
    }

    /// The port the bridge serves on.
    pub fn port(&self) -> u16 {
        self.port
    }

    /// Stops the bridge and waits for its thread; its error, or its panic, is the result.
    pub fn stop(mut self) -> Result<()> {
        self.end()
    }

    fn end(&mut self) -> Result<()> {
        if let Some(stop) = self.stop.take() {
            let _ = stop.send(());
        }
        match self.thread.take().map(std::thread::JoinHandle::join) {
            None | Some(Ok(Ok(()))) => Ok(()),
            Some(Ok(Err(e))) => Err(e),
            Some(Err(_)) => bail!("the bridge panicked"),
        }
    }
}

impl Drop for BridgeThread {
    /// Stops the bridge if [`BridgeThread::stop`] was not called (an error on the way out).
    fn drop(&mut self) {
        if let Err(e) = self.end() {
            warn!("{}: {e}", capsule_msgs::names::nodes::FOXGLOVE);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use capsule_msgs::Header;

    #[test]
    fn only_loopback_is_served() {
        assert_eq!(check_host("127.0.0.1").ok(), Some(Ipv4Addr::LOCALHOST));
        assert_eq!(check_host("localhost").ok(), Some(Ipv4Addr::LOCALHOST));
        for bad in ["0.0.0.0", "192.168.1.2", "::", "example.org", ""] {
            let e = check_host(bad).map(|_| ()).unwrap_err().to_string();
            assert!(e.contains("--host") && e.contains("127.0.0.1"), "{e}");
        }
    }

    #[test]
    fn feedback_json_has_the_fields_its_schema_names() {
        use capsule_msgs::actions::{FeedbackMessage, MoveFeedback, SwitchAttractorFeedback};
        let keys = |v: &serde_json::Value| {
            let mut k: Vec<String> = v
                .as_object()
                .map_or(vec![], |o| o.keys().cloned().collect());
            k.sort();
            k
        };
        let goal_id = [0xab; 16];
        let feedback = MoveFeedback {
            travelled_m: 0.004,
            remaining_m: -0.001,
            speed_m_per_s: 0.002,
            mode: 1,
        };
        let moved = action_json(
            &ActionSample::MoveFeedback(FeedbackMessage { goal_id, feedback }),
            1.5,
        );
        let feedback = SwitchAttractorFeedback {
            switch_state: 2,
            tries: 1,
            orbit_period: 3,
        };
        let switched = action_json(
            &ActionSample::SwitchFeedback(FeedbackMessage { goal_id, feedback }),
            2.0,
        );
        for (json, schema) in [
            (&moved, MOVE_FEEDBACK_SCHEMA),
            (&switched, SWITCH_FEEDBACK_SCHEMA),
        ] {
            let schema: serde_json::Value = serde_json::from_str(schema).unwrap_or_default();
            assert_eq!(keys(json), keys(&schema["properties"]), "{json}");
            assert_eq!(json["goal_id"], "ab".repeat(16));
        }
        assert_eq!(
            (moved["t"].as_f64(), moved["remaining_m"].as_f64()),
            (Some(1.5), Some(-0.001))
        );
        assert_eq!(moved["mode_name"], "FORWARD");
        assert_eq!(
            (
                switched["tries"].as_i64(),
                switched["orbit_period"].as_i64()
            ),
            (Some(1), Some(3))
        );
    }

    #[test]
    fn json_maps_the_sample() {
        let s = CapsuleState {
            header: Header {
                stamp: Time::from_secs_f64(2.25),
                frame_id: "odom".into(),
            },
            seq: 7,
            mass_position: 0.003,
            mass_velocity: 0.02,
            capsule_position: 0.001,
            capsule_velocity: 0.005,
            actuator_force: 0.15,
            ..CapsuleState::default()
        };
        let j = state_json(&s);
        assert_eq!(j["t"], 2.25);
        assert_eq!(j["x1"], 0.003);
        assert_eq!(j["x1_minus_x2"], 0.003 - 0.001);
        assert_eq!(j["y1_minus_y2"], 0.02 - 0.005);
        assert_eq!(j["force"], 0.15);
        let f = frame_json(&s);
        assert_eq!(f["timestamp"]["sec"], 2);
        assert_eq!(f["timestamp"]["nsec"], 250_000_000);
        assert_eq!(f["parent_frame_id"], "odom");
        assert_eq!(f["child_frame_id"], BODY_FRAME);
        assert_eq!(f["translation"]["x"], 0.001);
        let c = ActuatorForce {
            header: s.header.clone(),
            state_seq: 7,
            force: -0.5,
        };
        let j = force_json(&c);
        assert_eq!(
            (j["t"].as_f64(), j["state_seq"].as_u64()),
            (Some(2.25), Some(7))
        );
        assert_eq!(j["force"], -0.5);
        for schema in [
            STATE_SCHEMA,
            STATUS_SCHEMA,
            FRAME_SCHEMA,
            FORCE_SCHEMA,
            MOVE_FEEDBACK_SCHEMA,
            SWITCH_FEEDBACK_SCHEMA,
            GOAL_STATUS_SCHEMA,
        ] {
            let v: serde_json::Value = serde_json::from_str(schema).unwrap_or_default();
            assert!(v["title"].is_string(), "{schema}");
        }
    }

    #[test]
    fn thinning_follows_the_stamps() {
        let mut t = StampThinner::new(100.0);
        let ms = |k: i64| Time::from_nanos(k * 1_000_000);
        let passed: Vec<i64> = (0..35).filter(|&k| t.pass(ms(k))).collect();
        assert_eq!(passed, [0, 10, 20, 30]);
        // a restarted plant (time going back) starts afresh
        assert!(t.pass(ms(1)));
        let mut all = StampThinner::new(0.0);
        assert!((0..5).all(|k| all.pass(ms(k))));
    }
}

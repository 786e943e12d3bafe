//! The graph recorded inside the plant (`--record-dir`).

use std::time::{Duration, Instant};

use capsule_msgs::std_types::{Clock, DiagnosticArray};
use capsule_msgs::{ActuatorForce, CapsuleState, ControllerStatus};
use capsule_record::types::SetModeEvent;
use capsule_ros_base::error::{NodeError, Result};

use crate::action_readers::ActionReaders;
use crate::recorder::{drain_actions, drain_into, Channel, GraphRecording};

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

/// The graph recorded inside the plant: what it publishes (state, /clock, its /diagnostics) as
/// it publishes it,
/// every command as DDS delivered it, and the controller's status, service events and actions
/// from their own (low-rate) readers. The same file as `capsule_recorder` writes, without a
/// second process receiving every sample over the network (which costs that process, on this
/// machine, 5-10 us of kernel time per datagram).
pub struct InPlantRecording {
    pub(super) rec: GraphRecording,
    pub(super) status_sub: ros2_client::dds::Subscription<ControllerStatus>,
    pub(super) event_sub: ros2_client::dds::Subscription<SetModeEvent>,
    pub(super) actions: ActionReaders,
    pub(super) last_poll: Instant,
    /// Composed: the participant and node of the status and event readers (RustDDS does not
    /// deliver a writer's samples to a reader on its own participant, where the controller is).
    pub(super) _apart: Option<(ros2_client::dds::Context, ros2_client::dds::Node)>,
}

impl InPlantRecording {
    /// Records a published state sample and, if published with it, the clock.
    pub(super) fn published(&mut self, state: &CapsuleState, clock: Option<&Clock>) -> Result<()> {
        let now = capsule_record::writer::now_ns();
        if let Some(c) = clock {
            self.rec.write(Channel::Clock, c, now, now)?;
        }
        self.rec.write(Channel::State, state, now, now)
    }

    /// Records the diagnostics the plant just published (what went wrong, and when).
    pub(super) fn diagnostics(&mut self, d: &DiagnosticArray) -> Result<()> {
        let now = capsule_record::writer::now_ns();
        self.rec.write(Channel::Diagnostics, d, now, now)
    }

    /// Records a command as DDS delivered it (`info`), or as the in-process link did (now).
    pub(super) fn received(
        &mut self,
        cmd: &ActuatorForce,
        info: Option<&ros2_client::MessageInfo>,
    ) -> Result<()> {
        match info {
            Some(info) => self.rec.write_received(Channel::Force, cmd, info),
            None => {
                let now = capsule_record::writer::now_ns();
                self.rec.write(Channel::Force, cmd, now, now)
            }
        }
    }

    /// Every 10 ms: takes the controller's status and service events, closes the chunk when due.
    /// (A `take` on a DDS reader costs microseconds even when it is empty: not every sample.)
    pub(super) fn poll(&mut self) -> Result<()> {
        if self.last_poll.elapsed() < Duration::from_millis(10) {
            return Ok(());
        }
        self.last_poll = Instant::now();
        drain_into(&self.status_sub, &mut self.rec, Channel::Status)?;
        drain_into(&self.event_sub, &mut self.rec, Channel::ServiceEvent)?;
        drain_actions(&self.actions, &mut self.rec)?;
        self.rec.flush_if_due()
    }
}

impl InPlantRecording {
    /// Creates the file first (an unwritable place is an error before anything else starts).
    pub(super) fn create_file(
        r: &InPlantRecordOptions,
        settings: &capsule_ros_base::ros_options::RosOptions,
    ) -> Result<GraphRecording> {
        GraphRecording::create(
            &r.output,
            r.scene.clone(),
            settings,
            &r.controller_node,
            r.flush_period,
            r.bag,
        )
    }

    /// [`InPlantRecording::start`] with the readers on a participant of their own, named
    /// `<plant>_recording`: for a plant composed with its controller on one participant.
    pub(super) fn start_apart(
        rec: GraphRecording,
        r: &InPlantRecordOptions,
        settings: &capsule_ros_base::ros_options::RosOptions,
    ) -> Result<InPlantRecording> {
        let mut apart = settings.clone();
        apart.node_name = format!("{}_recording", settings.node_name);
        let context = apart.context()?;
        let (mut node, _graph) = apart.loop_node(&context)?;
        let mut recording = Self::start(rec, r, &context, &mut node, &apart)?;
        recording._apart = Some((context, node));
        Ok(recording)
    }

    /// Starts recording into `rec`: the readers of the controller's status, service events and
    /// actions.
    pub(super) fn start(
        rec: GraphRecording,
        r: &InPlantRecordOptions,
        context: &ros2_client::dds::Context,
        node: &mut ros2_client::dds::Node,
        settings: &capsule_ros_base::ros_options::RosOptions,
    ) -> Result<InPlantRecording> {
        use capsule_ros_base::{endpoints::subscribe, qos};
        // reliable, deep: status and service events are few and must all be kept
        let deep = qos::data().history(ros2_client::qos::History::KeepLast { depth: 1000 });
        let specs = crate::recorder::graph_topics(&r.controller_node);
        let [status_topic, event_topic] = [Channel::Status, Channel::ServiceEvent].map(|c| {
            let (name, ty, _, q) = &specs[c as usize];
            settings.topic(node, name, ty.clone(), q)
        });
        let (status_topic, event_topic) = (status_topic?, event_topic?);
        tracing::info!("recording the graph in-process to {}", r.output.display());
        Ok(InPlantRecording {
            rec,
            status_sub: subscribe(node, &status_topic, &deep)?,
            event_sub: subscribe(node, &event_topic, &qos::service_events())?,
            actions: ActionReaders::subscribe(context, node, settings, &r.controller_node, true)?,
            last_poll: Instant::now(),
            _apart: None,
        })
    }

    /// Ends the recording after a run that ended with `result`: the controller's last status
    /// and service events in, the file closed, also after an error of the run (a lock-step
    /// controller gone, the hardware): the recording then ends with the last sample. After an
    /// error of the recording itself the file is kept as far as it got.
    pub(super) fn finish(self, result: Result<()>) -> Result<()> {
        let mut rec = self.rec;
        if let Err(e @ NodeError::Record(_)) = result {
            return Err(rec.abandon(e));
        }
        let drained = drain_into(&self.status_sub, &mut rec, Channel::Status)
            .and_then(|_| drain_into(&self.event_sub, &mut rec, Channel::ServiceEvent))
            .and_then(|_| drain_actions(&self.actions, &mut rec));
        match drained {
            Ok(_) => {
                let report = rec.finish()?;
                let total: u64 = report.per_topic.values().sum();
                tracing::info!("recorded {total} messages to {}", report.path.display());
                result
            }
            Err(e) => Err(rec.abandon(e)),
        }
    }
}

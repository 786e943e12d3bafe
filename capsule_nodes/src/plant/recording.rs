//! The graph recorded inside the plant (`--record-dir`).

use std::time::{Duration, Instant};

use capsule_msgs::std_types::{Clock, DiagnosticArray};
use capsule_msgs::{ActuatorForce, CapsuleState, ControllerStatus};
use capsule_record::types::SetModeEvent;
use capsule_ros_base::error::Result;

use crate::recorder::{drain_into, Channel, GraphRecording};

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
/// every command as DDS delivered it, and the controller's status and service events from
/// their own (low-rate) readers. The same file as `capsule_recorder` writes, without a
/// second process receiving every sample over the network (which costs that process, on this
/// machine, 5-10 us of kernel time per datagram).
pub struct InPlantRecording {
    pub(super) rec: GraphRecording,
    pub(super) status_sub: ros2_client::Subscription<ControllerStatus>,
    pub(super) event_sub: ros2_client::Subscription<SetModeEvent>,
    pub(super) last_poll: Instant,
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

    /// Records a command as DDS delivered it.
    pub(super) fn received(
        &mut self,
        cmd: &ActuatorForce,
        info: &ros2_client::MessageInfo,
    ) -> Result<()> {
        self.rec.write_received(Channel::Force, cmd, info)
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
        self.rec.flush_if_due()
    }
}

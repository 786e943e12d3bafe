//! The plant's emergency stop: `~/emergency_stop` (`std_srvs/srv/SetBool`: true engages, false
//! releases) and the latched `capsule/emergency_stop` (`std_msgs/msg/Bool`, transient local: a
//! reader that joins later still sees it engaged). While engaged the plant applies zero force
//! from its next sample on, whatever the commands say; it stays engaged until released.
//!
//! Served by its own task, never by the sample loop; the loop reads one atomic flag per step,
//! and a device is sent a zero-force frame the moment the stop engages (whatever its loop is
//! doing: waiting for a hello, for a silent device, for a lock-step answer).

use std::sync::atomic::AtomicBool;
use std::sync::Arc;

use capsule_msgs::names::topics;
use capsule_msgs::std_types::Bool;
use capsule_ros_base::error::Result;
use capsule_ros_base::node_on::NodeOn;
use capsule_ros_base::{qos, ros_options::RosOptions, types};
use tracing::{info, warn};

use crate::flag_service::{serve_flag, FlagAnswers};
use capsule_hardware::Stopper;

/// What the stop answers, by what was asked and what it was.
pub const ANSWERS: FlagAnswers = FlagAnswers {
    set: "emergency stop engaged: zero force until released",
    already_set: "emergency stop already engaged",
    cleared: "emergency stop released: commands apply again",
    already_clear: "emergency stop was not engaged",
};

/// Starts serving the stop on the node `on` (DDS or Zenoh); `engaged` is the flag the sample loop reads, and
/// `stopper` (a device's) sends a zero-force frame at once, from a thread of the blocking pool,
/// so the answer never waits for it.
pub fn serve(
    mut on: NodeOn<'_>,
    settings: &RosOptions,
    engaged: Arc<AtomicBool>,
    stopper: Option<Stopper>,
) -> Result<()> {
    let state = on.publisher::<Bool>(
        settings,
        topics::EMERGENCY_STOP,
        types::bool(),
        &qos::latched(),
    )?;
    // the state from the start, so that a late reader knows the stop is released
    if let Err(e) = state.publish(Bool { data: false }) {
        warn!("emergency stop state not sent: {e}");
    }
    let state = Arc::new(state);
    serve_flag(
        on,
        settings,
        topics::EMERGENCY_STOP_SERVICE,
        ANSWERS,
        engaged,
        move |engage, resp| {
            if let Some(zero) = stopper.clone().filter(|_| engage) {
                tokio::task::spawn_blocking(move || zero());
            }
            if engage {
                warn!("{}", resp.message);
            } else {
                info!("{}", resp.message);
            }
            let state = state.clone();
            async move {
                if let Err(e) = state.async_publish(Bool { data: engage }).await {
                    warn!("emergency stop state not sent: {e}");
                }
            }
        },
    )
}

//! A lock-step plant's pause: `~/pause` (`std_srvs/srv/SetBool`: true pauses, false resumes),
//! and `--start-paused`. While paused the plant is active and answered as usual but takes no
//! step: it re-sends its sample and sim time stands still, as Gazebo's paused world does. A
//! client can then do something at a sample it knows (a Move goal accepted by the controller at
//! the held sample, for a lock-step run that repeats bit for bit), and resume.
//!
//! It holds a simulated plant's loop; a device keeps its own time and is not held (its loop
//! does not read the flag).
//!
//! Served by its own task, never by the sample loop; the loop reads one atomic flag per step and
//! is woken when the pause is released.

use std::sync::atomic::AtomicBool;
use std::sync::Arc;

use capsule_msgs::names::topics;
use capsule_ros_base::error::Result;
use capsule_ros_base::node_on::NodeOn;
use capsule_ros_base::ros_options::RosOptions;
use tokio::sync::Notify;
use tracing::info;

use crate::flag_service::{serve_flag, FlagAnswers};

/// Why `--start-paused` is refused in real time.
pub const NEEDS_LOCKSTEP: &str =
    "--start-paused needs lock-step pacing (a real-time plant keeps wall time)";

/// What the pause answers, by what was asked and what it was.
pub const ANSWERS: FlagAnswers = FlagAnswers {
    set: "paused: sim time stands still until resumed",
    already_set: "already paused",
    cleared: "resumed",
    already_clear: "was not paused",
};

/// Starts serving the pause on the node `on`; `paused` is the flag the sample loop reads,
/// `woken` wakes it.
pub fn serve(
    on: NodeOn<'_>,
    settings: &RosOptions,
    paused: Arc<AtomicBool>,
    woken: Arc<Notify>,
) -> Result<()> {
    serve_flag(
        on,
        settings,
        topics::PAUSE_SERVICE,
        ANSWERS,
        paused,
        move |_, resp| {
            woken.notify_one();
            info!("{}", resp.message);
            std::future::ready(())
        },
    )
}

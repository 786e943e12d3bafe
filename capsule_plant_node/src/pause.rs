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

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;

use capsule_msgs::names::topics;
use capsule_msgs::std_types::{SetBoolRequest, SetBoolResponse};
use capsule_ros_base::error::Result;
use capsule_ros_base::graph::Graph;
use capsule_ros_base::{endpoints::Wire, ros_options::RosOptions, types};
use futures::StreamExt;
use ros2_client::dds::Node;
use tokio::sync::Notify;
use tracing::{info, warn};

/// The answer to a request to set the pause to `pause` when it was `was`.
pub fn answer(pause: bool, was: bool) -> SetBoolResponse {
    let message = match (pause, was) {
        (true, false) => "paused: sim time stands still until resumed",
        (true, true) => "already paused",
        (false, true) => "resumed",
        (false, false) => "was not paused",
    };
    SetBoolResponse {
        success: true,
        message: message.to_string(),
    }
}

/// Starts serving the pause on `node`; `paused` is the flag the sample loop reads, `woken` wakes
/// it.
pub fn serve(
    node: &mut Node,
    graph: &Graph,
    settings: &RosOptions,
    paused: Arc<AtomicBool>,
    woken: Arc<Notify>,
) -> Result<()> {
    let server = settings.server::<Wire<SetBoolRequest>, Wire<SetBoolResponse>>(
        node,
        graph,
        topics::PAUSE_SERVICE,
        &types::set_bool(),
    )?;
    tokio::spawn(async move {
        let mut requests = server.requests();
        while let Some(rq) = requests.next().await {
            let (id, Wire(req)) = match rq {
                Ok(r) => r,
                Err(e) => {
                    warn!("undecodable pause request: {e:?}");
                    continue;
                }
            };
            let was = paused.swap(req.data, Ordering::SeqCst);
            woken.notify_one();
            let resp = answer(req.data, was);
            info!("{}", resp.message);
            server.answer(id, Wire(resp));
        }
    });
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn answers_say_what_changed() {
        assert!(answer(true, false).message.starts_with("paused"));
        assert!(answer(true, true).message.contains("already"));
        assert_eq!(answer(false, true).message, "resumed");
        assert!(answer(false, false).message.contains("was not"));
    }
}

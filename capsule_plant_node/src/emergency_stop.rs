//! The plant's emergency stop: `~/emergency_stop` (`std_srvs/srv/SetBool`: true engages, false
//! releases) and the latched `capsule/emergency_stop` (`std_msgs/msg/Bool`, transient local: a
//! reader that joins later still sees it engaged). While engaged the plant applies zero force
//! from its next sample on, whatever the commands say; it stays engaged until released.
//!
//! Served by its own task, never by the sample loop; the loop reads one atomic flag per step,
//! and a device is sent a zero-force frame the moment the stop engages (whatever its loop is
//! doing: waiting for a hello, for a silent device, for a lock-step answer).

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;

use capsule_msgs::names::topics;
use capsule_msgs::std_types::{Bool, SetBoolRequest, SetBoolResponse};
use capsule_ros_base::error::{Context as _, Result};
use capsule_ros_base::graph::Graph;
use capsule_ros_base::{endpoints::Wire, qos, ros_options::RosOptions, types};
use futures::StreamExt;
use ros2_client::dds::Node;
use tracing::{info, warn};

use capsule_hardware::Stopper;

/// The answer to a request to set the stop to `engage` when it was `was`.
pub fn answer(engage: bool, was: bool) -> SetBoolResponse {
    let message = match (engage, was) {
        (true, false) => "emergency stop engaged: zero force until released",
        (true, true) => "emergency stop already engaged",
        (false, true) => "emergency stop released: commands apply again",
        (false, false) => "emergency stop was not engaged",
    };
    SetBoolResponse {
        success: true,
        message: message.to_string(),
    }
}

/// Starts serving the stop on `node`; `engaged` is the flag the sample loop reads, and
/// `stopper` (a device's) sends a zero-force frame at once, from a thread of the blocking pool,
/// so the answer never waits for it.
pub fn serve(
    node: &mut Node,
    graph: &Graph,
    settings: &RosOptions,
    engaged: Arc<AtomicBool>,
    stopper: Option<Stopper>,
) -> Result<()> {
    let server = settings.server::<Wire<SetBoolRequest>, Wire<SetBoolResponse>>(
        node,
        graph,
        topics::EMERGENCY_STOP_SERVICE,
        &types::set_bool(),
    )?;
    let topic = settings.topic(node, topics::EMERGENCY_STOP, types::bool(), &qos::latched())?;
    let state = node
        .create_publisher::<Bool>(&topic, None)
        .context("emergency_stop publisher")?;
    // the state from the start, so that a late reader knows the stop is released
    if let Err(e) = state.publish(Bool { data: false }) {
        warn!("emergency stop state not sent: {e:?}");
    }
    tokio::spawn(async move {
        let mut requests = server.requests();
        while let Some(rq) = requests.next().await {
            let (id, Wire(req)) = match rq {
                Ok(r) => r,
                Err(e) => {
                    warn!("undecodable emergency_stop request: {e:?}");
                    continue;
                }
            };
            let was = engaged.swap(req.data, Ordering::SeqCst);
            if let Some(zero) = stopper.clone().filter(|_| req.data) {
                tokio::task::spawn_blocking(move || zero());
            }
            let resp = answer(req.data, was);
            if req.data {
                warn!("{}", resp.message);
            } else {
                info!("{}", resp.message);
            }
            if let Err(e) = state.async_publish(Bool { data: req.data }).await {
                warn!("emergency stop state not sent: {e:?}");
            }
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
        assert!(answer(true, false).message.contains("engaged: zero force"));
        assert!(answer(true, true).message.contains("already engaged"));
        assert!(answer(false, true).message.contains("released"));
        assert!(answer(false, false).message.contains("was not engaged"));
        assert!(answer(false, false).success);
    }
}

//! The controller on Zenoh (rmw_zenoh_cpp's protocol, through ros2-client's Zenoh backend), its
//! core interface first: the state in, the force command out, `~/set_mode` served, `~/status`
//! on every change and every status period; the same [`ControllerCore`] as on DDS. What is not
//! ported yet is refused by name before any work (`/diagnostics`, `--use-sim-time`); the
//! parameters, the actions and the set_mode service events are not served on Zenoh yet, which
//! the log says at start.

use std::time::Instant;

use capsule_msgs::names::topics;
use capsule_msgs::{
    ActuatorForce, CapsuleState, ControllerStatus, SetModeRequest, SetModeResponse,
};
use capsule_ros_base::endpoints::Wire;
use capsule_ros_base::error::{Context as _, Result};
use capsule_ros_base::{qos, ros_options::RosOptions, types};
use ros2_client::zenoh::{Node, Publisher, Server, Subscription};
use ros2_client::RmwRequestId;
use tracing::{info, warn};

use crate::controller_core::ControllerCore;

/// The wall clock as ROS time (no `/clock` on Zenoh yet).
fn now() -> capsule_msgs::Time {
    capsule_msgs::Time::from_nanos(capsule_record::writer::now_ns() as i64)
}

/// The controller's endpoints on Zenoh.
struct Endpoints {
    states: Subscription<CapsuleState>,
    force: Publisher<ActuatorForce>,
    status: Publisher<ControllerStatus>,
    server: Server<Wire<SetModeRequest>, Wire<SetModeResponse>>,
}

impl Endpoints {
    /// The state subscription, the force and status publishers and the set_mode server of
    /// `node`, named as on DDS.
    fn create(settings: &RosOptions, node: &Node) -> Result<Endpoints> {
        let topic = |name: &str, type_name| -> Result<_> {
            Ok(node.create_topic(&settings.ros_name(name)?, type_name, &qos::data()))
        };
        Ok(Endpoints {
            states: node
                .create_subscription(
                    &topic(topics::STATE, types::state())?,
                    Some(qos::data_reader()),
                )
                .context("state subscription on Zenoh")?,
            force: node
                .create_publisher(&topic(topics::FORCE, types::force())?, None)
                .context("force publisher on Zenoh")?,
            status: node
                .create_publisher(&topic(topics::STATUS, types::status())?, None)
                .context("status publisher on Zenoh")?,
            server: node
                .create_server(&settings.ros_name(topics::SET_MODE)?, &types::set_mode())
                .context("set_mode service on Zenoh")?,
        })
    }

    /// A state sample: the command sent; whether an attractor-switch event asks for a status.
    async fn on_state(&self, core: &mut ControllerCore, state: &CapsuleState, now: f64) -> bool {
        let Some(cmd) = core.on_state(state, now) else {
            return false;
        };
        if let Err(e) = self.force.async_publish(cmd).await {
            warn!("command not sent: {e:?}");
        }
        core.take_switch_event()
    }

    /// A set_mode request: the core's answer sent back.
    fn on_request(&self, core: &mut ControllerCore, id: RmwRequestId, req: &SetModeRequest) {
        let resp = core.set_mode(req);
        info!(
            "set_mode (mode {}): accepted {} ({})",
            req.mode, resp.accepted, resp.reason
        );
        if let Err(e) = self.server.send_response(id, Wire(resp)) {
            warn!("set_mode response not sent: {e:?}");
        }
    }
}

/// Runs the controller on Zenoh until SIGINT/SIGTERM: `core` answers, its status every
/// `status_period`; `diagnostics` (asked for) is refused.
pub(crate) async fn run(
    settings: RosOptions,
    mut core: ControllerCore,
    status_period: std::time::Duration,
    diagnostics: bool,
) -> Result<()> {
    let mw = &settings.middleware;
    if diagnostics {
        mw.refuse_on_zenoh("the controller's /diagnostics")?;
    }
    if settings.use_sim_time {
        mw.refuse_on_zenoh("the controller's --use-sim-time")?;
    }
    let context = settings.zenoh_context()?;
    let node = settings.zenoh_node(&context)?;
    let io = Endpoints::create(&settings, &node)?;
    info!(
        "{}: state {} -> force {}, status {}, service {}; {} k_p = {}; not on Zenoh yet: \
         parameters, actions, set_mode service events",
        settings.describe(),
        settings.resolve_name(topics::STATE),
        settings.resolve_name(topics::FORCE),
        settings.resolve_name(topics::STATUS),
        settings.resolve_name(topics::SET_MODE),
        core.mode(),
        core.law().kp
    );
    let start = Instant::now();
    let steady = || start.elapsed().as_secs_f64();
    let mut tick = tokio::time::interval(status_period);
    tick.set_missed_tick_behavior(tokio::time::MissedTickBehavior::Delay);
    let end = capsule_ros_base::signals::shutdown();
    tokio::pin!(end);
    loop {
        let report = tokio::select! {
            stopped = &mut end => return stopped,
            state = io.states.async_take() => match state {
                Ok((state, _)) => io.on_state(&mut core, &state, steady()).await,
                Err(e) => {
                    warn!("bad state sample: {e:?}");
                    false
                }
            },
            request = io.server.async_receive_request() => match request {
                Ok((id, Wire(req))) => {
                    io.on_request(&mut core, id, &req);
                    true
                }
                Err(e) => {
                    warn!("bad set_mode request: {e:?}");
                    false
                }
            },
            _ = tick.tick() => {
                if core.check_stale(steady()) {
                    warn!("state stale (no sample for the timeout; plant gone?): stopped commanding");
                }
                true
            }
        };
        if report {
            if let Err(e) = io.status.async_publish(core.status(now())).await {
                warn!("status not sent: {e:?}");
            }
        }
    }
}

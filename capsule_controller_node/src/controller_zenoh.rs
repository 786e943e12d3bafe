//! The controller on Zenoh (rmw_zenoh_cpp's protocol, through ros2-client's Zenoh backend), its
//! core interface first: the state in, the force command out, `~/set_mode` served, `~/status`
//! on every change and every status period, `/diagnostics` at 1 Hz (unless `--no-diagnostics`);
//! the same [`ControllerCore`] as on DDS. What is not ported yet is refused by name before any
//! work (`--use-sim-time`); the parameters, the actions and the set_mode service events are not
//! served on Zenoh yet, which the log says at start.

use std::time::{Duration, Instant};

use capsule_msgs::names::topics::{self, views};
use capsule_msgs::std_types::DiagnosticArray;
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
use crate::controller_diagnostics::ControllerDiag;

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
    /// `/diagnostics` (`None`: `--no-diagnostics`), its counters and when it is next due.
    diagnostics: Option<(Publisher<DiagnosticArray>, ControllerDiag, Instant)>,
}

impl Endpoints {
    /// The state subscription, the force and status publishers and the set_mode server of
    /// `node`, named as on DDS.
    fn create(settings: &RosOptions, node: &Node, diagnostics: bool) -> Result<Endpoints> {
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
            diagnostics: match diagnostics {
                true => Some((
                    node.create_publisher(&topic(views::DIAGNOSTICS, types::diagnostics())?, None)
                        .context("/diagnostics publisher on Zenoh")?,
                    ControllerDiag::default(),
                    Instant::now(),
                )),
                false => None,
            },
        })
    }

    /// `/diagnostics` when due (every second): the core's status as a one-status array.
    async fn diagnose(&mut self, settings: &RosOptions, core: &ControllerCore) {
        let Some((publisher, diag, next)) = self.diagnostics.as_mut() else {
            return;
        };
        if Instant::now() < *next {
            return;
        }
        *next = Instant::now() + Duration::from_secs(1);
        let array = DiagnosticArray {
            header: capsule_msgs::Header {
                stamp: now(),
                frame_id: String::new(),
            },
            status: vec![diag.status(&settings.node_name, core)],
        };
        if let Err(e) = publisher.async_publish(array).await {
            warn!("/diagnostics not sent: {e:?}");
        }
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
/// `status_period`, `/diagnostics` every second if `diagnostics`.
pub(crate) async fn run(
    settings: RosOptions,
    mut core: ControllerCore,
    status_period: std::time::Duration,
    diagnostics: bool,
) -> Result<()> {
    if settings.use_sim_time {
        let mw = &settings.middleware;
        mw.refuse_on_zenoh("the controller's --use-sim-time")?;
    }
    let context = settings.zenoh_context()?;
    let node = settings.zenoh_node(&context)?;
    let mut io = Endpoints::create(&settings, &node, diagnostics)?;
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
                io.diagnose(&settings, &core).await;
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

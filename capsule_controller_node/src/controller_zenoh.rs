//! The controller on Zenoh (rmw_zenoh_cpp's protocol, through ros2-client's Zenoh backend): the
//! state in, the force command out, `~/set_mode` served, `~/status` on every change and every
//! status period, `/diagnostics` at 1 Hz (unless `--no-diagnostics`), and the `~/move` and
//! `~/switch_attractor` actions ([`ControllerActions`], the same goal handling as on DDS, on a
//! task beside the loop); the same [`ControllerCore`] as on DDS. What is not ported yet is
//! refused by name before any work (`--use-sim-time`); the parameters are served as on DDS (the
//! same table and rules, [`capsule_ros_base::param_services::serve_on_zenoh`]); the services'
//! events are not served on Zenoh yet, which the log says at start.

use std::sync::{Arc, Mutex, MutexGuard};
use std::time::{Duration, Instant};

use capsule_msgs::names::topics::{self, views};
use capsule_msgs::std_types::DiagnosticArray;
use capsule_msgs::{
    ActuatorForce, CapsuleState, ControllerStatus, SetModeRequest, SetModeResponse,
};
use capsule_ros_base::endpoints::Wire;
use capsule_ros_base::error::{Context as _, Result};
use capsule_ros_base::{params::ParamTable, qos, ros_options::RosOptions, types};
use ros2_client::zenoh::{Node, Publisher, Server, Subscription};
use ros2_client::RmwRequestId;
use tokio::sync::mpsc::UnboundedReceiver;
use tracing::{info, warn};

use crate::controller_actions::{ControllerActions, CoreAccess};
use crate::controller_core::ControllerCore;
use crate::controller_diagnostics::ControllerDiag;
use crate::controller_options::ControllerOptions;
use crate::controller_params::{self, LiveSync};

/// The wall clock as ROS time (no `/clock` on Zenoh yet).
fn now() -> capsule_msgs::Time {
    capsule_msgs::Time::from_nanos(capsule_record::writer::now_ns() as i64)
}

/// The core, shared by the loop and the actions' task.
#[derive(Clone)]
struct SharedCore(Arc<Mutex<ControllerCore>>);

impl SharedCore {
    /// The core (a panic elsewhere leaves it usable: its state is whole after every call).
    fn lock(&self) -> MutexGuard<'_, ControllerCore> {
        self.0
            .lock()
            .unwrap_or_else(|poisoned| poisoned.into_inner())
    }
}

impl CoreAccess for SharedCore {
    fn with_core<T>(&self, f: impl FnOnce(&mut ControllerCore) -> T) -> T {
        f(&mut self.lock())
    }
    fn now(&self) -> capsule_msgs::Time {
        now()
    }
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
    async fn diagnose(&mut self, settings: &RosOptions, core: &SharedCore) {
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
            status: vec![diag.status(&settings.node_name, &core.lock())],
        };
        if let Err(e) = publisher.async_publish(array).await {
            warn!("/diagnostics not sent: {e:?}");
        }
    }

    /// A state sample: the command sent; whether an attractor-switch event asks for a status.
    async fn on_state(&self, core: &SharedCore, state: &CapsuleState, now: f64) -> bool {
        let Some(cmd) = core.lock().on_state(state, now) else {
            return false;
        };
        if let Err(e) = self.force.async_publish(cmd).await {
            warn!("command not sent: {e:?}");
        }
        core.lock().take_switch_event()
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
pub(crate) async fn run(settings: RosOptions, opts: ControllerOptions) -> Result<()> {
    let ControllerOptions {
        core,
        status_period,
        params,
        diagnostics,
        ..
    } = opts;
    if settings.use_sim_time {
        let mw = &settings.middleware;
        mw.refuse_on_zenoh("the controller's --use-sim-time")?;
    }
    let context = settings.zenoh_context()?;
    let node = settings.zenoh_node(&context)?;
    let mut io = Endpoints::create(&settings, &node, diagnostics)?;
    let actions = ControllerActions::on_zenoh(&settings, &node)?;
    let (handle, applied) = capsule_ros_base::param_services::serve_on_zenoh(
        &node,
        &settings,
        params,
        controller_params::rules,
        now,
    )?;
    let sync = LiveSync::new(handle, &core);
    info!(
        "{}: state {} -> force {}, status {}, service {}, actions {} and {}, parameters; {} k_p \
         = {}; not on Zenoh yet: service events",
        settings.describe(),
        settings.resolve_name(topics::STATE),
        settings.resolve_name(topics::FORCE),
        settings.resolve_name(topics::STATUS),
        settings.resolve_name(topics::SET_MODE),
        settings.resolve_name(topics::MOVE),
        settings.resolve_name(topics::SWITCH_ATTRACTOR),
        core.mode(),
        core.law().kp
    );
    let core = SharedCore(Arc::new(Mutex::new(core)));
    let actions = tokio::spawn(actions.run(core.clone()));
    let params = (sync, applied);
    let stopped = serve(&settings, &mut io, &core, params, status_period).await;
    actions.abort();
    stopped
}

/// Each input to the core (accepted parameter sets too, the core's own changes back to the
/// parameters), until SIGINT/SIGTERM.
async fn serve(
    settings: &RosOptions,
    io: &mut Endpoints,
    core: &SharedCore,
    (mut sync, mut applied): (LiveSync, UnboundedReceiver<ParamTable>),
    status_period: Duration,
) -> Result<()> {
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
                Ok((state, _)) => io.on_state(core, &state, steady()).await,
                Err(e) => {
                    warn!("bad state sample: {e:?}");
                    false
                }
            },
            request = io.server.async_receive_request() => match request {
                Ok((id, Wire(req))) => {
                    io.on_request(&mut core.lock(), id, &req);
                    true
                }
                Err(e) => {
                    warn!("bad set_mode request: {e:?}");
                    false
                }
            },
            Some(table) = applied.recv() => {
                sync.applied(&table, &mut core.lock());
                true
            }
            _ = tick.tick() => {
                if core.lock().check_stale(steady()) {
                    warn!("state stale (no sample for the timeout; plant gone?): stopped commanding");
                }
                io.diagnose(settings, core).await;
                true
            }
        };
        if report {
            let status = {
                let core = core.lock();
                sync.push(&core);
                core.status(now())
            };
            if let Err(e) = io.status.async_publish(status).await {
                warn!("status not sent: {e:?}");
            }
        }
    }
}

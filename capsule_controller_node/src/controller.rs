//! The controller node on DDS, in the phases of its life ([`NodeLife`], the skeleton both nodes
//! share): build (its endpoints, the clock, the parameters and their services, the handlers;
//! composed, its end of the in-process link), wait for the graph (nothing to wait for), run the
//! loop (each input to its handler, until SIGINT/SIGTERM or, composed, the plant's end), finish
//! (the commands' DDS copies counted).
//!
//! The decisions are [`ControllerCore`]'s ([`crate::controller_core`]); what the loop does with
//! each input apart from DDS is `controller_handlers`' (the core, the parameter sync,
//! which plant it serves, the logs); the inputs (state samples, mode requests, accepted
//! parameter sets) and the outputs (commands, status, service events, diagnostics) are the DDS
//! side, `controller_endpoints`. State and commands come and go over DDS or, composed
//! with the plant in one process, over the in-process link
//! ([`capsule_plant_node::intra_process`]): there the plant's loop calls the same handler on its
//! own thread, and the commands' DDS copies leave from a publisher thread. [`run_in`] takes the
//! transport from outside.
//!
//! Status messages are stamped with the node's ROS time (sim time under `use_sim_time`); the
//! stale-state watchdog runs on a steady clock, because sim time stops when the plant does.

use std::future::Future;
use std::sync::{Arc, Mutex};
use std::time::Duration;

use capsule_msgs::names::topics;
use capsule_plant_node::intra_process::{CopyCounts, Transport};
use capsule_ros_base::error::Result;
use capsule_ros_base::node_life::{self, NodeLife, Seat};
use capsule_ros_base::{clock::RosClock, ros_options::RosOptions};
use futures::StreamExt;
use ros2_client::dds::{Context, Node};
use tracing::{info, warn};

pub use crate::controller_options::ControllerOptions;

use crate::controller_actions::{ControllerActions, CoreAccess};
use crate::controller_core::ControllerCore;
use crate::controller_endpoints::{Inputs, Outputs};
use crate::controller_handlers::{lock, Handlers};
use crate::controller_params;
use capsule_ros_base::endpoints::Wire;

/// Runs the controller node on DDS (on Zenoh if `RMW_IMPLEMENTATION` asks: `controller_zenoh`),
/// in a participant of its own, until SIGINT/SIGTERM.
pub async fn run(settings: RosOptions, opts: ControllerOptions) -> Result<()> {
    #[cfg(feature = "zenoh")]
    if settings.middleware.is_zenoh() {
        return crate::controller_zenoh::run(settings, opts).await;
    }
    let end = capsule_ros_base::signals::shutdown();
    let node = ControllerNode {
        settings,
        opts,
        transport: Transport::Dds,
        end,
    };
    node_life::live(node, None).await
}

/// [`run`] in the participant of `context` (a composed process's), with state and force over
/// `transport`, until `end` resolves (its error is the run's).
pub async fn run_in(
    context: &Context,
    settings: RosOptions,
    opts: ControllerOptions,
    transport: Transport,
    end: impl Future<Output = Result<()>>,
) -> Result<()> {
    let node = ControllerNode {
        settings,
        opts,
        transport,
        end,
    };
    node_life::live(node, Some(context)).await
}

/// The controller node as asked for: what [`node_life::live`] builds and runs until `end`.
struct ControllerNode<E> {
    settings: RosOptions,
    opts: ControllerOptions,
    transport: Transport,
    end: E,
}

/// What the built node holds while it runs.
struct Built<E> {
    /// The participant's context and the node, kept until the finish.
    seat: (Context, Node),
    inputs: Inputs,
    outputs: Outputs,
    /// The Move and SwitchAttractor action servers, run beside the loop.
    actions: ControllerActions,
    handlers: Arc<Mutex<Handlers>>,
    /// In-process: what becomes of the commands' DDS copies.
    copies: Option<Arc<CopyCounts>>,
    status_period: Duration,
    end: E,
}

/// What the loop leaves to finish.
struct Ended {
    /// How the loop ended (`end`'s error, if any).
    stopped: Result<()>,
    seat: (Context, Node),
    /// The outputs and handlers, kept until the node has gone (as they were built).
    kept: (Outputs, Arc<Mutex<Handlers>>),
    copies: Option<Arc<CopyCounts>>,
}

impl<E: Future<Output = Result<()>>> NodeLife for ControllerNode<E> {
    type Built = Built<E>;
    type Ended = Ended;
    type Outcome = ();

    /// Build: the node, its clock, its outputs, the parameters and their services, its inputs,
    /// the handlers; composed, the handler the plant's loop calls.
    fn build(self, context: Option<&Context>) -> Result<Built<E>> {
        let ControllerNode {
            settings,
            opts,
            transport,
            end,
        } = self;
        let Seat {
            context,
            mut node,
            graph,
            ..
        } = Seat::take(context, &settings)?;
        let clock = RosClock::new(&settings, &mut node)?;
        let mut outputs = Outputs::build(&settings, &mut node, graph.clone(), opts.diagnostics)?;
        let (handle, applied) = capsule_ros_base::param_services::serve(
            &context,
            &mut node,
            &graph,
            &settings,
            opts.params,
            controller_params::rules,
            {
                let clock = clock.clone();
                move || clock.now()
            },
        )?;
        let in_process = matches!(transport, Transport::InProcess(_));
        let mut inputs = Inputs::build(&settings, &mut node, &graph, applied, in_process)?;
        let actions = ControllerActions::build(
            (&settings, &context),
            &mut node,
            &graph,
            &clock,
            opts.action_introspection,
        )?;
        let handlers = Arc::new(Mutex::new(Handlers::new(
            opts.core, handle, clock, &settings,
        )));
        let mut copies = None;
        if let Transport::InProcess(link) = transport {
            let (answer, counts) = outputs.in_process(&settings, graph, &handlers)?;
            link.attach(answer)?;
            copies = Some(counts);
        }
        announce(&settings, &handlers);
        if let Some(rx) = outputs.switch_status.take() {
            inputs.switch_status = Some(rx);
        }
        Ok(Built {
            seat: (context, node),
            inputs,
            outputs,
            actions,
            handlers,
            copies,
            status_period: opts.status_period,
            end,
        })
    }

    /// Wait for the graph: nothing to wait for. The controller answers each state as it comes;
    /// a plant that needs it before its first sample waits for it (`--wait-subscribers`).
    async fn wait_for_graph(_: &Built<E>) -> Result<()> {
        Ok(())
    }

    /// Run the loop: each input to its handler, until `end`; the action servers beside it.
    async fn run_loop(built: Built<E>) -> Result<Ended> {
        let Built {
            seat,
            inputs,
            mut outputs,
            actions,
            handlers,
            copies,
            status_period,
            end,
        } = built;
        let actions = tokio::spawn(actions.run(NodeCore(handlers.clone())));
        let stopped = serve(inputs, &mut outputs, &handlers, status_period, end).await;
        actions.abort();
        Ok(Ended {
            stopped,
            seat,
            kept: (outputs, handlers),
            copies,
        })
    }

    /// Finish: the commands' DDS copies counted; the node goes, then its endpoints and its
    /// participant.
    async fn finish(ended: Ended) -> Result<()> {
        let Ended {
            stopped,
            seat: (context, node),
            kept: (outputs, handlers),
            copies,
        } = ended;
        if let Some(c) = copies {
            info!("force's DDS copies: {}", c.describe());
        }
        drop(node);
        drop(handlers);
        drop(outputs);
        drop(context);
        stopped
    }
}

/// The actions' hook into the node: its core and its ROS time, through the handlers.
struct NodeCore(Arc<Mutex<Handlers>>);

impl CoreAccess for NodeCore {
    fn with_core<T>(&self, f: impl FnOnce(&mut ControllerCore) -> T) -> T {
        f(&mut lock(&self.0).core)
    }
    fn now(&self) -> capsule_msgs::Time {
        lock(&self.0).clock.now()
    }
}

/// One line for the log: where the controller talks, its mode and gain.
fn announce(settings: &RosOptions, handlers: &Mutex<Handlers>) {
    let h = lock(handlers);
    info!(
        "{}: state {} -> force {}, status {}, service {}; {} k_p = {}",
        settings.describe(),
        settings.resolve_name(topics::STATE),
        settings.resolve_name(topics::FORCE),
        settings.resolve_name(topics::STATUS),
        settings.resolve_name(topics::SET_MODE),
        h.core.mode(),
        h.core.law().kp
    );
}

/// Each input to its handler, until `end`.
async fn serve(
    inputs: Inputs,
    out: &mut Outputs,
    h: &Mutex<Handlers>,
    status_period: Duration,
    end: impl std::future::Future<Output = Result<()>>,
) -> Result<()> {
    let Inputs {
        states,
        switch_status,
        server,
        mut applied,
    } = inputs;
    // in-process, no state comes here (the plant's loop calls the handler)
    let states = match &states {
        Some(sub) => sub.async_stream().left_stream(),
        None => futures::stream::pending().fuse().right_stream(),
    };
    tokio::pin!(states);
    let mut switch_status = switch_status;
    let mut requests = server.requests();
    let mut tick = tokio::time::interval(status_period);
    tick.set_missed_tick_behavior(tokio::time::MissedTickBehavior::Delay);
    tokio::pin!(end);
    loop {
        tokio::select! {
            stopped = &mut end => break stopped?,
            msg = states.select_next_some() => match msg {
                Ok((state, info)) => out.answer_state(h, &state, info.publisher_gid()).await,
                Err(e) => warn!("bad state sample: {e:?}"),
            },
            Some(st) = async { switch_status.as_mut()?.recv().await } => {
                if let Err(e) = out.status.async_publish(st).await {
                    warn!("status not sent: {e:?}");
                }
            }
            req = requests.select_next_some() => match req {
                Ok((id, Wire(req))) => out.answer_request(h, &server, id, req).await,
                Err(e) => warn!("bad set_mode request: {e:?}"),
            },
            Some(table) = applied.recv() => {
                let status = {
                    let mut guard = lock(h);
                    let g = &mut *guard;
                    g.params.applied(&table, &mut g.core);
                    g.status()
                };
                let _ = out.status.async_publish(status).await;
            }
            _ = tick.tick() => out.tick(h).await,
        }
    }
    Ok(())
}

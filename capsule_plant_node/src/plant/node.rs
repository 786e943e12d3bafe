//! The plant node on DDS, in the phases of its life ([`NodeLife`], the skeleton both nodes
//! share): build (recording file, endpoints,
//! services), wait for the graph, run the sample loop on a thread of its own (the node's thread
//! only serves: the emergency stop, the parameters, the lifecycle), finish (statistics, the
//! recording).
//!
//! The state and force transport is [`Endpoints`] (DDS, or in-process when composed with the
//! controller: [`run_in`] takes it from outside); the loop takes everything else through
//! [`LoopControl`] and the hardware through [`PlantCore`].

use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::Arc;

use capsule_msgs::names::topics;
use capsule_msgs::{CapsuleState, Time};
use capsule_ros_base::error::{bail, chain, Context as _, Result};
use capsule_ros_base::node_life::{self, NodeLife, Seat};
use capsule_ros_base::node_on::NodeOn;
use capsule_ros_base::{conflicts, graph::Graph, ros_options::RosOptions};
use tokio::sync::{oneshot, Notify};
use tracing::{info, warn};

use super::endpoints::{Endpoints, MATCH_GRACE};
use super::lifecycle_services::{self, Lifecycle};
use super::loop_control::{apply_unconfigured, Exit, LoopControl};
use super::simulator_loop::SampleLoop;
use super::{InPlantRecording, LoopStats, Pacing, PlantCore, PlantOptions};
use crate::hardware::CapsuleHardware;
use crate::intra_process::{CopyCounts, Transport};

/// The plant node as asked for: what [`node_life::live`] builds and runs.
struct PlantNode<H: CapsuleHardware> {
    settings: RosOptions,
    core: PlantCore<H>,
    opts: PlantOptions,
    transport: Transport,
}

/// What the built node holds while it runs.
struct Built<H: CapsuleHardware> {
    settings: RosOptions,
    core: PlantCore<H>,
    opts: PlantOptions,
    io: Endpoints,
    graph: Graph,
    conflicts: Arc<AtomicU64>,
    lifecycle: Lifecycle,
    control: LoopControl,
    recording: Option<InPlantRecording>,
    /// The parameter services (served while they live).
    _params: (
        capsule_ros_base::param_services::ParamHandle,
        tokio::sync::mpsc::UnboundedReceiver<capsule_ros_base::params::ParamTable>,
    ),
}

/// What the loop leaves to finish.
struct Ended<H: CapsuleHardware> {
    /// What the loop's thread gave back.
    thread: LoopEnd<H>,
    /// Conflicts seen on the graph.
    conflicts: Arc<AtomicU64>,
    /// In-process: what became of the state's DDS copies.
    copies: Option<Arc<CopyCounts>>,
}

/// Runs the plant node on DDS (on Zenoh if `RMW_IMPLEMENTATION` asks: `zenoh_loop`), in a
/// participant of its own, until `until_s`, a lifecycle
/// shutdown, or SIGINT/SIGTERM; logs the loop statistics at the end.
pub async fn run<H: CapsuleHardware + 'static>(
    settings: RosOptions,
    core: PlantCore<H>,
    opts: PlantOptions,
) -> Result<(LoopStats, CapsuleState)> {
    #[cfg(feature = "zenoh")]
    if settings.middleware.is_zenoh() {
        return super::zenoh_loop::run(settings, core, opts).await;
    }
    run_in(None, settings, core, opts, Transport::Dds).await
}

/// [`run`] in the participant of `context` (a composed process's: `None` makes one) with state
/// and force over `transport`.
pub async fn run_in<H: CapsuleHardware + 'static>(
    context: Option<&ros2_client::dds::Context>,
    settings: RosOptions,
    core: PlantCore<H>,
    opts: PlantOptions,
    transport: Transport,
) -> Result<(LoopStats, CapsuleState)> {
    let node = PlantNode {
        settings,
        core,
        opts,
        transport,
    };
    node_life::live(node, context).await
}

impl<H: CapsuleHardware + 'static> NodeLife for PlantNode<H> {
    type Built = Built<H>;
    type Ended = Ended<H>;
    type Outcome = (LoopStats, CapsuleState);

    /// Build: the recording's file first (an unwritable place is an error before anything else
    /// starts), then DDS: endpoints, conflict watch, emergency stop, parameters, lifecycle.
    fn build(self, context: Option<&ros2_client::dds::Context>) -> Result<Built<H>> {
        let PlantNode {
            settings,
            core,
            opts,
            transport,
        } = self;
        if opts.joint_commands && opts.pacing == Pacing::Lockstep {
            bail!("JointState commands need real-time pacing: in lock-step none answers a particular sample");
        }
        let file = opts
            .record
            .as_ref()
            .map(|r| InPlantRecording::create_file(r, &settings))
            .transpose()?;
        let Seat {
            context,
            mut node,
            graph,
            composed,
        } = Seat::take(context, &settings)?;
        let (io, rules) =
            Endpoints::create(&mut node, &settings, &graph, &opts, core.rate_hz, transport)?;
        let conflicts = conflicts::watch(graph.clone(), rules);
        crate::emergency_stop::serve(
            NodeOn::Dds(&mut node, &graph),
            &settings,
            core.emergency_stop(),
            core.stopper(),
        )?;
        // ROS parameters (read-only here): served by their own task, never by the sample loop
        let params = capsule_ros_base::param_services::serve(
            &context,
            &mut node,
            &graph,
            &settings,
            opts.params.clone(),
            capsule_ros_base::params::no_rules,
            || Time::from_nanos(capsule_record::writer::now_ns() as i64),
        )?;
        let (lifecycle, requests) =
            lifecycle_services::serve(NodeOn::Dds(&mut node, &graph), &settings)?;
        let (woken, paused) = (Arc::new(Notify::new()), Arc::new(AtomicBool::new(false)));
        if opts.pacing == Pacing::Lockstep {
            paused.store(opts.start_paused, Ordering::SeqCst);
            crate::pause::serve(
                NodeOn::Dds(&mut node, &graph),
                &settings,
                paused.clone(),
                woken.clone(),
            )?;
        } else if opts.start_paused {
            bail!("{}", crate::pause::NEEDS_LOCKSTEP);
        }
        let recording = match (file, &opts.record) {
            (Some(rec), Some(r)) if composed => {
                Some(InPlantRecording::start_apart(rec, r, &settings)?)
            }
            (Some(rec), Some(r)) => Some(InPlantRecording::start(
                rec, r, &context, &mut node, &settings,
            )?),
            _ => None,
        };
        announce(&settings, &opts, core.rate_hz);
        Ok(Built {
            settings,
            core,
            opts,
            io,
            graph,
            conflicts,
            lifecycle,
            control: LoopControl {
                halt: Arc::default(),
                woken,
                requests,
                paused,
            },
            recording,
            _params: params,
        })
    }

    /// Wait for the graph: `--wait-subscribers` readers of the state before the first sample.
    async fn wait_for_graph(built: &Built<H>) -> Result<()> {
        let (settings, opts) = (&built.settings, &built.opts);
        if opts.wait_subscribers == 0 {
            return Ok(());
        }
        let writer = built.io.state_guid;
        if !built
            .graph
            .wait_subscribers(writer, opts.wait_subscribers, opts.startup_timeout)
            .await
        {
            bail!(
                "only {} of {} subscribers matched {} within {:?}",
                built.graph.subscribers(writer),
                opts.wait_subscribers,
                settings.resolve_name(topics::STATE),
                opts.startup_timeout
            );
        }
        // Our writer has matched them; their readers match our writer when they process our
        // announcement, which can be a moment later, and a reader that has not yet matched
        // drops what it gets. Give them that moment, or the first samples miss the recorder.
        tokio::time::sleep(MATCH_GRACE).await;
        info!("{} subscribers matched: starting", opts.wait_subscribers);
        Ok(())
    }

    /// Run the loop: on a thread of its own, started unconfigured; `--autostart` configures and
    /// activates it; a signal ends it.
    async fn run_loop(built: Built<H>) -> Result<Ended<H>> {
        let Built {
            core,
            opts,
            io,
            conflicts,
            lifecycle,
            control,
            recording,
            _params,
            ..
        } = built;
        let (halt, woken) = (control.halt.clone(), control.woken.clone());
        let stop = move || {
            halt.store(true, Ordering::SeqCst);
            woken.notify_one();
        };
        let autostart = opts.autostart;
        let copies = io.copies();
        let mut ended = spawn_loop(core, io, opts, control, recording)?;
        if autostart {
            if let Err(e) = lifecycle.autostart().await {
                stop();
                let _ = (&mut ended).await;
                return Err(e);
            }
        }
        let shutdown = capsule_ros_base::signals::shutdown_signal();
        tokio::pin!(shutdown);
        let thread = tokio::select! {
            done = &mut ended => done.context("the sample loop's thread ended without a word")?,
            sig = &mut shutdown => {
                match sig {
                    Ok(s) => info!("{s}: shutting down"),
                    Err(e) => warn!("{}", chain(&e)),
                }
                stop();
                ended.await.context("the sample loop's thread ended without a word")?
            }
        };
        Ok(Ended {
            thread,
            conflicts,
            copies,
        })
    }

    /// Finish: the last sample's way out, the statistics, the recording.
    async fn finish(ended: Ended<H>) -> Result<(LoopStats, CapsuleState)> {
        let Ended {
            thread: (result, mut core, recording, io),
            conflicts,
            copies,
        } = ended;
        // DDS sends from its own thread: let the last sample leave (and be repaired) before its
        // writer and the participant go
        tokio::time::sleep(MATCH_GRACE).await;
        // in-process, this waits for the DDS copies to go out: their counts are final after it
        drop(io);
        if let Some(c) = copies {
            let load = |n: &AtomicU64| n.load(Ordering::Relaxed);
            core.stats.dds_copies = Some(super::DdsCopyStats {
                published: load(&c.published),
                unread: load(&c.unread),
                dropped: load(&c.dropped),
            });
            info!("state's DDS copies: {}", c.describe());
        }
        core.stats.finish();
        core.stats.graph_conflicts = conflicts.load(Ordering::Relaxed);
        let stats = core.stats.clone();
        match stats.percentiles() {
            Some((p50, p99, max)) => info!(
                "loop: {} samples ({} before the first answer), {} lost, {} answered late, {} re-sent, latency p50 {:.3} ms p99 {:.3} ms max {:.3} ms, {} commands refused, {} saturated at {} N",
                stats.published,
                stats.before_first_answer,
                stats.unanswered,
                stats.late_answers,
                stats.resent,
                p50 * 1e3,
                p99 * 1e3,
                max * 1e3,
                core.rejected(),
                stats.saturated_commands,
                core.max_force_n()
            ),
            None => info!("loop: {} samples, no command answered", stats.published),
        }
        let result = match recording {
            Some(r) => r.finish(result),
            None => result,
        };
        result.map(|()| (stats, core.state()))
    }
}

fn announce(settings: &RosOptions, opts: &PlantOptions, rate_hz: f64) {
    info!(
        "{}: {:?} at {} Hz, state {} <- force {}, clock {} (while subscribed){}",
        settings.describe(),
        opts.pacing,
        rate_hz,
        settings.resolve_name(topics::STATE),
        settings.resolve_name(topics::FORCE),
        settings.resolve_name(topics::CLOCK),
        if opts.autostart {
            ""
        } else {
            "; unconfigured until `ros2 lifecycle set` configures it"
        }
    );
    if opts.joint_commands {
        info!(
            "taking JointState commands on {} (effort of {} = actuator force [N])",
            settings.resolve_name(topics::JOINT_COMMANDS),
            crate::joint_commands::JOINT
        );
    }
}

/// What the loop's thread gives back: with the endpoints, which must outlive the grace after
/// the last sample (a writer that goes with the thread takes its unsent samples with it).
type LoopEnd<H> = (
    Result<()>,
    PlantCore<H>,
    Option<InPlantRecording>,
    Endpoints,
);

/// Starts the sample loop's thread (a runtime of its own: nothing it does waits on the node's).
fn spawn_loop<H: CapsuleHardware + 'static>(
    mut core: PlantCore<H>,
    io: Endpoints,
    opts: PlantOptions,
    mut control: LoopControl,
    mut rec: Option<InPlantRecording>,
) -> Result<oneshot::Receiver<LoopEnd<H>>> {
    let (tx, rx) = oneshot::channel();
    std::thread::Builder::new()
        .name("capsule_plant_loop".into())
        .spawn(move || {
            let result = tokio::runtime::Builder::new_current_thread()
                .enable_all()
                .build()
                .context("cannot start the sample loop's runtime")
                .and_then(|rt| {
                    rt.block_on(drive(&mut core, &io, &opts, &mut control, rec.as_mut()))
                });
            let _ = core.cleanup();
            let _ = tx.send((result, core, rec, io));
        })
        .context("cannot start the sample loop's thread")?;
    Ok(rx)
}

/// The loop's life: unconfigured until configured, then the pacing loop of the hardware until
/// a cleanup (unconfigured again) or the end.
async fn drive<H: CapsuleHardware>(
    core: &mut PlantCore<H>,
    io: &Endpoints,
    opts: &PlantOptions,
    control: &mut LoopControl,
    mut rec: Option<&mut InPlantRecording>,
) -> Result<()> {
    loop {
        let woken = control.woken.clone();
        let request = tokio::select! {
            r = control.requests.recv() => r,
            _ = woken.notified() => None,
        };
        let Some(request) = request else {
            if control.halted() || control.requests.is_closed() {
                return Ok(());
            }
            continue;
        };
        match apply_unconfigured(core, request) {
            Some(Exit::Over) => return Ok(()),
            Some(Exit::CleanedUp) => continue,
            None => {}
        }
        let ready = core.ready();
        let sample_loop = SampleLoop {
            core,
            io,
            opts,
            control,
            rec: rec.as_deref_mut(),
        };
        let exit = match (ready, opts.pacing) {
            (Some(ready), _) => sample_loop.paced(ready).await?,
            (None, Pacing::Realtime) => sample_loop.realtime()?,
            (None, Pacing::Lockstep) => sample_loop.lockstep().await?,
        };
        if exit == Exit::Over {
            return Ok(());
        }
    }
}

//! The controller node on DDS, as its life reads: [`run`] builds the endpoints, then runs the
//! loop until SIGINT/SIGTERM. The decisions are [`ControllerCore`]'s
//! ([`crate::controller_core`]); what the loop does with each input apart from DDS is
//! `Handlers`' (the core, the parameter sync, which plant it serves, the logs); the inputs
//! (`Inputs`: state samples, mode requests, accepted parameter sets) and the outputs
//! (`Outputs`: commands, status, service events, diagnostics) are the DDS side. State and
//! commands come and go over DDS or, composed with the plant in one process, over the
//! in-process link ([`capsule_plant_node::intra_process`]): there the plant's loop calls the same
//! `Handlers::on_state` on its own thread, and the commands' DDS copies leave from a publisher
//! thread. [`run_in`] takes the transport from outside.
//!
//! Status messages are stamped with the node's ROS time (sim time under `use_sim_time`); the
//! stale-state watchdog runs on a steady clock, because sim time stops when the plant does.

use capsule_msgs::names::topics;
use capsule_plant::number_text::short;
use std::time::{Duration, Instant};

use capsule_msgs::{
    ActuatorForce, CapsuleState, ControllerStatus, SetModeRequest, SetModeResponse,
};
use capsule_record::types::{ServiceEventInfo, SetModeEvent};
use capsule_ros_base::error::{Context as _, Result};
use futures::StreamExt;
use ros2_client::{Gid, Node, Publisher, RmwRequestId, Subscription};
use std::sync::{Arc, Mutex, MutexGuard};
use tracing::{info, warn};

use crate::{
    controller_actions::{ControllerActions, CoreAccess},
    controller_core::ControllerCore,
    controller_diagnostics::ControllerDiag,
    controller_params::{self, LiveSync},
    plant_identity::{PlantIdentity, Source},
};
use capsule_hardware::throttle::Throttle;
use capsule_plant_node::{
    intra_process::{Answer, CopyCounts, DdsCopies, Transport},
    views::Diagnostics,
};
use capsule_ros_base::{
    clock::RosClock,
    conflicts::TopicRule,
    graph::Graph,
    params::ParamTable,
    ros::{qos, subscribe, types, RosOptions, Wire},
    service::Service,
};

/// How the controller node is set up (besides the ROS settings).
#[derive(Debug, Clone)]
pub struct ControllerOptions {
    /// The core, configured.
    pub core: ControllerCore,
    /// Stale-state check and status period.
    pub status_period: Duration,
    /// The ROS parameters served (see [`crate::controller_params`]).
    pub params: ParamTable,
    /// Publish `/diagnostics` at 1 Hz (see [`crate::controller_diagnostics`]).
    pub diagnostics: bool,
}

/// Runs the controller node on DDS, in a participant of its own, until SIGINT/SIGTERM: build,
/// then the loop.
pub async fn run(settings: RosOptions, opts: ControllerOptions) -> Result<()> {
    let context = settings.context()?;
    let end = capsule_ros_base::ros::shutdown();
    run_in(&context, settings, opts, Transport::Dds, end).await
}

/// [`run`] in the participant of `context` (a composed process's), with state and force over
/// `transport`, until `end` resolves (its error is the run's).
pub async fn run_in(
    context: &ros2_client::Context,
    settings: RosOptions,
    opts: ControllerOptions,
    transport: Transport,
    end: impl std::future::Future<Output = Result<()>>,
) -> Result<()> {
    let (mut node, graph) = settings.loop_node(context)?;
    let clock = RosClock::new(&settings, &mut node)?;
    let mut outputs = Outputs::build(&settings, &mut node, graph.clone(), opts.diagnostics)?;
    let (handle, applied) = capsule_ros_base::param_services::serve(
        context,
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
    let actions = ControllerActions::build(&settings, &mut node, &graph)?;
    let handlers = Arc::new(Mutex::new(Handlers::new(
        opts.core, handle, clock, &settings,
    )));
    let actions = tokio::spawn(actions.run(NodeCore(handlers.clone())));
    let mut copies = None;
    if let Transport::InProcess(link) = transport {
        let (answer, counts) = outputs.in_process(&settings, graph, &handlers)?;
        link.attach(answer)?;
        copies = Some(counts);
    }
    {
        let h = lock(&handlers);
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
    if let Some(rx) = outputs.switch_status.take() {
        inputs.switch_status = Some(rx);
    }
    let stopped = run_loop(inputs, &mut outputs, &handlers, opts.status_period, end).await;
    actions.abort();
    if let Some(c) = copies {
        info!("force's DDS copies: {}", c.describe());
    }
    drop(node);
    stopped
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

/// The handlers, also after a panic elsewhere (the link names it and answers nothing more).
fn lock(h: &Mutex<Handlers>) -> MutexGuard<'_, Handlers> {
    h.lock().unwrap_or_else(std::sync::PoisonError::into_inner)
}

/// Where the controller's inputs come from.
struct Inputs {
    /// State over DDS (`None` in-process: the plant's loop calls the handler).
    states: Option<Subscription<CapsuleState>>,
    /// In-process: the statuses of attractor-switch events, to publish.
    switch_status: Option<tokio::sync::mpsc::UnboundedReceiver<ControllerStatus>>,
    /// The mode service (its responses go back through it).
    server: Service<Wire<SetModeRequest>, Wire<SetModeResponse>>,
    /// Remote parameter sets the parameter services' task accepted.
    applied: tokio::sync::mpsc::UnboundedReceiver<ParamTable>,
}

impl Inputs {
    fn build(
        settings: &RosOptions,
        node: &mut Node,
        graph: &Graph,
        applied: tokio::sync::mpsc::UnboundedReceiver<ParamTable>,
        in_process: bool,
    ) -> Result<Inputs> {
        let state_topic = settings.topic(node, topics::STATE, types::state(), &qos::data())?;
        Ok(Inputs {
            states: (!in_process)
                .then(|| subscribe::<CapsuleState>(node, &state_topic, &qos::data_reader()))
                .transpose()?,
            switch_status: None,
            server: settings.server::<Wire<SetModeRequest>, Wire<SetModeResponse>>(
                node,
                graph,
                topics::SET_MODE,
                &types::set_mode(),
            )?,
            applied,
        })
    }
}

/// Where the controller's outputs go.
struct Outputs {
    /// Commands over DDS (`None` in-process: its copies go out from their own thread).
    force: Option<Publisher<ActuatorForce>>,
    /// In-process: the receiving end of the switch statuses, until the inputs take it.
    switch_status: Option<tokio::sync::mpsc::UnboundedReceiver<ControllerStatus>>,
    status: Publisher<ControllerStatus>,
    /// set_mode service events, as ROS 2 service introspection publishes them.
    events: Publisher<SetModeEvent>,
    diagnostics: Option<Diagnostics>,
}

impl Outputs {
    fn build(
        settings: &RosOptions,
        node: &mut Node,
        graph: capsule_ros_base::graph::Graph,
        diagnostics: bool,
    ) -> Result<Outputs> {
        let state_topic = settings.topic(node, topics::STATE, types::state(), &qos::data())?;
        let force_topic = settings.topic(node, topics::FORCE, types::force(), &qos::data())?;
        let status_topic = settings.topic(node, topics::STATUS, types::status(), &qos::data())?;
        let event_topic = settings.topic(
            node,
            &capsule_plant_node::recorder::service_event_topic("~"),
            capsule_plant_node::recorder::service_event_type(),
            &qos::service_events(),
        )?;
        // a second plant is told from the samples themselves (plant_identity): a SIGKILLed
        // plant stays in discovery until its lease ends, and its restarted successor would
        // look like one
        capsule_ros_base::conflicts::watch(
            graph,
            vec![
                TopicRule::new(
                    &state_topic,
                    settings.resolve_name(topics::STATE),
                    usize::MAX,
                    "",
                ),
                TopicRule::new(
                    &force_topic,
                    settings.resolve_name(topics::FORCE),
                    0,
                    "ANOTHER CONTROLLER commands the plant too: commands interleave",
                ),
            ],
        );
        Ok(Outputs {
            force: Some(
                node.create_publisher(&force_topic, None)
                    .context("force publisher")?,
            ),
            switch_status: None,
            status: node
                .create_publisher(&status_topic, None)
                .context("status publisher")?,
            events: node
                .create_publisher(&event_topic, None)
                .context("service-event publisher")?,
            diagnostics: diagnostics
                .then(|| Diagnostics::create(node, settings))
                .transpose()?,
        })
    }

    /// In-process: the state handler the plant's loop calls (the command back, its DDS copy
    /// queued, a switch event's status to the node's loop), and the copies' counts.
    fn in_process(
        &mut self,
        settings: &RosOptions,
        graph: capsule_ros_base::graph::Graph,
        handlers: &Arc<Mutex<Handlers>>,
    ) -> Result<(Box<Answer>, Arc<CopyCounts>)> {
        let publisher = self
            .force
            .take()
            .context("the force publisher, taken twice")?;
        let copies = DdsCopies::start(&settings.resolve_name(topics::FORCE), publisher, graph)?;
        let counts = copies.counts();
        let (tx, rx) = tokio::sync::mpsc::unbounded_channel();
        self.switch_status = Some(rx);
        let h = handlers.clone();
        let answer = move |state: &CapsuleState, plant: Gid| {
            let (cmd, status) = lock(&h).on_state(state, plant)?;
            copies.push(cmd.clone());
            if let Some(st) = status {
                let _ = tx.send(st);
            }
            Some(cmd)
        };
        Ok((Box::new(answer), counts))
    }

    /// Sends the command for a state sample, and the status after an attractor-switch event.
    async fn answer_state(&self, h: &Mutex<Handlers>, state: &CapsuleState, publisher: Gid) {
        let Some((cmd, status)) = lock(h).on_state(state, publisher) else {
            return;
        };
        if let Some(force) = &self.force {
            if let Err(e) = force.async_publish(cmd).await {
                warn!("force command not sent: {e:?}");
            }
        }
        if let Some(st) = status {
            if let Err(e) = self.status.async_publish(st).await {
                warn!("status not sent: {e:?}");
            }
        }
    }

    /// Answers a set_mode request, with the request and the response as service events.
    async fn answer_request(
        &self,
        h: &Mutex<Handlers>,
        server: &Service<Wire<SetModeRequest>, Wire<SetModeResponse>>,
        id: RmwRequestId,
        req: SetModeRequest,
    ) {
        let clock = lock(h).clock.clone();
        let event =
            |kind, request: Vec<SetModeRequest>, response: Vec<SetModeResponse>| SetModeEvent {
                info: ServiceEventInfo {
                    event_type: kind,
                    stamp: clock.now(),
                    client_gid: id.writer_gid.to_bytes16(),
                    sequence_number: id.sequence_number,
                },
                request,
                response,
            };
        let received = event(
            ServiceEventInfo::REQUEST_RECEIVED,
            vec![req.clone()],
            vec![],
        );
        if let Err(e) = self.events.async_publish(received).await {
            warn!("service event not sent: {e:?}");
        }
        let resp = lock(h).on_request(&req);
        let sent = event(ServiceEventInfo::RESPONSE_SENT, vec![], vec![resp.clone()]);
        if let Err(e) = self.events.async_publish(sent).await {
            warn!("service event not sent: {e:?}");
        }
        server.answer(id, Wire(resp));
        let status = {
            let mut guard = lock(h);
            let g = &mut *guard;
            g.params.push(&g.core);
            g.status()
        };
        let _ = self.status.async_publish(status).await;
    }

    /// The status period: the watchdog, the status, and the diagnostics when due.
    async fn tick(&mut self, h: &Mutex<Handlers>) {
        let st = lock(h).on_tick();
        if let Err(e) = self.status.async_publish(st).await {
            warn!("status not sent: {e:?}");
        }
        if let Some(d) = self.diagnostics.as_mut().and_then(|d| d.due().then_some(d)) {
            let diag = {
                let mut guard = lock(h);
                let g = &mut *guard;
                g.diag.status(&g.node_name, &g.core)
            };
            let _ = d.publish(diag);
        }
    }
}

/// The loop: each input to its handler, until `end`.
async fn run_loop(
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

/// What the loop does with each input, apart from DDS: the core's decisions, the parameters
/// kept in step, which plant is served, and the logs.
struct Handlers {
    core: ControllerCore,
    params: LiveSync,
    plants: PlantIdentity<Gid>,
    clock: RosClock,
    /// The steady clock of the watchdog and the plant identity.
    start: Instant,
    diag: ControllerDiag,
    node_name: String,
    /// The state topic as resolved, for the logs.
    state_topic: String,
    second_plant_log: Throttle,
    ignored_log: Throttle,
}

impl Handlers {
    fn new(
        core: ControllerCore,
        handle: capsule_ros_base::param_services::ParamHandle,
        clock: RosClock,
        settings: &RosOptions,
    ) -> Handlers {
        Handlers {
            params: LiveSync::new(handle, &core),
            core,
            plants: PlantIdentity::new(PlantIdentity::<Gid>::DEFAULT_HANDOVER_S),
            clock,
            start: Instant::now(),
            diag: ControllerDiag::default(),
            node_name: settings.node_name.clone(),
            state_topic: settings.resolve_name(topics::STATE),
            second_plant_log: Throttle::default(),
            ignored_log: Throttle::default(),
        }
    }

    fn steady(&self) -> f64 {
        self.start.elapsed().as_secs_f64()
    }

    /// The status now.
    fn status(&self) -> ControllerStatus {
        self.core.status(self.clock.now())
    }

    /// Whether a sample from `publisher` is the plant's to answer (a new plant is adopted, a
    /// second one ignored).
    fn is_our_plant(&mut self, state: &CapsuleState, publisher: Gid) -> bool {
        match self.plants.observe(publisher, self.steady()) {
            Source::Current | Source::Adopted(None) => true,
            Source::Adopted(Some(silent)) => {
                self.core.new_plant();
                info!("a new plant publishes (seq {}) after {silent:.3} s without the last one: commanding it from now on", state.seq);
                true
            }
            Source::Second => {
                if self.second_plant_log.tick() {
                    warn!(
                        "A SECOND PLANT publishes {} (seq {}) while the first does: both apply every command; its samples are ignored ({} so far)",
                        self.state_topic,
                        state.seq,
                        self.plants.ignored()
                    );
                }
                false
            }
        }
    }

    /// A state sample: the command to send and, after an attractor-switch event, the status
    /// to publish; `None` for a sample not answered.
    fn on_state(
        &mut self,
        state: &CapsuleState,
        publisher: Gid,
    ) -> Option<(ActuatorForce, Option<ControllerStatus>)> {
        if !self.is_our_plant(state, publisher) {
            return None;
        }
        let core = &mut self.core;
        let was = core.commanding();
        let refused = core.plant_refuses();
        let ignored = core.ignored_samples();
        let answer = core.on_state(state, self.start.elapsed().as_secs_f64());
        if core.ignored_samples() > ignored && self.ignored_log.tick() {
            let why = core
                .ignored_why()
                .map(|w| w.to_string())
                .unwrap_or_default();
            warn!(
                "state seq {} not used ({why}): {} so far",
                state.seq,
                core.ignored_samples()
            );
        }
        let cmd = answer?;
        if !was {
            info!("state fresh at seq {}: commanding", state.seq);
        }
        match (refused, core.plant_refuses()) {
            (false, true) => warn!(
                "the plant does not take our commands ({} refused so far, command_stale {}): not in control",
                state.rejected_commands, state.command_stale
            ),
            (true, false) => info!("the plant takes our commands again (seq {})", state.seq),
            _ => {}
        }
        if !core.take_switch_event() {
            return Some((cmd, None));
        }
        let st = self.status();
        info!(
            "attractor switch: {} (try {}, orbit period {}, k_p {})",
            self.core
                .attractor_switch()
                .map_or("?", |s| s.state().name()),
            st.switch_tries,
            st.orbit_period,
            st.gain
        );
        self.params.push(&self.core);
        Some((cmd, Some(st)))
    }

    /// A set_mode request: the answer (the core's), logged.
    fn on_request(&mut self, req: &SetModeRequest) -> SetModeResponse {
        let resp = self.core.set_mode(req);
        if resp.accepted {
            info!("set_mode accepted: {}", resp.reason);
        } else {
            warn!(
                "set_mode refused (mode {} gain {}): {}",
                req.mode,
                short(req.gain),
                resp.reason
            );
        }
        resp
    }

    /// The status period: the core's own mode changes to the parameters, the watchdog; the
    /// status to publish.
    fn on_tick(&mut self) -> ControllerStatus {
        self.params.push(&self.core);
        if self.core.check_stale(self.steady()) {
            warn!("state stale (no sample for the timeout; plant gone?): stopped commanding");
        }
        self.status()
    }
}

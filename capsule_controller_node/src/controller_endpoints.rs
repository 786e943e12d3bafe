//! The controller node's DDS side: where its inputs come from ([`Inputs`]: state samples, mode
//! requests, accepted parameter sets) and where its outputs go ([`Outputs`]: commands, status,
//! service events, diagnostics); composed with the plant, state and commands take the
//! in-process link ([`capsule_plant_node::intra_process`]) and the commands' DDS copies leave
//! from a publisher thread.

use std::sync::{Arc, Mutex};

use capsule_msgs::names::topics;
use capsule_msgs::{
    ActuatorForce, CapsuleState, ControllerStatus, SetModeRequest, SetModeResponse,
};
use capsule_plant_node::{
    intra_process::{Answer, CopyCounts, DdsCopies},
    views::Diagnostics,
};
use capsule_record::types::{ServiceEventInfo, SetModeEvent};
use capsule_ros_base::error::{Context as _, Result};
use capsule_ros_base::{
    conflicts::TopicRule,
    endpoints::{subscribe, Wire},
    graph::Graph,
    params::ParamTable,
    qos,
    ros_options::RosOptions,
    service::Service,
    types,
};
use ros2_client::dds::{Node, Publisher, Subscription};
use ros2_client::{Gid, RmwRequestId};
use tracing::warn;

use crate::controller_handlers::{lock, Handlers};

/// Where the controller's inputs come from.
pub(crate) struct Inputs {
    /// State over DDS (`None` in-process: the plant's loop calls the handler).
    pub(crate) states: Option<Subscription<CapsuleState>>,
    /// In-process: the statuses of attractor-switch events, to publish.
    pub(crate) switch_status: Option<tokio::sync::mpsc::UnboundedReceiver<ControllerStatus>>,
    /// The mode service (its responses go back through it).
    pub(crate) server: Service<Wire<SetModeRequest>, Wire<SetModeResponse>>,
    /// Remote parameter sets the parameter services' task accepted.
    pub(crate) applied: tokio::sync::mpsc::UnboundedReceiver<ParamTable>,
}

impl Inputs {
    pub(crate) fn build(
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
pub(crate) struct Outputs {
    /// Commands over DDS (`None` in-process: its copies go out from their own thread).
    pub(crate) force: Option<Publisher<ActuatorForce>>,
    /// In-process: the receiving end of the switch statuses, until the inputs take it.
    pub(crate) switch_status: Option<tokio::sync::mpsc::UnboundedReceiver<ControllerStatus>>,
    pub(crate) status: Publisher<ControllerStatus>,
    /// set_mode service events, as ROS 2 service introspection publishes them.
    pub(crate) events: Publisher<SetModeEvent>,
    pub(crate) diagnostics: Option<Diagnostics>,
}

impl Outputs {
    pub(crate) fn build(
        settings: &RosOptions,
        node: &mut Node,
        graph: Graph,
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
    pub(crate) fn in_process(
        &mut self,
        settings: &RosOptions,
        graph: Graph,
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
    pub(crate) async fn answer_state(
        &self,
        h: &Mutex<Handlers>,
        state: &CapsuleState,
        publisher: Gid,
    ) {
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
    pub(crate) async fn answer_request(
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
    pub(crate) async fn tick(&mut self, h: &Mutex<Handlers>) {
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

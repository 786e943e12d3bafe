//! Serves a [`ParamTable`] as rclcpp does: `~/list_parameters`, `~/describe_parameters`,
//! `~/get_parameters`, `~/get_parameter_types`, `~/set_parameters`,
//! `~/set_parameters_atomically` (`rcl_interfaces/srv`, in the node's service mapping, so
//! rmw_cyclonedds and rmw_fastrtps clients both find them), and `/parameter_events`.
//!
//! Off the hot path: one tokio task waits on the six request readers; nothing runs until a
//! request arrives (a DDS reader with nothing to deliver wakes no one), so the node's sample
//! loop pays nothing for it. Accepted changes go to the node through a channel it polls when it
//! likes (the controller's loop: one cheap channel branch), and its own changes (a mode switch
//! by service) come back through [`ParamHandle::put`] to be published as events.
//!
//! On Zenoh (`serve_on_zenoh`, feature `zenoh`) the same table, rules and answers, through
//! ros2-client's Zenoh servers (the services and `/parameter_events` as rmw_zenoh_cpp names
//! them), not ros2-client's own Zenoh parameter server (a store without our ranges and rules).

use std::sync::{Arc, Mutex, PoisonError};

use crate::error::{Context as _, Result};
use capsule_msgs::Time;
use futures::StreamExt;
use ros2_client::dds::{Context, Node, Publisher};
use ros2_client::{
    parameters::raw,
    qos::{Durability, History, WhenFull},
    rcl_interfaces as rcl, ParameterValue, QosProfile, ServiceTypeName,
};
use tokio::sync::mpsc;
use tracing::{info, warn};

use crate::{
    graph::Graph,
    params::{event, Param, ParamTable, Rules},
    ros_options::RosOptions,
    service::Service,
};

/// `/parameter_events` as rclcpp publishes it (`rmw_qos_profile_parameter_events`): reliable,
/// volatile, keep last 1000.
pub fn events_qos() -> QosProfile {
    QosProfile::publisher_default()
        .reliability_reliable(WhenFull::Wait(std::time::Duration::from_millis(100)))
        .durability(Durability::Volatile)
        .history(History::KeepLast { depth: 1000 })
}

/// The node's side of a served table: read it, and change it (changes are published).
#[derive(Clone)]
pub struct ParamHandle {
    table: Arc<Mutex<ParamTable>>,
    own_changes: mpsc::UnboundedSender<Vec<Param>>,
}

impl ParamHandle {
    /// A copy of the table now.
    pub fn snapshot(&self) -> ParamTable {
        locked(&self.table).clone()
    }

    /// Sets values without the set rules (the node's own changes, e.g. a mode switch by its
    /// service) and publishes what changed on `/parameter_events`.
    pub fn put(&self, values: &[(&str, ParameterValue)]) {
        let mut changed = Vec::new();
        {
            let mut t = locked(&self.table);
            for (name, value) in values {
                if t.put(name, value.clone()) {
                    changed.push((name.to_string(), value.clone()));
                }
            }
        }
        if !changed.is_empty() {
            let _ = self.own_changes.send(changed);
        }
    }
}

/// Starts serving `table` on `node` under `rules`; events are stamped with `now()`. Returns the
/// node's handle and the receiver of the tables remote sets produced (drop it if the node has
/// nothing to reconfigure).
pub fn serve(
    context: &Context,
    node: &mut Node,
    graph: &Graph,
    settings: &RosOptions,
    table: ParamTable,
    rules: Rules,
    now: impl Fn() -> Time + Send + Sync + 'static,
) -> Result<(ParamHandle, mpsc::UnboundedReceiver<ParamTable>)> {
    let servers = Servers::create(node, graph, settings)?;
    let events = node
        .create_publisher::<raw::ParameterEvent>(
            &context.get_parameter_events_topic(),
            Some(events_qos()),
        )
        .context("/parameter_events publisher")?;
    let node_name = node.fully_qualified_name();
    Ok(start(
        servers,
        Events::Dds(Box::new(events)),
        node_name,
        table,
        rules,
        now,
    ))
}

/// [`serve`] on the Zenoh `node`.
#[cfg(feature = "zenoh")]
pub fn serve_on_zenoh(
    node: &ros2_client::zenoh::Node,
    settings: &RosOptions,
    table: ParamTable,
    rules: Rules,
    now: impl Fn() -> Time + Send + Sync + 'static,
) -> Result<(ParamHandle, mpsc::UnboundedReceiver<ParamTable>)> {
    let servers = Servers::on_zenoh(node, settings)?;
    let name = ros2_client::Name::new("/", "parameter_events").context("/parameter_events")?;
    let topic = node.create_topic(
        &name,
        ros2_client::MessageTypeName::new("rcl_interfaces", "ParameterEvent"),
        &events_qos(),
    );
    let events = node
        .create_publisher::<raw::ParameterEvent>(&topic, None)
        .context("/parameter_events publisher on Zenoh")?;
    let node_name = node.fully_qualified_name();
    Ok(start(
        servers,
        Events::Zenoh(events),
        node_name,
        table,
        rules,
        now,
    ))
}

/// Starts the task that answers `servers` on `table`, publishing the changes on `events`.
fn start(
    servers: Servers,
    events: Events,
    node_name: String,
    table: ParamTable,
    rules: Rules,
    now: impl Fn() -> Time + Send + Sync + 'static,
) -> (ParamHandle, mpsc::UnboundedReceiver<ParamTable>) {
    let table = Arc::new(Mutex::new(table));
    let (own_tx, own_rx) = mpsc::unbounded_channel::<Vec<Param>>();
    let (applied_tx, applied_rx) = mpsc::unbounded_channel();
    let handle = ParamHandle {
        table: Arc::clone(&table),
        own_changes: own_tx,
    };
    let answering = Answering {
        table,
        rules,
        events,
        node_name,
        now,
        applied: applied_tx,
    };
    tokio::spawn(answering.run(servers, own_rx));
    (handle, applied_rx)
}

/// The `/parameter_events` publisher, on DDS or on Zenoh.
enum Events {
    Dds(Box<Publisher<raw::ParameterEvent>>),
    #[cfg(feature = "zenoh")]
    Zenoh(ros2_client::zenoh::Publisher<raw::ParameterEvent>),
}

/// The six rcl_interfaces services of a node.
struct Servers {
    list: Service<rcl::ListParametersRequest, rcl::ListParametersResponse>,
    describe: Service<rcl::DescribeParametersRequest, rcl::DescribeParametersResponse>,
    get: Service<rcl::GetParametersRequest, rcl::GetParametersResponse>,
    types: Service<rcl::GetParameterTypesRequest, rcl::GetParameterTypesResponse>,
    set: Service<rcl::SetParametersRequest, rcl::SetParametersResponse>,
    set_atomic: Service<rcl::SetParametersRequest, rcl::SetParametersAtomicallyResponse>,
}

impl Servers {
    /// The node's services `~/NAME` of type `rcl_interfaces/srv/TYPE`, in its service mapping.
    fn create(node: &mut Node, graph: &Graph, settings: &RosOptions) -> Result<Servers> {
        let ty = |name: &str| ServiceTypeName::new("rcl_interfaces", name);
        Ok(Servers {
            list: settings.server(node, graph, "~/list_parameters", &ty("ListParameters"))?,
            describe: settings.server(
                node,
                graph,
                "~/describe_parameters",
                &ty("DescribeParameters"),
            )?,
            get: settings.server(node, graph, "~/get_parameters", &ty("GetParameters"))?,
            types: settings.server(
                node,
                graph,
                "~/get_parameter_types",
                &ty("GetParameterTypes"),
            )?,
            set: settings.server(node, graph, "~/set_parameters", &ty("SetParameters"))?,
            set_atomic: settings.server(
                node,
                graph,
                "~/set_parameters_atomically",
                &ty("SetParametersAtomically"),
            )?,
        })
    }

    /// The node's services `~/NAME` of type `rcl_interfaces/srv/TYPE` on the Zenoh `node`.
    #[cfg(feature = "zenoh")]
    fn on_zenoh(node: &ros2_client::zenoh::Node, settings: &RosOptions) -> Result<Servers> {
        let ty = |name: &str| ServiceTypeName::new("rcl_interfaces", name);
        Ok(Servers {
            list: settings.zenoh_server(node, "~/list_parameters", &ty("ListParameters"))?,
            describe: settings.zenoh_server(
                node,
                "~/describe_parameters",
                &ty("DescribeParameters"),
            )?,
            get: settings.zenoh_server(node, "~/get_parameters", &ty("GetParameters"))?,
            types: settings.zenoh_server(
                node,
                "~/get_parameter_types",
                &ty("GetParameterTypes"),
            )?,
            set: settings.zenoh_server(node, "~/set_parameters", &ty("SetParameters"))?,
            set_atomic: settings.zenoh_server(
                node,
                "~/set_parameters_atomically",
                &ty("SetParametersAtomically"),
            )?,
        })
    }
}

/// What the serving task holds besides the servers.
struct Answering<N> {
    table: Arc<Mutex<ParamTable>>,
    rules: Rules,
    events: Events,
    node_name: String,
    now: N,
    /// The tables remote sets produced, to the node.
    applied: mpsc::UnboundedSender<ParamTable>,
}

impl<N: Fn() -> Time> Answering<N> {
    /// Publishes `changed` on `/parameter_events`.
    async fn publish(&self, changed: &[Param]) {
        let ev = event(&self.node_name, changed, (self.now)());
        let sent = match &self.events {
            Events::Dds(p) => p.async_publish(ev).await.map_err(|e| format!("{e:?}")),
            #[cfg(feature = "zenoh")]
            Events::Zenoh(p) => p.async_publish(ev).await.map_err(|e| format!("{e:?}")),
        };
        if let Err(e) = sent {
            warn!("parameter event not sent: {e}");
        }
    }

    /// Answers requests, and publishes the node's own changes, until the node goes.
    async fn run(self, sv: Servers, mut own_rx: mpsc::UnboundedReceiver<Vec<Param>>) {
        let a = &self;
        let mut list_rq = sv.list.requests();
        let mut describe_rq = sv.describe.requests();
        let mut get_rq = sv.get.requests();
        let mut types_rq = sv.types.requests();
        let mut set_rq = sv.set.requests();
        let mut atomic_rq = sv.set_atomic.requests();
        // `next`, not `select_next_some`: a Zenoh server's requests end when its session
        // closes (at shutdown), and `select_next_some` panics on an ended stream
        loop {
            tokio::select! {
                Some(Ok((id, rq))) = list_rq.next() => {
                    let result = locked(&a.table).list(&rq.prefixes, rq.depth);
                    sv.list.answer(id, rcl::ListParametersResponse { result });
                }
                Some(Ok((id, rq))) = describe_rq.next() => {
                    let values = locked(&a.table).describe(&rq.names);
                    sv.describe.answer(id, rcl::DescribeParametersResponse { values });
                }
                Some(Ok((id, rq))) = get_rq.next() => {
                    let values = locked(&a.table).values(&rq.names);
                    sv.get.answer(id, rcl::GetParametersResponse { values });
                }
                Some(Ok((id, rq))) = types_rq.next() => {
                    let values = locked(&a.table).types(&rq.names);
                    sv.types.answer(id, rcl::GetParameterTypesResponse { values });
                }
                Some(Ok((id, rq))) = set_rq.next() => {
                    let params = from_wire(rq.parameter);
                    let (results, changed, after) = {
                        let mut t = locked(&a.table);
                        let (r, c) = t.set_each(&params, a.rules);
                        (r, c, t.clone())
                    };
                    log_set(&params, &results);
                    if !changed.is_empty() {
                        a.publish(&changed).await;
                        let _ = a.applied.send(after);
                    }
                    let results = results.into_iter().map(raw::SetParametersResult::from).collect();
                    sv.set.answer(id, rcl::SetParametersResponse { results });
                }
                Some(Ok((id, rq))) = atomic_rq.next() => {
                    let params = from_wire(rq.parameter);
                    let (result, after) = {
                        let mut t = locked(&a.table);
                        let r = t.set_atomically(&params, a.rules);
                        (r, t.clone())
                    };
                    log_set(&params, std::slice::from_ref(&result.as_ref().map(|_| ()).map_err(Clone::clone)));
                    if let Ok(changed) = &result {
                        if !changed.is_empty() {
                            a.publish(changed).await;
                            let _ = a.applied.send(after);
                        }
                    }
                    let result = result.map(|_| ()).into();
                    sv.set_atomic.answer(id, rcl::SetParametersAtomicallyResponse { result });
                }
                Some(changed) = own_rx.recv() => a.publish(&changed).await,
                else => break,
            }
        }
    }
}

fn locked(t: &Mutex<ParamTable>) -> std::sync::MutexGuard<'_, ParamTable> {
    t.lock().unwrap_or_else(PoisonError::into_inner)
}

fn from_wire(params: Vec<raw::Parameter>) -> Vec<Param> {
    params
        .into_iter()
        .map(|p| (p.name, ParameterValue::from(p.value)))
        .collect()
}

fn log_set(params: &[Param], results: &[Result<(), String>]) {
    for (i, r) in results.iter().enumerate() {
        let what = if results.len() == params.len() {
            format!("{} = {:?}", params[i].0, params[i].1)
        } else {
            format!("{params:?}")
        };
        match r {
            Ok(()) => info!("parameter set: {what}"),
            Err(e) => warn!("parameter set refused ({what}): {e}"),
        }
    }
}

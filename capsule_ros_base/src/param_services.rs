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

use std::sync::{Arc, Mutex, PoisonError};

use crate::error::{Context as _, Result};
use capsule_msgs::Time;
use futures::StreamExt;
use ros2_client::{
    parameters::raw,
    qos::{Durability, History, WhenFull},
    rcl_interfaces as rcl, Context, Node, ParameterValue, QosProfile, ServiceTypeName,
};
use tokio::sync::mpsc;
use tracing::{info, warn};

use crate::{
    params::{event, Param, ParamTable, Rules},
    ros::{qos, RosOptions},
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
    settings: &RosOptions,
    table: ParamTable,
    rules: Rules,
    now: impl Fn() -> Time + Send + Sync + 'static,
) -> Result<(ParamHandle, mpsc::UnboundedReceiver<ParamTable>)> {
    let mapping = settings.mapping.into();
    // The six rcl_interfaces services: `variable: service name, type => request, response`.
    macro_rules! servers {
        ($($var:ident: $name:literal, $ty:literal => $req:ident, $resp:ident;)*) => {$(
            let $var: ros2_client::Server<rcl::$req, rcl::$resp> = node
                .create_server(
                    mapping,
                    &settings.ros_name(concat!("~/", $name))?,
                    &ServiceTypeName::new("rcl_interfaces", $ty),
                    qos::service(),
                    qos::service(),
                )
                .context(concat!($name, " service"))?;
        )*};
    }
    servers! {
        list: "list_parameters", "ListParameters" => ListParametersRequest, ListParametersResponse;
        describe: "describe_parameters", "DescribeParameters" => DescribeParametersRequest, DescribeParametersResponse;
        get: "get_parameters", "GetParameters" => GetParametersRequest, GetParametersResponse;
        types: "get_parameter_types", "GetParameterTypes" => GetParameterTypesRequest, GetParameterTypesResponse;
        set: "set_parameters", "SetParameters" => SetParametersRequest, SetParametersResponse;
        set_atomic: "set_parameters_atomically", "SetParametersAtomically" => SetParametersRequest, SetParametersAtomicallyResponse;
    }
    let events = node
        .create_publisher::<raw::ParameterEvent>(
            &context.get_parameter_events_topic(),
            Some(events_qos()),
        )
        .context("/parameter_events publisher")?;
    let node_name = node.fully_qualified_name();
    let table = Arc::new(Mutex::new(table));
    let (own_tx, mut own_rx) = mpsc::unbounded_channel::<Vec<Param>>();
    let (applied_tx, applied_rx) = mpsc::unbounded_channel();
    let handle = ParamHandle {
        table: Arc::clone(&table),
        own_changes: own_tx,
    };
    tokio::spawn(async move {
        let publish = |changed: &[Param]| {
            let ev = event(&node_name, changed, now());
            let events = &events;
            async move {
                if let Err(e) = events.async_publish(ev).await {
                    warn!("parameter event not sent: {e:?}");
                }
            }
        };
        let mut list_rq = list.receive_request_stream();
        let mut describe_rq = describe.receive_request_stream();
        let mut get_rq = get.receive_request_stream();
        let mut types_rq = types.receive_request_stream();
        let mut set_rq = set.receive_request_stream();
        let mut atomic_rq = set_atomic.receive_request_stream();
        loop {
            tokio::select! {
                Ok((id, rq)) = list_rq.select_next_some() => {
                    let result = locked(&table).list(&rq.prefixes, rq.depth);
                    let _ = list.async_send_response(id, rcl::ListParametersResponse { result }).await;
                }
                Ok((id, rq)) = describe_rq.select_next_some() => {
                    let values = locked(&table).describe(&rq.names);
                    let _ = describe.async_send_response(id, rcl::DescribeParametersResponse { values }).await;
                }
                Ok((id, rq)) = get_rq.select_next_some() => {
                    let values = locked(&table).values(&rq.names);
                    let _ = get.async_send_response(id, rcl::GetParametersResponse { values }).await;
                }
                Ok((id, rq)) = types_rq.select_next_some() => {
                    let values = locked(&table).types(&rq.names);
                    let _ = types.async_send_response(id, rcl::GetParameterTypesResponse { values }).await;
                }
                Ok((id, rq)) = set_rq.select_next_some() => {
                    let params = from_wire(rq.parameter);
                    let (results, changed, after) = {
                        let mut t = locked(&table);
                        let (r, c) = t.set_each(&params, rules);
                        (r, c, t.clone())
                    };
                    log_set(&params, &results);
                    if !changed.is_empty() {
                        publish(&changed).await;
                        let _ = applied_tx.send(after);
                    }
                    let results = results.into_iter().map(raw::SetParametersResult::from).collect();
                    let _ = set.async_send_response(id, rcl::SetParametersResponse { results }).await;
                }
                Ok((id, rq)) = atomic_rq.select_next_some() => {
                    let params = from_wire(rq.parameter);
                    let (result, after) = {
                        let mut t = locked(&table);
                        let r = t.set_atomically(&params, rules);
                        (r, t.clone())
                    };
                    log_set(&params, std::slice::from_ref(&result.as_ref().map(|_| ()).map_err(Clone::clone)));
                    if let Ok(changed) = &result {
                        if !changed.is_empty() {
                            publish(changed).await;
                            let _ = applied_tx.send(after);
                        }
                    }
                    let result = result.map(|_| ()).into();
                    let _ = set_atomic.async_send_response(id, rcl::SetParametersAtomicallyResponse { result }).await;
                }
                Some(changed) = own_rx.recv() => publish(&changed).await,
                else => break,
            }
        }
    });
    Ok((handle, applied_rx))
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

//! The lifecycle served as rclcpp_lifecycle serves it: `~/change_state`, `~/get_state`,
//! `~/get_available_states`, `~/get_available_transitions`, `~/get_transition_graph`
//! (`lifecycle_msgs` types) and `~/transition_event`, on DDS or Zenoh ([`NodeOn`]: the same
//! machine and answers on both). Served by tasks of their own; the steps are taken by the
//! sample loop (its own thread on DDS, its task on Zenoh: [`super::loop_control`]), which
//! answers within a sample, so `~/get_state` says `configuring` (or `activating`, ...)
//! meanwhile.

use std::sync::{Arc, Mutex};

use capsule_msgs::names::topics::lifecycle::Endpoint;
use capsule_msgs::names::{topics::lifecycle as names, type_names};
use capsule_msgs::std_types::{
    ChangeStateRequest, ChangeStateResponse, EmptyRequest, GetAvailableStatesResponse,
    GetAvailableTransitionsResponse, GetStateResponse, LifecycleTransition, TransitionEvent,
};
use capsule_ros_base::error::Result;
use capsule_ros_base::node_on::{AnyPublisher, NodeOn};
use capsule_ros_base::service::Service;
use capsule_ros_base::{endpoints::Wire, qos, ros_options::RosOptions};
use futures::{Future, StreamExt};
use ros2_client::{MessageTypeName, ServiceTypeName};
use serde::{de::DeserializeOwned, Serialize};
use tokio::sync::{mpsc, oneshot};
use tracing::{info, warn};

use super::lifecycle::{self, Outcome, State, Step};
use super::loop_control::Request;

/// The machine's side on the node's thread: the state, the way to the loop, the events.
#[derive(Clone)]
pub struct Lifecycle {
    state: Arc<Mutex<State>>,
    to_loop: mpsc::UnboundedSender<Request>,
    events: Arc<AnyPublisher<TransitionEvent>>,
    /// One transition at a time.
    busy: Arc<tokio::sync::Mutex<()>>,
}

impl Lifecycle {
    /// The current state.
    pub fn state(&self) -> State {
        *self
            .state
            .lock()
            .unwrap_or_else(std::sync::PoisonError::into_inner)
    }

    fn enter(&self, edge: (u8, &'static str, State, State)) {
        *self
            .state
            .lock()
            .unwrap_or_else(std::sync::PoisonError::into_inner) = edge.3;
        let d = lifecycle::describe(&edge);
        let event = TransitionEvent {
            timestamp: capsule_record::writer::now_ns(),
            transition: d.transition,
            start_state: d.start_state,
            goal_state: d.goal_state,
        };
        if let Err(e) = self.events.publish(event) {
            warn!("transition event not sent: {e}");
        }
    }

    /// Takes the transition `asked` (refused with the reason in the log, the state unchanged,
    /// when it is not valid from here); true when it succeeded.
    pub async fn change(&self, asked: &LifecycleTransition) -> bool {
        let _one = self.busy.lock().await;
        let from = self.state();
        let (edge, step) = match lifecycle::begin(from, asked) {
            Ok(found) => found,
            Err(reason) => {
                warn!("lifecycle: {reason}");
                return false;
            }
        };
        info!(
            "lifecycle: {} ({} -> {})",
            edge.1,
            from.label(),
            edge.3.label()
        );
        self.enter(edge);
        let outcome = self.run(step).await;
        let out = lifecycle::finish(edge.3, outcome);
        self.enter(out);
        if out.3 == State::ErrorProcessing {
            // on_error: the loop has let go of the hardware already
            self.enter(lifecycle::finish(State::ErrorProcessing, Outcome::Success));
        }
        info!("lifecycle: {}", self.state().label());
        outcome == Outcome::Success
    }

    /// Asks the loop to take `step` and waits for its outcome (ERROR if it has ended).
    async fn run(&self, step: Step) -> Outcome {
        let (reply, outcome) = oneshot::channel();
        if self.to_loop.send(Request { step, reply }).is_err() {
            return if step == Step::Shutdown {
                Outcome::Success
            } else {
                Outcome::Error
            };
        }
        outcome.await.unwrap_or(Outcome::Error)
    }

    /// Configure, then activate (`--autostart`); the error names the step that failed.
    pub async fn autostart(&self) -> Result<()> {
        for (id, label) in [(1, "configure"), (3, "activate")] {
            let asked = LifecycleTransition {
                id,
                label: String::new(),
            };
            if !self.change(&asked).await {
                return Err(capsule_ros_base::error::NodeError::Invalid(format!(
                    "--autostart: {label} failed (the log says why)"
                )));
            }
        }
        Ok(())
    }
}

/// Serves `server`'s requests with `answer` on a task of its own.
fn serve_with<Req, Resp, F, Fut>(
    server: Service<Wire<Req>, Wire<Resp>>,
    name: &'static str,
    answer: F,
) where
    Req: Serialize + DeserializeOwned + Clone + Send + Sync + 'static,
    Resp: Serialize + DeserializeOwned + Send + Sync + 'static,
    F: Fn(Req) -> Fut + Send + 'static,
    Fut: Future<Output = Resp> + Send,
{
    tokio::spawn(async move {
        let mut requests = server.requests();
        while let Some(rq) = requests.next().await {
            match rq {
                Ok((id, Wire(req))) => {
                    server.answer(id, Wire(answer(req).await));
                }
                Err(e) => warn!("undecodable {name} request: {e:?}"),
            }
        }
    });
}

/// A server of the lifecycle service `(name, type)`.
fn server<Req, Resp>(
    on: &mut NodeOn<'_>,
    settings: &RosOptions,
    (name, full): Endpoint,
) -> Result<Service<Wire<Req>, Wire<Resp>>>
where
    Req: Serialize + DeserializeOwned + Clone + Send + Sync + 'static,
    Resp: Serialize + DeserializeOwned + Send + Sync + 'static,
{
    let (package, ty) = type_names::split(full);
    on.server(settings, name, &ServiceTypeName::new(package, ty))
}

/// Serves the lifecycle on the node `on`; the loop takes its steps from the receiver.
pub fn serve(
    mut on: NodeOn<'_>,
    settings: &RosOptions,
) -> Result<(Lifecycle, mpsc::UnboundedReceiver<Request>)> {
    let (name, full) = names::TRANSITION_EVENT;
    let (package, ty) = type_names::split(full);
    let events = on.publisher::<TransitionEvent>(
        settings,
        name,
        MessageTypeName::new(package, ty),
        &qos::data(),
    )?;
    let (to_loop, requests) = mpsc::unbounded_channel();
    let lc = Lifecycle {
        state: Arc::new(Mutex::new(State::Unconfigured)),
        to_loop,
        events: Arc::new(events),
        busy: Arc::default(),
    };
    let change =
        server::<ChangeStateRequest, ChangeStateResponse>(&mut on, settings, names::CHANGE_STATE)?;
    let l = lc.clone();
    serve_with(change, "change_state", move |req: ChangeStateRequest| {
        let l = l.clone();
        async move {
            ChangeStateResponse {
                success: l.change(&req.transition).await,
            }
        }
    });
    let get = server::<EmptyRequest, GetStateResponse>(&mut on, settings, names::GET_STATE)?;
    let l = lc.clone();
    serve_with(get, "get_state", move |_| {
        let current_state = l.state().msg();
        async move { GetStateResponse { current_state } }
    });
    let states = server::<EmptyRequest, GetAvailableStatesResponse>(
        &mut on,
        settings,
        names::GET_AVAILABLE_STATES,
    )?;
    serve_with(states, "get_available_states", |_| async {
        GetAvailableStatesResponse {
            available_states: State::ALL.iter().map(|s| s.msg()).collect(),
        }
    });
    // the transitions from here, and the whole graph: one type, two services
    for (endpoint, what, whole) in [
        (
            names::GET_AVAILABLE_TRANSITIONS,
            "get_available_transitions",
            false,
        ),
        (names::GET_TRANSITION_GRAPH, "get_transition_graph", true),
    ] {
        let srv =
            server::<EmptyRequest, GetAvailableTransitionsResponse>(&mut on, settings, endpoint)?;
        let l = lc.clone();
        serve_with(srv, what, move |_| {
            let available_transitions = if whole {
                lifecycle::GRAPH.iter().map(lifecycle::describe).collect()
            } else {
                lifecycle::available(l.state())
            };
            async move {
                GetAvailableTransitionsResponse {
                    available_transitions,
                }
            }
        });
    }
    Ok((lc, requests))
}

//! An action server on DDS that behaves as rcl_action's: ros2-client's endpoints (its
//! `ActionServer` names the three services and two topics and their types as rosidl does),
//! driven with the goal bookkeeping of [`crate::action_goals`], not with ros2-client's
//! `AsyncActionServer`, which keeps no result after it was sent once, answers no `get_result`
//! for an ended or unknown goal, and drops ended goals from the status topic at the next goal.
//!
//! ros2-client 0.12.1 hands out its three servers only one at a time (`&mut` getters), so the
//! requests are polled ([`Action::poll`]), e.g. every 10 ms; answers wait for the client's
//! reply reader as [`crate::service`]'s do.
//!
//! QoS as rcl_action's defaults: services reliable and volatile (keep last 10), feedback
//! reliable and volatile, status reliable and transient local (keep last 1), so a client that
//! joins late reads the statuses.
//!
//! Service introspection as rcl_action's (`rcl_action_server_configure_action_introspection`),
//! so rosbag2's `--all-actions` and our recorder get the goals and results, which travel only
//! in the services: each of the three services publishes on `<service>/_service_event`
//! (`<action>/_action/send_goal/_service_event`, rosidl's `A_SendGoal_Event`,
//! `A_GetResult_Event`, `action_msgs/srv/CancelGoal_Event`) a REQUEST_RECEIVED event per request
//! and a RESPONSE_SENT event per answer sent, with the client's gid and the request's sequence
//! number, stamped with the node's ROS time; [`Introspection`] chooses off, metadata or
//! contents.
//!
//! The bookkeeping does not depend on the transport: [`Action`] drives its endpoints through
//! `Endpoints`, which ros2-client's DDS `ActionServer` implements here and its Zenoh one in
//! `action_zenoh` (feature `zenoh`; there without the answers' wait for a reply reader, which
//! Zenoh's queries do not need, and without service introspection).

use std::sync::Arc;
use std::time::Instant;

use capsule_msgs::actions::{self as msgs, GoalStatus, Uuid};
use capsule_msgs::Time;
use capsule_record::cdr;
use capsule_record::types::{
    CancelGoalEvent, GetResultEvent, SendGoalEvent, ServiceEvent, ServiceEventInfo,
};
use ros2_client::action::{
    ActionServer, ActionServerQosPolicies, CancelGoalRequest, CancelGoalResponse, GoalId, GoalInfo,
    GoalStatusEnum,
};
use ros2_client::action::{GetResultResponse, SendGoalResponse};
use ros2_client::action_msgs::{self, CancelGoalResponseEnum, GoalStatusArray};
use ros2_client::dds::Node;
use ros2_client::dds::Publisher;
use ros2_client::qos::{Durability, History};
use ros2_client::{builtin_interfaces, ActionTypeName, RmwRequestId};
use serde::{de::DeserializeOwned, Serialize};
use tracing::warn;

use crate::action_goals::{GoalTable, ResultAnswer, RESULT_TIMEOUT_S};
use crate::clock::RosClock;
use crate::error::{Context as _, Result};
use crate::graph::Graph;
use crate::service::MATCH_WAIT;
use crate::{endpoints::Wire, qos, ros_options::RosOptions};

/// A request to an action server.
#[derive(Debug, Clone)]
pub enum Request<G> {
    /// A new goal: accept it ([`Action::accept`]) or refuse it ([`Action::refuse`]).
    Goal {
        /// The goal's id.
        id: GoalId,
        /// The request, to answer.
        req: RmwRequestId,
        /// The goal.
        goal: G,
    },
    /// A cancel: handled by [`Action::cancel`], which names the goals to stop.
    Cancel {
        /// The request, to answer.
        req: RmwRequestId,
        /// The goal named (zero: none).
        id: GoalId,
        /// Accepted at or before (zero: none).
        stamp: Time,
    },
}

/// A request taken, if one was waiting, or why it could not be read.
pub(crate) type Received<T> = std::result::Result<Option<T>, String>;

/// An action server's endpoints as [`Action`] drives them, whatever the transport: each
/// `receive_*` takes one request (`Ok(None)`: none waiting), each `send_*` says whether it went.
pub(crate) trait Endpoints<G, R, F>: Send + Sync {
    /// A goal request: its request id, goal id and goal.
    fn receive_goal(&self) -> Received<(RmwRequestId, GoalId, G)>;
    /// A cancel request: its request id, the goal named and the stamp.
    fn receive_cancel(&self) -> Received<(RmwRequestId, GoalId, Time)>;
    /// A get_result request: its request id and the goal named.
    fn receive_result_request(&self) -> Received<(RmwRequestId, GoalId)>;
    /// Answers a goal request.
    fn send_goal_response(&self, req: RmwRequestId, response: SendGoalResponse) -> bool;
    /// Answers a cancel request.
    fn send_cancel_response(&self, req: RmwRequestId, response: CancelGoalResponse) -> bool;
    /// Answers a get_result request with a terminal status and the result.
    fn send_result(&self, req: RmwRequestId, status: i8, result: R) -> bool;
    /// Publishes feedback of goal `id`.
    fn send_feedback(&self, id: GoalId, feedback: F) -> bool;
    /// Publishes the goals' statuses.
    fn send_statuses(&self, list: GoalStatusArray) -> std::result::Result<(), String>;
}

impl<G, R, F> Endpoints<G, R, F> for ActionServer<Wire<G>, Wire<R>, Wire<F>>
where
    G: Clone + Serialize + DeserializeOwned + Send + Sync + 'static,
    R: Clone + Serialize + DeserializeOwned + Send + Sync + 'static,
    F: Serialize + DeserializeOwned + Send + Sync + 'static,
{
    fn receive_goal(&self) -> Received<(RmwRequestId, GoalId, G)> {
        match self.receive_goal() {
            Ok(got) => Ok(got.map(|(req, goal)| (req, goal.goal_id, goal.goal.0))),
            Err(e) => Err(format!("{e:?}")),
        }
    }
    fn receive_cancel(&self) -> Received<(RmwRequestId, GoalId, Time)> {
        match self.receive_cancel_request() {
            Ok(Some((req, cancel))) => match read_cancel(&cancel) {
                Some((id, stamp)) => Ok(Some((req, id, stamp))),
                None => Err("cancel request not readable".into()),
            },
            Ok(None) => Ok(None),
            Err(e) => Err(format!("{e:?}")),
        }
    }
    fn receive_result_request(&self) -> Received<(RmwRequestId, GoalId)> {
        match self.receive_result_request() {
            Ok(got) => Ok(got.map(|(req, r)| (req, r.goal_id))),
            Err(e) => Err(format!("{e:?}")),
        }
    }
    fn send_goal_response(&self, req: RmwRequestId, response: SendGoalResponse) -> bool {
        ActionServer::send_goal_response(self, req, response).is_ok()
    }
    fn send_cancel_response(&self, req: RmwRequestId, response: CancelGoalResponse) -> bool {
        ActionServer::send_cancel_response(self, req, response).is_ok()
    }
    fn send_result(&self, req: RmwRequestId, status: i8, result: R) -> bool {
        let response = GetResultResponse {
            status: status_enum(status),
            result: Wire(result),
        };
        ActionServer::send_result(self, req, response).is_ok()
    }
    fn send_feedback(&self, id: GoalId, feedback: F) -> bool {
        ActionServer::send_feedback(self, id, Wire(feedback)).is_ok()
    }
    fn send_statuses(&self, list: GoalStatusArray) -> std::result::Result<(), String> {
        self.send_goal_statuses(list).map_err(|e| format!("{e:?}"))
    }
}

/// The status topic's QoS (rcl_action's): reliable, transient local, keep last 1.
pub fn status_qos() -> ros2_client::QosProfile {
    qos::service()
        .durability(Durability::TransientLocal)
        .history(History::KeepLast { depth: 1 })
}

/// A topic `<full>/_action/<suffix>` of DDS type `dds_type`, made on the participant
/// (ros2-client names an action's DDS types only inside its own action client and server).
fn action_topic(
    context: &ros2_client::dds::Context,
    full: &str,
    suffix: &str,
    dds_type: String,
    qos: ros2_client::QosProfile,
) -> Result<rustdds::Topic> {
    let qos: rustdds::QosPolicies = (&qos).into();
    context
        .domain_participant()
        .create_topic(
            format!("rt{full}/_action/{suffix}"),
            dds_type,
            &qos,
            rustdds::TopicKind::NoKey,
        )
        .with_context(|| format!("topic {full}/_action/{suffix}"))
}

/// The feedback and status topics of the action `name` (resolved as [`RosOptions::ros_name`])
/// of type `type_name` (`pkg/action/Name`), as an action client or a recorder reads them:
/// `<name>/_action/feedback` (`pkg::action::dds_::Name_FeedbackMessage_`) and
/// `<name>/_action/status` (`action_msgs::msg::dds_::GoalStatusArray_`), without the client's
/// three services.
pub fn feedback_and_status_topics(
    context: &ros2_client::dds::Context,
    settings: &RosOptions,
    name: &str,
    type_name: &str,
) -> Result<[rustdds::Topic; 2]> {
    let (package, ty) = capsule_msgs::names::type_names::split(type_name);
    let full = settings.resolve_name(name);
    Ok([
        action_topic(
            context,
            &full,
            "feedback",
            format!("{package}::action::dds_::{ty}_FeedbackMessage_"),
            qos::service(),
        )?,
        action_topic(
            context,
            &full,
            "status",
            "action_msgs::msg::dds_::GoalStatusArray_".to_string(),
            status_qos(),
        )?,
    ])
}

/// The service-event topics of the action `name` (resolved as [`RosOptions::ros_name`]) of
/// type `type_name` (`pkg/action/Name`), as rcl names them: `send_goal`, `get_result` and
/// `cancel_goal`'s `_service_event` under `<name>/_action/`, of rosidl's types
/// (`pkg::action::dds_::Name_SendGoal_Event_`, `pkg::action::dds_::Name_GetResult_Event_`,
/// `action_msgs::srv::dds_::CancelGoal_Event_`), with [`qos::service_events`].
pub fn service_event_topics(
    context: &ros2_client::dds::Context,
    settings: &RosOptions,
    name: &str,
    type_name: &str,
) -> Result<[rustdds::Topic; 3]> {
    let (package, ty) = capsule_msgs::names::type_names::split(type_name);
    let full = settings.resolve_name(name);
    let topic = |service: &str, dds_type: String| {
        action_topic(
            context,
            &full,
            &format!("{service}/_service_event"),
            dds_type,
            qos::service_events(),
        )
    };
    Ok([
        topic(
            "send_goal",
            format!("{package}::action::dds_::{ty}_SendGoal_Event_"),
        )?,
        topic(
            "get_result",
            format!("{package}::action::dds_::{ty}_GetResult_Event_"),
        )?,
        topic(
            "cancel_goal",
            "action_msgs::srv::dds_::CancelGoal_Event_".to_string(),
        )?,
    ])
}

/// What an action server's services publish about their requests and answers, as rcl's
/// `rcl_service_introspection_state_t`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Introspection {
    /// No service events.
    Off,
    /// Events with their kind, stamp, client and sequence number, without the request or the
    /// response.
    Metadata,
    /// Events with the request or the response too (the goals and the results).
    Contents,
}

impl std::str::FromStr for Introspection {
    type Err = String;
    fn from_str(s: &str) -> std::result::Result<Self, String> {
        match s {
            "off" => Ok(Introspection::Off),
            "metadata" => Ok(Introspection::Metadata),
            "contents" => Ok(Introspection::Contents),
            other => Err(format!(
                "{other:?} is not an introspection state (off, metadata, contents)"
            )),
        }
    }
}

/// The three services' introspection publishers.
struct Events<G: Serialize, R: Serialize> {
    send_goal: Publisher<SendGoalEvent<G>>,
    get_result: Publisher<GetResultEvent<R>>,
    cancel_goal: Publisher<CancelGoalEvent>,
    /// With the requests and responses ([`Introspection::Contents`]).
    contents: bool,
    clock: RosClock,
    name: Arc<str>,
}

impl<G: Serialize, R: Serialize> Events<G, R> {
    /// Publishes the event of request `req`: REQUEST_RECEIVED with `request`, or RESPONSE_SENT
    /// with `response`.
    fn publish<Q: Serialize, A: Serialize>(
        &self,
        on: &Publisher<ServiceEvent<Q, A>>,
        req: RmwRequestId,
        request: Option<Q>,
        response: Option<A>,
    ) {
        let event_type = match response {
            Some(_) => ServiceEventInfo::RESPONSE_SENT,
            None => ServiceEventInfo::REQUEST_RECEIVED,
        };
        fn kept<T>(x: Option<T>, contents: bool) -> Vec<T> {
            x.filter(|_| contents).into_iter().collect()
        }
        let event = ServiceEvent {
            info: ServiceEventInfo {
                event_type,
                stamp: self.clock.now(),
                client_gid: req.writer_gid.to_bytes16(),
                sequence_number: req.sequence_number,
            },
            request: kept(request, self.contents),
            response: kept(response, self.contents),
        };
        if on.publish(event).is_err() {
            warn!("{}: service event not sent", self.name);
        }
    }
}

/// One action served: goals `G`, results `R`, feedback `F`.
pub struct Action<G, R, F>
where
    G: Serialize + DeserializeOwned + Clone,
    R: Serialize + DeserializeOwned + Clone,
    F: Serialize + DeserializeOwned,
{
    server: Arc<dyn Endpoints<G, R, F>>,
    goals: GoalTable<GoalId, R, RmwRequestId>,
    /// On DDS, the graph an answer waits in for the client's reply reader (`None`: Zenoh, whose
    /// replies go to the query itself).
    graph: Option<Graph>,
    /// The action's resolved name (`/capsule_controller/move`).
    name: Arc<str>,
    start: Instant,
    /// Service introspection (`None`: off).
    events: Option<Arc<Events<G, R>>>,
}

/// The bytes of a goal id.
pub fn goal_id_bytes(id: &GoalId) -> Uuid {
    *id.uuid.as_bytes()
}

fn to_ros_time(t: Time) -> builtin_interfaces::Time {
    builtin_interfaces::Time::from_nanos(t.to_nanos())
}

fn status_enum(status: i8) -> GoalStatusEnum {
    match status {
        GoalStatus::STATUS_ACCEPTED => GoalStatusEnum::Accepted,
        GoalStatus::STATUS_EXECUTING => GoalStatusEnum::Executing,
        GoalStatus::STATUS_CANCELING => GoalStatusEnum::Canceling,
        GoalStatus::STATUS_SUCCEEDED => GoalStatusEnum::Succeeded,
        GoalStatus::STATUS_CANCELED => GoalStatusEnum::Canceled,
        GoalStatus::STATUS_ABORTED => GoalStatusEnum::Aborted,
        _ => GoalStatusEnum::Unknown,
    }
}

impl<G, R, F> Action<G, R, F>
where
    G: Clone + Serialize + DeserializeOwned + Send + Sync + 'static,
    R: Clone + Default + Serialize + DeserializeOwned + Send + Sync + 'static,
    F: Serialize + DeserializeOwned + Send + Sync + 'static,
{
    /// Serves the action `name` (resolved as [`RosOptions::ros_name`]) of type `type_name`
    /// (`pkg/action/Name`) on `node`, in the settings' service mapping.
    pub fn new(
        settings: &RosOptions,
        node: &mut Node,
        graph: &Graph,
        name: &str,
        type_name: &str,
    ) -> Result<Self> {
        let (package, ty) = capsule_msgs::names::type_names::split(type_name);
        let service = qos::service();
        let policies = ActionServerQosPolicies {
            goal_service: service.clone(),
            result_service: service.clone(),
            cancel_service: service,
            feedback_publisher: qos::service(),
            status_publisher: status_qos(),
        };
        let server = node
            .create_action_server::<Wire<G>, Wire<R>, Wire<F>>(
                settings.mapping.into(),
                &settings.ros_name(name)?,
                &ActionTypeName::new(package, ty),
                policies,
            )
            .with_context(|| format!("action {name}"))?;
        Ok(Action::with_endpoints(
            Arc::new(server),
            Some(graph.clone()),
            settings.resolve_name(name).into(),
        ))
    }

    /// The action served on `server`, its answers waiting in `graph` if any.
    pub(crate) fn with_endpoints(
        server: Arc<dyn Endpoints<G, R, F>>,
        graph: Option<Graph>,
        name: Arc<str>,
    ) -> Self {
        Action {
            server,
            goals: GoalTable::new(RESULT_TIMEOUT_S),
            graph,
            name,
            start: Instant::now(),
            events: None,
        }
    }

    /// Publishes the services' events (rcl's service introspection, [`Introspection`]) of the
    /// action of type `type_name` on `node`, stamped with `clock`.
    pub fn introspect(
        mut self,
        context: &ros2_client::dds::Context,
        settings: &RosOptions,
        node: &mut Node,
        type_name: &str,
        (clock, state): (&RosClock, Introspection),
    ) -> Result<Self> {
        if state == Introspection::Off {
            self.events = None;
            return Ok(self);
        }
        let [goal, result, cancel] =
            service_event_topics(context, settings, &self.name, type_name)?;
        let publisher = "service-event publisher";
        self.events = Some(Arc::new(Events {
            send_goal: node.create_publisher(&goal, None).context(publisher)?,
            get_result: node.create_publisher(&result, None).context(publisher)?,
            cancel_goal: node.create_publisher(&cancel, None).context(publisher)?,
            contents: state == Introspection::Contents,
            clock: clock.clone(),
            name: Arc::clone(&self.name),
        }));
        Ok(self)
    }

    /// The action's resolved name.
    pub fn name(&self) -> &str {
        &self.name
    }

    /// Whether goal `id` is known (running, or ended and its result still kept).
    pub fn knows(&self, id: GoalId) -> bool {
        self.goals.contains(id)
    }

    fn steady(&self) -> f64 {
        self.start.elapsed().as_secs_f64()
    }

    /// The requests that came since the last call (goals and cancels, in that order);
    /// `get_result` requests are answered here, now or when their goal ends. Expired results
    /// are dropped.
    pub fn poll(&mut self) -> Vec<Request<G>> {
        let mut out = Vec::new();
        loop {
            match self.server.receive_goal() {
                Ok(Some((req, id, goal))) => {
                    if let Some(ev) = &self.events {
                        let request = msgs::SendGoalRequest {
                            goal_id: goal_id_bytes(&id),
                            goal: goal.clone(),
                        };
                        ev.publish(&ev.send_goal, req, Some(request), None);
                    }
                    out.push(Request::Goal { id, req, goal })
                }
                Ok(None) => break,
                Err(e) => {
                    warn!("{}: bad goal request: {e}", self.name);
                    break;
                }
            }
        }
        loop {
            match self.server.receive_cancel() {
                Ok(Some((req, id, stamp))) => {
                    if let Some(ev) = &self.events {
                        let goal_info = msgs::GoalInfo {
                            goal_id: goal_id_bytes(&id),
                            stamp,
                        };
                        let request = msgs::CancelGoalRequest { goal_info };
                        ev.publish(&ev.cancel_goal, req, Some(request), None);
                    }
                    out.push(Request::Cancel { req, id, stamp })
                }
                Ok(None) => break,
                Err(e) => {
                    warn!("{}: bad cancel request: {e}", self.name);
                    break;
                }
            }
        }
        loop {
            match self.server.receive_result_request() {
                Ok(Some((req, goal_id))) => match self.result_request(req, goal_id) {
                    ResultAnswer::Now(status, result) => {
                        self.answer_result(req, status, result.unwrap_or_default())
                    }
                    ResultAnswer::Later => {}
                },
                Ok(None) => break,
                Err(e) => {
                    warn!("{}: bad get_result request: {e}", self.name);
                    break;
                }
            }
        }
        if self.goals.expire(self.steady()) {
            self.publish_status();
        }
        out
    }

    /// Accepts goal `id` at `stamp` (the node's ROS time) and starts executing it; false (and
    /// refused) if its id is known already.
    pub fn accept(&mut self, id: GoalId, req: RmwRequestId, stamp: Time) -> bool {
        if !self.goals.accept(id, stamp) {
            warn!(
                "{}: goal id {id:?} reused: refused (ids must be unique)",
                self.name
            );
            self.refuse(req);
            return false;
        }
        self.goals.set_status(id, GoalStatus::STATUS_EXECUTING);
        self.answer_goal(req, true, stamp);
        self.publish_status();
        true
    }

    /// Refuses a goal (rcl_action: it never shows on the status topic).
    pub fn refuse(&self, req: RmwRequestId) {
        self.answer_goal(req, false, Time::ZERO);
    }

    /// Answers a cancel request: the running goals it names become CANCELING and are returned;
    /// the caller stops them and ends them with [`Action::finish`] (CANCELED).
    pub fn cancel(&mut self, req: RmwRequestId, id: GoalId, stamp: Time) -> Vec<GoalId> {
        let (code, picked) = self.goals.cancel_request(id, stamp, GoalId::ZERO);
        for (g, _) in &picked {
            self.goals.set_status(*g, GoalStatus::STATUS_CANCELING);
        }
        if !picked.is_empty() {
            self.publish_status();
        }
        let return_code = match code {
            capsule_msgs::actions::CancelGoalResponse::ERROR_NONE => CancelGoalResponseEnum::None,
            capsule_msgs::actions::CancelGoalResponse::ERROR_UNKNOWN_GOAL_ID => {
                CancelGoalResponseEnum::UnknownGoal
            }
            capsule_msgs::actions::CancelGoalResponse::ERROR_GOAL_TERMINATED => {
                CancelGoalResponseEnum::GoalTerminated
            }
            _ => CancelGoalResponseEnum::Rejected,
        };
        let response = CancelGoalResponse {
            return_code,
            goals_canceling: picked
                .iter()
                .map(|(goal_id, s)| GoalInfo {
                    goal_id: *goal_id,
                    stamp: to_ros_time(*s),
                })
                .collect(),
        };
        let event = msgs::CancelGoalResponse {
            return_code: code,
            goals_canceling: picked
                .iter()
                .map(|(g, stamp)| msgs::GoalInfo {
                    goal_id: goal_id_bytes(g),
                    stamp: *stamp,
                })
                .collect(),
        };
        let (server, events) = (Arc::clone(&self.server), self.events.clone());
        self.answer(req, "cancel_goal", move |req| {
            let sent = server.send_cancel_response(req, response);
            if let Some(ev) = events.filter(|_| sent) {
                ev.publish(&ev.cancel_goal, req, None, Some(event));
            }
            sent
        });
        picked.into_iter().map(|(g, _)| g).collect()
    }

    /// Publishes feedback of goal `id`.
    pub fn feedback(&self, id: GoalId, feedback: F) {
        if !self.server.send_feedback(id, feedback) {
            warn!("{}: feedback not sent", self.name);
        }
    }

    /// Ends goal `id` with a terminal status and its result: the status topic says so, and
    /// every `get_result` waiting for it (and every later one, until it expires) gets it.
    pub fn finish(&mut self, id: GoalId, status: i8, result: R) {
        let waiting = self.goals.finish(id, status, result.clone(), self.steady());
        self.publish_status();
        for req in waiting {
            self.answer_result(req, status, result.clone());
        }
    }

    /// A `get_result` request for goal `id`: its event, and the table's answer.
    fn result_request(&mut self, req: RmwRequestId, id: GoalId) -> ResultAnswer<R> {
        if let Some(ev) = &self.events {
            let request = msgs::GetResultRequest {
                goal_id: goal_id_bytes(&id),
            };
            ev.publish(&ev.get_result, req, Some(request), None);
        }
        self.goals.result_request(id, req)
    }

    fn answer_goal(&self, req: RmwRequestId, accepted: bool, stamp: Time) {
        let response = SendGoalResponse {
            accepted,
            stamp: to_ros_time(stamp),
        };
        let event = msgs::SendGoalResponse { accepted, stamp };
        let (server, events) = (Arc::clone(&self.server), self.events.clone());
        self.answer(req, "send_goal", move |req| {
            let sent = server.send_goal_response(req, response);
            if let Some(ev) = events.filter(|_| sent) {
                ev.publish(&ev.send_goal, req, None, Some(event));
            }
            sent
        });
    }

    fn answer_result(&self, req: RmwRequestId, status: i8, result: R) {
        let event = msgs::GetResultResponse {
            status,
            result: result.clone(),
        };
        let (server, events) = (Arc::clone(&self.server), self.events.clone());
        self.answer(req, "get_result", move |req| {
            let sent = server.send_result(req, status, result);
            if let Some(ev) = events.filter(|_| sent) {
                ev.publish(&ev.get_result, req, None, Some(event));
            }
            sent
        });
    }

    /// Sends an answer: on DDS on a task of its own once the client's reply reader has matched
    /// ours (or after [`MATCH_WAIT`]), as [`crate::service::Service::answer`] does; on Zenoh
    /// now.
    fn answer(
        &self,
        req: RmwRequestId,
        service: &'static str,
        send: impl FnOnce(RmwRequestId) -> bool + Send + 'static,
    ) {
        let name = Arc::clone(&self.name);
        let Some(graph) = self.graph.clone() else {
            if !send(req) {
                warn!("{name}: {service} answer not sent");
            }
            return;
        };
        tokio::spawn(async move {
            let client = req.writer_gid.to_bytes16();
            let requests = format!("rq{name}/_action/{service}Request");
            let replies = format!("rr{name}/_action/{service}Reply");
            graph
                .wait_client_readers(&requests, &replies, &client[..8], MATCH_WAIT)
                .await;
            if !send(req) {
                warn!("{name}: {service} answer not sent");
            }
        });
    }

    fn publish_status(&self) {
        let list = action_msgs::GoalStatusArray {
            status_list: self
                .goals
                .statuses()
                .map(|(goal_id, stamp, status)| action_msgs::GoalStatus {
                    goal_info: GoalInfo {
                        goal_id,
                        stamp: to_ros_time(stamp),
                    },
                    status: status_enum(status),
                })
                .collect(),
        };
        if let Err(e) = self.server.send_statuses(list) {
            warn!("{}: status not sent: {e}", self.name);
        }
    }
}

/// The goal id and stamp of a cancel request. Its field is crate-private in ros2-client
/// 0.12.1: read through its wire form (CDR) as capsule_msgs' `CancelGoalRequest`.
fn read_cancel(cancel: &CancelGoalRequest) -> Option<(GoalId, Time)> {
    let ours: capsule_msgs::actions::CancelGoalRequest =
        cdr::decode(&cdr::encode(cancel).ok()?).ok()?;
    let info = ours.goal_info;
    Some((goal_id_from_bytes(info.goal_id)?, info.stamp))
}

/// A goal id from its bytes (through its wire form, 16 octets).
pub fn goal_id_from_bytes(bytes: Uuid) -> Option<GoalId> {
    cdr::decode(&cdr::encode(&bytes).ok()?).ok()
}

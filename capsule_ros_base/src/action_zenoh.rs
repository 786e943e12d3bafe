//! An action server on Zenoh ([`Action::on_zenoh`]): ros2-client's Zenoh `ActionServer` (the
//! `send_goal`, `get_result` and `cancel_goal` services and the `feedback` and `status` topics
//! under `<action>/_action/`, as rmw_zenoh_cpp names them, announced with our types' hashes)
//! behind `Endpoints`, so the goals are kept by the same [`Action`] as on DDS.
//!
//! What ros2-client's Zenoh server does not carry, and so neither do we on Zenoh: the stamp of
//! an accepted goal in its `send_goal` answer (zero; the status topic has it) and the stamp of a
//! cancel request (a cancel names its goal, or all goals with the zero id); no service
//! introspection.

use std::sync::Arc;

use capsule_msgs::Time;
use ros2_client::action::{CancelGoalResponse, GoalId, SendGoalResponse};
use ros2_client::action_msgs::GoalStatusArray;
use ros2_client::zenoh::{ActionServer, Node};
use ros2_client::{ActionTypeName, RmwRequestId};
use serde::{de::DeserializeOwned, Serialize};

use crate::action::{Action, Endpoints, Received};
use crate::endpoints::Wire;
use crate::error::{Context as _, Result};
use crate::ros_options::RosOptions;

type Server<G, R, F> = ActionServer<Wire<G>, Wire<R>, Wire<F>>;

impl<G, R, F> Endpoints<G, R, F> for Server<G, R, F>
where
    G: Serialize + DeserializeOwned + Send + Sync,
    R: Serialize + DeserializeOwned + Send + Sync,
    F: Serialize + DeserializeOwned + Send + Sync,
{
    fn receive_goal(&self) -> Received<(RmwRequestId, GoalId, G)> {
        Ok(self
            .try_receive_goal()
            .map(|(req, id, Wire(goal))| (req, id, goal)))
    }
    fn receive_cancel(&self) -> Received<(RmwRequestId, GoalId, Time)> {
        Ok(self
            .try_receive_cancel()
            .map(|(req, id)| (req, id, Time::ZERO)))
    }
    fn receive_result_request(&self) -> Received<(RmwRequestId, GoalId)> {
        Ok(self.try_receive_result_request())
    }
    fn send_goal_response(&self, req: RmwRequestId, response: SendGoalResponse) -> bool {
        self.respond_goal(req, response.accepted).is_ok()
    }
    fn send_cancel_response(&self, req: RmwRequestId, response: CancelGoalResponse) -> bool {
        self.respond_cancel(req, response.return_code, response.goals_canceling)
            .is_ok()
    }
    fn send_result(&self, req: RmwRequestId, status: i8, result: R) -> bool {
        self.respond_result(req, status, Wire(result)).is_ok()
    }
    fn send_feedback(&self, id: GoalId, feedback: F) -> bool {
        self.publish_feedback(id, Wire(feedback)).is_ok()
    }
    fn send_statuses(&self, list: GoalStatusArray) -> std::result::Result<(), String> {
        self.publish_status(list.status_list)
            .map_err(|e| format!("{e:?}"))
    }
}

impl<G, R, F> Action<G, R, F>
where
    G: Clone + Serialize + DeserializeOwned + Send + Sync + 'static,
    R: Clone + Default + Serialize + DeserializeOwned + Send + Sync + 'static,
    F: Serialize + DeserializeOwned + Send + Sync + 'static,
{
    /// Serves the action `name` (resolved as [`RosOptions::ros_name`]) of type `type_name`
    /// (`pkg/action/Name`) on the Zenoh `node`.
    pub fn on_zenoh(
        settings: &RosOptions,
        node: &Node,
        name: &str,
        type_name: &str,
    ) -> Result<Self> {
        let (package, ty) = capsule_msgs::names::type_names::split(type_name);
        let server: Server<G, R, F> = node
            .create_action_server(&settings.ros_name(name)?, &ActionTypeName::new(package, ty))
            .with_context(|| format!("action {name} on Zenoh"))?;
        Ok(Action::with_endpoints(
            Arc::new(server),
            None,
            settings.resolve_name(name).into(),
        ))
    }
}

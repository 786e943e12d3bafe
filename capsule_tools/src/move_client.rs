//! A client of the controller's Move action (`capsule_ros move`), as `ros2 action send_goal
//! --feedback` is one: sends the goal, hands each feedback to the caller, asks for the result,
//! and cancels the goal when told to (Ctrl-C).

use std::future::Future;
use std::time::Duration;

use capsule_msgs::actions::{MoveFeedback, MoveGoal, MoveResult};
use capsule_msgs::names::type_names;
use capsule_ros_base::error::{bail, invalid, Context as _, Result};
use capsule_ros_base::{endpoints::Wire, qos, ros_options::RosOptions};
use ros2_client::action::{ActionClient, ActionClientQosPolicies};
use ros2_client::dds::Node;
use ros2_client::qos::{Durability, History};
use ros2_client::ActionTypeName;

type Client = ActionClient<Wire<MoveGoal>, Wire<MoveResult>, Wire<MoveFeedback>>;

const POLL: Duration = Duration::from_millis(10);

/// How a goal ended, as the server said.
#[derive(Debug, Clone)]
pub enum MoveEnded {
    /// Refused at once (the reason is in the controller's log).
    Refused,
    /// Ended: the terminal status (`GoalStatus::STATUS_*`) and the result.
    Ended(i8, MoveResult),
}

/// The Move action's client.
pub struct MoveClient {
    client: Client,
}

impl MoveClient {
    /// The client on `node` of the action `action` (e.g. `/capsule_controller/move`).
    pub fn new(node: &mut Node, settings: &RosOptions, action: &str) -> Result<Self> {
        let (package, name) = type_names::split(type_names::MOVE);
        let policies = ActionClientQosPolicies {
            goal_service: qos::service(),
            result_service: qos::service(),
            cancel_service: qos::service(),
            feedback_subscription: qos::service(),
            status_subscription: qos::service()
                .durability(Durability::TransientLocal)
                .history(History::KeepLast { depth: 1 }),
        };
        let client = node
            .create_action_client(
                settings.mapping.into(),
                &settings.ros_name(action)?,
                &ActionTypeName::new(package, name),
                policies,
            )
            .with_context(|| format!("action client of {action}"))?;
        Ok(MoveClient { client })
    }

    /// Sends `goal`; hands every feedback to `feedback`; once `cancel` resolves, cancels the
    /// goal (once) and waits for its end. Fails when no answer comes within `answer` (the
    /// goal's) or the result does not within `result_wait` of acceptance.
    pub async fn run(
        &self,
        node: &Node,
        goal: MoveGoal,
        answer: Duration,
        result_wait: Duration,
        mut feedback: impl FnMut(&MoveFeedback),
        cancel: impl Future<Output = ()>,
    ) -> Result<MoveEnded> {
        let _ = tokio::time::timeout(
            answer.min(Duration::from_secs(5)),
            self.client.goal_client().wait_for_service(node),
        )
        .await;
        let (req, goal_id) = self
            .client
            .send_goal(Wire(goal))
            .map_err(|e| invalid!("goal not sent: {e:?}"))?;
        let deadline = tokio::time::Instant::now() + answer;
        let accepted = loop {
            if let Some(r) = self
                .client
                .receive_goal_response(req)
                .map_err(|e| invalid!("goal answer unreadable: {e:?}"))?
            {
                break r.accepted;
            }
            if tokio::time::Instant::now() >= deadline {
                bail!("no answer to the goal within {answer:?} (is the controller running?)");
            }
            tokio::time::sleep(POLL).await;
        };
        if !accepted {
            return Ok(MoveEnded::Refused);
        }
        let result_req = self
            .client
            .request_result(goal_id)
            .map_err(|e| invalid!("result request not sent: {e:?}"))?;
        let deadline = tokio::time::Instant::now() + result_wait;
        tokio::pin!(cancel);
        let mut canceled = false;
        loop {
            while let Ok(Some(Wire(f))) = self.client.receive_feedback(goal_id) {
                feedback(&f);
            }
            if let Some((status, Wire(result))) = self
                .client
                .receive_result(result_req)
                .map_err(|e| invalid!("result unreadable: {e:?}"))?
            {
                return Ok(MoveEnded::Ended(status as i8, result));
            }
            if tokio::time::Instant::now() >= deadline {
                bail!("no result within {result_wait:?} of acceptance");
            }
            tokio::select! {
                _ = &mut cancel, if !canceled => {
                    canceled = true;
                    self.client
                        .cancel_goal(goal_id)
                        .map_err(|e| invalid!("cancel not sent: {e:?}"))?;
                }
                _ = tokio::time::sleep(POLL) => {}
            }
        }
    }
}

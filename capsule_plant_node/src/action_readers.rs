//! Readers of the controller's actions for a recording and the live view, as rosbag2 records
//! an action: its feedback and status topics (`<action>/_action/feedback`,
//! `<action>/_action/status`, rosidl's types), read as an action client reads them but without
//! the client's three services, so a recorder sends no goal and needs no permission to. The
//! goals and results themselves travel in the action's services: a recorder reads them as
//! rosbag2's `--all-actions` does, from the services' introspection events
//! (`<action>/_action/{send_goal,get_result,cancel_goal}/_service_event`, which the controller
//! publishes as rcl_action does, [`capsule_ros_base::action`]).

use capsule_msgs::actions::{
    FeedbackMessage, GoalStatusArray, MoveFeedback, MoveGoal, MoveResult, SwitchAttractorFeedback,
    SwitchAttractorGoal, SwitchAttractorResult,
};
use capsule_msgs::names::{topics, type_names};
use capsule_record::types::{CancelGoalEvent, GetResultEvent, SendGoalEvent};
use capsule_ros_base::action::{feedback_and_status_topics, service_event_topics, status_qos};
use capsule_ros_base::error::Result;
use capsule_ros_base::{endpoints::subscribe, qos, ros_options::RosOptions};
use ros2_client::dds::Subscription;
use ros2_client::qos::History;
use ros2_client::MessageInfo;

/// One sample of an action's topics.
#[derive(Debug, Clone)]
pub enum ActionSample {
    /// Move's feedback.
    MoveFeedback(FeedbackMessage<MoveFeedback>),
    /// Move's statuses.
    MoveStatus(GoalStatusArray),
    /// SwitchAttractor's feedback.
    SwitchFeedback(FeedbackMessage<SwitchAttractorFeedback>),
    /// SwitchAttractor's statuses.
    SwitchStatus(GoalStatusArray),
}

/// One service event of an action (its goals, results and cancels).
#[derive(Debug, Clone)]
pub enum ActionEvent {
    /// Move's `send_goal`.
    MoveSendGoal(SendGoalEvent<MoveGoal>),
    /// Move's `get_result`.
    MoveGetResult(GetResultEvent<MoveResult>),
    /// Move's `cancel_goal`.
    MoveCancelGoal(CancelGoalEvent),
    /// SwitchAttractor's `send_goal`.
    SwitchSendGoal(SendGoalEvent<SwitchAttractorGoal>),
    /// SwitchAttractor's `get_result`.
    SwitchGetResult(GetResultEvent<SwitchAttractorResult>),
    /// SwitchAttractor's `cancel_goal`.
    SwitchCancelGoal(CancelGoalEvent),
}

/// The actions' names under `controller_node` (relative, as a recorder names it): move, then
/// switch_attractor.
pub fn action_names(controller_node: &str) -> [String; 2] {
    [topics::MOVE, topics::SWITCH_ATTRACTOR]
        .map(|relative| format!("{controller_node}/{}", relative.trim_start_matches("~/")))
}

/// Readers of both actions' feedback and status.
pub struct ActionReaders {
    move_feedback: Subscription<FeedbackMessage<MoveFeedback>>,
    move_status: Subscription<GoalStatusArray>,
    switch_feedback: Subscription<FeedbackMessage<SwitchAttractorFeedback>>,
    switch_status: Subscription<GoalStatusArray>,
    events: Option<EventReaders>,
}

/// Readers of both actions' service events.
struct EventReaders {
    move_goal: Subscription<SendGoalEvent<MoveGoal>>,
    move_result: Subscription<GetResultEvent<MoveResult>>,
    move_cancel: Subscription<CancelGoalEvent>,
    switch_goal: Subscription<SendGoalEvent<SwitchAttractorGoal>>,
    switch_result: Subscription<GetResultEvent<SwitchAttractorResult>>,
    switch_cancel: Subscription<CancelGoalEvent>,
}

/// Takes every sample `sub` holds into `f`, wrapped by `wrap`; how many.
fn take_all<M: serde::de::DeserializeOwned + 'static, S>(
    sub: &Subscription<M>,
    wrap: fn(M) -> S,
    f: &mut impl FnMut(S, &MessageInfo) -> Result<()>,
) -> Result<usize> {
    crate::take_each::take_each(sub, "action", |msg, info| f(wrap(msg), info).map(|()| true))
}

impl ActionReaders {
    /// Subscribes to the actions of `controller_node` (relative, as the recorder names it): to
    /// their service events too if `with_events`.
    pub fn subscribe(
        context: &ros2_client::dds::Context,
        node: &mut ros2_client::dds::Node,
        settings: &RosOptions,
        controller_node: &str,
        with_events: bool,
    ) -> Result<Self> {
        let [m, s] = action_names(controller_node);
        let [mf, ms] = feedback_and_status_topics(context, settings, &m, type_names::MOVE)?;
        let [sf, ss] =
            feedback_and_status_topics(context, settings, &s, type_names::SWITCH_ATTRACTOR)?;
        // reliable and deep (few, and all kept); the status transient local as offered, so the
        // goals' last statuses come in too
        let deep = qos::data().history(History::KeepLast { depth: 1000 });
        let status = status_qos().history(History::KeepLast { depth: 1000 });
        Ok(ActionReaders {
            move_feedback: subscribe(node, &mf, &deep)?,
            move_status: subscribe(node, &ms, &status)?,
            switch_feedback: subscribe(node, &sf, &deep)?,
            switch_status: subscribe(node, &ss, &status)?,
            events: with_events
                .then(|| EventReaders::subscribe(context, node, settings, [m.as_str(), s.as_str()]))
                .transpose()?,
        })
    }

    /// Hands every service event the readers hold to `f`, with how it was received; how many
    /// (none if not subscribed to them).
    pub fn take_events(
        &self,
        mut f: impl FnMut(ActionEvent, &MessageInfo) -> Result<()>,
    ) -> Result<usize> {
        let Some(e) = &self.events else { return Ok(0) };
        use ActionEvent::*;
        Ok(take_all(&e.move_goal, MoveSendGoal, &mut f)?
            + take_all(&e.move_result, MoveGetResult, &mut f)?
            + take_all(&e.move_cancel, MoveCancelGoal, &mut f)?
            + take_all(&e.switch_goal, SwitchSendGoal, &mut f)?
            + take_all(&e.switch_result, SwitchGetResult, &mut f)?
            + take_all(&e.switch_cancel, SwitchCancelGoal, &mut f)?)
    }

    /// Hands every sample the readers hold to `f`, with how it was received; how many.
    pub fn take(
        &self,
        mut f: impl FnMut(ActionSample, &MessageInfo) -> Result<()>,
    ) -> Result<usize> {
        Ok(
            take_all(&self.move_feedback, ActionSample::MoveFeedback, &mut f)?
                + take_all(&self.move_status, ActionSample::MoveStatus, &mut f)?
                + take_all(&self.switch_feedback, ActionSample::SwitchFeedback, &mut f)?
                + take_all(&self.switch_status, ActionSample::SwitchStatus, &mut f)?,
        )
    }
}

impl EventReaders {
    /// Subscribes to the service events of the actions `move` and `switch` (relative names),
    /// with the QoS the controller offers them (transient local: the events of goals sent
    /// before the recorder matched come in too).
    fn subscribe(
        context: &ros2_client::dds::Context,
        node: &mut ros2_client::dds::Node,
        settings: &RosOptions,
        [m, s]: [&str; 2],
    ) -> Result<Self> {
        let [mg, mr, mc] = service_event_topics(context, settings, m, type_names::MOVE)?;
        let [sg, sr, sc] =
            service_event_topics(context, settings, s, type_names::SWITCH_ATTRACTOR)?;
        let q = qos::service_events();
        Ok(EventReaders {
            move_goal: subscribe(node, &mg, &q)?,
            move_result: subscribe(node, &mr, &q)?,
            move_cancel: subscribe(node, &mc, &q)?,
            switch_goal: subscribe(node, &sg, &q)?,
            switch_result: subscribe(node, &sr, &q)?,
            switch_cancel: subscribe(node, &sc, &q)?,
        })
    }
}

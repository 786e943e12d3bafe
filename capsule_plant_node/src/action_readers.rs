//! Readers of the controller's actions for a recording and the live view, as rosbag2 records
//! an action: its feedback and status topics (`<action>/_action/feedback`,
//! `<action>/_action/status`, rosidl's types), read as an action client reads them but without
//! the client's three services, so a recorder sends no goal and needs no permission to. The
//! goals and results themselves travel in the action's services (rosbag2 gets them from service
//! introspection, which the controller does not publish for its actions); the status topic shows
//! each goal's acceptance and end.

use capsule_msgs::actions::{
    FeedbackMessage, GoalStatusArray, MoveFeedback, SwitchAttractorFeedback,
};
use capsule_msgs::names::{topics, type_names};
use capsule_ros_base::action::{feedback_and_status_topics, status_qos};
use capsule_ros_base::error::Result;
use capsule_ros_base::{endpoints::subscribe, qos, ros_options::RosOptions};
use ros2_client::dds::Subscription;
use ros2_client::qos::History;
use ros2_client::MessageInfo;
use tracing::warn;

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
}

/// Takes every sample `sub` holds into `f`, wrapped by `wrap`; how many.
fn take_all<M: serde::de::DeserializeOwned + 'static>(
    sub: &Subscription<M>,
    wrap: fn(M) -> ActionSample,
    f: &mut impl FnMut(ActionSample, &MessageInfo) -> Result<()>,
) -> Result<usize> {
    let mut n = 0;
    loop {
        match sub.take() {
            Ok(Some((msg, info))) => {
                f(wrap(msg), &info)?;
                n += 1;
            }
            Ok(None) => return Ok(n),
            Err(e) => {
                warn!("bad action sample: {e:?}");
                return Ok(n);
            }
        }
    }
}

impl ActionReaders {
    /// Subscribes to the actions of `controller_node` (relative, as the recorder names it).
    pub fn subscribe(
        context: &ros2_client::dds::Context,
        node: &mut ros2_client::dds::Node,
        settings: &RosOptions,
        controller_node: &str,
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
        })
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

//! The plant's lifecycle state as the controller follows it: every `transition_event` the plant
//! publishes, and its `get_state` asked at start and every [`PlantLifecycle::ASK_EVERY`] (a
//! plant started before the controller publishes no event, a restarted one's first events can
//! come before discovery matched).
//!
//! Why: the controller's other evidence of an inactive plant is the state samples' applied
//! force (zero on a run of new samples, [`crate::command_feedback`]); a lock-step plant that is
//! inactive stands still, re-sending one sample, so in lock-step that evidence never comes and
//! a goal was accepted for an inactive plant. The plant followed is `capsule_plant` in the
//! controller's namespace (`capsule_msgs::names::nodes::PLANT`); the core decides with what it
//! hears ([`crate::controller_core::ControllerCore::plant_lifecycle`]).

use std::time::{Duration, Instant};

use capsule_msgs::names::{nodes, topics::lifecycle as names, type_names};
use capsule_msgs::std_types::{EmptyRequest, GetStateResponse, TransitionEvent};
use capsule_ros_base::endpoints::{subscribe, Wire};
use capsule_ros_base::error::{Context as _, Result};
use capsule_ros_base::{qos, ros_options::RosOptions};
use ros2_client::dds::{Client, Node, Subscription};
use ros2_client::{MessageTypeName, RmwRequestId, ServiceTypeName};
use tracing::{debug, info};

/// Follows the plant's lifecycle state.
pub struct PlantLifecycle {
    events: Subscription<Wire<TransitionEvent>>,
    get_state: Client<Wire<EmptyRequest>, Wire<GetStateResponse>>,
    /// The last `get_state` request, when it went, and whether an event came since (its
    /// answer is then older than what the event said, and ignored, as are earlier requests').
    asked: Option<(RmwRequestId, Instant, bool)>,
    state: Option<(u8, String)>,
}

impl PlantLifecycle {
    /// How often `get_state` is asked again.
    pub const ASK_EVERY: Duration = Duration::from_secs(1);

    /// The follower's subscription and client on `node`.
    pub fn new(settings: &RosOptions, node: &mut Node) -> Result<Self> {
        let of_plant = |name: &str| format!("{}/{}", nodes::PLANT, name.trim_start_matches("~/"));
        let (event_name, event_type) = names::TRANSITION_EVENT;
        let (package, ty) = type_names::split(event_type);
        let topic = settings.topic(
            node,
            &of_plant(event_name),
            MessageTypeName::new(package, ty),
            &qos::data(),
        )?;
        let events = subscribe(node, &topic, &qos::data())?;
        let (service, full) = names::GET_STATE;
        let (package, ty) = type_names::split(full);
        let name = of_plant(service);
        let get_state = node
            .create_client::<Wire<EmptyRequest>, Wire<GetStateResponse>>(
                settings.mapping.into(),
                &settings.ros_name(&name)?,
                &ServiceTypeName::new(package, ty),
                qos::service(),
                qos::service(),
            )
            .with_context(|| format!("{name} client"))?;
        Ok(PlantLifecycle {
            events,
            get_state,
            asked: None,
            state: None,
        })
    }

    /// Reads what came and asks again when due; returns the state's id when it changed.
    pub fn poll(&mut self) -> Option<u8> {
        let before = self.state.as_ref().map(|s| s.0);
        while let Ok(Some((Wire(e), _))) = self.events.take() {
            self.asked = self.asked.map(|(id, t, _)| (id, t, true));
            self.state = Some((e.goal_state.id, e.goal_state.label));
        }
        while let Ok(Some((id, Wire(r)))) = self.get_state.receive_response() {
            if self
                .asked
                .is_some_and(|(last, _, stale)| last == id && !stale)
            {
                self.state = Some((r.current_state.id, r.current_state.label));
            }
        }
        if self
            .asked
            .is_none_or(|(_, t, _)| t.elapsed() >= Self::ASK_EVERY)
        {
            match self.get_state.send_request(Wire(EmptyRequest::default())) {
                Ok(id) => self.asked = Some((id, Instant::now(), false)),
                Err(e) => debug!("plant get_state not sent: {e:?}"),
            }
        }
        let now = self.state.as_ref().map(|s| s.0);
        if now != before {
            if let Some((id, label)) = &self.state {
                info!("the plant's lifecycle: {label} ({id})");
            }
            return now;
        }
        None
    }
}

//! The plant's managed lifecycle, as rclcpp_lifecycle's state machine defines it: the primary
//! states unconfigured, inactive, active and finalized, the transition states between them, and
//! ErrorProcessing when a callback fails. This file is the machine (no DDS): which transition
//! is valid from where, what the sample loop must do for it ([`Step`]), and where each result
//! leads; `lifecycle_services` serves it.

use capsule_msgs::std_types::{LifecycleState, LifecycleTransition, TransitionDescription};

/// A lifecycle state, numbered as `lifecycle_msgs/msg/State`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum State {
    /// Built, nothing opened (id 1).
    Unconfigured,
    /// The hardware configured; samples published, zero force (2).
    Inactive,
    /// Commands actuate (3).
    Active,
    /// Shut down (4).
    Finalized,
    /// Configuring (10).
    Configuring,
    /// Cleaning up (11).
    CleaningUp,
    /// Shutting down (12).
    ShuttingDown,
    /// Activating (13).
    Activating,
    /// Deactivating (14).
    Deactivating,
    /// A callback failed; cleaning up (15).
    ErrorProcessing,
}

impl State {
    /// Every state, as `~/get_available_states` lists them.
    pub const ALL: [State; 10] = [
        State::Unconfigured,
        State::Inactive,
        State::Active,
        State::Finalized,
        State::Configuring,
        State::CleaningUp,
        State::ShuttingDown,
        State::Activating,
        State::Deactivating,
        State::ErrorProcessing,
    ];

    /// lifecycle_msgs' id and rcl's label, in [`State::ALL`]'s order.
    const NAMES: [(u8, &'static str); 10] = [
        (1, "unconfigured"),
        (2, "inactive"),
        (3, "active"),
        (4, "finalized"),
        (10, "configuring"),
        (11, "cleaningup"),
        (12, "shuttingdown"),
        (13, "activating"),
        (14, "deactivating"),
        (15, "errorprocessing"),
    ];

    fn names(self) -> (u8, &'static str) {
        let i = State::ALL.iter().position(|s| *s == self).unwrap_or(0);
        State::NAMES[i]
    }

    /// lifecycle_msgs' id.
    pub fn id(self) -> u8 {
        self.names().0
    }

    /// rcl's label.
    pub fn label(self) -> &'static str {
        self.names().1
    }

    /// As a message.
    pub fn msg(self) -> LifecycleState {
        LifecycleState {
            id: self.id(),
            label: self.label().into(),
        }
    }
}

/// What the sample loop does for a transition (the `on_*` callback).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Step {
    /// Build the simulator / open the device; samples start.
    Configure,
    /// Close the line; samples stop.
    Cleanup,
    /// Commands actuate.
    Activate,
    /// Zero force from the next sample on.
    Deactivate,
    /// Close the line; the node ends.
    Shutdown,
}

/// How a callback ended (rclcpp's `CallbackReturn`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Outcome {
    /// SUCCESS.
    Success,
    /// FAILURE: back to where it started.
    Failure,
    /// ERROR: to ErrorProcessing.
    Error,
}

/// One edge of the graph: `(id, label, start, goal)`.
type Edge = (u8, &'static str, State, State);

use State::*;

/// rcl's default state machine, every edge (what `~/get_transition_graph` lists).
pub const GRAPH: [Edge; 25] = [
    (1, "configure", Unconfigured, Configuring),
    (10, "transition_success", Configuring, Inactive),
    (11, "transition_failure", Configuring, Unconfigured),
    (12, "transition_error", Configuring, ErrorProcessing),
    (2, "cleanup", Inactive, CleaningUp),
    (20, "transition_success", CleaningUp, Unconfigured),
    (21, "transition_failure", CleaningUp, Inactive),
    (22, "transition_error", CleaningUp, ErrorProcessing),
    (3, "activate", Inactive, Activating),
    (30, "transition_success", Activating, Active),
    (31, "transition_failure", Activating, Inactive),
    (32, "transition_error", Activating, ErrorProcessing),
    (4, "deactivate", Active, Deactivating),
    (40, "transition_success", Deactivating, Inactive),
    (41, "transition_failure", Deactivating, Active),
    (42, "transition_error", Deactivating, ErrorProcessing),
    (5, "shutdown", Unconfigured, ShuttingDown),
    (6, "shutdown", Inactive, ShuttingDown),
    (7, "shutdown", Active, ShuttingDown),
    (50, "transition_success", ShuttingDown, Finalized),
    (51, "transition_failure", ShuttingDown, Finalized),
    (52, "transition_error", ShuttingDown, ErrorProcessing),
    (60, "transition_success", ErrorProcessing, Unconfigured),
    (61, "transition_failure", ErrorProcessing, Finalized),
    (62, "transition_error", ErrorProcessing, Finalized),
];

/// An edge as a message.
pub fn describe(e: &Edge) -> TransitionDescription {
    TransitionDescription {
        transition: LifecycleTransition {
            id: e.0,
            label: e.1.into(),
        },
        start_state: e.2.msg(),
        goal_state: e.3.msg(),
    }
}

/// The edges a client may ask for from `state` (`~/get_available_transitions`).
pub fn available(state: State) -> Vec<TransitionDescription> {
    GRAPH
        .iter()
        .filter(|e| e.2 == state && e.0 < 10)
        .map(describe)
        .collect()
}

/// The transition a request asks for from `state` (its label takes precedence over its id, as
/// in rclcpp: `ros2 service call` leaves the id 0), with the step the loop takes; the reason
/// when it is not valid from there.
pub fn begin(state: State, asked: &LifecycleTransition) -> Result<(Edge, Step), String> {
    let found = GRAPH.iter().find(|e| {
        e.2 == state
            && e.0 < 10
            && if asked.label.is_empty() {
                e.0 == asked.id
            } else {
                e.1 == asked.label
            }
    });
    let Some(edge) = found else {
        let what = if asked.label.is_empty() {
            format!("transition {}", asked.id)
        } else {
            format!("transition `{}`", asked.label)
        };
        let valid: Vec<String> = available(state)
            .iter()
            .map(|t| format!("{} ({})", t.transition.label, t.transition.id))
            .collect();
        return Err(format!(
            "{what} is not valid from {}: valid are {}",
            state.label(),
            if valid.is_empty() {
                "none".to_string()
            } else {
                valid.join(", ")
            }
        ));
    };
    let step = match edge.0 {
        1 => Step::Configure,
        2 => Step::Cleanup,
        3 => Step::Activate,
        4 => Step::Deactivate,
        _ => Step::Shutdown,
    };
    Ok((*edge, step))
}

/// The edge a callback's `outcome` takes out of the transition state `from`.
pub fn finish(from: State, outcome: Outcome) -> Edge {
    let label = match outcome {
        Outcome::Success => "transition_success",
        Outcome::Failure => "transition_failure",
        Outcome::Error => "transition_error",
    };
    GRAPH
        .iter()
        .find(|e| e.2 == from && e.1 == label)
        .copied()
        .unwrap_or((62, "transition_error", from, Finalized))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn ask(id: u8, label: &str) -> LifecycleTransition {
        LifecycleTransition {
            id,
            label: label.into(),
        }
    }

    #[test]
    fn the_graph_is_rcl_s_and_invalid_transitions_say_why() {
        let (edge, step) = begin(Unconfigured, &ask(1, "")).expect("configure");
        assert_eq!((edge.3, step), (Configuring, Step::Configure));
        assert_eq!(finish(Configuring, Outcome::Success).3, Inactive);
        assert_eq!(finish(Configuring, Outcome::Error).3, ErrorProcessing);
        assert_eq!(finish(ErrorProcessing, Outcome::Success).3, Unconfigured);
        // by label, id 0 (ros2 service call's default)
        assert_eq!(begin(Active, &ask(0, "shutdown")).map(|(e, _)| e.0), Ok(7));
        let e = begin(Unconfigured, &ask(3, "")).err().unwrap_or_default();
        assert_eq!(
            e,
            "transition 3 is not valid from unconfigured: valid are configure (1), shutdown (5)"
        );
        assert!(
            begin(Finalized, &ask(0, "configure")).is_err_and(|e| e.ends_with("valid are none"))
        );
        assert_eq!(available(Inactive).len(), 3);
        assert_eq!(State::ALL.len(), 10);
        assert_eq!(
            (ErrorProcessing.id(), ErrorProcessing.label()),
            (15, "errorprocessing")
        );
    }
}

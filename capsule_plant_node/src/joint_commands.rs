//! Commands as `topic_based_ros2_control` sends them: a `sensor_msgs/JointState` on
//! `capsule/joint_commands` (the plant's `--joint-commands`), whose `effort` of the inner-mass
//! joint ([`JOINT`]) is the actuator force \[N\].
//!
//! The joint is found by name; `effort` must hold one value per name (sensor_msgs/JointState's
//! rule; `topic_based_ros2_control` sends it so when every joint of its `ros2_control` block has
//! an effort command interface, as in docs/ros2_control/). A command answers the plant's newest
//! sample: its stamp is the sender's clock (`node->now()`), which orders nothing here. The
//! force then goes through the plant's own checks, as one from the force topic: non-finite
//! refused and counted, beyond the limit saturated (see [`crate::command_gate`]), the watchdog.

use capsule_msgs::{std_types::JointState, ActuatorForce, Header, Time};

use crate::views::JOINTS;

/// The commanded joint: the inner mass's prismatic joint in the capsule.
pub const JOINT: &str = JOINTS[1];

/// Why a JointState command cannot be taken.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum JointCommandError {
    /// The inner-mass joint is not among the names.
    #[error("no joint named {JOINT} in {0:?}")]
    NoJoint(Vec<String>),
    /// `effort` does not hold one value per name.
    #[error("effort has {effort} values for {names} names (sensor_msgs/JointState: one per name): cannot tell {JOINT}'s")]
    Effort {
        /// Values in `effort`.
        effort: usize,
        /// Names.
        names: usize,
    },
}

/// The force command a JointState carries, answering the sample `seq` stamped `stamp`.
pub fn to_force(
    js: &JointState,
    seq: u64,
    stamp: Time,
    frame_id: &str,
) -> Result<ActuatorForce, JointCommandError> {
    let i = js
        .name
        .iter()
        .position(|n| n == JOINT)
        .ok_or_else(|| JointCommandError::NoJoint(js.name.clone()))?;
    if js.effort.len() != js.name.len() {
        return Err(JointCommandError::Effort {
            effort: js.effort.len(),
            names: js.name.len(),
        });
    }
    Ok(ActuatorForce {
        header: Header {
            stamp,
            frame_id: frame_id.to_string(),
        },
        state_seq: seq,
        force: js.effort[i],
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn js(names: &[&str], effort: &[f64]) -> JointState {
        JointState {
            name: names.iter().map(|s| s.to_string()).collect(),
            effort: effort.to_vec(),
            ..JointState::default()
        }
    }

    #[test]
    fn the_inner_mass_effort_is_the_force_by_name() {
        let t = Time::from_secs_f64(1.5);
        let c = to_force(&js(&["inner_mass_joint"], &[0.25]), 7, t, "odom");
        assert_eq!(c.as_ref().map(|c| c.force), Ok(0.25));
        assert_eq!(
            c.as_ref().map(|c| (c.state_seq, c.header.stamp)),
            Ok((7, t))
        );
        let c = to_force(
            &js(&["capsule_joint", "inner_mass_joint"], &[9.0, -0.5]),
            0,
            t,
            "odom",
        );
        assert_eq!(c.map(|c| c.force), Ok(-0.5));
        // non-finite passes through: the plant refuses it as from the force topic
        let c = to_force(&js(&["inner_mass_joint"], &[f64::NAN]), 0, t, "odom");
        assert!(c.is_ok_and(|c| c.force.is_nan()));
    }

    #[test]
    fn a_command_without_the_joint_or_its_effort_is_refused_with_the_reason() {
        let t = Time::ZERO;
        let e = to_force(&js(&["wheel"], &[1.0]), 0, t, "odom");
        assert_eq!(e, Err(JointCommandError::NoJoint(vec!["wheel".into()])));
        let e = to_force(
            &js(&["capsule_joint", "inner_mass_joint"], &[1.0]),
            0,
            t,
            "o",
        );
        assert_eq!(
            e,
            Err(JointCommandError::Effort {
                effort: 1,
                names: 2
            })
        );
        let msg = to_force(&js(&["inner_mass_joint"], &[]), 0, t, "o")
            .map(|_| ())
            .unwrap_err()
            .to_string();
        assert!(msg.contains("effort has 0 values for 1 names"), "{msg}");
    }
}

//! The `CapsuleState` message a hardware sample becomes: what the plant node publishes and an
//! offline recording (`capsule simulate --record`) holds, so both carry the same numbers.

use capsule_hardware::Sample;
use capsule_msgs::{CapsuleState, Header};

/// A sample `s` (SI) as a `CapsuleState` with `header` and `seq`, its commands fresh and none
/// refused: the plant node's messages and offline recordings alike.
pub fn state_message(s: &Sample, header: Header, seq: u64) -> CapsuleState {
    CapsuleState {
        header,
        seq,
        mass_position: s.mass_position,
        mass_velocity: s.mass_velocity,
        capsule_position: s.capsule_position,
        capsule_velocity: s.capsule_velocity,
        in_contact: s.in_contact,
        stuck: s.stuck,
        friction_force: s.friction_force,
        contact_force: s.contact_force,
        actuator_force: s.actuator_force,
        command_stale: false,
        rejected_commands: 0,
    }
}

//! The `CapsuleState` message a simulator sample becomes: what the plant node publishes and an
//! offline recording (`capsule simulate --record`) holds, so both carry the same numbers.

use capsule_msgs::{CapsuleState, Header};
use capsule_plant::scene::PhysicalScale;
use capsule_plant::Snapshot;

/// A sample `s` as a `CapsuleState` in SI units (`scale`) with `header` and `seq`, its commands
/// fresh and none refused: the plant node's messages and offline recordings alike.
pub fn state_message(
    s: &Snapshot,
    scale: &PhysicalScale,
    header: Header,
    seq: u64,
) -> CapsuleState {
    let (l, v, f) = (scale.length_m(), scale.velocity_m_per_s(), scale.force_n());
    CapsuleState {
        header,
        seq,
        mass_position: s.state.x1 * l,
        mass_velocity: s.state.y1 * v,
        capsule_position: s.state.x2 * l,
        capsule_velocity: s.state.y2 * v,
        in_contact: s.contact,
        stuck: s.stuck,
        friction_force: s.friction_force * f,
        contact_force: s.contact_force * f,
        actuator_force: s.actuator_force * f,
        command_stale: false,
        rejected_commands: 0,
    }
}

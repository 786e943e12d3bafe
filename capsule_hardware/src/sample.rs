//! What a hardware `read` returns: one measurement of the capsule in SI, NaN where a device does
//! not measure. The plant node adds the header, the sample counter and its own flags when it
//! publishes it as a `CapsuleState`.

use capsule_plant::scene::PhysicalScale;
use capsule_plant::Snapshot;

/// One sample of the capsule in SI units.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct Sample {
    /// Inner mass position \[m\].
    pub mass_position: f64,
    /// Inner mass velocity \[m/s\].
    pub mass_velocity: f64,
    /// Capsule position \[m\].
    pub capsule_position: f64,
    /// Capsule velocity \[m/s\].
    pub capsule_velocity: f64,
    /// The mass touches the secondary spring.
    pub in_contact: bool,
    /// The capsule sticks to the ground.
    pub stuck: bool,
    /// Friction force on the capsule \[N\].
    pub friction_force: f64,
    /// Secondary-spring contact force \[N\].
    pub contact_force: f64,
    /// Actuator force applied on the inner mass over the last period \[N\].
    pub actuator_force: f64,
}

impl Sample {
    /// Nothing measured yet: NaN everywhere.
    pub fn unknown() -> Sample {
        let nan = f64::NAN;
        Sample {
            mass_position: nan,
            mass_velocity: nan,
            capsule_position: nan,
            capsule_velocity: nan,
            in_contact: false,
            stuck: false,
            friction_force: nan,
            contact_force: nan,
            actuator_force: nan,
        }
    }

    /// A simulator's non-dimensional snapshot `s` in SI with `scale`.
    pub fn from_snapshot(s: &Snapshot, scale: &PhysicalScale) -> Sample {
        let (l, v, f) = (scale.length_m(), scale.velocity_m_per_s(), scale.force_n());
        Sample {
            mass_position: s.state.x1 * l,
            mass_velocity: s.state.y1 * v,
            capsule_position: s.state.x2 * l,
            capsule_velocity: s.state.y2 * v,
            in_contact: s.contact,
            stuck: s.stuck,
            friction_force: s.friction_force * f,
            contact_force: s.contact_force * f,
            actuator_force: s.actuator_force * f,
        }
    }
}

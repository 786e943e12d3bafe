//! capsule's ROS 2 interfaces as plain serde types (no ROS, no I/O).
//!
//! The `.msg` / `.srv` / `.action` files beside this crate are the contract: they form a regular rosidl
//! interface package (`package.xml`, `CMakeLists.txt`) that colcon builds for rclcpp / rclpy,
//! and the structs here serialise field for field, in the same order, to the same CDR layout.
//! A test parses the interface files and checks every struct against them, so the two cannot
//! drift. The interface texts are embedded (`CapsuleState::MSG_TEXT`, ...) so that
//! recorders can write `ros2msg` schemas.

#![warn(missing_docs)]

use serde::{Deserialize, Serialize};

pub mod actions;
mod constants;
pub mod hashes;
pub mod interface;
pub mod names;
pub mod std_types;
pub mod type_hash;

pub use interface::RosInterface;

/// `builtin_interfaces/Time`: seconds and nanoseconds (the ROS 2 wire form).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, PartialOrd, Ord, Serialize, Deserialize)]
pub struct Time {
    /// Whole seconds (may be negative).
    pub sec: i32,
    /// Nanoseconds in `[0, 1e9)`.
    pub nanosec: u32,
}

impl Time {
    /// Time zero.
    pub const ZERO: Time = Time { sec: 0, nanosec: 0 };

    /// From nanoseconds since the epoch (saturates at the i32 seconds range).
    pub fn from_nanos(nanos: i64) -> Time {
        let sec = nanos.div_euclid(1_000_000_000);
        let nanosec = nanos.rem_euclid(1_000_000_000) as u32;
        let sec = sec.clamp(i32::MIN as i64, i32::MAX as i64) as i32;
        Time { sec, nanosec }
    }

    /// Nanoseconds since the epoch.
    pub fn to_nanos(self) -> i64 {
        self.sec as i64 * 1_000_000_000 + self.nanosec as i64
    }

    /// From seconds (rounded to the nearest nanosecond).
    pub fn from_secs_f64(secs: f64) -> Time {
        Time::from_nanos((secs * 1e9).round() as i64)
    }

    /// Seconds as a float.
    pub fn as_secs_f64(self) -> f64 {
        self.sec as f64 + self.nanosec as f64 * 1e-9
    }

    /// True for the all-zero time.
    pub fn is_zero(self) -> bool {
        self == Time::ZERO
    }
}

/// `std_msgs/Header`: a stamp and a coordinate frame.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct Header {
    /// Time of the data.
    pub stamp: Time,
    /// Coordinate frame of the data.
    pub frame_id: String,
}

/// `capsule_msgs/msg/CapsuleState`: the capsule's state in SI units (see the `.msg` file).
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct CapsuleState {
    /// Stamp of the sample and frame (`odom`).
    pub header: Header,
    /// Sample counter.
    pub seq: u64,
    /// Inner mass position \[m\].
    pub mass_position: f64,
    /// Inner mass velocity [m/s].
    pub mass_velocity: f64,
    /// Capsule position \[m\].
    pub capsule_position: f64,
    /// Capsule velocity [m/s].
    pub capsule_velocity: f64,
    /// Mass touches the secondary spring.
    pub in_contact: bool,
    /// Capsule sticks to the ground.
    pub stuck: bool,
    /// Friction force on the capsule \[N\].
    pub friction_force: f64,
    /// Secondary-spring contact force \[N\].
    pub contact_force: f64,
    /// Actuator force applied on the inner mass over the last step \[N\].
    pub actuator_force: f64,
    /// Watchdog fired: no fresh command, zero force applied.
    pub command_stale: bool,
    /// Commands refused so far.
    pub rejected_commands: u32,
}

/// `capsule_msgs/msg/ActuatorForce`: a stamped force command on the inner mass.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct ActuatorForce {
    /// Stamp of the state sample this command answers.
    pub header: Header,
    /// Seq of the state sample this command answers (lock-step key).
    pub state_seq: u64,
    /// Force on the inner mass \[N\].
    pub force: f64,
}

/// `capsule_msgs/msg/ControllerStatus`: the controller's mode, gain, drive and running figures.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct ControllerStatus {
    /// Stamp (controller's ROS time).
    pub header: Header,
    /// Current mode (a [`SetModeRequest`] constant).
    pub mode: u8,
    /// Mode name.
    pub mode_name: String,
    /// Feedback gain `k_p`.
    pub gain: f64,
    /// Drive amplitude `alpha` (non-dim).
    pub drive_amplitude: f64,
    /// Drive frequency `omega` (non-dim).
    pub drive_frequency: f64,
    /// Drive amplitude \[N\].
    pub drive_amplitude_si: f64,
    /// Drive frequency \[Hz\].
    pub drive_frequency_hz: f64,
    /// False when the controller stopped commanding (stale state).
    pub commanding: bool,
    /// Commands published so far.
    pub commands_sent: u64,
    /// Drive periods completed since the last mode change.
    pub periods: u32,
    /// Running progression per period (non-dim).
    pub progression_per_period: f64,
    /// Running progression per period \[m\].
    pub progression_per_period_m: f64,
    /// Running mean capsule speed [m/s].
    pub mean_speed: f64,
    /// Running control efficiency (paper eq. 4).
    pub efficiency: f64,
    /// State of the last attractor switch (a `SWITCH_*` constant).
    pub switch_state: u8,
    /// Orbit period the switch wants.
    pub switch_target_period: i32,
    /// Pulses applied so far.
    pub switch_tries: i32,
    /// Most pulses the switch may apply.
    pub switch_max_tries: i32,
    /// `k_p` during the pulses.
    pub switch_pulse_gain: f64,
    /// Pulse length [drive periods].
    pub switch_pulse_periods: i32,
    /// Stamp of the sample the last pulse started at (zero: none yet).
    pub switch_pulse_start: Time,
    /// Stamp of the sample the last pulse ended at (zero: none yet, or still on).
    pub switch_pulse_end: Time,
    /// Period of the orbit on the Poincaré section (0: not periodic or not known).
    pub orbit_period: i32,
}

constants!(ControllerStatus: u8 {
    /// No switch requested yet.
    SWITCH_NONE: 0,
    /// Watching the section until the orbit's period is known.
    SWITCH_OBSERVING: 1,
    /// A pulse is on.
    SWITCH_PULSING: 2,
    /// Released, waiting to judge the orbit.
    SWITCH_SETTLING: 3,
    /// On the wanted orbit, gain released.
    SWITCH_SUCCEEDED: 4,
    /// Tries used up, gain released.
    SWITCH_FAILED: 5,
    /// Another mode was requested first.
    SWITCH_CANCELLED: 6,
});

/// `capsule_msgs/srv/SetMode` request.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct SetModeRequest {
    /// Requested mode (one of the constants).
    pub mode: u8,
    /// Gain (meaning depends on the mode, see the `.srv` file).
    pub gain: f64,
    /// Apply from the first sample stamped at or after this time; zero = next sample.
    pub effective_from: Time,
    /// `SWITCH_ATTRACTOR`: pulse length [drive periods].
    pub pulse_periods: i32,
    /// `SWITCH_ATTRACTOR`: period of the orbit wanted [drive periods].
    pub target_period: i32,
    /// `SWITCH_ATTRACTOR`: most pulses to apply.
    pub max_tries: i32,
}

constants!(SetModeRequest: u8 {
    /// Drive only, `k_p = 0`.
    OFF: 0,
    /// `k_p > 0`: forward motion.
    FORWARD: 1,
    /// `k_p < 0`: backward motion.
    BACKWARD: 2,
    /// The paper's stabilising gain.
    CHAOS_CONTROL: 3,
    /// Any finite gain within limits.
    CUSTOM: 4,
    /// The attractor-switching action.
    SWITCH_ATTRACTOR: 5,
});

/// `capsule_msgs/srv/SetMode` response.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct SetModeResponse {
    /// False: refused, mode unchanged.
    pub accepted: bool,
    /// Mode in force (or scheduled) after the call.
    pub mode: u8,
    /// Gain in force (or scheduled) after the call.
    pub gain: f64,
    /// Reason for a refusal, or what was accepted.
    pub reason: String,
}

/// Name of a mode constant, or `None` for an unknown value.
pub fn mode_name(mode: u8) -> Option<&'static str> {
    SetModeRequest::constant_name(mode)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn time_round_trips_through_nanos_including_negative() {
        for n in [
            0_i64,
            1,
            999_999_999,
            1_000_000_000,
            1_500_000_000,
            -1,
            -1_500_000_000,
        ] {
            let t = Time::from_nanos(n);
            assert!(t.nanosec < 1_000_000_000);
            assert_eq!(t.to_nanos(), n, "{t:?}");
        }
        assert_eq!(
            Time::from_nanos(-1_500_000_000),
            Time {
                sec: -2,
                nanosec: 500_000_000
            }
        );
        assert_eq!(Time::from_secs_f64(2.25).to_nanos(), 2_250_000_000);
    }

    #[test]
    fn mode_names_cover_the_constants_and_nothing_else() {
        assert_eq!(
            mode_name(SetModeRequest::CHAOS_CONTROL),
            Some("CHAOS_CONTROL")
        );
        assert_eq!(mode_name(5), Some("SWITCH_ATTRACTOR"));
        assert_eq!(mode_name(6), None);
    }
}

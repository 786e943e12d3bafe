//! QoS of the capsule topics, services and service events.

use std::time::Duration;

use ros2_client::{
    qos::{Durability, History, WhenFull},
    QosProfile,
};

/// A reliable, volatile, keep-last-`depth` writer's profile whose full window waits at most
/// `wait_ms`.
fn reliable(wait_ms: u64, depth: usize) -> QosProfile {
    QosProfile::publisher_default()
        .reliability_reliable(WhenFull::Wait(Duration::from_millis(wait_ms)))
        .durability(Durability::Volatile)
        .history(History::KeepLast { depth })
}
/// State, force and status: reliable (so both reliable and best-effort rclcpp
/// subscribers match), volatile, keep last 16; a full window waits at most 5 ms.
pub fn data() -> QosProfile {
    reliable(5, 16)
}
/// Readers of state and force: best effort, keep last 16. A best-effort reader matches
/// reliable and best-effort writers alike, and against our reliable writers it spares the
/// acknowledgement traffic (a quarter of each node's CPU at 1 kHz, and latency); rclpy
/// reliable subscribers still get reliable delivery from the same writers. A lost sample is
/// re-sent by the lock-step plant and superseded by the next one in real time.
pub fn data_reader() -> QosProfile {
    QosProfile::subscription_default().history(History::KeepLast { depth: 16 })
}
/// /clock readers: best effort keep-last 1, like rclcpp's and rclpy's time source.
pub fn clock_reader() -> QosProfile {
    QosProfile::subscription_default()
}
/// /clock: reliable keep-last 1 (matches rclcpp's best-effort clock subscription too).
pub fn clock() -> QosProfile {
    reliable(5, 1)
}
/// Services: reliable, volatile, keep last 10 (rmw's services default).
pub fn service() -> QosProfile {
    reliable(100, 10)
}
/// The controller's service events (`set_mode/_service_event`): reliable, transient local,
/// keep last 64, writer and readers alike. rcl's are volatile; here a recorder whose
/// discovery of the event writer ends late (seconds with DDS Security) still gets the
/// requests made before, and volatile readers (rosbag2, rclcpp) match it all the same.
pub fn service_events() -> QosProfile {
    QosProfile::publisher_default()
        .reliability_reliable(WhenFull::Wait(Duration::from_millis(100)))
        .durability(Durability::TransientLocal)
        .history(History::KeepLast { depth: 64 })
}
/// Latched state (robot_description, the emergency stop): reliable, transient local, keep
/// last 1, so a reader that joins later gets the last value.
pub fn latched() -> QosProfile {
    QosProfile::publisher_default()
        .reliability_reliable(WhenFull::Wait(Duration::from_millis(100)))
        .durability(Durability::TransientLocal)
        .history(History::KeepLast { depth: 1 })
}

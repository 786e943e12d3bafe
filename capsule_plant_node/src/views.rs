//! Standard-type views of the plant's state, for what a ROS 2 stack already runs (RViz,
//! Foxglove, robot_state_publisher, diagnostics aggregators, topic_based_ros2_control):
//!
//! - `joint_states` (`sensor_msgs/JointState`): two prismatic joints along x, `capsule_joint`
//!   (the capsule in `odom`: x2, its velocity, the friction force on it) and `inner_mass_joint`
//!   (the mass relative to the capsule, the joint's own coordinate: x1 - x2, y1 - y2, the
//!   actuator force);
//! - `/tf` (`tf2_msgs/TFMessage`): the `capsule` body frame in `odom`;
//! - `robot_description` (`std_msgs/String`, transient local): a URDF with the inner mass on a
//!   prismatic joint in the capsule (robot_state_publisher turns `joint_states` into its frame);
//! - `/diagnostics` (`diagnostic_msgs/DiagnosticArray`, 1 Hz): loop latency, lost and refused
//!   commands, watchdog, pacing, with OK / WARN / ERROR levels.
//!
//! Each is a thin mapping of the one state sample (pure functions here, unit-tested), each can
//! be switched off (`--no-joint-states` ..., or `-p views.joint_states:=false`: rows of the
//! plant's settings table, [`capsule_args::view_settings`]). joint_states
//! and /tf go out with every n-th sample (`--views-rate-hz`, 100 Hz by default), and only while
//! they have a subscriber (rclcpp's
//! `get_subscription_count()` idiom, as /clock): a DDS write without readers still wakes DDS's
//! thread. A view switched off costs one branch per sample.

use std::time::Duration;

use capsule_args::view_settings as views;
use capsule_msgs::{
    names::topics::views as view_topics,
    std_types::{
        DiagnosticArray, DiagnosticStatus, JointState, KeyValue, Quaternion, StringMsg, TFMessage,
        Transform, TransformStamped, Vector3,
    },
    CapsuleState, Header, Time,
};
use capsule_ros_base::error::{Context as _, Result};
use ros2_client::dds::{Node, Publisher};
use ros2_client::{qos::History, MessageTypeName, QosProfile};

use crate::plant::LoopStats;
use capsule_hardware::latency::LatencyHistogram;
use capsule_ros_base::{graph::Graph, params::ParamTable, qos, ros_options::RosOptions, types};

/// Joint names, in `JointState` order.
pub const JOINTS: [&str; 2] = ["capsule_joint", "inner_mass_joint"];
/// The capsule's body frame.
pub const BODY_FRAME: &str = "capsule";
/// The inner mass's frame (from the URDF).
pub const MASS_FRAME: &str = "inner_mass";

/// Which views run.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ViewSwitches {
    /// joint_states.
    pub joint_states: bool,
    /// /tf.
    pub tf: bool,
    /// robot_description.
    pub robot_description: bool,
    /// /diagnostics.
    pub diagnostics: bool,
    /// Most joint_states / tf per second.
    pub rate_hz: f64,
}

impl ViewSwitches {
    /// The switches a table holds (after `-p` overrides).
    pub fn from_table(t: &ParamTable) -> Self {
        ViewSwitches {
            joint_states: t.boolean(views::JOINT_STATES.name),
            tf: t.boolean(views::TF.name),
            robot_description: t.boolean(views::ROBOT_DESCRIPTION.name),
            diagnostics: t.boolean(views::DIAGNOSTICS.name),
            rate_hz: t.double(views::RATE_HZ.name),
        }
    }
}

/// `sensor_msgs/JointState` of a state sample.
pub fn joint_state(s: &CapsuleState) -> JointState {
    JointState {
        header: Header {
            stamp: s.header.stamp,
            frame_id: String::new(),
        },
        name: JOINTS.iter().map(|j| j.to_string()).collect(),
        position: vec![s.capsule_position, s.mass_position - s.capsule_position],
        velocity: vec![s.capsule_velocity, s.mass_velocity - s.capsule_velocity],
        effort: vec![s.friction_force, s.actuator_force],
    }
}

/// `/tf` of a state sample: the capsule frame in the sample's frame (`odom`).
pub fn tf(s: &CapsuleState) -> TFMessage {
    TFMessage {
        transforms: vec![TransformStamped {
            header: s.header.clone(),
            child_frame_id: BODY_FRAME.to_string(),
            transform: Transform {
                translation: Vector3 {
                    x: s.capsule_position,
                    y: 0.0,
                    z: 0.0,
                },
                rotation: Quaternion::IDENTITY,
            },
        }],
    }
}

/// The capsule's URDF: the body (`capsule`) and the inner mass on a prismatic joint along x.
/// Visual sizes are illustrative (the paper's model has no geometry beyond the gap).
pub fn urdf(m1_kg: f64) -> String {
    format!(
        r#"<?xml version="1.0"?>
<robot name="capsule">
  <link name="{BODY_FRAME}">
    <visual>
      <geometry><box size="0.04 0.02 0.02"/></geometry>
      <material name="shell"><color rgba="0.6 0.7 0.9 0.4"/></material>
    </visual>
  </link>
  <link name="{MASS_FRAME}">
    <visual>
      <geometry><box size="0.01 0.012 0.012"/></geometry>
      <material name="mass"><color rgba="0.9 0.4 0.2 1.0"/></material>
    </visual>
    <inertial>
      <mass value="{m1_kg}"/>
      <inertia ixx="1e-7" ixy="0" ixz="0" iyy="1e-7" iyz="0" izz="1e-7"/>
    </inertial>
  </link>
  <joint name="{}" type="prismatic">
    <parent link="{BODY_FRAME}"/>
    <child link="{MASS_FRAME}"/>
    <axis xyz="1 0 0"/>
    <limit lower="-0.015" upper="0.015" effort="100" velocity="10"/>
  </joint>
</robot>
"#,
        JOINTS[1]
    )
}

/// One second of the loop as a diagnostics status, from the statistics now and one second ago.
#[derive(Debug, Clone, Default)]
pub struct DiagWindow {
    latencies_seen: LatencyHistogram,
    unanswered: u64,
    rejected: u32,
    ever_commanded: bool,
}

impl DiagWindow {
    /// The status for the window ending now, and the start of the next one.
    pub fn status(
        &mut self,
        node: &str,
        pacing: &str,
        rate_hz: f64,
        stats: &LoopStats,
        last: &CapsuleState,
    ) -> DiagnosticStatus {
        let window = stats.latencies.since(&self.latencies_seen);
        let (p50, p99) = (window.quantile(0.5), window.quantile(0.99));
        let lost = stats.unanswered.saturating_sub(self.unanswered);
        let refused = last.rejected_commands.saturating_sub(self.rejected);
        self.ever_commanded |= window.count() > 0;
        let period = 1.0 / rate_hz;
        let device_fault = stats.device.as_ref().and_then(|d| d.fault.clone());
        let (level, message) = if stats.emergency_stop {
            (
                DiagnosticStatus::ERROR,
                "emergency stop engaged: zero force".to_string(),
            )
        } else if let Some(fault) = device_fault {
            (DiagnosticStatus::ERROR, format!("device: {fault}"))
        } else if last.command_stale && self.ever_commanded {
            (
                DiagnosticStatus::ERROR,
                "watchdog: no fresh command, zero force".to_string(),
            )
        } else if last.command_stale {
            (
                DiagnosticStatus::WARN,
                "waiting for the first command".to_string(),
            )
        } else if lost > 0 || refused > 0 {
            (
                DiagnosticStatus::WARN,
                format!("{lost} samples unanswered, {refused} commands refused in the last second"),
            )
        } else if pacing == "realtime" && p99.is_some_and(|p| p > period) {
            (
                DiagnosticStatus::WARN,
                "latency p99 above one sample period".to_string(),
            )
        } else {
            (DiagnosticStatus::OK, "commanded, on time".to_string())
        };
        let ms = |v: Option<f64>| v.map_or("n/a".to_string(), |v| format!("{:.3}", v * 1e3));
        let kv = |k: &str, v: String| KeyValue {
            key: k.to_string(),
            value: v,
        };
        self.latencies_seen = stats.latencies.clone();
        self.unanswered = stats.unanswered;
        self.rejected = last.rejected_commands;
        let mut values = vec![
            kv("pacing", pacing.to_string()),
            kv("rate_hz", format!("{rate_hz}")),
            kv(
                "sim_time_s",
                format!("{:.6}", last.header.stamp.as_secs_f64()),
            ),
            kv("samples", stats.published.to_string()),
            kv("answers_last_s", window.count().to_string()),
            kv("latency_p50_ms", ms(p50)),
            kv("latency_p99_ms", ms(p99)),
            kv("unanswered_last_s", lost.to_string()),
            kv("unanswered_total", stats.unanswered.to_string()),
            kv("refused_last_s", refused.to_string()),
            kv("refused_total", last.rejected_commands.to_string()),
            kv(
                "watchdog",
                if last.command_stale {
                    "fired (zero force)"
                } else {
                    "ok"
                }
                .to_string(),
            ),
        ];
        let hardware_id = match &stats.device {
            Some(d) => {
                values.extend(d.values.iter().map(|(k, v)| kv(k, v.clone())));
                format!("capsule ({})", d.label)
            }
            None => "capsule (simulated)".to_string(),
        };
        DiagnosticStatus {
            level,
            name: format!("{node}: loop"),
            message,
            hardware_id,
            values,
        }
    }
}

/// A node's `/diagnostics` publisher: one `DiagnosticArray` a second, stamped with the wall
/// clock (as diagnostic_updater does). The plant's loop and the controller both use it.
pub struct Diagnostics {
    publisher: Publisher<DiagnosticArray>,
    next: std::time::Instant,
}

impl Diagnostics {
    /// The publisher on `/diagnostics` (resolved with the node's settings); first due in 1 s.
    pub fn create(node: &mut Node, settings: &RosOptions) -> Result<Self> {
        let topic = settings.topic(
            node,
            view_topics::DIAGNOSTICS,
            types::diagnostics(),
            &qos::data(),
        )?;
        Ok(Diagnostics {
            publisher: node
                .create_publisher(&topic, None)
                .context("/diagnostics publisher")?,
            next: std::time::Instant::now() + Duration::from_secs(1),
        })
    }

    /// True once a second (then not again until the next second).
    pub fn due(&mut self) -> bool {
        let now = std::time::Instant::now();
        if now < self.next {
            return false;
        }
        self.next = now + Duration::from_secs(1);
        true
    }

    /// Publishes `status` as a one-status array (a failed write is logged); the array, for a
    /// recording.
    pub fn publish(&self, status: DiagnosticStatus) -> DiagnosticArray {
        let array = DiagnosticArray {
            header: Header {
                stamp: Time::from_nanos(capsule_record::writer::now_ns() as i64),
                frame_id: String::new(),
            },
            status: vec![status],
        };
        if let Err(e) = self.publisher.publish(array.clone()) {
            tracing::warn!("/diagnostics not sent: {e:?}");
        }
        array
    }
}

/// Every how many samples joint_states and /tf go out: `rate / views_rate`, rounded, >= 1.
pub fn view_every(rate_hz: f64, views_rate_hz: f64) -> u64 {
    ((rate_hz / views_rate_hz).round() as u64).max(1)
}

/// The plant's views: the per-sample ones (`None` when all are off, so the loop pays one
/// branch) and the URDF's writer (kept for late joiners: transient local).
pub struct PlantViews {
    /// joint_states, /tf, /diagnostics.
    pub per_sample: Option<std::sync::Mutex<Views>>,
    _robot_description: Option<Publisher<StringMsg>>,
}

/// The per-sample view publishers (each `None` when switched off).
pub struct Views {
    joint_states: Option<Publisher<JointState>>,
    tf: Option<Publisher<TFMessage>>,
    diagnostics: Option<Diagnostics>,
    graph: Graph,
    node: String,
    pacing: String,
    rate_hz: f64,
    diag: DiagWindow,
    every: u64,
    count: u64,
}

fn type_name(pkg: &str, ty: &str) -> MessageTypeName {
    MessageTypeName::new(pkg, ty)
}

/// `/tf` as tf2's dynamic broadcaster: reliable, volatile, keep last 100.
fn tf_qos() -> QosProfile {
    qos::data().history(History::KeepLast { depth: 100 })
}

/// `robot_description` as robot_state_publisher: reliable, transient local, keep last 1.
impl Views {
    /// Creates the publishers of the views switched on; publishes the URDF once.
    pub fn create(
        node: &mut Node,
        settings: &RosOptions,
        graph: &Graph,
        on: ViewSwitches,
        pacing: &str,
        rate_hz: f64,
        m1_kg: f64,
    ) -> Result<PlantViews> {
        let data = qos::data();
        let topic =
            |name: &str, ty: MessageTypeName, q: &QosProfile| settings.topic(node, name, ty, q);
        let js_topic = on
            .joint_states
            .then(|| topic(view_topics::JOINT_STATES, types::joint_state(), &data))
            .transpose()?;
        let tf_topic = on
            .tf
            .then(|| {
                topic(
                    view_topics::TF,
                    type_name("tf2_msgs", "TFMessage"),
                    &tf_qos(),
                )
            })
            .transpose()?;
        let rd_topic = on
            .robot_description
            .then(|| {
                topic(
                    view_topics::ROBOT_DESCRIPTION,
                    type_name("std_msgs", "String"),
                    &qos::latched(),
                )
            })
            .transpose()?;
        let robot_description = match rd_topic {
            Some(t) => {
                let p = node
                    .create_publisher::<StringMsg>(&t, None)
                    .context("robot_description publisher")?;
                p.publish(StringMsg { data: urdf(m1_kg) })
                    .context("robot_description not published")?;
                Some(p)
            }
            None => None,
        };
        let views = Views {
            joint_states: js_topic
                .map(|t| node.create_publisher(&t, None))
                .transpose()
                .context("joint_states publisher")?,
            tf: tf_topic
                .map(|t| node.create_publisher(&t, None))
                .transpose()
                .context("/tf publisher")?,
            diagnostics: on
                .diagnostics
                .then(|| Diagnostics::create(node, settings))
                .transpose()?,
            graph: graph.clone(),
            node: settings.node_name.clone(),
            pacing: pacing.to_string(),
            rate_hz,
            diag: DiagWindow::default(),
            every: view_every(rate_hz, on.rate_hz),
            count: 0,
        };
        let any = views.joint_states.is_some() || views.tf.is_some() || views.diagnostics.is_some();
        Ok(PlantViews {
            per_sample: any.then(|| std::sync::Mutex::new(views)),
            _robot_description: robot_description,
        })
    }

    /// Publishes the views of the sample just published (those with subscribers), and once a
    /// second the diagnostics (returned, for the in-plant recording).
    pub fn on_sample(
        &mut self,
        state: &CapsuleState,
        stats: &LoopStats,
    ) -> Option<DiagnosticArray> {
        self.count += 1;
        let due = self.count >= self.every;
        if due {
            self.count = 0;
        }
        if let Some(p) = self.joint_states.as_ref().filter(|_| due) {
            if self.graph.subscribers(p.guid()) > 0 {
                let _ = p.publish(joint_state(state));
            }
        }
        if let Some(p) = self.tf.as_ref().filter(|_| due) {
            if self.graph.subscribers(p.guid()) > 0 {
                let _ = p.publish(tf(state));
            }
        }
        let d = self
            .diagnostics
            .as_mut()
            .and_then(|d| d.due().then_some(d))?;
        Some(
            d.publish(
                self.diag
                    .status(&self.node, &self.pacing, self.rate_hz, stats, state),
            ),
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sample() -> CapsuleState {
        CapsuleState {
            header: Header {
                stamp: Time::from_secs_f64(1.5),
                frame_id: "odom".into(),
            },
            seq: 1500,
            mass_position: 0.003,
            mass_velocity: 0.02,
            capsule_position: 0.001,
            capsule_velocity: 0.005,
            friction_force: -0.07,
            actuator_force: 0.15,
            ..CapsuleState::default()
        }
    }

    #[test]
    fn joint_states_and_tf_map_the_sample() {
        let s = sample();
        let js = joint_state(&s);
        assert_eq!(js.name, ["capsule_joint", "inner_mass_joint"]);
        assert_eq!(js.header.stamp, s.header.stamp);
        assert_eq!(js.position, [0.001, 0.003 - 0.001]);
        assert_eq!(js.velocity, [0.005, 0.02 - 0.005]);
        assert_eq!(js.effort, [-0.07, 0.15]);
        let t = tf(&s);
        assert_eq!(t.transforms.len(), 1);
        let t = &t.transforms[0];
        assert_eq!(
            (t.header.frame_id.as_str(), t.child_frame_id.as_str()),
            ("odom", "capsule")
        );
        assert_eq!(t.transform.translation.x, 0.001);
        assert_eq!(t.transform.rotation, Quaternion::IDENTITY);
    }

    #[test]
    fn views_thin_to_their_rate() {
        assert_eq!(view_every(1000.0, 100.0), 10);
        assert_eq!(view_every(10000.0, 100.0), 100);
        assert_eq!(view_every(50.0, 100.0), 1);
        assert_eq!(view_every(1000.0, 300.0), 3);
    }

    #[test]
    fn urdf_names_the_frames_and_the_joint() {
        let u = urdf(0.05);
        for needle in [
            "<link name=\"capsule\">",
            "<link name=\"inner_mass\">",
            "<joint name=\"inner_mass_joint\" type=\"prismatic\">",
            "<mass value=\"0.05\"/>",
        ] {
            assert!(u.contains(needle), "{needle}");
        }
    }

    #[test]
    fn diagnostics_levels_follow_the_loop() {
        let mut w = DiagWindow::default();
        let mut stats = LoopStats::default();
        let mut s = sample();
        s.command_stale = true;
        let st = w.status("capsule_plant", "realtime", 1000.0, &stats, &s);
        assert_eq!(st.level, DiagnosticStatus::WARN, "{st:?}");
        assert_eq!(st.name, "capsule_plant: loop");
        // answered, on time
        s.command_stale = false;
        for _ in 0..1000 {
            stats.latencies.record(0.0002);
        }
        let st = w.status("capsule_plant", "realtime", 1000.0, &stats, &s);
        assert_eq!(st.level, DiagnosticStatus::OK, "{st:?}");
        let value = |st: &DiagnosticStatus, k: &str| {
            st.values
                .iter()
                .find(|kv| kv.key == k)
                .map(|kv| kv.value.clone())
        };
        assert_eq!(value(&st, "latency_p99_ms").as_deref(), Some("0.200"));
        assert_eq!(value(&st, "answers_last_s").as_deref(), Some("1000"));
        // lost samples and refused commands in the next second
        for _ in 0..10 {
            stats.latencies.record(0.0003);
        }
        stats.unanswered = 3;
        s.rejected_commands = 2;
        let st = w.status("capsule_plant", "realtime", 1000.0, &stats, &s);
        assert_eq!(st.level, DiagnosticStatus::WARN, "{st:?}");
        assert_eq!(value(&st, "unanswered_last_s").as_deref(), Some("3"));
        assert_eq!(value(&st, "refused_last_s").as_deref(), Some("2"));
        // late answers
        for _ in 0..10 {
            stats.latencies.record(0.002);
        }
        let st = w.status("capsule_plant", "realtime", 1000.0, &stats, &s);
        assert_eq!(st.level, DiagnosticStatus::WARN, "{st:?}");
        assert!(st.message.contains("latency"), "{st:?}");
        // the controller went away after commanding: watchdog
        s.command_stale = true;
        let st = w.status("capsule_plant", "realtime", 1000.0, &stats, &s);
        assert_eq!(st.level, DiagnosticStatus::ERROR, "{st:?}");
    }
}

//! The controller's `/diagnostics` status (1 Hz, through [`capsule_plant_node::views::Diagnostics`], the
//! plant's publisher): mode, gain, commands sent, state samples ignored, whether the plant is
//! seen and takes the commands, with OK / WARN / ERROR levels.

use capsule_msgs::{
    std_types::{DiagnosticStatus, KeyValue},
    Time,
};

use crate::controller_core::ControllerCore;

/// One second of the controller as a diagnostics status, from its counters now and one second
/// ago.
#[derive(Debug, Clone, Default)]
pub struct ControllerDiag {
    commands_sent: u64,
    ignored: u64,
}

impl ControllerDiag {
    /// The status for the window ending now, and the start of the next one.
    pub fn status(&mut self, node: &str, core: &ControllerCore) -> DiagnosticStatus {
        let st = core.status(Time::ZERO);
        let sent = st.commands_sent.saturating_sub(self.commands_sent);
        let ignored = core.ignored_samples().saturating_sub(self.ignored);
        self.commands_sent = st.commands_sent;
        self.ignored = core.ignored_samples();
        let fresh = core.commanding();
        let (level, message) = if st.commands_sent > 0 && !fresh {
            (
                DiagnosticStatus::ERROR,
                "watchdog: no state from the plant within the timeout, not commanding".to_string(),
            )
        } else if !fresh {
            (
                DiagnosticStatus::WARN,
                "waiting for the plant's first state sample".to_string(),
            )
        } else if core.plant_refuses() {
            (
                DiagnosticStatus::ERROR,
                "the plant refuses our commands: not in control".to_string(),
            )
        } else if ignored > 0 {
            (
                DiagnosticStatus::WARN,
                format!("{ignored} state samples ignored in the last second"),
            )
        } else {
            (
                DiagnosticStatus::OK,
                format!("commanding {} with k_p = {}", st.mode_name, st.gain),
            )
        };
        let kv = |k: &str, v: String| KeyValue {
            key: k.to_string(),
            value: v,
        };
        DiagnosticStatus {
            level,
            name: format!("{node}: control"),
            message,
            hardware_id: "capsule (simulated)".to_string(),
            values: vec![
                kv("mode", st.mode_name.clone()),
                kv("gain", format!("{}", st.gain)),
                kv("commands_sent", st.commands_sent.to_string()),
                kv("commands_last_s", sent.to_string()),
                kv("states_ignored_total", core.ignored_samples().to_string()),
                kv("states_ignored_last_s", ignored.to_string()),
                kv(
                    "plant",
                    if fresh {
                        "seen"
                    } else if st.commands_sent > 0 {
                        "lost (watchdog fired)"
                    } else {
                        "not seen yet"
                    }
                    .to_string(),
                ),
                kv("plant_takes_commands", (!core.plant_refuses()).to_string()),
                kv("periods", st.periods.to_string()),
                kv(
                    "progression_per_period_m",
                    format!("{:e}", st.progression_per_period_m),
                ),
            ],
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use capsule_controller::mode::{Mode, ModeConfig};
    use capsule_msgs::{CapsuleState, Header};
    use capsule_plant::scene::PhysicalScale;

    fn core() -> ControllerCore {
        let scale = PhysicalScale {
            m1_kg: 0.04,
            k1_n_per_m: 100.0,
            pf_n: 2.0,
        };
        ControllerCore::new(
            scale,
            1.6,
            1.1,
            Mode::Forward,
            0.2,
            ModeConfig::default(),
            0.5,
        )
    }

    fn state(seq: u64) -> CapsuleState {
        CapsuleState {
            header: Header {
                stamp: Time::from_secs_f64(seq as f64 * 1e-3),
                frame_id: "odom".into(),
            },
            seq,
            ..CapsuleState::default()
        }
    }

    fn value(st: &DiagnosticStatus, k: &str) -> Option<String> {
        st.values
            .iter()
            .find(|kv| kv.key == k)
            .map(|kv| kv.value.clone())
    }

    #[test]
    fn levels_follow_the_plant_and_the_commands() {
        let mut c = core();
        let mut d = ControllerDiag::default();
        let st = d.status("capsule_controller", &c);
        assert_eq!(st.level, DiagnosticStatus::WARN, "{st:?}");
        assert_eq!(st.name, "capsule_controller: control");
        assert_eq!(value(&st, "plant").as_deref(), Some("not seen yet"));
        for k in 0..10 {
            assert!(c.on_state(&state(k), 0.0).is_some());
        }
        let st = d.status("capsule_controller", &c);
        assert_eq!(st.level, DiagnosticStatus::OK, "{st:?}");
        assert_eq!(value(&st, "mode").as_deref(), Some("FORWARD"));
        assert_eq!(value(&st, "gain").as_deref(), Some("0.2"));
        assert_eq!(value(&st, "commands_last_s").as_deref(), Some("10"));
        // a late sample ignored
        assert!(c.on_state(&state(3), 0.1).is_none());
        let st = d.status("capsule_controller", &c);
        assert_eq!(st.level, DiagnosticStatus::WARN, "{st:?}");
        assert_eq!(value(&st, "states_ignored_last_s").as_deref(), Some("1"));
        assert_eq!(value(&st, "commands_last_s").as_deref(), Some("0"));
        let st = d.status("capsule_controller", &c);
        assert_eq!(st.level, DiagnosticStatus::OK, "{st:?}");
        // the plant gone: the watchdog fires
        assert!(c.check_stale(1.0));
        let st = d.status("capsule_controller", &c);
        assert_eq!(st.level, DiagnosticStatus::ERROR, "{st:?}");
        assert_eq!(
            value(&st, "plant").as_deref(),
            Some("lost (watchdog fired)")
        );
    }
}

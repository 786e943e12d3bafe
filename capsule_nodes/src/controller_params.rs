//! The controller's ROS parameters: mode and gain (a set is a `set_mode` request, refused for
//! the same reason), the mode defaults and limit, the drive, and read-only settings.
//!
//! One source for the refusals: [`rules`] runs `ModeConfig::validate` and
//! `ModeConfig::select`, the checks `set_mode` runs. The table stores what the controller
//! really uses (`gain` is the k_p in effect: FORWARD with gain -0.3 stores 0.3, as `set_mode`
//! answers).

use capsule_controller::mode::{Mode, ModeConfig};
use ros2_client::ParameterValue as V;

use crate::controller::ControllerCore;
use capsule_ros_base::{
    param_services::ParamHandle,
    params::{ParamSpec, ParamTable, Range},
};

/// Parameter names.
pub mod names {
    /// Mode name (OFF, FORWARD, BACKWARD, CHAOS_CONTROL, CUSTOM; any case, `-` or `_`).
    pub const MODE: &str = "mode";
    /// k_p in effect.
    pub const GAIN: &str = "gain";
    /// |k_p| of FORWARD / BACKWARD when the gain is 0.
    pub const DIRECTION_GAIN: &str = "direction_gain";
    /// k_p of CHAOS_CONTROL when the gain is 0.
    pub const CHAOS_GAIN: &str = "chaos_gain";
    /// Largest |k_p|.
    pub const GAIN_LIMIT: &str = "gain_limit";
    /// Drive amplitude alpha (non-dim).
    pub const ALPHA: &str = "alpha";
    /// Drive frequency omega (non-dim).
    pub const OMEGA: &str = "omega";
    /// Stale-state timeout \[s\].
    pub const STATE_TIMEOUT_S: &str = "state_timeout_s";
    /// The orbit watch's recurrence tolerance on the Poincaré section (non-dim).
    pub const ORBIT_TOLERANCE: &str = "orbit_tolerance";
    pub use capsule_ros_base::params::names::*;
}
use names::*;

/// Values that must be > 0.
const POSITIVE: Range = Range::Float {
    from: 1.0e-12,
    to: 1.0e12,
};

/// The orbit tolerance's range: above zero, below the switch's reduction tolerance (0.25),
/// which must stay below the distance between the points of a real cycle.
pub const ORBIT_TOLERANCE_RANGE: Range = Range::Float {
    from: 1.0e-6,
    to: 0.2,
};

/// The table of a controller configured as `core`.
pub fn table(core: &ControllerCore, use_sim_time: bool, state_timeout_s: f64) -> ParamTable {
    let law = core.law();
    let config = core.config();
    let scale = core.scale();
    let table = ParamTable::new()
        .declare(
            MODE,
            ParamSpec::writable("controller mode, as in a set_mode request taking effect now")
                .constraints("OFF, FORWARD, BACKWARD, CHAOS_CONTROL or CUSTOM"),
            V::String(core.mode().name().to_string()),
        )
        .declare(
            GAIN,
            ParamSpec::writable("feedback gain k_p in effect (non-dim); set as a set_mode gain")
                .constraints("|k_p| <= gain_limit; FORWARD/BACKWARD take the sign of the mode, 0 means the mode's default"),
            V::Double(law.kp),
        )
        .declare(
            DIRECTION_GAIN,
            ParamSpec::writable("|k_p| of FORWARD / BACKWARD when the gain is 0")
                .constraints("finite, <= gain_limit"),
            V::Double(config.direction_gain),
        )
        .declare(
            CHAOS_GAIN,
            ParamSpec::writable("k_p of CHAOS_CONTROL when the gain is 0")
                .constraints("finite, |value| <= gain_limit"),
            V::Double(config.chaos_gain),
        )
        .declare(
            GAIN_LIMIT,
            ParamSpec::writable("largest |k_p| any mode accepts")
                .range(Range::Float { from: 0.0, to: 1.0e6 }),
            V::Double(config.gain_limit),
        )
        .declare(
            ALPHA,
            ParamSpec::writable("drive amplitude alpha = P_d / P_f (non-dim)"),
            V::Double(law.alpha),
        )
        .declare(
            OMEGA,
            ParamSpec::writable("drive frequency omega = Omega / Omega0 (non-dim)")
                .range(Range::Float { from: 1.0e-6, to: 1.0e6 }),
            V::Double(law.omega),
        )
        .declare(
            USE_SIM_TIME,
            ParamSpec::read_only("take time from /clock (set at start: --use-sim-time or -p use_sim_time:=true)"),
            V::Boolean(use_sim_time),
        )
        .declare(
            STATE_TIMEOUT_S,
            ParamSpec::read_only("seconds without state before the controller stops commanding")
                .range(POSITIVE),
            V::Double(state_timeout_s),
        )
        .declare(
            ORBIT_TOLERANCE,
            ParamSpec::read_only("recurrence tolerance of the orbit watch on the Poincare section (non-dim; orbit_period and the attractor switch)")
                .range(ORBIT_TOLERANCE_RANGE),
            V::Double(core.orbit_tolerance()),
        );
    let values = [scale.m1_kg, scale.k1_n_per_m, scale.pf_n];
    capsule_ros_base::params::declare_scale(table, values, |what| {
        ParamSpec::read_only(what).range(POSITIVE)
    })
}

/// The mode configuration the table holds.
fn config(t: &ParamTable) -> ModeConfig {
    ModeConfig {
        direction_gain: t.double(DIRECTION_GAIN),
        chaos_gain: t.double(CHAOS_GAIN),
        gain_limit: t.double(GAIN_LIMIT),
    }
}

/// The controller's rules: the mode configuration must validate, and mode + gain must pass
/// `ModeConfig::select` (the `set_mode` check, same reason); the gain stored is the k_p
/// selected.
pub fn rules(t: &mut ParamTable) -> Result<(), String> {
    let config = config(t);
    config.validate().map_err(|e| e.to_string())?;
    let name = t.string(MODE).to_string();
    let mode = Mode::parse_name(&name).ok_or_else(|| {
        format!("unknown mode {name:?} (expected OFF, FORWARD, BACKWARD, CHAOS_CONTROL or CUSTOM)")
    })?;
    let (mode, kp) = config
        .select(mode.code(), t.double(GAIN))
        .map_err(|e| e.to_string())?;
    t.put(MODE, V::String(mode.name().to_string()));
    t.put(GAIN, V::Double(kp));
    Ok(())
}

/// A controller configured as the table says (the table passed [`rules`]); for the start,
/// after `-p` / `--params-file` overrides.
pub fn core_from(t: &ParamTable) -> ControllerCore {
    let scale = capsule_plant::scene::PhysicalScale {
        m1_kg: t.double(M1_KG),
        k1_n_per_m: t.double(K1_N_PER_M),
        pf_n: t.double(PF_N),
    };
    let mode = Mode::parse_name(t.string(MODE)).unwrap_or(Mode::Off);
    let (alpha, omega) = (t.double(ALPHA), t.double(OMEGA));
    let stale = t.double(STATE_TIMEOUT_S);
    ControllerCore::new(scale, alpha, omega, mode, t.double(GAIN), config(t), stale)
        .with_orbit_tolerance(t.double(ORBIT_TOLERANCE))
}

/// Reconfigures `core` to what the table says (the table passed [`rules`]).
pub fn apply(t: &ParamTable, core: &mut ControllerCore) {
    let mode = Mode::parse_name(t.string(MODE)).unwrap_or(core.mode());
    core.reconfigure(
        mode,
        t.double(GAIN),
        t.double(ALPHA),
        t.double(OMEGA),
        config(t),
    );
}

/// The values `core` may change by itself (a `set_mode` call, a scheduled switch).
/// During an attractor switch: the mode and gain it returns to (the pulses don't show).
pub fn live_values(core: &ControllerCore) -> [(&'static str, V); 2] {
    let (mode, kp) = core.settled_mode();
    [
        (MODE, V::String(mode.name().to_string())),
        (GAIN, V::Double(kp)),
    ]
}

/// Keeps the served table in step with the controller: applies remote sets to the core, and
/// publishes the core's own mode changes (only those: a set being applied is not undone).
pub struct LiveSync {
    handle: ParamHandle,
    synced: [(&'static str, V); 2],
}

impl LiveSync {
    /// Starts from `core` as served by `handle`.
    pub fn new(handle: ParamHandle, core: &ControllerCore) -> Self {
        LiveSync {
            handle,
            synced: live_values(core),
        }
    }

    /// A remote set was accepted: reconfigure `core` to `table`.
    pub fn applied(&mut self, table: &ParamTable, core: &mut ControllerCore) {
        apply(table, core);
        self.synced = live_values(core);
    }

    /// After the core may have switched by itself: publish its mode and gain if they changed.
    pub fn push(&mut self, core: &ControllerCore) {
        let now = live_values(core);
        if now != self.synced {
            self.handle.put(&now);
            self.synced = now;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use capsule_msgs::SetModeRequest;
    use capsule_plant::scene::PhysicalScale;

    fn core(mode: Mode, kp: f64) -> ControllerCore {
        let scale = PhysicalScale {
            m1_kg: 0.05,
            k1_n_per_m: 200.0,
            pf_n: 0.1,
        };
        ControllerCore::new(scale, 1.6, 1.1, mode, kp, ModeConfig::default(), 0.5)
    }

    fn p(name: &str, v: V) -> (String, V) {
        (name.to_string(), v)
    }

    #[test]
    fn the_orbit_tolerance_is_set_at_start_and_read_only_after() {
        let c = core(Mode::Forward, 0.2).with_orbit_tolerance(0.1);
        let mut t = table(&c, false, 0.5);
        assert_eq!(t.double(ORBIT_TOLERANCE), 0.1);
        // at start (-p orbit_tolerance:=0.15): the core built from the table watches with it
        t.override_with(&[p(ORBIT_TOLERANCE, V::Double(0.15))], rules)
            .unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(core_from(&t).orbit_tolerance(), 0.15);
        // beyond the switch's reduction tolerance, or set on a running node: refused
        let e = t
            .override_with(&[p(ORBIT_TOLERANCE, V::Double(0.3))], rules)
            .unwrap_err();
        assert!(e.contains("orbit_tolerance") || e.contains("0.2"), "{e}");
        let e = t
            .set_atomically(&[p(ORBIT_TOLERANCE, V::Double(0.05))], rules)
            .unwrap_err();
        assert!(e.contains("read-only"), "{e}");
    }

    #[test]
    fn a_set_set_mode_refuses_is_refused_for_the_same_reason() {
        let mut c = core(Mode::Forward, 0.2);
        let mut t = table(&c, false, 0.5);
        let before = t.clone();
        for (params, mode, gain) in [
            (vec![p(GAIN, V::Double(3.0))], SetModeRequest::FORWARD, 3.0),
            (
                vec![
                    p(MODE, V::String("custom".into())),
                    p(GAIN, V::Double(-2.5)),
                ],
                SetModeRequest::CUSTOM,
                -2.5,
            ),
        ] {
            let e = t.set_atomically(&params, rules).unwrap_err();
            let r = c.set_mode(&SetModeRequest {
                mode,
                gain,
                ..SetModeRequest::default()
            });
            assert!(!r.accepted);
            assert_eq!(e, r.reason);
            assert_eq!(t, before);
        }
        // (the set, why it is refused)
        let refused = [
            (vec![p(GAIN, V::Double(f64::NAN))], "not finite"),
            (vec![p(MODE, V::String("sideways".into()))], "unknown mode"),
            // lowering the limit below a default or the gain in effect is refused
            (vec![p(GAIN_LIMIT, V::Double(0.1))], "beyond gain_limit"),
            (
                vec![
                    p(GAIN_LIMIT, V::Double(0.15)),
                    p(DIRECTION_GAIN, V::Double(0.1)),
                    p(CHAOS_GAIN, V::Double(0.1)),
                ],
                "beyond the configured limit",
            ),
            (vec![p(M1_KG, V::Double(0.1))], "read-only"),
        ];
        for (set, why) in refused {
            let e = t.set_atomically(&set, rules).unwrap_err();
            assert!(e.contains(why), "{set:?}: {e}");
        }
        assert_eq!(t, before);
    }

    #[test]
    fn accepted_sets_store_what_set_mode_would_and_reconfigure_the_core() {
        let mut c = core(Mode::Forward, 0.2);
        let mut t = table(&c, false, 0.5);
        // BACKWARD with gain 0.3: k_p -0.3, as set_mode answers
        let changed = t
            .set_atomically(
                &[
                    p(MODE, V::String("backward".into())),
                    p(GAIN, V::Double(0.3)),
                ],
                rules,
            )
            .unwrap();
        assert_eq!(
            changed,
            vec![
                p(GAIN, V::Double(-0.3)),
                p(MODE, V::String("BACKWARD".into()))
            ]
        );
        let expected = c.set_mode(&SetModeRequest {
            mode: SetModeRequest::BACKWARD,
            gain: 0.3,
            ..SetModeRequest::default()
        });
        assert_eq!(t.double(GAIN), expected.gain);
        let mut d = core(Mode::Forward, 0.2);
        t.set_atomically(&[p(ALPHA, V::Double(2.0))], rules)
            .unwrap();
        apply(&t, &mut d);
        assert_eq!(
            (d.mode(), d.law().kp, d.law().alpha),
            (Mode::Backward, -0.3, 2.0)
        );
        assert_eq!(d.config(), config(&t));
        assert_eq!(live_values(&d)[1], (GAIN, V::Double(-0.3)));
    }
}

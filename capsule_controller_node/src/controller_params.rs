//! The controller's ROS parameters: mode and gain (a set is a `set_mode` request, refused for
//! the same reason), the mode defaults and limit, the drive, and read-only settings; declared
//! from the controller's settings table ([`crate::controller_settings`]).
//!
//! One source for the refusals: [`rules`] runs `ModeConfig::validate` and
//! `ModeConfig::select`, the checks `set_mode` runs. The table stores what the controller
//! really uses (`gain` is the k_p in effect: FORWARD with gain -0.3 stores 0.3, as `set_mode`
//! answers).

use capsule_args::scene_file::SceneFile;
use capsule_controller::mode::{Mode, ModeConfig};
use ros2_client::ParameterValue as V;

use crate::controller_core::ControllerCore;
use crate::controller_settings::ControllerFlags;
use capsule_ros_base::error::{invalid, Result as NodeResult};
use capsule_ros_base::{param_services::ParamHandle, params::ParamTable, ros_args};

use capsule_args::controller_settings::{
    ALPHA, CHAOS_GAIN, DIRECTION_GAIN, GAIN, GAIN_LIMIT, K1_N_PER_M, M1_KG, MODE, OMEGA,
    ORBIT_TOLERANCE, PF_N, STATE_TIMEOUT_S, USE_SIM_TIME,
};

/// The controller's start: its parameters (each setting by the precedence: default, scene,
/// flag; then `-p` / `--params-file`, `overrides`), checked by the settings' rules and
/// [`rules`], and the core configured as they say. `file` names the scene in refusals.
pub fn start(
    flags: &ControllerFlags,
    scene: Option<&SceneFile>,
    file: &str,
    use_sim_time: bool,
    overrides: &[ros_args::Override],
) -> NodeResult<(ParamTable, ControllerCore)> {
    let mut params = start_table(flags, scene, file, use_sim_time).map_err(|e| invalid!("{e}"))?;
    crate::controller_settings::start_config(&params)?;
    rules(&mut params).map_err(|e| invalid!("--mode/--gain: {e}"))?;
    ros_args::apply_overrides(&mut params, overrides, rules)?;
    let core = core_from(&params);
    Ok((params, core))
}

/// The parameters a controller starts with, before `-p` / `--params-file`: each setting by
/// the precedence (flag, scene, default); the scene's control.kp is the start gain (in CUSTOM
/// mode if it is not 0, else OFF) when no `--mode` is given.
pub fn start_table(
    flags: &ControllerFlags,
    scene: Option<&SceneFile>,
    file: &str,
    use_sim_time: bool,
) -> Result<ParamTable, String> {
    let kp = scene.map_or(0.0, |f| f.scene.control.kp);
    let mode_given = flags.given(MODE.name).is_some();
    let other = |name: &str| match name {
        n if n == MODE.name => Some(V::String(
            if kp != 0.0 { Mode::Custom } else { Mode::Off }
                .name()
                .to_string(),
        )),
        n if n == GAIN.name => Some(V::Double(if mode_given { 0.0 } else { kp })),
        n if n == USE_SIM_TIME.name => Some(V::Boolean(use_sim_time)),
        _ => None,
    };
    let from_scene = |key: &str| scene?.scene.number(key).ok();
    let mut table = flags.start_table(file, from_scene, other)?;
    // a mode given by name, as the flag and the parameter take it
    let name = table.string(MODE.name).to_string();
    let mode = Mode::parse_name(&name).ok_or_else(|| {
        format!("--mode {name:?}: expected off, forward, backward, chaos-control or custom")
    })?;
    table.put(MODE.name, V::String(mode.name().to_string()));
    Ok(table)
}

/// The mode configuration the table holds.
fn config(t: &ParamTable) -> ModeConfig {
    ModeConfig {
        direction_gain: t.double(DIRECTION_GAIN.name),
        chaos_gain: t.double(CHAOS_GAIN.name),
        gain_limit: t.double(GAIN_LIMIT.name),
    }
}

/// The controller's rules: the mode configuration must validate, and mode + gain must pass
/// `ModeConfig::select` (the `set_mode` check, same reason); the gain stored is the k_p
/// selected.
pub fn rules(t: &mut ParamTable) -> Result<(), String> {
    let config = config(t);
    config.validate().map_err(|e| e.to_string())?;
    let name = t.string(MODE.name).to_string();
    let mode = Mode::parse_name(&name).ok_or_else(|| {
        format!("unknown mode {name:?} (expected OFF, FORWARD, BACKWARD, CHAOS_CONTROL or CUSTOM)")
    })?;
    let (mode, kp) = config
        .select(mode.code(), t.double(GAIN.name))
        .map_err(|e| e.to_string())?;
    t.put(MODE.name, V::String(mode.name().to_string()));
    t.put(GAIN.name, V::Double(kp));
    Ok(())
}

/// A controller configured as the table says (the table passed [`rules`]); for the start,
/// after `-p` / `--params-file` overrides.
pub fn core_from(t: &ParamTable) -> ControllerCore {
    let scale = capsule_plant::scene::PhysicalScale {
        m1_kg: t.double(M1_KG.name),
        k1_n_per_m: t.double(K1_N_PER_M.name),
        pf_n: t.double(PF_N.name),
    };
    let mode = Mode::parse_name(t.string(MODE.name)).unwrap_or(Mode::Off);
    let (alpha, omega) = (t.double(ALPHA.name), t.double(OMEGA.name));
    let stale = t.double(STATE_TIMEOUT_S.name);
    ControllerCore::new(
        scale,
        alpha,
        omega,
        mode,
        t.double(GAIN.name),
        config(t),
        stale,
    )
    .with_orbit_tolerance(t.double(ORBIT_TOLERANCE.name))
}

/// Reconfigures `core` to what the table says (the table passed [`rules`]).
pub fn apply(t: &ParamTable, core: &mut ControllerCore) {
    let mode = Mode::parse_name(t.string(MODE.name)).unwrap_or(core.mode());
    core.reconfigure(
        mode,
        t.double(GAIN.name),
        t.double(ALPHA.name),
        t.double(OMEGA.name),
        config(t),
    );
}

/// The values `core` may change by itself (a `set_mode` call, a scheduled switch).
/// During an attractor switch: the mode and gain it returns to (the pulses don't show).
pub fn live_values(core: &ControllerCore) -> [(&'static str, V); 2] {
    let (mode, kp) = core.settled_mode();
    [
        (MODE.name, V::String(mode.name().to_string())),
        (GAIN.name, V::Double(kp)),
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

    /// The parameters of a controller configured as `core` (as the node would start it).
    fn table(core: &ControllerCore, _use_sim_time: bool, state_timeout_s: f64) -> ParamTable {
        let scale = core.scale();
        let law = core.law();
        let config = core.config();
        let mut args = vec!["x".to_string()];
        for (name, v) in [
            (MODE.name, 0.0),
            (GAIN.name, law.kp),
            (DIRECTION_GAIN.name, config.direction_gain),
            (CHAOS_GAIN.name, config.chaos_gain),
            (GAIN_LIMIT.name, config.gain_limit),
            (ALPHA.name, law.alpha),
            (OMEGA.name, law.omega),
            (STATE_TIMEOUT_S.name, state_timeout_s),
            (ORBIT_TOLERANCE.name, core.orbit_tolerance()),
            (M1_KG.name, scale.m1_kg),
            (K1_N_PER_M.name, scale.k1_n_per_m),
            (PF_N.name, scale.pf_n),
        ] {
            args.push(format!("--{}", name.replace('_', "-")));
            args.push(if name == MODE.name {
                core.mode().name().to_string()
            } else {
                v.to_string()
            });
        }
        #[derive(clap::Parser)]
        struct Cli {
            #[command(flatten)]
            flags: ControllerFlags,
        }
        let cli = <Cli as clap::Parser>::try_parse_from(args).unwrap_or_else(|e| panic!("{e}"));
        start_table(&cli.flags, None, "", false).unwrap_or_else(|e| panic!("{e}"))
    }

    fn p(name: &str, v: V) -> (String, V) {
        (name.to_string(), v)
    }

    #[test]
    fn huge_numbers_are_written_short_in_set_mode_and_set_parameters_refusals() {
        let mut c = core(Mode::Forward, 0.2);
        let mut t = table(&c, false, 0.5);
        let r = c.set_mode(&SetModeRequest {
            mode: SetModeRequest::CUSTOM,
            gain: 1e308,
            ..SetModeRequest::default()
        });
        assert_eq!(
            r.reason,
            "gain 1e308 is beyond the configured limit |k_p| <= 2"
        );
        let e = t
            .set_atomically(&[p(GAIN.name, V::Double(1e308))], rules)
            .unwrap_err();
        assert_eq!(e, r.reason);
        let e = t
            .set_atomically(&[p(GAIN_LIMIT.name, V::Double(-1e300))], rules)
            .unwrap_err();
        assert_eq!(
            e,
            "parameter 'gain_limit': must be in [0, 1e12] (got -1e300)"
        );
        let r = c.set_mode(&SetModeRequest {
            mode: SetModeRequest::SWITCH_ATTRACTOR,
            gain: -1.5e300,
            pulse_periods: 1,
            target_period: 1,
            max_tries: 1,
            ..SetModeRequest::default()
        });
        assert_eq!(
            r.reason,
            "SWITCH_ATTRACTOR: pulse gain -1.5e300 is beyond the configured limit |k_p| <= 2"
        );
    }

    #[test]
    fn one_range_is_refused_the_same_way_by_flag_scene_and_parameter_set() {
        #[derive(Debug, clap::Parser)]
        struct Cli {
            #[command(flatten)]
            flags: ControllerFlags,
        }
        let parse = |args: &[&str]| <Cli as clap::Parser>::try_parse_from(args);
        let flag = parse(&["x", "--alpha", "150"]).unwrap_err().to_string();
        // the scene reader refuses the key by the same rule (capsule_plant::scene::KEY_RULES)
        let scene = SceneFile::from_bytes(b"[drive]\nalpha = 150.0\n", "f.toml", "f".into())
            .err()
            .map(|e| e.to_string());
        let mut t = table(&core(Mode::Forward, 0.2), false, 0.5);
        let set = t
            .set_atomically(&[p(ALPHA.name, V::Double(150.0))], rules)
            .unwrap_err();
        let why = "must be in [0, 100] (got 150)";
        assert!(
            flag.contains(&format!("'--alpha <ALPHA>': {why}")),
            "{flag}"
        );
        assert_eq!(scene, Some(format!("f.toml: drive.alpha: {why}")));
        assert_eq!(set, format!("parameter 'alpha': {why}"));
        // the descriptor announces the range, writable
        let spec = t
            .spec(ALPHA.name)
            .cloned()
            .unwrap_or_else(|| panic!("no alpha"));
        assert_eq!(
            (spec.range, spec.read_only),
            (
                capsule_ros_base::params::Range::Float {
                    from: 0.0,
                    to: 100.0
                },
                false
            )
        );
    }

    #[test]
    fn the_orbit_tolerance_is_set_at_start_and_read_only_after() {
        let c = core(Mode::Forward, 0.2).with_orbit_tolerance(0.1);
        let mut t = table(&c, false, 0.5);
        assert_eq!(t.double(ORBIT_TOLERANCE.name), 0.1);
        // at start (-p orbit_tolerance:=0.15): the core built from the table watches with it
        t.override_with(&[p(ORBIT_TOLERANCE.name, V::Double(0.15))], rules)
            .unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(core_from(&t).orbit_tolerance(), 0.15);
        // beyond the switch's reduction tolerance, or set on a running node: refused
        let e = t
            .override_with(&[p(ORBIT_TOLERANCE.name, V::Double(0.3))], rules)
            .unwrap_err();
        assert!(e.contains("orbit_tolerance") || e.contains("0.2"), "{e}");
        let e = t
            .set_atomically(&[p(ORBIT_TOLERANCE.name, V::Double(0.05))], rules)
            .unwrap_err();
        assert!(e.contains("read-only"), "{e}");
    }

    #[test]
    fn a_set_set_mode_refuses_is_refused_for_the_same_reason() {
        let mut c = core(Mode::Forward, 0.2);
        let mut t = table(&c, false, 0.5);
        let before = t.clone();
        for (params, mode, gain) in [
            (
                vec![p(GAIN.name, V::Double(3.0))],
                SetModeRequest::FORWARD,
                3.0,
            ),
            (
                vec![
                    p(MODE.name, V::String("custom".into())),
                    p(GAIN.name, V::Double(-2.5)),
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
            (
                vec![p(GAIN.name, V::Double(f64::NAN))],
                "must be a finite number",
            ),
            (
                vec![p(MODE.name, V::String("sideways".into()))],
                "unknown mode",
            ),
            // lowering the limit below a default or the gain in effect is refused
            (
                vec![p(GAIN_LIMIT.name, V::Double(0.1))],
                "beyond gain_limit",
            ),
            (
                vec![
                    p(GAIN_LIMIT.name, V::Double(0.15)),
                    p(DIRECTION_GAIN.name, V::Double(0.1)),
                    p(CHAOS_GAIN.name, V::Double(0.1)),
                ],
                "beyond the configured limit",
            ),
            (vec![p(M1_KG.name, V::Double(0.1))], "read-only"),
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
                    p(MODE.name, V::String("backward".into())),
                    p(GAIN.name, V::Double(0.3)),
                ],
                rules,
            )
            .unwrap();
        assert_eq!(
            changed,
            vec![
                p(GAIN.name, V::Double(-0.3)),
                p(MODE.name, V::String("BACKWARD".into()))
            ]
        );
        let expected = c.set_mode(&SetModeRequest {
            mode: SetModeRequest::BACKWARD,
            gain: 0.3,
            ..SetModeRequest::default()
        });
        assert_eq!(t.double(GAIN.name), expected.gain);
        let mut d = core(Mode::Forward, 0.2);
        t.set_atomically(&[p(ALPHA.name, V::Double(2.0))], rules)
            .unwrap();
        apply(&t, &mut d);
        assert_eq!(
            (d.mode(), d.law().kp, d.law().alpha),
            (Mode::Backward, -0.3, 2.0)
        );
        assert_eq!(d.config(), config(&t));
        assert_eq!(live_values(&d)[1], (GAIN.name, V::Double(-0.3)));
    }
}

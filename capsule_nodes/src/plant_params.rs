//! The plant's ROS parameters: what it was started with, all read-only (a running simulation
//! does not change its scene, rate or pacing); `ros2 param get` / `describe` show them, and
//! `-p` / `--params-file` set them at start.

use ros2_client::ParameterValue as V;

use capsule_ros_base::params::{ParamSpec, ParamTable, Range};

/// Parameter names.
pub mod names {
    /// Scene file.
    pub const SCENE: &str = "scene";
    /// Pacing: realtime or lockstep.
    pub const PACING: &str = "pacing";
    /// Sample rate \[Hz\].
    pub const RATE_HZ: &str = "rate_hz";
    /// Watchdog timeout \[s\].
    pub const COMMAND_TIMEOUT_S: &str = "command_timeout_s";
    /// /clock with every N-th sample.
    pub const CLOCK_EVERY: &str = "clock_every";
    /// JointState commands on capsule/joint_commands (`--joint-commands`).
    pub const JOINT_COMMANDS: &str = "joint_commands";
    /// Sim time from /clock (the plant is the clock: always false) and the physical scale.
    pub use capsule_ros_base::params::names::*;
}
use names::*;

/// What the plant runs with.
#[derive(Debug, Clone, PartialEq)]
pub struct PlantParams {
    /// Scene file.
    pub scene: String,
    /// `realtime` or `lockstep`.
    pub pacing: String,
    /// Sample rate \[Hz\].
    pub rate_hz: f64,
    /// Watchdog timeout \[s\].
    pub command_timeout_s: f64,
    /// /clock with every N-th sample.
    pub clock_every: u64,
    /// Physical scale (m1 \[kg\], k1 [N/m], P_f \[N\]).
    pub scale: (f64, f64, f64),
}

/// The table of a plant started with `s`.
pub fn table(s: &PlantParams) -> ParamTable {
    let ro = ParamSpec::read_only;
    let table = ParamTable::new()
        .declare(SCENE, ro("scene file (model, friction, initial state, scale)"), V::String(s.scene.clone()))
        .declare(
            PACING,
            ro("realtime (one sample per 1/rate of wall time) or lockstep (each step waits for its command)"),
            V::String(s.pacing.clone()),
        )
        .declare(
            RATE_HZ,
            ro("sample rate [Hz]").range(Range::Float { from: 1.0e-3, to: 1.0e6 }),
            V::Double(s.rate_hz),
        )
        .declare(
            COMMAND_TIMEOUT_S,
            ro("seconds without a fresh command before zero force").range(Range::Float { from: 1.0e-6, to: 1.0e6 }),
            V::Double(s.command_timeout_s),
        )
        .declare(
            CLOCK_EVERY,
            ro("/clock with every N-th sample").range(Range::Integer { from: 1, to: i64::MAX }),
            V::Integer(s.clock_every.min(i64::MAX as u64) as i64),
        )
        .declare(
            USE_SIM_TIME,
            ro("the plant is the clock: its time is sim time by construction").constraints("false"),
            V::Boolean(false),
        );
    let (m1, k1, pf) = s.scale;
    capsule_ros_base::params::declare_scale(table, [m1, k1, pf], ro)
}

/// Declares [`JOINT_COMMANDS`] (read-only once running), valued by the flag.
pub fn declare_joint_commands(t: ParamTable, on: bool) -> ParamTable {
    t.declare(
        JOINT_COMMANDS,
        ParamSpec::read_only(
            "take JointState commands on capsule/joint_commands (topic_based_ros2_control; set at start)",
        ),
        V::Boolean(on),
    )
}

/// Rate, command timeout and clock thinning from the table after start-up overrides; the
/// scene, pacing and scale come from `--scene` / `--pacing` only (overriding them is refused).
pub fn overridable(t: &ParamTable, started: &PlantParams) -> Result<(f64, f64, u64), String> {
    let fixed = [
        (SCENE, t.string(SCENE) == started.scene, "--scene"),
        (PACING, t.string(PACING) == started.pacing, "--pacing"),
        (
            M1_KG,
            t.double(M1_KG) == started.scale.0,
            "the scene's [physical]",
        ),
        (
            K1_N_PER_M,
            t.double(K1_N_PER_M) == started.scale.1,
            "the scene's [physical]",
        ),
        (
            PF_N,
            t.double(PF_N) == started.scale.2,
            "the scene's [physical]",
        ),
        (
            USE_SIM_TIME,
            !t.boolean(USE_SIM_TIME),
            "nothing: the plant is the clock",
        ),
    ];
    if let Some((name, _, by)) = fixed.iter().find(|(_, same, _)| !same) {
        return Err(format!(
            "parameter '{name}' is set by {by}, not as a parameter"
        ));
    }
    let every = u64::try_from(t.integer(CLOCK_EVERY)).unwrap_or(1).max(1);
    Ok((t.double(RATE_HZ), t.double(COMMAND_TIMEOUT_S), every))
}

#[cfg(test)]
mod tests {
    use super::*;
    use capsule_ros_base::params::no_rules;

    #[test]
    fn everything_is_read_only_once_running_but_overridable_at_start() {
        let s = PlantParams {
            scene: "scenes/control_point.toml".into(),
            pacing: "realtime".into(),
            rate_hz: 1000.0,
            command_timeout_s: 0.1,
            clock_every: 1,
            scale: (0.05, 200.0, 0.1),
        };
        let mut t = table(&s);
        for name in t.names().map(str::to_string).collect::<Vec<_>>() {
            assert!(t.spec(&name).is_some_and(|d| d.read_only), "{name}");
        }
        let e = t
            .set_atomically(&[(RATE_HZ.into(), V::Double(10.0))], no_rules)
            .unwrap_err();
        assert!(e.contains("read-only"), "{e}");
        t.override_with(&[(RATE_HZ.into(), V::Double(500.0))], no_rules)
            .unwrap();
        assert_eq!(t.double(RATE_HZ), 500.0);
        assert!(t
            .override_with(&[(RATE_HZ.into(), V::Double(-1.0))], no_rules)
            .is_err());
        assert_eq!(overridable(&t, &s), Ok((500.0, 0.1, 1)));
        t.override_with(&[(SCENE.into(), V::String("other.toml".into()))], no_rules)
            .unwrap();
        let e = overridable(&t, &s).unwrap_err();
        assert!(e.contains("'scene' is set by --scene"), "{e}");
    }
}

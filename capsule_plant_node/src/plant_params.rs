//! The plant's ROS parameters, declared from its settings table
//! ([`capsule_args::plant_settings`]): what it was started with, all read-only (a running
//! simulation does not change its scene, rate or pacing); `ros2 param get` / `describe` show
//! them, and `-p` / `--params-file` set the numeric ones at start.

use capsule_args::plant_settings::PLANT;
use capsule_args::scene_file::SceneFile;
use capsule_args::settings::Setting;
use capsule_ros_base::params::ParamTable;

use crate::node_settings::{SettingFlags, SettingsTable};

use capsule_args::plant_settings::{
    CLOCK_EVERY, COMMAND_TIMEOUT_S, JOINT_COMMANDS, LOCKSTEP_GIVE_UP_S, PACING, RATE_HZ, SCENE,
    USE_SIM_TIME,
};
use capsule_args::scale_settings::{K1_N_PER_M, M1_KG, PF_N};

/// The plant's settings table.
#[derive(Debug, Clone)]
pub struct Plant;
impl SettingsTable for Plant {
    const SETTINGS: &'static [Setting] = &PLANT;
}

/// The plant's flags made from its table.
pub type PlantFlags = SettingFlags<Plant>;

/// What only its own source sets: `--scene`, `--pacing` and the scene's `[physical]` (a `-p`
/// changing one is refused).
#[derive(Debug, Clone, PartialEq)]
pub struct Fixed {
    /// Scene file.
    pub scene: String,
    /// `realtime` or `lockstep`.
    pub pacing: String,
    /// Physical scale (m1 \[kg\], k1 [N/m], P_f \[N\]).
    pub scale: (f64, f64, f64),
}

/// What the plant runs with, after the start-up overrides.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PlantParams {
    /// Sample rate \[Hz\].
    pub rate_hz: f64,
    /// Watchdog timeout \[s\].
    pub command_timeout_s: f64,
    /// Lock-step: wall seconds without an answer before the run ends.
    pub lockstep_give_up_s: f64,
    /// /clock with every N-th sample.
    pub clock_every: u64,
    /// JointState commands on capsule/joint_commands.
    pub joint_commands: bool,
}

impl Fixed {
    /// What `flags` (the plant's, or a table holding its `scene` and `pacing` rows) and the
    /// scene `file` fix.
    pub fn of<T: SettingsTable>(flags: &SettingFlags<T>, file: &SceneFile) -> Fixed {
        let physical = &file.scene.physical;
        Fixed {
            scene: flags.text(&SCENE).unwrap_or_default(),
            pacing: flags.text(&PACING).unwrap_or_default(),
            scale: (physical.m1_kg, physical.k1_n_per_m, physical.pf_n),
        }
    }
}

/// The table of a plant started with `flags` on the scene `file`: each parameter by the
/// precedence (flag, the scene's key: its `[node]` table or its physical scale, default). A
/// plant with a table of its own (a subset of the plant's rows, as `custom_plant` has) gets
/// the parameters of its rows.
pub fn start_table<T: SettingsTable>(
    flags: &SettingFlags<T>,
    file: &SceneFile,
) -> Result<ParamTable, String> {
    let scene = |key: &str| file.node.value(key).or_else(|| file.scene.number(key).ok());
    let name = flags.text(&SCENE).unwrap_or_default();
    flags.start_table(&name, scene, |_| None)
}

/// What the plant runs with from the table after start-up overrides; the scene, pacing and
/// scale come from `--scene` / `--pacing` only (overriding them is refused).
pub fn overridable(t: &ParamTable, started: &Fixed) -> Result<PlantParams, String> {
    let fixed = [
        (SCENE.name, t.string(SCENE.name) == started.scene, "--scene"),
        (
            PACING.name,
            t.string(PACING.name) == started.pacing,
            "--pacing",
        ),
        (
            M1_KG.name,
            t.double(M1_KG.name) == started.scale.0,
            "the scene's [physical]",
        ),
        (
            K1_N_PER_M.name,
            t.double(K1_N_PER_M.name) == started.scale.1,
            "the scene's [physical]",
        ),
        (
            PF_N.name,
            t.double(PF_N.name) == started.scale.2,
            "the scene's [physical]",
        ),
        (
            USE_SIM_TIME.name,
            !t.boolean(USE_SIM_TIME.name),
            "nothing: the plant is the clock",
        ),
    ];
    if let Some((name, _, by)) = fixed.iter().find(|(_, same, _)| !same) {
        return Err(format!(
            "parameter '{name}' is set by {by}, not as a parameter"
        ));
    }
    Ok(PlantParams {
        rate_hz: t.double(RATE_HZ.name),
        command_timeout_s: t.double(COMMAND_TIMEOUT_S.name),
        lockstep_give_up_s: t.double(LOCKSTEP_GIVE_UP_S.name),
        clock_every: u64::try_from(t.integer(CLOCK_EVERY.name))
            .unwrap_or(1)
            .max(1),
        joint_commands: t.boolean(JOINT_COMMANDS.name),
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use capsule_ros_base::params::no_rules;
    use clap::Parser;
    use ros2_client::ParameterValue as V;

    #[derive(Debug, Parser)]
    struct Cli {
        #[command(flatten)]
        flags: PlantFlags,
    }

    #[test]
    fn everything_is_read_only_once_running_but_overridable_at_start() {
        let fixed = Fixed {
            scene: "scenes/control_point.toml".into(),
            pacing: "realtime".into(),
            scale: (0.05, 200.0, 0.1),
        };
        let file =
            SceneFile::from_bytes(b"[node]\ncommand_timeout_s = 0.25\n", "f.toml", "f".into())
                .unwrap_or_else(|e| panic!("{e}"));
        let cli = Cli::try_parse_from(["x", "--scene", &fixed.scene, "--clock-every", "4"])
            .unwrap_or_else(|e| panic!("{e}"));
        let mut t = start_table(&cli.flags, &file).unwrap_or_else(|e| panic!("{e}"));
        for name in t.names().map(str::to_string).collect::<Vec<_>>() {
            assert!(t.spec(&name).is_some_and(|d| d.read_only), "{name}");
        }
        assert_eq!(t.string(SCENE.name), "scenes/control_point.toml");
        let e = t
            .set_atomically(&[(RATE_HZ.name.into(), V::Double(10.0))], no_rules)
            .unwrap_err();
        assert!(e.contains("read-only"), "{e}");
        t.override_with(&[(RATE_HZ.name.into(), V::Double(500.0))], no_rules)
            .unwrap();
        assert_eq!(t.double(RATE_HZ.name), 500.0);
        assert!(t
            .override_with(&[(RATE_HZ.name.into(), V::Double(-1.0))], no_rules)
            .is_err());
        let run = PlantParams {
            rate_hz: 500.0,
            command_timeout_s: 0.25,
            lockstep_give_up_s: 30.0,
            clock_every: 4,
            joint_commands: false,
        };
        assert_eq!(overridable(&t, &fixed), Ok(run));
        t.override_with(
            &[(SCENE.name.into(), V::String("other.toml".into()))],
            no_rules,
        )
        .unwrap();
        let e = overridable(&t, &fixed).unwrap_err();
        assert!(e.contains("'scene' is set by --scene"), "{e}");
    }

    /// The rows that name what the node parses (an enum, a node's name) say what it takes.
    #[test]
    fn the_rows_choices_are_the_nodes_own() {
        use crate::plant::{OnSilence, Pacing};
        use capsule_args::plant_settings::{CONTROLLER_NODE, LOCKSTEP_ON_SILENCE};
        use capsule_args::settings::Kind;
        use clap::ValueEnum;
        fn words<E: ValueEnum>() -> Vec<String> {
            E::value_variants()
                .iter()
                .filter_map(|v| v.to_possible_value().map(|p| p.get_name().to_string()))
                .collect()
        }
        let row = |s: &Setting| match s.kind {
            Kind::Choice(w) => w.iter().map(|w| w.to_string()).collect::<Vec<_>>(),
            _ => vec![],
        };
        assert_eq!(row(&PACING), words::<Pacing>());
        assert_eq!(row(&LOCKSTEP_ON_SILENCE), words::<OnSilence>());
        assert_eq!(
            CONTROLLER_NODE.default_text,
            Some(capsule_msgs::names::nodes::CONTROLLER)
        );
        let cli = Cli::try_parse_from(["x", "--scene", "s.toml", "--pacing", "lockstep"])
            .unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(cli.flags.choice::<Pacing>(&PACING), Ok(Pacing::Lockstep));
        assert_eq!(
            cli.flags.choice::<OnSilence>(&LOCKSTEP_ON_SILENCE),
            Ok(OnSilence::Wait)
        );
        assert!(Cli::try_parse_from(["x", "--scene", "s", "--pacing", "fast"]).is_err());
    }
}

//! A node's settings table ([`capsule_args::settings`]) as its command-line flags
//! ([`SettingFlags`], a `clap::Args`: one flag per setting marked `flag`, its help and range
//! from the entry; the values of the flags that are not parameters by [`SettingFlags::number`]
//! and its kin) and its ROS parameters ([`SettingFlags::start_table`]: each parameter
//! declared with its descriptor, valued by the precedence: default, scene, flag, and checked
//! against it there; `-p` and `--params-file` then go over the table, `ros2 param set` over the
//! running node's).

use std::collections::BTreeMap;
use std::marker::PhantomData;

use capsule_args::settings::{Kind, Setting, PRECEDENCE};
use capsule_plant::scene::Rule;
use capsule_ros_base::params::{ParamSpec, ParamTable, Range};
use ros2_client::ParameterValue as V;

/// A node's settings table.
pub trait SettingsTable: std::fmt::Debug + Clone + Send + Sync + 'static {
    /// The settings, in the order `--help` shows their flags.
    const SETTINGS: &'static [Setting];
    /// `--help` ends with the precedence (a node's table; not a tool borrowing some flags).
    const PRECEDENCE_IN_HELP: bool = true;
}

/// The flags of a settings table as given on the command line (a flag not given is absent).
#[derive(Debug, Clone)]
pub struct SettingFlags<T> {
    given: BTreeMap<&'static str, V>,
    table: PhantomData<T>,
}

impl<T> Default for SettingFlags<T> {
    fn default() -> Self {
        SettingFlags {
            given: BTreeMap::new(),
            table: PhantomData,
        }
    }
}

/// The ROS descriptor of a setting: its help, range, rule and whether it is read-only.
pub fn spec(s: &Setting) -> ParamSpec {
    let spec = if s.writable {
        ParamSpec::writable(s.help)
    } else {
        ParamSpec::read_only(s.help)
    };
    let range = match s.kind {
        Kind::Number { min, max } => Range::Float { from: min, to: max },
        Kind::Count { min, max } => Range::Integer {
            from: i64::try_from(min).unwrap_or(i64::MAX),
            to: i64::try_from(max).unwrap_or(i64::MAX),
        },
        Kind::Rule(rule) => return spec.scene_rule(rule).constraints(s.rule),
        Kind::Positive { max } => {
            let range = Range::Float { from: 0.0, to: max };
            return spec
                .scene_rule(Rule::Positive)
                .range(range)
                .constraints(s.rule);
        }
        Kind::Finite | Kind::Switch | Kind::Choice(_) | Kind::Text => Range::None,
    };
    spec.range(range).constraints(s.rule)
}

/// A number as the parameter of a setting holds it (a double, an integer for a count, a bool
/// for a switch: not 0).
pub fn param_value(s: &Setting, v: f64) -> V {
    match s.kind {
        Kind::Count { .. } => V::Integer(v as i64),
        Kind::Switch => V::Boolean(v != 0.0),
        _ => V::Double(v),
    }
}

/// A setting's value when no source gives one: its default (a switch is off unless its
/// default is on; a choice is its first word).
pub fn default_value(s: &Setting) -> Option<V> {
    match s.kind {
        Kind::Choice(words) => words.first().map(|w| V::String(w.to_string())),
        Kind::Text => s.default_text.map(|t| V::String(t.to_string())),
        Kind::Switch => Some(V::Boolean(s.default.is_some_and(|d| d != 0.0))),
        _ => s.default.map(|d| param_value(s, d)),
    }
}

impl<T: SettingsTable> SettingFlags<T> {
    /// The value given by the flag of `name`, if it was given.
    pub fn given(&self, name: &str) -> Option<&V> {
        self.given.get(name)
    }

    /// The value of setting `s`: its flag's, else its default.
    pub fn value(&self, s: &Setting) -> Option<V> {
        self.given(s.name).cloned().or_else(|| default_value(s))
    }

    /// The number of setting `s` (a count too): its flag's, else its default.
    pub fn number(&self, s: &Setting) -> Option<f64> {
        match self.value(s) {
            Some(V::Double(v)) => Some(v),
            Some(V::Integer(i)) => Some(i as f64),
            _ => None,
        }
    }

    /// The count of setting `s`: its flag's, else its default (0 for none).
    pub fn count(&self, s: &Setting) -> u64 {
        match self.value(s) {
            Some(V::Integer(i)) => u64::try_from(i).unwrap_or(0),
            _ => 0,
        }
    }

    /// The text (or choice) of setting `s`: its flag's, else its default.
    pub fn text(&self, s: &Setting) -> Option<String> {
        match self.value(s) {
            Some(V::String(t)) => Some(t),
            _ => None,
        }
    }

    /// The choice of setting `s` as the enum `E` whose values are its words.
    pub fn choice<E: clap::ValueEnum>(&self, s: &Setting) -> Result<E, String> {
        let text = self.text(s).unwrap_or_default();
        E::from_str(&text, false)
            .map_err(|_| format!("--{} {text}: not one of its choices", s.flag_name()))
    }

    /// Setting `s` as a switch: its flag's, else its default.
    pub fn switch(&self, s: &Setting) -> bool {
        matches!(self.value(s), Some(V::Boolean(true)))
    }

    /// The parameter table of the settings that are parameters, with their start values, by
    /// the precedence: the flag, else the scene's value for the setting's key (`scene`;
    /// checked against the setting's range, refused naming `file` and the key), else the
    /// default, else what the node says (`other`, by name: values from elsewhere, such as the
    /// scene's scale). A setting no source values is refused naming its flag; every value is
    /// checked against its descriptor as it is declared ([`ParamTable::validate`]).
    pub fn start_table(
        &self,
        file: &str,
        scene: impl Fn(&str) -> Option<f64>,
        other: impl Fn(&str) -> Option<V>,
    ) -> Result<ParamTable, String> {
        let mut table = ParamTable::new();
        for s in T::SETTINGS.iter().filter(|s| s.parameter) {
            let from_scene = || -> Result<Option<V>, String> {
                let Some((key, v)) = s.scene.and_then(|k| Some((k, scene(k)?))) else {
                    return Ok(None);
                };
                s.check(v).map_err(|e| format!("{file}: {key}: {e}"))?;
                Ok(Some(param_value(s, v)))
            };
            let value = match self.given(s.name) {
                Some(v) => Some(v.clone()),
                None => from_scene()?
                    .or_else(|| other(s.name))
                    .or_else(|| default_value(s)),
            };
            let value = value.ok_or_else(|| match s.scene {
                Some(key) => format!(
                    "--{} is needed (or a --scene that has {key})",
                    s.flag_name()
                ),
                None => format!("--{} is needed", s.flag_name()),
            })?;
            table = table.declare(s.name, spec(s), value);
        }
        table.validate()?;
        Ok(table)
    }
}

/// The clap argument of a setting.
fn arg(s: &'static Setting) -> clap::Arg {
    let value_name = s
        .value_name
        .map_or_else(|| s.name.replace('.', "_").to_uppercase(), str::to_string);
    let arg = clap::Arg::new(s.name)
        .long(s.flag_name())
        .help(s.help_line())
        .value_name(value_name)
        .required(s.required);
    match s.kind {
        Kind::Number { .. } | Kind::Positive { .. } | Kind::Rule(_) | Kind::Finite => arg
            .value_parser(s.number_parser())
            .allow_negative_numbers(true),
        Kind::Count { .. } => arg.value_parser(s.count_parser()),
        Kind::Switch if s.inverted => arg.action(clap::ArgAction::SetFalse),
        // on by default: `--autostart` alone, or `--autostart false`
        Kind::Switch if s.default.is_some_and(|d| d != 0.0) => arg
            .action(clap::ArgAction::Set)
            .num_args(0..=1)
            .default_missing_value("true")
            .value_name("BOOL")
            .value_parser(clap::value_parser!(bool)),
        Kind::Switch => arg.action(clap::ArgAction::SetTrue),
        Kind::Choice(words) => arg.value_parser(clap::builder::PossibleValuesParser::new(words)),
        Kind::Text => arg.value_parser(clap::value_parser!(String)),
    }
}

impl<T: SettingsTable> clap::FromArgMatches for SettingFlags<T> {
    fn from_arg_matches(matches: &clap::ArgMatches) -> Result<Self, clap::Error> {
        let mut flags = SettingFlags::default();
        flags.update_from_arg_matches(matches)?;
        Ok(flags)
    }

    fn update_from_arg_matches(&mut self, m: &clap::ArgMatches) -> Result<(), clap::Error> {
        for s in T::SETTINGS.iter().filter(|s| s.flag) {
            if m.value_source(s.name) != Some(clap::parser::ValueSource::CommandLine) {
                continue;
            }
            let value = match s.kind {
                Kind::Number { .. } | Kind::Positive { .. } | Kind::Rule(_) | Kind::Finite => {
                    m.get_one::<f64>(s.name).map(|v| V::Double(*v))
                }
                Kind::Count { .. } => m
                    .get_one::<u64>(s.name)
                    .map(|v| V::Integer(i64::try_from(*v).unwrap_or(i64::MAX))),
                Kind::Switch => m.get_one::<bool>(s.name).map(|v| V::Boolean(*v)),
                Kind::Choice(_) | Kind::Text => {
                    m.get_one::<String>(s.name).map(|v| V::String(v.clone()))
                }
            };
            if let Some(v) = value {
                self.given.insert(s.name, v);
            }
        }
        Ok(())
    }
}

impl<T: SettingsTable> clap::Args for SettingFlags<T> {
    fn augment_args(cmd: clap::Command) -> clap::Command {
        let cmd = T::SETTINGS
            .iter()
            .filter(|s| s.flag)
            .fold(cmd, |cmd, s| cmd.arg(arg(s)));
        if T::PRECEDENCE_IN_HELP {
            cmd.after_help(PRECEDENCE)
        } else {
            cmd
        }
    }

    fn augment_args_for_update(cmd: clap::Command) -> clap::Command {
        Self::augment_args(cmd)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use capsule_args::plant_settings::{PLANT, RATE_HZ};
    use clap::Parser;

    #[derive(Debug, Clone)]
    struct Plant;
    impl SettingsTable for Plant {
        const SETTINGS: &'static [Setting] = &PLANT;
    }

    #[derive(Debug, Parser)]
    struct Cli {
        #[command(flatten)]
        settings: SettingFlags<Plant>,
    }

    #[test]
    fn flags_over_the_scene_over_the_defaults_into_the_parameters() {
        let cli = Cli::try_parse_from([
            "x",
            "--scene",
            "s.toml",
            "--rate-hz",
            "500",
            "--joint-commands",
        ])
        .unwrap_or_else(|e| panic!("{e}"));
        let scene = |key: &str| match key {
            "node.command_timeout_s" => Some(0.25),
            _ => key.starts_with("physical.").then_some(1.0),
        };
        let other = |_: &str| -> Option<V> { None };
        let t = cli
            .settings
            .start_table("f.toml", scene, other)
            .unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(t.double("rate_hz"), 500.0);
        assert_eq!(t.double("command_timeout_s"), 0.25);
        assert_eq!(t.integer("clock_every"), 1);
        assert!(t.boolean("joint_commands"));
        // the flags that are not parameters are not declared; the views' switches are, on
        assert_eq!((t.get("until_s"), t.string("pacing")), (None, "realtime"));
        assert!(t.boolean("views.tf") && !t.boolean("use_sim_time"));
        let off = Cli::try_parse_from(["x", "--scene", "s", "--no-tf", "--autostart", "false"])
            .unwrap_or_else(|e| panic!("{e}"));
        let t_off = off.settings.start_table("f.toml", scene, other);
        assert!(t_off.is_ok_and(|t| !t.boolean("views.tf") && t.boolean("views.joint_states")));
        assert!(!off
            .settings
            .switch(&capsule_args::plant_settings::AUTOSTART));
        assert!(cli
            .settings
            .switch(&capsule_args::plant_settings::AUTOSTART));
        assert_eq!(
            t.spec("clock_every").map(|s| (s.range, s.read_only)),
            Some((
                Range::Integer {
                    from: 1,
                    to: 1_000_000
                },
                true
            ))
        );
        // a scene value out of the setting's range, refused as the flag and parameter are
        let bad = |_: &str| Some(1e9);
        let e = cli.settings.start_table("f.toml", bad, other).unwrap_err();
        assert_eq!(
            e,
            "f.toml: node.command_timeout_s: must be in [1e-6, 1e6] (got 1e9)"
        );
        let e = Cli::try_parse_from(["x", "--scene", "s", "--clock-every", "0"])
            .unwrap_err()
            .to_string();
        assert!(
            e.contains(
                "--clock-every <CLOCK_EVERY>': must be a whole number from 1 to 1000000 (got 0)"
            ),
            "{e}"
        );
        assert_eq!(find_help(&RATE_HZ), RATE_HZ.help_line());
    }

    fn find_help(s: &'static Setting) -> String {
        arg(s).get_help().map(|h| h.to_string()).unwrap_or_default()
    }
}

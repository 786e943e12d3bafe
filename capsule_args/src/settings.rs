//! A node's settings, declared once: one [`Setting`] per value a node starts with, from which
//! its command-line flag, its ROS parameter (descriptor, range, read-only), its scene key, its
//! help and its place in the precedence all come (the friction constants' way:
//! `capsule_plant::friction::FRICTION_CONSTANTS`). The tables: [`crate::plant_settings::PLANT`]
//! and [`crate::controller_settings::CONTROLLER`], beside each other.
//!
//! Precedence, the same for every setting of every node (later wins):
//!
//! 1. the setting's default;
//! 2. the scene file's key;
//! 3. the command-line flag;
//! 4. the ROS parameter at start (`--ros-args -p NAME:=VALUE`, `--params-file`);
//! 5. `ros2 param set` on the running node (writable settings only).
//!
//! Each source refuses a value out of the setting's range with the same range in the message
//! ([`Setting::check`], [`Setting::range_text`]); the ROS descriptor announces that range.

use capsule_plant::number_text::short;
use capsule_plant::scene::{key_rule, Rule};

use crate::ranges::{self, FlagParser};

/// The values a setting takes.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Kind {
    /// A finite number in the closed range `[min, max]`.
    Number {
        /// Smallest value.
        min: f64,
        /// Largest value.
        max: f64,
    },
    /// Any finite number: the node's own rules judge it (a gain against the gain limit).
    Finite,
    /// A number the scene reader's rule for the setting's scene key admits
    /// ([`capsule_plant::scene::KEY_RULES`]): flag, parameter and scene refuse alike.
    Rule(Rule),
    /// A whole number in `[min, max]`.
    Count {
        /// Smallest value.
        min: u64,
        /// Largest value.
        max: u64,
    },
    /// A finite number in `(0, max]` (a duration, a limit: zero means nothing).
    Positive {
        /// Largest value.
        max: f64,
    },
    /// On or off: a flag without value; one on by default takes an optional `BOOL`
    /// (`--autostart false`), or is turned off by `--no-NAME` ([`Setting::inverted`]).
    Switch,
    /// One of these words; the first is the default.
    Choice(&'static [&'static str]),
    /// Text (a name, a path).
    Text,
}

/// One setting of a node.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Setting {
    /// The ROS parameter's name; the flag is `--` and the name with `-` for `_`.
    pub name: &'static str,
    /// What it is, with its unit (one line: the flag's help and the parameter's description).
    pub help: &'static str,
    /// The values it takes.
    pub kind: Kind,
    /// What else a value must satisfy, in words (between settings: "at most the gain limit").
    pub rule: &'static str,
    /// It has a command-line flag made from this entry (else it has none).
    pub flag: bool,
    /// It is a ROS parameter of the node (else only a flag: [`Setting::flag_only`]).
    pub parameter: bool,
    /// A switch on by default whose flag, `--no-` and the name's last part, turns it off.
    pub inverted: bool,
    /// The flag must be given.
    pub required: bool,
    /// The flag's value as `--help` names it (`DIR`; else the name in capitals).
    pub value_name: Option<&'static str>,
    /// Its value when no source gives one (text).
    pub default_text: Option<&'static str>,
    /// Its key in the scene file (`node.rate_hz`), if the scene gives it.
    pub scene: Option<&'static str>,
    /// `ros2 param set` may change it on the running node (else read-only once running).
    pub writable: bool,
    /// Its value when no source gives one (numbers and counts).
    pub default: Option<f64>,
}

impl Setting {
    /// A setting of `kind`: read-only once running, no flag, no scene key, no default.
    pub const fn new(name: &'static str, help: &'static str, kind: Kind) -> Setting {
        Setting {
            name,
            help,
            kind,
            rule: "",
            flag: false,
            parameter: true,
            inverted: false,
            required: false,
            value_name: None,
            scene: None,
            writable: false,
            default: None,
            default_text: None,
        }
    }

    /// A setting the scene file's fixed `key` gives, with that key's rule as its range (a
    /// compile-time error for a key without one).
    pub const fn of_scene(name: &'static str, help: &'static str, key: &'static str) -> Setting {
        Setting::new(name, help, Kind::Rule(key_rule(key))).scene(key)
    }

    /// With a command-line flag.
    pub const fn flag(mut self) -> Setting {
        self.flag = true;
        self
    }

    /// A command-line flag and not a ROS parameter (how the node runs, not what it simulates or
    /// controls: `--until-s`, `--record-dir`).
    pub const fn flag_only(mut self) -> Setting {
        self.flag = true;
        self.parameter = false;
        self
    }

    /// The flag's value named `name` in `--help`.
    pub const fn value_name(self, name: &'static str) -> Setting {
        Setting {
            value_name: Some(name),
            ..self
        }
    }

    /// The flag must be given.
    pub const fn required(mut self) -> Setting {
        self.required = true;
        self
    }

    /// With a default text.
    pub const fn default_text(self, text: &'static str) -> Setting {
        Setting {
            default_text: Some(text),
            ..self
        }
    }

    /// A switch on by default, turned off by `--no-` and the name's last part (`views.tf`:
    /// `--no-tf`); its help says what it does when on, as a verb (`publish /tf`).
    pub const fn inverted(mut self) -> Setting {
        self.inverted = true;
        self.default = Some(1.0);
        self
    }

    /// Given by the scene file's `key`.
    pub const fn scene(mut self, key: &'static str) -> Setting {
        self.scene = Some(key);
        self
    }

    /// Writable on the running node.
    pub const fn writable(mut self) -> Setting {
        self.writable = true;
        self
    }

    /// With a default value.
    pub const fn default(mut self, value: f64) -> Setting {
        self.default = Some(value);
        self
    }

    /// With a rule between settings, in words.
    pub const fn rule(mut self, text: &'static str) -> Setting {
        self.rule = text;
        self
    }

    /// The flag's name without the dashes (`rate-hz`, `views-rate-hz`; `no-tf` for the
    /// inverted `views.tf`).
    pub fn flag_name(&self) -> String {
        if self.inverted {
            let last = self.name.rsplit('.').next().unwrap_or(self.name);
            return format!("no-{}", last.replace('_', "-"));
        }
        self.name.replace(['_', '.'], "-")
    }

    /// The default as text (`1e3`, `realtime`), if it has one.
    pub fn default_label(&self) -> Option<String> {
        match self.kind {
            Kind::Choice(words) => words.first().map(|w| w.to_string()),
            Kind::Switch => None,
            _ => self
                .default
                .map(short)
                .or_else(|| self.default_text.map(str::to_string)),
        }
    }

    /// The range as messages and help write it: `[1e-3, 1e6]`, `1 to 1000000`; `None` for
    /// any finite number, a switch, a choice (clap lists its words) or text.
    pub fn range_text(&self) -> Option<String> {
        match self.kind {
            Kind::Number { min, max } => Some(format!("[{}, {}]", short(min), short(max))),
            Kind::Count { min, max } => Some(format!("{min} to {max}")),
            Kind::Positive { max } => Some(format!("(0, {}]", short(max))),
            Kind::Rule(rule) => rule.range_text(),
            Kind::Finite | Kind::Switch | Kind::Choice(_) | Kind::Text => None,
        }
    }

    /// The scene reader's rule for this setting's value (numbers only).
    pub fn scene_rule(&self) -> Rule {
        match self.kind {
            Kind::Number { min, max } => Rule::Within((min, max)),
            Kind::Count { min, max } => Rule::Within((min as f64, max as f64)),
            Kind::Positive { max } => Rule::Within((f64::MIN_POSITIVE, max)),
            Kind::Rule(rule) => rule,
            Kind::Finite | Kind::Switch | Kind::Choice(_) | Kind::Text => Rule::Finite,
        }
    }

    /// Checks a number (from the scene, or any source but the flag's text): the reason it is
    /// refused, as the flag's parser words it.
    pub fn check(&self, v: f64) -> Result<(), String> {
        if let Kind::Rule(rule) = self.kind {
            return rule.admits(v).map_err(|fault| fault.to_string());
        }
        if !v.is_finite() {
            return Err(format!("must be a finite number (got {})", short(v)));
        }
        let inside = match self.kind {
            Kind::Number { min, max } => (min..=max).contains(&v),
            Kind::Count { min, max } => v.fract() == 0.0 && (min as f64..=max as f64).contains(&v),
            Kind::Positive { max } => v > 0.0 && v <= max,
            Kind::Finite | Kind::Switch | Kind::Choice(_) | Kind::Text | Kind::Rule(_) => true,
        };
        match (inside, self.kind) {
            (true, _) => Ok(()),
            (false, Kind::Positive { max }) => Err(format!(
                "must be > 0 and <= {} (got {})",
                short(max),
                short(v)
            )),
            (false, Kind::Count { min, max }) => Err(format!(
                "must be a whole number from {min} to {max} (got {})",
                short(v)
            )),
            (false, _) => Err(format!(
                "must be in {} (got {})",
                self.range_text().unwrap_or_default(),
                short(v)
            )),
        }
    }

    /// The flag's parser of a number (a [`Kind::Number`], [`Kind::Positive`], [`Kind::Rule`] or
    /// [`Kind::Finite`]):
    /// refuses what [`Setting::check`] refuses, in its words.
    pub fn number_parser(&self) -> impl FlagParser<f64> {
        let setting = *self;
        move |text: &str| {
            let v = ranges::number(text)?;
            setting.check(v).map(|()| v)
        }
    }

    /// The flag's parser of a count (a [`Kind::Count`]).
    pub fn count_parser(&self) -> impl FlagParser<u64> {
        let (min, max) = match self.kind {
            Kind::Count { min, max } => (min, max),
            _ => (0, u64::MAX),
        };
        ranges::count(min, max)
    }

    /// The help line: what it is, its range and rule, then its default, scene key and
    /// parameter (`Sample rate [Hz], [1e-3, 1e6] [default: 1000; scene: node.rate_hz;
    /// parameter rate_hz, read-only]`); an inverted switch's says what its flag turns off.
    pub fn help_line(&self) -> String {
        let mut text = if self.inverted {
            format!("Do not {}", self.help)
        } else {
            self.help.to_string()
        };
        if let Some(range) = self.range_text() {
            text += &format!(", {range}");
        }
        if !self.rule.is_empty() {
            text += &format!(" and {}", self.rule);
        }
        let mut tags = Vec::new();
        if let Some(d) = self.default_label() {
            tags.push(format!("default: {d}"));
        }
        if let Some(key) = self.scene {
            tags.push(format!("scene: {key}"));
        }
        let access = if self.writable {
            "writable"
        } else {
            "read-only"
        };
        if self.parameter {
            tags.push(format!("parameter {}, {access}", self.name));
        }
        if tags.is_empty() {
            return text;
        }
        format!("{text} [{}]", tags.join("; "))
    }
}

/// `--check`, a row of every node's table.
pub const CHECK: Setting = Setting::new(
    "check",
    "Check the scene and flags, print what would run, and exit (no DDS)",
    Kind::Switch,
)
.flag_only();

/// The setting named `name` in `table`.
pub fn find<'a>(table: &'a [Setting], name: &str) -> Option<&'a Setting> {
    table.iter().find(|s| s.name == name)
}

/// The precedence, as `--help` ends with it.
pub const PRECEDENCE: &str = "Settings with a [parameter] take, later winning: their default, the scene file's key, the \
flag, `--ros-args -p NAME:=VALUE` or `--params-file` at start, and (writable ones) `ros2 param set` on the running node; \
each refuses a value out of its range the same way.";

#[cfg(test)]
mod tests {
    use super::*;

    const RATE: Setting = Setting::new(
        "rate_hz",
        "Sample rate [Hz]",
        Kind::Number {
            min: 1e-3,
            max: 1e6,
        },
    )
    .flag()
    .scene("node.rate_hz")
    .default(1000.0);

    #[test]
    fn a_setting_says_its_range_the_same_way_to_every_source() {
        assert_eq!(RATE.flag_name(), "rate-hz");
        assert_eq!(RATE.range_text().as_deref(), Some("[1e-3, 1e6]"));
        let flag = RATE.number_parser()("1e-300").unwrap_err();
        let checked = RATE.check(1e-300).unwrap_err();
        assert_eq!(flag, "must be in [1e-3, 1e6] (got 1e-300)");
        assert_eq!(checked, flag);
        assert_eq!(RATE.number_parser()("500"), Ok(500.0));
        assert_eq!(
            RATE.check(f64::NAN).unwrap_err(),
            "must be a finite number (got NaN)"
        );
        assert_eq!(
            RATE.help_line(),
            "Sample rate [Hz], [1e-3, 1e6] [default: 1e3; scene: node.rate_hz; parameter rate_hz, read-only]"
        );
        let every = Setting::new("clock_every", "x", Kind::Count { min: 1, max: 10 });
        assert!(every.check(2.5).is_err_and(|e| e.contains("from 1 to 10")));
        assert_eq!(
            every.count_parser()("0").unwrap_err(),
            "must be a whole number from 1 to 10 (got 0)"
        );
        assert_eq!(find(&[RATE, every], "clock_every"), Some(&every));
    }
}

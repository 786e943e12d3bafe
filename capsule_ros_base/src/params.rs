//! A node's ROS parameters as rclcpp keeps them: declared names with a descriptor (type,
//! description, read-only, numeric range) and a value, and the rules of `set_parameters`.
//!
//! Pure (no DDS): [`crate::param_services`] serves a [`ParamTable`] over the `rcl_interfaces`
//! services. The wire types are ros2-client's (`rcl_interfaces` and `parameters::raw`), which
//! have the CDR layout of the `.msg` / `.srv` files.
//!
//! Rules of a set (rclcpp's, plus the node's own [`Rules`]): the name must be declared, the
//! type must be the declared one (no dynamic typing), a double must be finite and inside its
//! range, a read-only parameter refuses (except as a start-up override), and the node's rules
//! must accept the whole table with the new values. A refused set changes nothing and produces
//! no event; an accepted one reports the values that really changed.

use std::collections::BTreeMap;

use capsule_plant::number_text::short;
use capsule_plant::scene::Rule;

use ros2_client::{parameters::raw, rcl_interfaces::ListParametersResult, ParameterValue};

/// The numeric range a descriptor announces (and a set must respect).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Range {
    /// No range.
    None,
    /// Doubles in `[from, to]` (inclusive, as rclcpp).
    Float {
        /// Lowest value.
        from: f64,
        /// Highest value.
        to: f64,
    },
    /// Integers in `[from, to]`.
    Integer {
        /// Lowest value.
        from: i64,
        /// Highest value.
        to: i64,
    },
}

/// What `describe_parameters` says of a parameter.
#[derive(Debug, Clone, PartialEq)]
pub struct ParamSpec {
    /// One line for `ros2 param describe`.
    pub description: String,
    /// Constraints a range cannot express.
    pub constraints: String,
    /// Cannot be set once the node runs (start-up overrides still may).
    pub read_only: bool,
    /// Numeric range.
    pub range: Range,
    /// The scene reader's rule the value must also pass (a setting given by a scene key):
    /// refusals then say what the scene file's would.
    pub rule: Option<Rule>,
}

impl ParamSpec {
    /// A writable parameter without range.
    pub fn writable(description: &str) -> Self {
        ParamSpec {
            description: description.to_string(),
            constraints: String::new(),
            read_only: false,
            range: Range::None,
            rule: None,
        }
    }

    /// A read-only parameter (fixed once the node runs).
    pub fn read_only(description: &str) -> Self {
        ParamSpec {
            read_only: true,
            ..ParamSpec::writable(description)
        }
    }

    /// With a range.
    pub fn range(mut self, range: Range) -> Self {
        self.range = range;
        self
    }

    /// With the scene reader's rule, and the range it announces.
    pub fn scene_rule(mut self, rule: Rule) -> Self {
        self.rule = Some(rule);
        if let Some((from, to)) = rule.bounds() {
            self.range = Range::Float { from, to };
        }
        self
    }

    /// With additional constraints in words.
    pub fn constraints(mut self, text: &str) -> Self {
        self.constraints = text.to_string();
        self
    }
}

/// The node's own rules over the whole table: may refuse (with the reason) and may normalise
/// values (e.g. the controller stores the gain a mode really uses).
pub type Rules = fn(&mut ParamTable) -> Result<(), String>;

/// Rules that accept everything the table itself accepts.
pub fn no_rules(_: &mut ParamTable) -> Result<(), String> {
    Ok(())
}

/// A node's declared parameters.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct ParamTable {
    entries: BTreeMap<String, (ParamSpec, ParameterValue)>,
}

/// A name and a value, as the services carry them.
pub type Param = (String, ParameterValue);

fn type_name(v: &ParameterValue) -> &'static str {
    match v {
        ParameterValue::NotSet => "not set",
        ParameterValue::Boolean(_) => "bool",
        ParameterValue::Integer(_) => "integer",
        ParameterValue::Double(_) => "double",
        ParameterValue::String(_) => "string",
        ParameterValue::ByteArray(_) => "byte_array",
        ParameterValue::BooleanArray(_) => "bool_array",
        ParameterValue::IntegerArray(_) => "integer_array",
        ParameterValue::DoubleArray(_) => "double_array",
        ParameterValue::StringArray(_) => "string_array",
    }
}

impl ParamTable {
    /// An empty table.
    pub fn new() -> Self {
        ParamTable::default()
    }

    /// Declares `name` with its descriptor and initial value (builder style).
    pub fn declare(mut self, name: &str, spec: ParamSpec, value: ParameterValue) -> Self {
        self.entries.insert(name.to_string(), (spec, value));
        self
    }

    /// The value of `name`.
    pub fn get(&self, name: &str) -> Option<&ParameterValue> {
        self.entries.get(name).map(|(_, v)| v)
    }

    /// The descriptor of `name`.
    pub fn spec(&self, name: &str) -> Option<&ParamSpec> {
        self.entries.get(name).map(|(s, _)| s)
    }

    /// The double `name` (NaN if it is not a declared double: a programming error).
    pub fn double(&self, name: &str) -> f64 {
        match self.get(name) {
            Some(ParameterValue::Double(d)) => *d,
            _ => f64::NAN,
        }
    }

    /// The bool `name` (false if it is not a declared bool).
    pub fn boolean(&self, name: &str) -> bool {
        matches!(self.get(name), Some(ParameterValue::Boolean(true)))
    }

    /// The string `name` (empty if it is not a declared string).
    pub fn string(&self, name: &str) -> &str {
        match self.get(name) {
            Some(ParameterValue::String(s)) => s,
            _ => "",
        }
    }

    /// The integer `name` (0 if it is not a declared integer).
    pub fn integer(&self, name: &str) -> i64 {
        match self.get(name) {
            Some(ParameterValue::Integer(i)) => *i,
            _ => 0,
        }
    }

    /// Sets `name` without checks (the node's own changes, e.g. a mode switch by service).
    /// Returns true if the value changed.
    pub fn put(&mut self, name: &str, value: ParameterValue) -> bool {
        match self.entries.get_mut(name) {
            Some((_, v)) if *v != value => {
                *v = value;
                true
            }
            _ => false,
        }
    }

    /// Names, in order.
    pub fn names(&self) -> impl Iterator<Item = &str> {
        self.entries.keys().map(String::as_str)
    }

    /// `list_parameters` as rclcpp answers it: with no prefixes, the names with fewer than
    /// `depth` dots (0: all); else the names equal to a prefix or under `prefix.` within
    /// `depth` further levels; `prefixes` are the distinct namespaces of the names listed.
    pub fn list(&self, prefixes: &[String], depth: u64) -> ListParametersResult {
        let within = |s: &str| depth == 0 || (s.matches('.').count() as u64) < depth;
        let mut out = ListParametersResult {
            names: vec![],
            prefixes: vec![],
        };
        for name in self.entries.keys() {
            let all = prefixes.is_empty() && within(name);
            let under = prefixes.iter().any(|p| {
                name == p
                    || name
                        .strip_prefix(p.as_str())
                        .and_then(|r| r.strip_prefix('.'))
                        .is_some_and(&within)
            });
            if all || under {
                out.names.push(name.clone());
                if let Some((ns, _)) = name.rsplit_once('.') {
                    if !out.prefixes.iter().any(|p| p == ns) {
                        out.prefixes.push(ns.to_string());
                    }
                }
            }
        }
        out
    }

    /// `get_parameters`: the values (NOT_SET for an unknown name, as rclcpp).
    pub fn values(&self, names: &[String]) -> Vec<raw::ParameterValue> {
        names
            .iter()
            .map(|n| {
                self.get(n)
                    .cloned()
                    .unwrap_or(ParameterValue::NotSet)
                    .into()
            })
            .collect()
    }

    /// `get_parameter_types`: the type codes (NOT_SET = 0 for an unknown name).
    pub fn types(&self, names: &[String]) -> Vec<u8> {
        names
            .iter()
            .map(|n| self.get(n).map_or(0, ParameterValue::to_parameter_type_raw))
            .collect()
    }

    /// `describe_parameters`: one descriptor per name (type NOT_SET for an unknown name).
    pub fn describe(&self, names: &[String]) -> Vec<raw::ParameterDescriptor> {
        names
            .iter()
            .map(|n| {
                let Some((spec, value)) = self.entries.get(n) else {
                    return raw::ParameterDescriptor {
                        name: n.clone(),
                        r#type: 0,
                        description: String::new(),
                        additional_constraints: String::new(),
                        read_only: false,
                        dynamic_typing: false,
                        floating_point_range: vec![],
                        integer_range: vec![],
                    };
                };
                let (floating_point_range, integer_range) = match spec.range {
                    Range::None => (vec![], vec![]),
                    Range::Float { from, to } => (
                        vec![raw::FloatingPointRange {
                            from_value: from,
                            to_value: to,
                            step: 0.0,
                        }],
                        vec![],
                    ),
                    Range::Integer { from, to } => (
                        vec![],
                        vec![raw::IntegerRange {
                            from_value: from,
                            to_value: to,
                            step: 0,
                        }],
                    ),
                };
                raw::ParameterDescriptor {
                    name: n.clone(),
                    r#type: ParameterValue::to_parameter_type_raw(value),
                    description: spec.description.clone(),
                    additional_constraints: spec.constraints.clone(),
                    read_only: spec.read_only,
                    dynamic_typing: false,
                    floating_point_range,
                    integer_range,
                }
            })
            .collect()
    }

    /// Checks one value against its declaration; `startup` lets read-only ones through.
    fn check(&self, name: &str, value: &ParameterValue, startup: bool) -> Result<(), String> {
        let Some((spec, current)) = self.entries.get(name) else {
            return Err(format!("parameter '{name}' is not declared"));
        };
        if spec.read_only && !startup {
            return Err(format!("parameter '{name}' is read-only"));
        }
        if std::mem::discriminant(current) != std::mem::discriminant(value) {
            return Err(format!(
                "wrong parameter type: '{name}' is of type {}, setting it to {} is not allowed",
                type_name(current),
                type_name(value)
            ));
        }
        // the reasons in the words of the flags and the scene reader (capsule_args::settings)
        if let (ParameterValue::Double(d), Some(rule)) = (value, spec.rule) {
            if let Err(fault) = rule.admits(*d) {
                return Err(format!("parameter '{name}': {fault}"));
            }
        }
        match (value, spec.range) {
            (ParameterValue::Double(d), _) if !d.is_finite() => Err(format!(
                "parameter '{name}': must be a finite number (got {})",
                short(*d)
            )),
            (ParameterValue::Double(d), Range::Float { from, to }) if !(from..=to).contains(d) => {
                Err(format!(
                    "parameter '{name}': must be in [{}, {}] (got {})",
                    short(from),
                    short(to),
                    short(*d)
                ))
            }
            (ParameterValue::Integer(i), Range::Integer { from, to })
                if !(from..=to).contains(i) =>
            {
                Err(format!(
                    "parameter '{name}': must be a whole number from {from} to {to} (got {i})"
                ))
            }
            _ => Ok(()),
        }
    }

    /// Applies `params` all or nothing: every one checked, the node's `rules` run on the
    /// result. On success the table holds the new values and the changed ones are returned
    /// (empty if nothing changed); on refusal the table is unchanged.
    fn apply(
        &mut self,
        params: &[Param],
        rules: Rules,
        startup: bool,
    ) -> Result<Vec<Param>, String> {
        let mut candidate = self.clone();
        for (name, value) in params {
            self.check(name, value, startup)?;
            candidate.put(name, value.clone());
        }
        rules(&mut candidate)?;
        let changed = candidate
            .entries
            .iter()
            .filter(|(n, (_, v))| self.get(n) != Some(v))
            .map(|(n, (_, v))| (n.clone(), v.clone()))
            .collect();
        *self = candidate;
        Ok(changed)
    }

    /// `set_parameters_atomically`: all or nothing.
    pub fn set_atomically(&mut self, params: &[Param], rules: Rules) -> Result<Vec<Param>, String> {
        self.apply(params, rules, false)
    }

    /// `set_parameters`: each parameter on its own (as rclcpp), one result per parameter and
    /// the values that changed overall.
    pub fn set_each(
        &mut self,
        params: &[Param],
        rules: Rules,
    ) -> (Vec<Result<(), String>>, Vec<Param>) {
        let mut results = Vec::with_capacity(params.len());
        let mut changed: Vec<Param> = Vec::new();
        for p in params {
            match self.apply(std::slice::from_ref(p), rules, false) {
                Ok(c) => {
                    for (n, v) in c {
                        changed.retain(|(m, _)| *m != n);
                        changed.push((n, v));
                    }
                    results.push(Ok(()));
                }
                Err(e) => results.push(Err(e)),
            }
        }
        (results, changed)
    }

    /// Every value against its own declaration (type, range, rule): the first that fails, by
    /// name. A node's start table passes it before the node starts, whatever built it.
    pub fn validate(&self) -> Result<(), String> {
        self.entries
            .iter()
            .try_for_each(|(name, (_, value))| self.check(name, value, true))
    }

    /// Start-up overrides (`-p`, `--params-file`): as an atomic set, read-only ones included.
    pub fn override_with(&mut self, params: &[Param], rules: Rules) -> Result<(), String> {
        self.apply(params, rules, true).map(|_| ())
    }
}

/// A `/parameter_events` message for `changed` on node `node` (fully qualified) at `stamp`.
pub fn event(node: &str, changed: &[Param], stamp: capsule_msgs::Time) -> raw::ParameterEvent {
    raw::ParameterEvent {
        stamp: ros2_client::builtin_interfaces::Time::from_nanos(stamp.to_nanos()),
        node: node.to_string(),
        new_parameters: vec![],
        changed_parameters: changed
            .iter()
            .map(|(n, v)| raw::Parameter {
                name: n.clone(),
                value: v.clone().into(),
            })
            .collect(),
        deleted_parameters: vec![],
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use ParameterValue as V;

    fn table() -> ParamTable {
        ParamTable::new()
            .declare("gain", ParamSpec::writable("k_p"), V::Double(0.2))
            .declare(
                "limit",
                ParamSpec::writable("|k_p| limit").range(Range::Float {
                    from: 0.0,
                    to: 10.0,
                }),
                V::Double(2.0),
            )
            .declare("rate_hz", ParamSpec::read_only("rate"), V::Double(1000.0))
            .declare("views.tf", ParamSpec::writable("tf"), V::Boolean(true))
            .declare(
                "views.joint_states",
                ParamSpec::writable("js"),
                V::Boolean(true),
            )
    }

    /// |gain| <= limit, the way a node's rules refuse.
    fn gain_within_limit(t: &mut ParamTable) -> Result<(), String> {
        if t.double("gain").abs() > t.double("limit") {
            return Err(format!(
                "|k_p| = {} above the limit {}",
                t.double("gain").abs(),
                t.double("limit")
            ));
        }
        Ok(())
    }

    fn p(name: &str, v: V) -> Param {
        (name.to_string(), v)
    }

    #[test]
    fn bad_sets_are_refused_with_a_reason_and_change_nothing() {
        let mut t = table();
        let before = t.clone();
        for (params, needle) in [
            (
                vec![p("gain", V::String("x".into()))],
                "wrong parameter type",
            ),
            (vec![p("gain", V::Integer(1))], "wrong parameter type"),
            (
                vec![p("gain", V::Double(f64::NAN))],
                "must be a finite number",
            ),
            (
                vec![p("limit", V::Double(11.0))],
                "must be in [0, 10] (got 11)",
            ),
            (vec![p("nope", V::Double(1.0))], "not declared"),
            (vec![p("rate_hz", V::Double(10.0))], "read-only"),
            (vec![p("gain", V::Double(3.0))], "above the limit"),
            // atomically: one bad one spoils the set
            (
                vec![p("gain", V::Double(0.5)), p("nope", V::Double(1.0))],
                "not declared",
            ),
        ] {
            let e = t.set_atomically(&params, gain_within_limit).unwrap_err();
            assert!(e.contains(needle), "{e} vs {needle}");
            assert_eq!(t, before);
            let (results, changed) = t.set_each(&params, gain_within_limit);
            assert!(results.iter().any(|r| r.is_err()));
            if params.len() == 1 {
                assert!(changed.is_empty());
                assert_eq!(t, before);
            }
        }
    }

    #[test]
    fn refusals_write_numbers_as_short_as_they_round_trip() {
        let mut t = table();
        let e = t
            .set_atomically(&[p("limit", V::Double(1e308))], no_rules)
            .unwrap_err();
        assert_eq!(e, "parameter 'limit': must be in [0, 10] (got 1e308)");
        let e = t
            .set_atomically(&[p("limit", V::Double(-0.25))], no_rules)
            .unwrap_err();
        assert_eq!(e, "parameter 'limit': must be in [0, 10] (got -0.25)");
    }

    #[test]
    fn accepted_sets_report_only_what_changed() {
        let mut t = table();
        let changed = t
            .set_atomically(
                &[p("gain", V::Double(0.5)), p("views.tf", V::Boolean(true))],
                gain_within_limit,
            )
            .unwrap();
        assert_eq!(changed, vec![p("gain", V::Double(0.5))]);
        assert_eq!(t.double("gain"), 0.5);
        // set_parameters: each on its own, the good one stays
        let (results, changed) = t.set_each(
            &[p("gain", V::Double(0.7)), p("gain", V::Double(9.0))],
            gain_within_limit,
        );
        assert_eq!(results[0], Ok(()));
        assert!(results[1].is_err());
        assert_eq!(changed, vec![p("gain", V::Double(0.7))]);
        assert_eq!(t.double("gain"), 0.7);
        // the same value again: accepted, nothing to report
        assert!(t
            .set_atomically(&[p("gain", V::Double(0.7))], gain_within_limit)
            .unwrap()
            .is_empty());
    }

    #[test]
    fn startup_overrides_may_set_read_only_parameters_but_not_bad_values() {
        let mut t = table();
        t.override_with(&[p("rate_hz", V::Double(500.0))], no_rules)
            .unwrap();
        assert_eq!(t.double("rate_hz"), 500.0);
        assert!(t
            .override_with(&[p("rate_hz", V::Boolean(true))], no_rules)
            .is_err());
        assert_eq!(t.double("rate_hz"), 500.0);
    }

    #[test]
    fn list_get_types_and_describe_answer_as_rclcpp() {
        let t = table();
        let all = t.list(&[], 0);
        assert_eq!(
            all.names,
            ["gain", "limit", "rate_hz", "views.joint_states", "views.tf"]
        );
        assert_eq!(all.prefixes, ["views"]);
        assert_eq!(t.list(&[], 1).names, ["gain", "limit", "rate_hz"]);
        assert_eq!(
            t.list(&["views".into()], 0).names,
            ["views.joint_states", "views.tf"]
        );
        let names = ["gain".to_string(), "views.tf".into(), "nope".into()];
        let values = t.values(&names);
        assert_eq!((values[0].ptype, values[0].double_value), (3, 0.2));
        assert_eq!((values[1].ptype, values[1].boolean_value), (1, true));
        assert_eq!(values[2].ptype, 0);
        assert_eq!(t.types(&names), [3, 1, 0]);
        let d = t.describe(&["limit".into(), "rate_hz".into(), "nope".into()]);
        assert_eq!(d[0].floating_point_range.len(), 1);
        assert_eq!(d[0].floating_point_range[0].to_value, 10.0);
        assert!(!d[0].read_only && d[1].read_only);
        assert_eq!((d[1].r#type, d[2].r#type), (3, 0));
    }

    #[test]
    fn events_carry_the_changed_values() {
        let e = event(
            "/n",
            &[p("gain", V::Double(0.5))],
            capsule_msgs::Time { sec: 3, nanosec: 4 },
        );
        assert_eq!(
            (
                e.node.as_str(),
                e.stamp.to_nanos(),
                e.changed_parameters.len()
            ),
            ("/n", 3_000_000_004, 1)
        );
        assert_eq!(e.changed_parameters[0].value.double_value, 0.5);
        assert!(e.new_parameters.is_empty() && e.deleted_parameters.is_empty());
    }
}

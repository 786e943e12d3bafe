//! The ROS 2 command-line habits beside the nodes' own flags: `--ros-args ... [--]` with
//! `-p NAME:=VALUE`, `--params-file FILE` (ROS 2 YAML: `/**:` or `/node_name:`, then
//! `ros__parameters:`), `-r __ns:=/x`, `-r __node:=name`, `-r [node:]from:=to`, `-e` /
//! `--enclave /name` (SROS2, [`crate::security`]).
//!
//! [`split`] takes the `--ros-args` blocks out of argv before clap sees the rest; the names
//! and remaps go into [`RosArgs`] (one place resolves them: [`crate::ros_options::RosOptions`]); the
//! parameter overrides are applied to the node's [`ParamTable`] at start, in command-line
//! order (later wins), as rcl does. Values are typed as YAML types them (`1` integer, `1.0`
//! double, `true` bool, `[1.0, 2.0]` array, else string); an integer for a declared double is
//! taken as that double. Every error names the argument or the file and key.

use std::{ffi::OsString, path::PathBuf};

use crate::error::{bail, invalid, Context as _, Result};
use ros2_client::ParameterValue as V;
use yaml_rust2::{Yaml, YamlLoader};

use crate::{
    params::{Param, ParamTable, Rules},
    ros_options::RosArgs,
};

/// One parameter source, in command-line order.
#[derive(Debug, Clone, PartialEq)]
enum Source {
    /// `-p NAME:=VALUE` (the argument text).
    Param(String),
    /// `--params-file FILE`.
    File(PathBuf),
}

/// What the `--ros-args` blocks said.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct RosCli {
    sources: Vec<Source>,
    remaps: Vec<String>,
    enclave: Option<String>,
}

/// A parameter override and where it came from (for error messages).
#[derive(Debug, Clone, PartialEq)]
pub struct Override {
    /// Parameter name (dots for nesting).
    pub name: String,
    /// Value as YAML typed it.
    pub value: V,
    /// `-p ...` or `FILE: /node.ros__parameters.name`.
    pub origin: String,
}

/// Splits `--ros-args` blocks (up to `--` or the end) out of `argv`.
pub fn split(argv: impl IntoIterator<Item = OsString>) -> Result<(Vec<OsString>, RosCli)> {
    let mut rest = Vec::new();
    let mut cli = RosCli::default();
    let mut args = argv.into_iter();
    while let Some(a) = args.next() {
        if a != "--ros-args" {
            rest.push(a);
            continue;
        }
        while let Some(a) = args.next() {
            let a = a
                .into_string()
                .map_err(|a| invalid!("--ros-args: {a:?} is not UTF-8"))?;
            let mut value = |flag: &str| {
                args.next()
                    .and_then(|v| v.into_string().ok())
                    .with_context(|| format!("--ros-args {flag}: a value is missing"))
            };
            match a.as_str() {
                "--" => break,
                "--ros-args" => {}
                "-p" | "--param" => {
                    let v = value(&a)?;
                    if !v.contains(":=") {
                        bail!("--ros-args {a} {v:?}: expected NAME:=VALUE");
                    }
                    cli.sources.push(Source::Param(v));
                }
                "--params-file" => cli.sources.push(Source::File(value(&a)?.into())),
                "-e" | "--enclave" => cli.enclave = Some(value(&a)?),
                "-r" | "--remap" => {
                    let v = value(&a)?;
                    if !v.contains(":=") {
                        bail!("--ros-args {a} {v:?}: expected FROM:=TO");
                    }
                    cli.remaps.push(v);
                }
                other => bail!(
                    "--ros-args {other:?}: not supported (supported: -p NAME:=VALUE, --params-file FILE, -r FROM:=TO with __ns / __node, -e ENCLAVE, --; log levels: RUST_LOG)"
                ),
            }
        }
    }
    Ok((rest, cli))
}

/// The command line of a node binary: `--ros-args ...` split off, the rest parsed as `C` (clap
/// exits on its own errors), and the ROS arguments put into its [`RosArgs`] (`ros` picks them
/// out) for the node `default_node` unless renamed. Returns it with the parameter overrides.
pub fn parse_node_cli<C: clap::Parser>(
    default_node: &str,
    ros: fn(&mut C) -> &mut RosArgs,
) -> Result<(C, Vec<Override>)> {
    let (argv, ros_cli) = split(std::env::args_os())?;
    let mut cli = C::parse_from(argv);
    let overrides = ros_cli.apply_to(ros(&mut cli), default_node)?;
    Ok((cli, overrides))
}

/// [`parse_node_cli`] of a command line given as `argv` (its first item the program's name),
/// as a composed process parses the arguments it gives each of its nodes: clap's errors are
/// returned (naming `default_node`), not printed and exited on.
pub fn parse_node_cli_from<C: clap::Parser>(
    argv: impl IntoIterator<Item = OsString>,
    default_node: &str,
    ros: fn(&mut C) -> &mut RosArgs,
) -> Result<(C, Vec<Override>)> {
    let (argv, ros_cli) = split(argv)?;
    let mut cli = C::try_parse_from(argv).map_err(|e| {
        let text = e.to_string();
        let first = text.lines().next().unwrap_or_default();
        invalid!(
            "{default_node}'s arguments: {}",
            first.trim_start_matches("error: ")
        )
    })?;
    let overrides = ros_cli.apply_to(ros(&mut cli), default_node)?;
    Ok((cli, overrides))
}

/// [`parse_node_cli`] for a node or tool that has no ROS parameters: names, remaps and the
/// enclave are taken, a parameter (`-p`, `--params-file`) is an error naming it.
pub fn parse_cli_without_params<C: clap::Parser>(
    default_node: &str,
    ros: fn(&mut C) -> &mut RosArgs,
) -> Result<C> {
    let (cli, overrides) = parse_node_cli(default_node, ros)?;
    match overrides.first() {
        Some(o) => bail!("{}: {default_node} has no ROS parameters", o.origin),
        None => Ok(cli),
    }
}

impl RosCli {
    /// Puts the names and remaps into `ros` (`__ns`, `__node`/`__name`, node-specific
    /// `node:from:=to` for this node, plain `from:=to`) and then, from the parameters for the
    /// node so named, `use_sim_time`. Returns the other overrides, in order.
    pub fn apply_to(&self, ros: &mut RosArgs, default_node: &str) -> Result<Vec<Override>> {
        if let Some(e) = &self.enclave {
            ros.enclave = Some(e.clone());
        }
        for r in &self.remaps {
            let (lhs, to) = r.split_once(":=").unwrap_or((r, ""));
            let (node, from) = match lhs.split_once(':') {
                Some((n, f)) => (Some(n), f),
                None => (None, lhs),
            };
            let this = ros.node_name.as_deref().unwrap_or(default_node);
            if node.is_some_and(|n| n != this) {
                continue;
            }
            match from {
                "__ns" => ros.namespace = to.to_string(),
                "__node" | "__name" => ros.node_name = Some(to.to_string()),
                f if f.starts_with("__") => {
                    bail!("--ros-args -r {r:?}: {f} is not supported (only __ns and __node)")
                }
                f => ros.remap.push(format!("{f}:={to}")),
            }
        }
        let node = ros.node_name.as_deref().unwrap_or(default_node);
        let ns = ros.namespace.trim().trim_end_matches('/');
        let ns = if ns.is_empty() || ns.starts_with('/') {
            ns.to_string()
        } else {
            format!("/{ns}")
        };
        let fqn = format!("{ns}/{node}");
        let mut out = Vec::new();
        for s in &self.sources {
            match s {
                Source::Param(text) => out.push(param_arg(text)?),
                Source::File(path) => out.extend(params_file(path, &fqn, node)?),
            }
        }
        let mut rest = Vec::new();
        for o in out {
            if o.name == "use_sim_time" {
                match o.value {
                    V::Boolean(b) => ros.use_sim_time = b,
                    _ => bail!("{}: use_sim_time must be true or false", o.origin),
                }
            } else {
                rest.push(o);
            }
        }
        Ok(rest)
    }
}

/// `NAME:=VALUE` of `-p`.
fn param_arg(text: &str) -> Result<Override> {
    let origin = format!("--ros-args -p {text}");
    let (name, value) = text.split_once(":=").unwrap_or((text, ""));
    let name = name.trim();
    if name.is_empty() {
        bail!("{origin}: the parameter name is empty");
    }
    let doc = YamlLoader::load_from_str(value)
        .ok()
        .and_then(|d| d.into_iter().next())
        .unwrap_or(Yaml::String(value.to_string()));
    let value = to_value(&doc).with_context(|| origin.clone())?;
    Ok(Override {
        name: name.to_string(),
        value,
        origin,
    })
}

/// A YAML value as a parameter value.
fn to_value(y: &Yaml) -> Result<V> {
    Ok(match y {
        Yaml::Boolean(b) => V::Boolean(*b),
        Yaml::Integer(i) => V::Integer(*i),
        Yaml::Real(_) => V::Double(
            y.as_f64()
                .with_context(|| format!("{y:?} is not a number"))?,
        ),
        Yaml::String(s) => V::String(s.clone()),
        Yaml::Array(items) if items.is_empty() => bail!("an empty list has no type"),
        Yaml::Array(items) => {
            let values = items.iter().map(to_value).collect::<Result<Vec<_>>>()?;
            let all = |f: fn(&V) -> bool| values.iter().all(f);
            if all(|v| matches!(v, V::Boolean(_))) {
                V::BooleanArray(
                    values
                        .iter()
                        .map(|v| matches!(v, V::Boolean(true)))
                        .collect(),
                )
            } else if all(|v| matches!(v, V::Integer(_))) {
                V::IntegerArray(
                    values
                        .iter()
                        .map(|v| if let V::Integer(i) = v { *i } else { 0 })
                        .collect(),
                )
            } else if all(|v| matches!(v, V::Integer(_) | V::Double(_))) {
                V::DoubleArray(
                    values
                        .iter()
                        .map(|v| match v {
                            V::Integer(i) => *i as f64,
                            V::Double(d) => *d,
                            _ => 0.0,
                        })
                        .collect(),
                )
            } else if all(|v| matches!(v, V::String(_))) {
                V::StringArray(
                    values
                        .iter()
                        .map(|v| {
                            if let V::String(s) = v {
                                s.clone()
                            } else {
                                String::new()
                            }
                        })
                        .collect(),
                )
            } else {
                bail!("a list mixes types")
            }
        }
        Yaml::Null => bail!("no value"),
        Yaml::Hash(_) | Yaml::Alias(_) | Yaml::BadValue => bail!("not a parameter value"),
    })
}

/// Whether a params-file section key names this node (`/**`, `/**/name`, the fully qualified
/// name, or the bare name for a node in `/`); `Some(true)` if it names it specifically.
fn section_matches(key: &str, fqn: &str, node: &str) -> Option<bool> {
    let key = key.trim();
    if key == "/**" || key == "**" {
        return Some(false);
    }
    let full = if key.starts_with('/') {
        key.to_string()
    } else {
        format!("/{key}")
    };
    (full == fqn || key == format!("/**/{node}")).then_some(true)
}

/// The overrides a ROS 2 params file holds for the node `fqn` (base name `node`).
fn params_file(path: &PathBuf, fqn: &str, node: &str) -> Result<Vec<Override>> {
    let shown = path.display();
    let text = std::fs::read_to_string(path)
        .with_context(|| format!("--params-file {shown}: cannot read it"))?;
    let docs = YamlLoader::load_from_str(&text)
        .with_context(|| format!("--params-file {shown}: not YAML"))?;
    let mut out = Vec::new();
    for doc in &docs {
        let Yaml::Hash(sections) = doc else {
            bail!("--params-file {shown}: expected node sections (`/**:` or `/node_name:`) at the top");
        };
        for (key, body) in sections {
            let Some(key) = key.as_str() else {
                bail!("--params-file {shown}: top-level key {key:?} is not a node name");
            };
            let Some(specific) = section_matches(key, fqn, node) else {
                continue;
            };
            let Some(params) = body["ros__parameters"].as_hash() else {
                bail!("--params-file {shown}: {key}: expected `ros__parameters:` with the parameters under it");
            };
            flatten(params, "", &mut |name, value| {
                let origin = format!("--params-file {shown}: {key}.ros__parameters.{name}");
                let value = to_value(value).with_context(|| origin.clone())?;
                out.push(Override {
                    name,
                    value,
                    origin: if specific {
                        origin
                    } else {
                        format!("{origin} (wildcard)")
                    },
                });
                Ok(())
            })
            .with_context(|| format!("--params-file {shown}: {key}"))?;
        }
    }
    Ok(out)
}

/// Calls `f` for every leaf of nested maps, names joined with dots.
fn flatten(
    map: &yaml_rust2::yaml::Hash,
    prefix: &str,
    f: &mut dyn FnMut(String, &Yaml) -> Result<()>,
) -> Result<()> {
    for (k, v) in map {
        let k = match k {
            Yaml::String(s) => s.clone(),
            Yaml::Integer(i) => i.to_string(),
            other => bail!("key {other:?} is not a parameter name"),
        };
        let name = if prefix.is_empty() {
            k
        } else {
            format!("{prefix}.{k}")
        };
        match v {
            Yaml::Hash(inner) => flatten(inner, &name, f)?,
            _ => f(name, v)?,
        }
    }
    Ok(())
}

/// Applies `overrides` to `table` (later ones win), then the node's `rules` once on the
/// result, as one start-up set (so `-p gain:=0.3 -p mode:=custom` means CUSTOM 0.3 in either
/// order). A name, type or range error names its source; a refusal by the rules names them all.
/// Unknown names from a wildcard section (`/**`) are skipped: such a file serves many nodes.
/// Then every value is checked against its declaration ([`ParamTable::validate`]), so a value
/// a flag let through is refused before the node starts.
pub fn apply_overrides(table: &mut ParamTable, overrides: &[Override], rules: Rules) -> Result<()> {
    overrides_onto(table, overrides, rules)?;
    table
        .validate()
        .map_err(|e| invalid!("the start values: {e}"))
}

/// [`apply_overrides`] without the final check.
fn overrides_onto(table: &mut ParamTable, overrides: &[Override], rules: Rules) -> Result<()> {
    let mut scratch = table.clone();
    let mut all: Vec<Param> = Vec::new();
    let mut origins = Vec::new();
    for o in overrides {
        if table.get(&o.name).is_none() && o.origin.ends_with("(wildcard)") {
            tracing::debug!("{}: not a parameter of this node, skipped", o.origin);
            continue;
        }
        let value = match (&o.value, table.get(&o.name)) {
            (V::Integer(i), Some(V::Double(_))) => V::Double(*i as f64),
            (v, _) => v.clone(),
        };
        let p: Param = (o.name.clone(), value);
        scratch
            .override_with(std::slice::from_ref(&p), crate::params::no_rules)
            .map_err(|e| invalid!("{}: {e}", o.origin))?;
        all.retain(|(n, _)| *n != p.0);
        all.push(p);
        origins.push(o.origin.as_str());
    }
    if all.is_empty() {
        return Ok(());
    }
    table
        .override_with(&all, rules)
        .map_err(|e| invalid!("{}: {e}", origins.join(", ")))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::params::{no_rules, ParamSpec};
    use clap::Parser;

    #[derive(Parser)]
    struct T {
        #[arg(long)]
        scene: Option<String>,
        #[command(flatten)]
        ros: RosArgs,
    }

    fn os(args: &[&str]) -> Vec<OsString> {
        args.iter().map(OsString::from).collect()
    }

    fn parse(args: &[&str]) -> Result<(T, Vec<Override>)> {
        let (rest, ros) = split(os(args))?;
        let mut t = T::try_parse_from(rest).context("the test command line")?;
        let o = ros.apply_to(&mut t.ros, "capsule_controller")?;
        Ok((t, o))
    }

    fn tmp(name: &str, text: &str) -> PathBuf {
        let p =
            std::env::temp_dir().join(format!("capsule_ros_args_{}_{name}", std::process::id()));
        std::fs::write(&p, text).unwrap_or_else(|e| panic!("{e}"));
        p
    }

    #[test]
    fn ros_args_blocks_are_taken_out_and_names_and_remaps_resolved() -> Result<()> {
        let (t, o) = parse(&[
            "c",
            "--scene",
            "s.toml",
            "--ros-args",
            "-r",
            "__ns:=/robot1",
            "-r",
            "__node:=ctl",
            "-r",
            "capsule/state:=/sim/state",
            "-r",
            "other_node:x:=y",
            "-p",
            "gain:=0.3",
            "-p",
            "use_sim_time:=true",
            "-e",
            "/capsule/controller",
            "--",
            "-r",
            "a:=b",
        ])?;
        assert_eq!(t.scene.as_deref(), Some("s.toml"));
        assert_eq!(t.ros.namespace, "/robot1");
        assert_eq!(t.ros.node_name.as_deref(), Some("ctl"));
        assert_eq!(t.ros.remap, ["a:=b", "capsule/state:=/sim/state"]);
        assert!(t.ros.use_sim_time);
        assert_eq!(t.ros.enclave.as_deref(), Some("/capsule/controller"));
        assert_eq!(o.len(), 1);
        assert_eq!((o[0].name.as_str(), &o[0].value), ("gain", &V::Double(0.3)));
        Ok(())
    }

    #[test]
    fn yaml_types_values_like_rcl() -> Result<()> {
        for (text, v) in [
            ("a:=1", V::Integer(1)),
            ("a:=1.5", V::Double(1.5)),
            ("a:=true", V::Boolean(true)),
            ("a:=forward", V::String("forward".into())),
            ("a:=[1, 2.5]", V::DoubleArray(vec![1.0, 2.5])),
            ("a:='1'", V::String("1".into())),
        ] {
            assert_eq!(param_arg(text)?.value, v, "{text}");
        }
        Ok(())
    }

    #[test]
    fn params_files_by_wildcard_and_node_name_in_order() -> Result<()> {
        let f = tmp(
            "ok.yaml",
            "/**:\n  ros__parameters:\n    use_sim_time: true\n    other_nodes_param: 3\n\
             /robot1/capsule_controller:\n  ros__parameters:\n    gain: 0.4\n    views:\n      tf: false\n\
             /capsule_plant:\n  ros__parameters:\n    rate_hz: 10.0\n",
        );
        let path = f.display().to_string();
        let (t, o) = parse(&[
            "c",
            "--ros-args",
            "-r",
            "__ns:=/robot1",
            "--params-file",
            &path,
            "-p",
            "gain:=1",
        ])?;
        assert!(t.ros.use_sim_time);
        let names: Vec<_> = o
            .iter()
            .map(|o| (o.name.as_str(), o.value.clone()))
            .collect();
        assert_eq!(
            names,
            [
                ("other_nodes_param", V::Integer(3)),
                ("gain", V::Double(0.4)),
                ("views.tf", V::Boolean(false)),
                ("gain", V::Integer(1)),
            ]
        );
        let mut table = ParamTable::new()
            .declare("gain", ParamSpec::writable("g"), V::Double(0.2))
            .declare("views.tf", ParamSpec::writable("tf"), V::Boolean(true));
        apply_overrides(&mut table, &o, no_rules)?;
        // the later -p wins, an integer taken as the declared double; the wildcard's unknown
        // parameter is skipped
        assert_eq!(
            (table.double("gain"), table.boolean("views.tf")),
            (1.0, false)
        );
        let _ = std::fs::remove_file(f);
        Ok(())
    }

    #[test]
    fn malformed_arguments_and_files_are_named() {
        let err = |args: &[&str]| parse(args).map(|_| ()).unwrap_err().to_string();
        assert!(
            err(&["c", "--ros-args", "-p", "gain"]).contains("-p \"gain\": expected NAME:=VALUE")
        );
        assert!(err(&["c", "--ros-args", "-p"]).contains("a value is missing"));
        assert!(err(&["c", "--ros-args", "--log-level", "x"])
            .contains("\"--log-level\": not supported"));
        assert!(err(&["c", "--ros-args", "--enclave"]).contains("--enclave: a value is missing"));
        assert!(err(&["c", "--ros-args", "-r", "__log_level:=x"])
            .contains("__log_level is not supported"));
        let e = err(&["c", "--ros-args", "--params-file", "/nonexistent/p.yaml"]);
        assert!(e.contains("/nonexistent/p.yaml: cannot read it"), "{e}");
        let bad = tmp("bad.yaml", "/**:\n  parameters:\n    a: 1\n");
        let e = err(&[
            "c",
            "--ros-args",
            "--params-file",
            &bad.display().to_string(),
        ]);
        assert!(
            e.contains("bad.yaml") && e.contains("/**: expected `ros__parameters:`"),
            "{e}"
        );
        let bad2 = tmp(
            "bad2.yaml",
            "/capsule_controller:\n  ros__parameters:\n    gain: [1, x]\n",
        );
        let e = crate::error::chain(
            &parse(&[
                "c",
                "--ros-args",
                "--params-file",
                &bad2.display().to_string(),
            ])
            .map(|_| ())
            .unwrap_err(),
        );
        assert!(
            e.contains("/capsule_controller.ros__parameters.gain") && e.contains("mixes types"),
            "{e}"
        );
        let bad3 = tmp("bad3.yaml", "a: [\n");
        assert!(err(&[
            "c",
            "--ros-args",
            "--params-file",
            &bad3.display().to_string()
        ])
        .contains("not YAML"));
        // a refused override names its source
        let mut table = ParamTable::new().declare("gain", ParamSpec::writable("g"), V::Double(0.2));
        let o = vec![param_arg("gain:=x").unwrap_or_else(|e| panic!("{e}"))];
        let e = apply_overrides(&mut table, &o, no_rules)
            .unwrap_err()
            .to_string();
        assert!(
            e.starts_with("--ros-args -p gain:=x: wrong parameter type"),
            "{e}"
        );
        let o = vec![param_arg("nope:=1").unwrap_or_else(|e| panic!("{e}"))];
        let e = apply_overrides(&mut table, &o, no_rules)
            .unwrap_err()
            .to_string();
        assert!(e.contains("'nope' is not declared"), "{e}");
        // the node's rules see all overrides at once, and a refusal names them
        fn small(t: &mut ParamTable) -> Result<(), String> {
            if t.double("gain") > 1.0 {
                return Err("gain above 1".into());
            }
            Ok(())
        }
        let o = vec![param_arg("gain:=3.0").unwrap_or_else(|e| panic!("{e}"))];
        let e = apply_overrides(&mut table, &o, small)
            .unwrap_err()
            .to_string();
        assert_eq!(e, "--ros-args -p gain:=3.0: gain above 1");
        assert_eq!(table.double("gain"), 0.2);
        for f in [bad, bad2, bad3] {
            let _ = std::fs::remove_file(f);
        }
    }
}

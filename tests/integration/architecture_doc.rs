//! docs/architecture.md's crate table says what each crate depends on; this checks it against
//! the crates' Cargo.toml files, so the picture a newcomer reads first cannot drift from the
//! code (it once left out two crates).

use crate::root;
use std::collections::{BTreeMap, BTreeSet};

/// The workspace crates (`capsule_*` folders with a Cargo.toml) and the workspace crates each
/// one's `[dependencies]` names, without the `capsule_` prefix.
fn from_cargo() -> BTreeMap<String, BTreeSet<String>> {
    let mut out = BTreeMap::new();
    let entries = std::fs::read_dir(root()).unwrap_or_else(|e| panic!("{e}"));
    for entry in entries.flatten() {
        let name = entry.file_name().to_string_lossy().into_owned();
        let manifest = entry.path().join("Cargo.toml");
        if !name.starts_with("capsule_") || !manifest.is_file() {
            continue;
        }
        let text = std::fs::read_to_string(&manifest).unwrap_or_else(|e| panic!("{e}"));
        let mut in_deps = false;
        let mut deps = BTreeSet::new();
        for line in text.lines() {
            if line.starts_with('[') {
                in_deps = line.trim() == "[dependencies]";
            } else if let Some(dep) = line.strip_prefix("capsule_").filter(|_| in_deps) {
                let dep: String = dep
                    .chars()
                    .take_while(|c| c.is_ascii_alphanumeric() || *c == '_')
                    .collect();
                deps.insert(dep);
            }
        }
        out.insert(name, deps);
    }
    out
}

/// The table in docs/architecture.md's first code block: `capsule_NAME  deps  job`, the
/// dependency column (short names, `-` for none) continued on the lines below it.
fn from_doc() -> BTreeMap<String, BTreeSet<String>> {
    let text = std::fs::read_to_string(root().join("docs/architecture.md"))
        .unwrap_or_else(|e| panic!("{e}"));
    let block = text
        .split("```")
        .nth(1)
        .unwrap_or_else(|| panic!("no code block in docs/architecture.md"));
    let header = block
        .lines()
        .find(|l| l.starts_with("crate"))
        .unwrap_or_else(|| panic!("no `crate ... depends on ... job` header"));
    let (deps_at, job_at) = (
        header.find("depends on").unwrap_or(0),
        header.find("job").unwrap_or(header.len()),
    );
    let mut out: BTreeMap<String, BTreeSet<String>> = BTreeMap::new();
    let mut current: Option<String> = None;
    for line in block.lines() {
        let name = line.trim_start();
        if name.starts_with("capsule_") && line.starts_with("  ") {
            current = name.split_whitespace().next().map(str::to_string);
        } else if !line.starts_with("    ") {
            current = None; // a layer's title
        }
        // a name longer than its column (capsule_controller_node) reaches into the next one
        let line = match &current {
            Some(n) if name.starts_with(n.as_str()) => line.replacen(n, &" ".repeat(n.len()), 1),
            _ => line.to_string(),
        };
        let (Some(crate_name), Some(column)) =
            (&current, line.get(deps_at..job_at.min(line.len())))
        else {
            continue;
        };
        let deps = out.entry(crate_name.clone()).or_default();
        for dep in column.split([',', ' ']).map(str::trim) {
            if !dep.is_empty() && dep != "-" && !dep.starts_with('(') && !dep.ends_with(')') {
                deps.insert(dep.to_string());
            }
        }
    }
    out
}

#[test]
fn the_crate_table_in_architecture_md_matches_the_manifests() {
    let (cargo, doc) = (from_cargo(), from_doc());
    assert!(cargo.len() >= 10, "{cargo:?}");
    assert_eq!(
        doc.keys().collect::<Vec<_>>(),
        cargo.keys().collect::<Vec<_>>(),
        "docs/architecture.md lists other crates than the workspace has"
    );
    for (name, deps) in &cargo {
        assert_eq!(
            &doc[name], deps,
            "docs/architecture.md: {name}'s dependencies differ from {name}/Cargo.toml"
        );
    }
}

/// The crates in `krate`'s normal dependency tree, by name, as `cargo tree` resolves them
/// from Cargo.lock (no network).
fn dependency_tree(krate: &str) -> BTreeSet<String> {
    let cargo = std::env::var_os("CARGO").unwrap_or_else(|| "cargo".into());
    let out = std::process::Command::new(cargo)
        .args([
            "tree",
            "--offline",
            "--locked",
            "-e",
            "normal",
            "--prefix",
            "none",
            "-p",
        ])
        .arg(krate)
        .current_dir(root())
        .output()
        .unwrap_or_else(|e| panic!("cannot run cargo tree: {e}"));
    crate::common::succeeded(&out, &format!("cargo tree -p {krate}"))
        .lines()
        .filter_map(|l| l.split_whitespace().next().map(str::to_string))
        .collect()
}

#[test]
fn the_hardware_interface_and_the_offline_tools_build_without_an_async_runtime_or_dds() {
    let hardware = dependency_tree("capsule_hardware");
    // what a driver for one's own capsule builds: the interface, the physics, the protocol
    assert!(hardware.contains("capsule_plant") && hardware.contains("capsule_serial"));
    for (krate, tree) in [
        ("capsule_hardware", hardware),
        ("capsule_cli", dependency_tree("capsule_cli")),
    ] {
        let found: Vec<&String> = tree
            .iter()
            .filter(|d| {
                // an async runtime, DDS, and every crate of the ROS 2 layer
                [
                    "tokio",
                    "rustdds",
                    "ros2-client",
                    "capsule_nodes",
                    "capsule_tools",
                ]
                .contains(&d.as_str())
                    || d.starts_with("capsule_ros")
                    || d.ends_with("_node")
            })
            .collect();
        assert!(found.is_empty(), "{krate} depends on {found:?}");
    }
}

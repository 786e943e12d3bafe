//! colcon builds the nodes as a ROS 2 package (#19): `colcon build` (colcon-core with
//! colcon-cargo and colcon-ros-cargo from PyPI, which bring cargo-ament-build as a wheel;
//! installed by `.ci/ros-setup.sh`) installs `capsule_nodes` with its ament index entry, `install/setup.sh`
//! puts it on `AMENT_PREFIX_PATH`, and an executable found there the way `ros2 run` finds it
//! runs as a ROS 2 node that a Cyclone DDS peer reads.
//!
//! The build directory of `capsule_nodes` is a link to the workspace's target directory and the
//! build passes `--cargo-args --workspace`, so colcon's cargo finds what the test command's
//! `cargo build --workspace` compiled (same features, same profile) instead of compiling a
//! second time; a user's plain `colcon build` compiles into its own `build/` (15 min from a
//! fresh clone here).

use super::harness::{assert_state_at_1khz, json_number, netns_with_peer_from, root};
use crate::common::succeeded;
use std::path::{Path, PathBuf};
use std::process::Command;

/// The node executables the package installs.
const EXECUTABLES: [&str; 7] = [
    "capsule_plant",
    "capsule_controller",
    "capsule_container",
    "capsule_ros",
    "capsule_recorder",
    "capsule_foxglove",
    "capsule_replay",
];

/// Runs `colcon build` for capsule_nodes in a scratch workspace, once per test run, and returns
/// its install base.
fn colcon_install() -> PathBuf {
    static BUILT: std::sync::OnceLock<Result<PathBuf, String>> = std::sync::OnceLock::new();
    match BUILT.get_or_init(colcon_build) {
        Ok(install) => install.clone(),
        Err(e) => panic!("{e}"),
    }
}

/// `colcon build --packages-skip capsule_msgs` into `target/tmp/colcon`.
fn colcon_build() -> Result<PathBuf, String> {
    let tmp = PathBuf::from(env!("CARGO_TARGET_TMPDIR"));
    let target = tmp.parent().ok_or("CARGO_TARGET_TMPDIR has no parent")?;
    let work = tmp.join("colcon");
    let _ = std::fs::remove_dir_all(&work);
    std::fs::create_dir_all(work.join("build")).map_err(|e| e.to_string())?;
    std::os::unix::fs::symlink(target, work.join("build/capsule_nodes"))
        .map_err(|e| format!("link the build directory to the target directory: {e}"))?;
    // capsule_msgs is skipped: its ament_cmake build needs rosidl_default_generators, which
    // only a ROS 2 installation provides (docs/ros.md, colcon)
    let mut colcon = Command::new("colcon");
    // cargo gives this test binary its package's variables (CARGO_MANIFEST_DIR, CARGO_PKG_*);
    // passed on to colcon's cargo they rerun build scripts that watch them (ring's watches
    // CARGO_MANIFEST_DIR), and everything above ring is compiled again
    for (name, _) in std::env::vars_os() {
        let name = name.to_string_lossy();
        if name.starts_with("CARGO_PKG_")
            || [
                "CARGO_MANIFEST_DIR",
                "CARGO_MANIFEST_PATH",
                "CARGO_CRATE_NAME",
                "CARGO_PRIMARY_PACKAGE",
                "CARGO_TARGET_TMPDIR",
                "OUT_DIR",
            ]
            .contains(&name.as_ref())
        {
            colcon.env_remove(name.as_ref());
        }
    }
    let out = colcon
        .current_dir(&work)
        .arg("--log-base")
        .arg(work.join("log"))
        .args(["build", "--base-paths"])
        .arg(root())
        .args(["--packages-skip", "capsule_msgs"])
        // the features the test command's `cargo build --workspace` resolved, so that nothing
        // is compiled again (capsule_nodes alone resolves some shared crates' features
        // differently); colcon takes an argument that starts with a dash after a space
        .args(["--cargo-args", " --workspace", "--build-base"])
        .arg(work.join("build"))
        .arg("--install-base")
        .arg(work.join("install"))
        .output()
        .map_err(|e| format!("cannot run colcon (.ci/ros-setup.sh installs it): {e}"))?;
    if !out.status.success() {
        return Err(format!(
            "colcon build failed:\n{}\n{}",
            String::from_utf8_lossy(&out.stdout),
            String::from_utf8_lossy(&out.stderr)
        ));
    }
    Ok(work.join("install"))
}

/// What `install/setup.sh` exports as `AMENT_PREFIX_PATH`, sourced as a user's shell does.
fn sourced_ament_prefix_path(install: &Path) -> String {
    let out = Command::new("sh")
        .arg("-c")
        .arg(r#". "$1/setup.sh" && printf '%s' "$AMENT_PREFIX_PATH""#)
        .arg("sh")
        .arg(install)
        .env_remove("AMENT_PREFIX_PATH")
        .output()
        .expect("run sh");
    succeeded(&out, "sourcing install/setup.sh")
}

/// `ros2 run PACKAGE EXECUTABLE`'s look-up: the first prefix of `AMENT_PREFIX_PATH` whose ament
/// index lists the package, then the executable in its `lib/PACKAGE`.
fn ros2_run_lookup(prefix_path: &str, package: &str, executable: &str) -> Option<PathBuf> {
    let prefix = prefix_path.split(':').map(Path::new).find(|p| {
        p.join("share/ament_index/resource_index/packages")
            .join(package)
            .is_file()
    })?;
    let exe = prefix.join("lib").join(package).join(executable);
    exe.is_file().then_some(exe)
}

#[test]
fn colcon_build_installs_the_nodes_where_ros2_run_finds_them() {
    use std::os::unix::fs::PermissionsExt;
    let install = colcon_install();
    // colcon's default, isolated layout: one prefix per package
    let prefix = install.join("capsule_nodes");
    for exe in EXECUTABLES {
        let path = prefix.join("lib/capsule_nodes").join(exe);
        let mode = std::fs::metadata(&path)
            .unwrap_or_else(|e| panic!("{} not installed: {e}", path.display()))
            .permissions()
            .mode();
        assert!(mode & 0o111 != 0, "{} is not executable", path.display());
    }
    let manifest = std::fs::read_to_string(prefix.join("share/capsule_nodes/package.xml"))
        .expect("package.xml installed");
    let source = std::fs::read_to_string(root().join("capsule_nodes/package.xml"))
        .expect("read capsule_nodes/package.xml");
    assert_eq!(manifest, source);

    let prefixes = sourced_ament_prefix_path(&install);
    let plant = ros2_run_lookup(&prefixes, "capsule_nodes", "capsule_plant")
        .unwrap_or_else(|| panic!("ros2 run would not find capsule_plant in {prefixes}"));
    assert!(plant.starts_with(&prefix), "{}", plant.display());
    assert!(ros2_run_lookup(&prefixes, "capsule_nodes", "no_such_node").is_none());
    assert!(ros2_run_lookup(&prefixes, "no_such_package", "capsule_plant").is_none());

    // the installed executable is the node: it checks a scene ...
    let check = Command::new(&plant)
        .args(["--scene"])
        .arg(root().join("scenes/control_point.toml"))
        .arg("--check")
        .output()
        .expect("run the installed capsule_plant");
    let text = String::from_utf8_lossy(&check.stdout);
    assert!(
        check.status.success() && text.contains("discovery"),
        "{text}"
    );

    // ... and serves its state to a ROS 2 peer (Cyclone DDS), in a loopback-only namespace
    let bin = plant.parent().expect("lib/capsule_nodes");
    let run = netns_with_peer_from(
        bin,
        120,
        r#"
        start_plant --until-s 12
        peer state --samples 100 || exit 1
        stop $P"#,
    );
    run.assert_ok();
    let state = assert_state_at_1khz(&run);
    assert!(json_number(state, "samples") >= Some(100.0), "{state}");
}

/// The graph the ROS 2 launch file computes for `args` (`node_commands` of the installed file,
/// called with python3: ROS 2's `launch` package is on neither PyPI nor Debian, so the launch
/// runtime itself cannot run here), as (executable, arguments) pairs; or the error it raises.
fn launch_file_graph(launch: &Path, args: &str) -> Result<Vec<(String, Vec<String>)>, String> {
    let code = format!(
        "import importlib.util, json, sys\n\
         spec = importlib.util.spec_from_file_location('capsule_launch', sys.argv[1])\n\
         m = importlib.util.module_from_spec(spec); spec.loader.exec_module(m)\n\
         try:\n    print(json.dumps(m.node_commands({args})))\n\
         except ValueError as e:\n    print(e, file=sys.stderr); sys.exit(2)\n"
    );
    let out = Command::new("python3")
        .args(["-c", &code])
        .arg(launch)
        .output()
        .expect("run python3");
    if !out.status.success() {
        return Err(String::from_utf8_lossy(&out.stderr).into_owned());
    }
    serde_json::from_slice(&out.stdout).map_err(|e| format!("not JSON: {e}"))
}

#[test]
fn the_ros2_launch_file_is_installed_and_starts_the_launchers_graph() {
    let install = colcon_install();
    let prefix = install.join("capsule_nodes");
    let launch = prefix.join("share/capsule_nodes/launch/capsule.launch.py");
    let bin = prefix.join("lib/capsule_nodes");
    let compiled = Command::new("python3")
        .args(["-m", "py_compile"])
        .arg(&launch)
        .status()
        .is_ok_and(|s| s.success());
    assert!(compiled, "{} does not compile", launch.display());

    let scene = root().join("scenes/control_point.toml");
    let record = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("colcon/runs");
    let cases = [
        format!(
            "{:?}, 'lockstep', '30', 'forward', 'true', {:?}",
            scene, record
        ),
        format!("{:?}, 'realtime', '', '', 'false'", scene),
    ];
    for args in &cases {
        let graph = launch_file_graph(&launch, args).unwrap_or_else(|e| panic!("{args}: {e}"));
        let names: Vec<&str> = graph.iter().map(|(exe, _)| exe.as_str()).collect();
        assert_eq!(names.first(), Some(&"capsule_controller"), "{args}");
        assert_eq!(names.last(), Some(&"capsule_plant"), "{args}");
        // every node of the graph accepts its arguments (the nodes' own --check)
        for (exe, arguments) in &graph {
            let out = Command::new(bin.join(exe))
                .args(arguments)
                .arg("--check")
                .output()
                .expect("run an installed node");
            succeeded(&out, &format!("{exe} {arguments:?} --check"));
        }
    }
    // recording: the plant waits for controller and recorder, as capsule_launch.sh has it
    let graph = launch_file_graph(&launch, &cases[0]).unwrap_or_default();
    let plant = graph
        .last()
        .map(|(_, args)| args.clone())
        .unwrap_or_default();
    assert!(
        plant.windows(2).any(|w| w == ["--wait-subscribers", "2"]),
        "{plant:?}"
    );
    assert!(graph.iter().any(|(exe, _)| exe == "capsule_recorder"));

    // bad values are refused, naming the argument
    for (args, needle) in [
        ("''", "scene:="),
        ("'s.toml', 'fast'", "pacing:='fast'"),
        ("'s.toml', 'lockstep', '-3'", "until_s:='-3'"),
        ("'s.toml', 'lockstep', '', '', 'maybe'", "record:='maybe'"),
    ] {
        let err = launch_file_graph(&launch, args).expect_err(args);
        assert!(err.contains(needle), "{args}: {err}");
    }
}

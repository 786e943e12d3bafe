//! Locating the binaries and running scripts inside a loopback-only network namespace.

use std::{
    path::{Path, PathBuf},
    process::{Command, Output},
};

/// The workspace root.
pub fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("..")
}

/// Where the node binaries are (`$CAPSULE_BIN`, else target/debug); panics with the fix if a
/// binary is missing.
pub fn bin_dir() -> PathBuf {
    let dir = std::env::var_os("CAPSULE_BIN")
        .map(PathBuf::from)
        .unwrap_or_else(|| root().join("target/debug"));
    for b in [
        "capsule_plant",
        "capsule_controller",
        "capsule_ros",
        "capsule_foxglove",
    ] {
        assert!(
            dir.join(b).is_file(),
            "{} missing: run `cargo build --workspace` first",
            dir.join(b).display()
        );
    }
    dir
}

/// The demo scene of the paper's section 5 control point.
pub fn control_point() -> PathBuf {
    let p = root().join("scenes/control_point.toml");
    assert!(p.is_file(), "{} missing", p.display());
    p
}

/// Output of a namespaced run.
pub struct Run {
    /// Exit status of the script (None: killed).
    pub code: Option<i32>,
    /// Its stdout.
    pub stdout: String,
    /// Its stderr.
    pub stderr: String,
}

impl Run {
    /// Both streams, for assertion messages.
    pub fn all(&self) -> String {
        format!("--- stdout\n{}\n--- stderr\n{}", self.stdout, self.stderr)
    }
}

/// Runs a bash script in a fresh loopback-only namespace for at most `timeout_s`.
/// `$B` is the binary directory, `$ROOT` the workspace, `$SCENE` the control-point scene and
/// `$TMP` a scratch directory.
pub fn netns(timeout_s: u32, script: &str) -> Run {
    let b = bin_dir();
    let tmp = std::env::temp_dir().join(format!("capsule_ros_{}_{}", std::process::id(), unique()));
    std::fs::create_dir_all(&tmp)
        .unwrap_or_else(|e| panic!("cannot create {}: {e}", tmp.display()));
    let out: Output = Command::new("bash")
        .arg(root().join("tests/peers/netns_run.sh"))
        .arg(timeout_s.to_string())
        .args(["bash", "-c", script])
        .env("B", &b)
        .env("CAPSULE_BIN", &b)
        .env("ROOT", root())
        .env("SCENE", control_point())
        .env("TMP", &tmp)
        .env("ROS_AUTOMATIC_DISCOVERY_RANGE", "LOCALHOST")
        .env_remove("RMW_IMPLEMENTATION")
        .env_remove("RUST_LOG")
        .output()
        .unwrap_or_else(|e| panic!("cannot run netns_run.sh: {e}"));
    let _ = std::fs::remove_dir_all(&tmp);
    Run {
        code: out.status.code(),
        stdout: String::from_utf8_lossy(&out.stdout).into_owned(),
        stderr: String::from_utf8_lossy(&out.stderr).into_owned(),
    }
}

fn unique() -> u64 {
    use std::sync::atomic::{AtomicU64, Ordering};
    static N: AtomicU64 = AtomicU64::new(0);
    N.fetch_add(1, Ordering::Relaxed)
}

/// The number after `"key":` in a one-line JSON text.
pub fn json_number(json: &str, key: &str) -> Option<f64> {
    let pat = format!("\"{key}\":");
    let at = json.find(&pat)? + pat.len();
    let rest = json[at..].trim_start();
    let end = rest.find([',', '}']).unwrap_or(rest.len());
    rest[..end].trim().parse().ok()
}

/// The text after `"key":` up to the next `,` or `}` (for booleans and exact comparisons).
pub fn json_raw<'a>(json: &'a str, key: &str) -> Option<&'a str> {
    let pat = format!("\"{key}\":");
    let at = json.find(&pat)? + pat.len();
    let rest = &json[at..];
    let end = rest.find([',', '}']).unwrap_or(rest.len());
    Some(rest[..end].trim())
}

#[test]
fn json_helpers_read_numbers_and_raw_values() {
    let j = r#"{"a":1.5,"b":{"c":-2e-3,"d":true}}"#;
    assert_eq!(json_number(j, "a"), Some(1.5));
    assert_eq!(json_number(j, "c"), Some(-2e-3));
    assert_eq!(json_raw(j, "d"), Some("true"));
    assert_eq!(json_number(j, "zz"), None);
}

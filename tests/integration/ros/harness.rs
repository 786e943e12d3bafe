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
    let missing: Vec<String> = [
        "capsule_plant",
        "capsule_controller",
        "capsule_ros",
        "capsule_foxglove",
        "capsule_container",
    ]
    .iter()
    .map(|b| dir.join(b))
    .filter(|p| !p.is_file())
    .map(|p| p.display().to_string())
    .collect();
    assert!(
        missing.is_empty(),
        "{} missing: run `cargo build --workspace` first",
        missing.join(", ")
    );
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

    /// Panics with both streams unless the script exited with 0.
    #[track_caller]
    pub fn assert_ok(&self) {
        assert_eq!(self.code, Some(0), "{}", self.all());
    }

    /// The stdout lines that start with `prefix`.
    pub fn lines_starting(&self, prefix: &str) -> Vec<&str> {
        self.stdout
            .lines()
            .filter(|l| l.starts_with(prefix))
            .collect()
    }

    /// The stdout lines that start with `prefix`; panics with both streams unless there are
    /// exactly `n`.
    #[track_caller]
    pub fn lines_exactly(&self, prefix: &str, n: usize) -> Vec<&str> {
        let lines = self.lines_starting(prefix);
        assert_eq!(lines.len(), n, "{}", self.all());
        lines
    }

    /// The first stdout line that starts with `prefix`; panics with both streams if none does.
    #[track_caller]
    pub fn line(&self, prefix: &str) -> &str {
        self.stdout
            .lines()
            .find(|l| l.starts_with(prefix))
            .unwrap_or_else(|| panic!("no line starting with {prefix:?}\n{}", self.all()))
    }

    /// The first JSON line on stdout with the key `key`; panics with both streams if none has.
    #[track_caller]
    pub fn json_with(&self, key: &str) -> &str {
        let quoted = format!("\"{key}\"");
        self.stdout
            .lines()
            .find(|l| l.starts_with('{') && l.contains(&quoted))
            .unwrap_or_else(|| panic!("no JSON line with {quoted}\n{}", self.all()))
    }

    /// The rest of the first stdout line that starts with `prefix`; panics with both streams if
    /// none does.
    #[track_caller]
    pub fn after(&self, prefix: &str) -> &str {
        &self.line(prefix)[prefix.len()..]
    }

    /// Panics with both streams unless stdout contains every one of `needles`.
    #[track_caller]
    pub fn assert_stdout(&self, needles: &[&str]) {
        self.assert_in("stdout", &self.stdout, needles);
    }

    /// Panics with both streams unless stderr contains every one of `needles`.
    #[track_caller]
    pub fn assert_stderr(&self, needles: &[&str]) {
        self.assert_in("stderr", &self.stderr, needles);
    }

    #[track_caller]
    fn assert_in(&self, name: &str, text: &str, needles: &[&str]) {
        for n in needles {
            assert!(text.contains(n), "{name} lacks {n:?}\n{}", self.all());
        }
    }
}

/// The `"last": {...}` sample of the summary JSON on the stdout line starting with `tag`.
#[track_caller]
pub fn last_sample(run: &Run, tag: &str) -> String {
    let line = run.line(tag);
    line[line
        .find("\"last\"")
        .unwrap_or_else(|| panic!("no last sample in {line}\n{}", run.all()))..]
        .to_string()
}

/// Panics unless `last` (a [`last_sample`]) is seq 1500 of a capsule that moved: what the
/// lock-step comparisons of 1.5 s compare.
#[track_caller]
pub fn assert_moved_to_seq_1500(last: &str) {
    assert_eq!(json_raw(last, "seq"), Some("1500"), "{last}");
    assert_ne!(
        json_raw(last, "capsule_position"),
        Some("0.0"),
        "the capsule never moved: {last}"
    );
}

/// The `i`-th of `items` (a peer's lines or records, named `what` in the failure).
pub fn nth<'a>(items: &[&'a str], i: usize, what: &str) -> &'a str {
    items
        .get(i)
        .copied()
        .unwrap_or_else(|| panic!("no {what} {i}: {items:?}"))
}

/// Panics unless `text` contains every one of `needles`.
#[track_caller]
pub fn assert_contains(text: &str, needles: &[&str]) {
    for n in needles {
        assert!(text.contains(n), "{n:?} missing: {text}");
    }
}

/// A peer's `state` report (the line with `rate_hz`): its stamps' rate is the scene's 1 kHz, to
/// rounding. Returns the report.
#[track_caller]
pub fn assert_state_at_1khz(run: &Run) -> &str {
    let state = run.json_with("rate_hz");
    let rate = json_number(state, "rate_hz").unwrap_or(f64::NAN);
    assert!((rate - 1000.0).abs() < 1e-6, "rate {rate}: {state}");
    state
}

/// The script in which `peer` (the script's command for a peer: `peer`, `fpeer`) reads 200 states
/// of a plant that runs until `until_s`, then commands it (see
/// [`assert_peer_read_state_and_commanded`]).
pub fn state_and_force_script(peer: &str, until_s: u32) -> String {
    format!(
        "start_plant --until-s {until_s}
        {peer} state --samples 200 || exit 1
        {peer} force --force 0.05 || exit 1
        stop $P"
    )
}

/// The script lines in which `peer` calls `set_mode` for BACKWARD with gain 0.1, then for an
/// unknown mode 9, then CUSTOM with a NaN gain (see [`assert_set_mode_answers`]).
pub fn set_mode_calls(peer: &str) -> String {
    format!(
        "{peer} set-mode 2 0.1 || exit 1
        {peer} set-mode 9 0.1 || exit 1
        {peer} set-mode 4 nan || exit 1"
    )
}

/// The answers to [`set_mode_calls`]: BACKWARD taken with the gain -0.1, the unknown mode and
/// the NaN gain refused, the mode left BACKWARD.
#[track_caller]
pub fn assert_set_mode_answers(run: &Run) {
    run.assert_ok();
    let answers = run.lines_exactly("{\"accepted\"", 3);
    assert_contains(answers[0], &["\"accepted\": true", "\"mode\": 2"]);
    assert_eq!(
        json_number(answers[0], "gain"),
        Some(-0.1),
        "{}",
        answers[0]
    );
    assert_contains(
        answers[1],
        &["\"accepted\": false", "unknown mode 9", "\"mode\": 2"],
    );
    assert_contains(answers[2], &["\"accepted\": false", "not finite"]);
}

/// The run of a [`state_and_force_script`] passed: the peer's stamps came at 1 kHz, the plant
/// applied its commands and refused the bad one it sent.
#[track_caller]
pub fn assert_peer_read_state_and_commanded(run: &Run) {
    run.assert_ok();
    assert_state_at_1khz(run);
    let force = run.json_with("applied_samples");
    assert_at_least(force, "applied_samples", 5.0);
    assert!(
        json_number(force, "refused_after") > json_number(force, "refused_before"),
        "{force}"
    );
}

/// Panics unless the number after `"key":` in `json` is at least `min` (missing: fails).
#[track_caller]
pub fn assert_at_least(json: &str, key: &str, min: f64) {
    let v = json_number(json, key).unwrap_or(f64::NAN);
    assert!(v >= min, "{key} = {v}, expected >= {min}: {json}");
}

/// Bash functions every script can call: `start_plant ARGS...` / `start_controller ARGS...`
/// start the node on `$SCENE` in the background (pid in `$P` / `$C`; a redirection after the call
/// applies to the node), `stop PID...` sends SIGTERM and waits (the status is the last one's),
/// `peer ARGS...` runs the Cyclone DDS Python peer (tests/peers/cyclone_peer.py), `fpeer ARGS...`
/// the Fast DDS C++ peer (tests/peers/fastdds/, see [`fastdds_peer`]),
/// `wait_nodes_of PID N` waits (at most 15 s) until N children of PID run their DDS threads,
/// `wait_line PATH` (at most 15 s) until a device's line (a pty's link) exists.
const PRELUDE: &str = r#"
start_plant() { "$B/capsule_plant" --scene "$SCENE" "$@" & P=$!; }
start_controller() { "$B/capsule_controller" --scene "$SCENE" "$@" & C=$!; }
stop() { kill -TERM "$@"; wait "$@"; }
peer() { python3 "$ROOT/tests/peers/cyclone_peer.py" "$@"; }
fpeer() { "$FASTDDS_PEER" "$@"; }
wait_line() { for i in $(seq 150); do [ -e "$1" ] && return 0; sleep 0.1; done; return 1; }
wait_nodes_of() {
    for i in $(seq 150); do
        n=0; for k in $(pgrep -P "$1"); do [ $(ls /proc/$k/task | wc -l) -ge 3 ] && n=$((n+1)); done
        [ $n -ge "$2" ] && break; sleep 0.1
    done
    sleep 0.5
}
"#;

/// [`netns`] for a script that calls `peer`: first checks that the peer can run.
pub fn netns_with_peer(timeout_s: u32, script: &str) -> Run {
    assert_cyclone_peer_runs();
    netns(timeout_s, script)
}

/// [`netns_with_peer`] with the node binaries (`$B`) taken from `bin` instead of target/debug.
pub fn netns_with_peer_from(bin: &Path, timeout_s: u32, script: &str) -> Run {
    assert_cyclone_peer_runs();
    netns_env(timeout_s, script, &[("B", bin.as_os_str())])
}

/// Fails with the set-up command when the Cyclone DDS Python peer cannot run.
fn assert_cyclone_peer_runs() {
    let ok = Command::new("python3")
        .args(["-c", "import cyclonedds"])
        .status()
        .is_ok_and(|s| s.success());
    assert!(ok, "python3 with cyclonedds needed: run .ci/ros-setup.sh");
}

/// The Fast DDS C++ peer (tests/peers/fastdds/fastdds_peer.cpp against Debian's
/// libfastrtps-dev), compiled once per test run into the test target directory.
pub fn fastdds_peer() -> PathBuf {
    static BUILT: std::sync::OnceLock<Result<PathBuf, String>> = std::sync::OnceLock::new();
    let built = BUILT.get_or_init(|| {
        let src = root().join("tests/peers/fastdds");
        let exe = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("fastdds_peer");
        let out = Command::new("c++")
            .args(["-std=c++17", "-O1", "-Wall", "-Werror", "-o"])
            .arg(&exe)
            .arg(src.join("fastdds_peer.cpp"))
            .args(["-lfastrtps", "-lfastcdr"])
            .output()
            .map_err(|e| format!("cannot run c++: {e}"))?;
        if out.status.success() {
            Ok(exe)
        } else {
            Err(String::from_utf8_lossy(&out.stderr).into_owned())
        }
    });
    match built {
        Ok(exe) => exe.clone(),
        Err(e) => panic!(
            "the Fast DDS peer does not build (run .ci/ros-setup.sh for libfastrtps-dev):\n{e}"
        ),
    }
}

/// [`netns`] for a script that calls `fpeer`: builds the Fast DDS peer first.
pub fn netns_with_fastdds_peer(timeout_s: u32, script: &str) -> Run {
    let exe = fastdds_peer();
    netns_env(timeout_s, script, &[("FASTDDS_PEER", exe.as_os_str())])
}

/// Runs a bash script in a fresh loopback-only namespace for at most `timeout_s`.
/// `$B` is the binary directory, `$ROOT` the workspace, `$SCENE` the control-point scene and
/// `$TMP` a scratch directory; the functions of [`PRELUDE`] are defined.
pub fn netns(timeout_s: u32, script: &str) -> Run {
    netns_env(timeout_s, script, &[])
}

/// [`netns`] with extra environment variables.
fn netns_env(timeout_s: u32, script: &str, envs: &[(&str, &std::ffi::OsStr)]) -> Run {
    let b = bin_dir();
    let tmp = std::env::temp_dir().join(format!("capsule_ros_{}_{}", std::process::id(), unique()));
    std::fs::create_dir_all(&tmp)
        .unwrap_or_else(|e| panic!("cannot create {}: {e}", tmp.display()));
    let out: Output = Command::new("bash")
        .arg(root().join("tests/peers/netns_run.sh"))
        .arg(timeout_s.to_string())
        .args(["bash", "-c", &format!("{PRELUDE}{script}")])
        .env("B", &b)
        .env("CAPSULE_BIN", &b)
        .env("ROOT", root())
        .env("SCENE", control_point())
        .env("TMP", &tmp)
        .env("ROS_AUTOMATIC_DISCOVERY_RANGE", "LOCALHOST")
        .env_remove("RMW_IMPLEMENTATION")
        .env_remove("RUST_LOG")
        .envs(envs.iter().copied())
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

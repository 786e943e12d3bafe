//! What the non-ROS tests share: the built binaries and how they run, command lines written as
//! one string, directories of a test's own that go away with it, the files of a folder.

use crate::root;
use std::path::{Path, PathBuf};
use std::process::{Command, Output, Stdio};
use std::time::{Duration, Instant};

/// Where the built binaries are (`$CAPSULE_BIN`, else target/debug).
pub fn bin_dir() -> PathBuf {
    std::env::var_os("CAPSULE_BIN")
        .map(PathBuf::from)
        .unwrap_or_else(|| root().join("target/debug"))
}

/// A built binary; panics with the fix when it is missing.
pub fn bin(name: &str) -> PathBuf {
    let p = bin_dir().join(name);
    assert!(
        p.is_file(),
        "{} missing: run `cargo build --workspace` first",
        p.display()
    );
    p
}

/// A binary to run from the repository root, stdin closed, output captured, DDS on loopback.
pub fn command(name: &str) -> Command {
    let mut c = Command::new(bin(name));
    c.current_dir(root())
        .env("ROS_AUTOMATIC_DISCOVERY_RANGE", "LOCALHOST")
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped());
    c
}

/// Runs a binary with a deadline of 60 s (a hang is a failure, not a stuck test run).
pub fn run(name: &str, args: &[&str]) -> Output {
    let mut child = command(name)
        .args(args)
        .spawn()
        .unwrap_or_else(|e| panic!("cannot run {name}: {e}"));
    let t0 = Instant::now();
    loop {
        match child.try_wait() {
            Ok(Some(_)) => break,
            Ok(None) if t0.elapsed() > Duration::from_secs(60) => {
                let _ = child.kill();
                panic!("{name} {args:?} still running after 60 s");
            }
            Ok(None) => std::thread::sleep(Duration::from_millis(10)),
            Err(e) => panic!("{name}: {e}"),
        }
    }
    child
        .wait_with_output()
        .unwrap_or_else(|e| panic!("{name}: {e}"))
}

/// Runs the `capsule` command to the end, however long it takes.
pub fn capsule(args: &[&str]) -> Output {
    capsule_in(&root(), args)
}

/// Runs the `capsule` command in `dir` (where it writes what it writes by default) to the end.
pub fn capsule_in(dir: &Path, args: &[&str]) -> Output {
    command("capsule")
        .args(args)
        .current_dir(dir)
        .output()
        .unwrap_or_else(|e| panic!("cannot run capsule: {e}"))
}

/// Asserts that `capsule` run in `dir` refuses `args` at once (within 5 s: before any work),
/// with `words` in its stderr.
pub fn assert_refused_at_once(dir: &Path, args: &[&str], words: &str) {
    let t0 = Instant::now();
    let out = capsule_in(dir, args);
    let err = stderr(&out);
    assert!(!out.status.success(), "{args:?} succeeded");
    assert!(err.contains(words), "{args:?}: {err}");
    assert!(
        t0.elapsed().as_secs_f64() < 5.0,
        "{args:?} worked before refusing"
    );
}

/// What a run wrote to stderr.
pub fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

/// Asserts that a run succeeded, its stderr in the message.
pub fn assert_ok(o: &Output) {
    assert!(o.status.success(), "{}", stderr(o));
}

/// Asserts that the program `what` succeeded (its stderr in the message); returns its stdout.
#[track_caller]
pub fn succeeded(o: &Output, what: &str) -> String {
    assert!(o.status.success(), "{what} failed:\n{}", stderr(o));
    String::from_utf8_lossy(&o.stdout).into_owned()
}

/// Asserts that the run `what` exited with `code`, and that its stderr holds `words` and no
/// panic; returns stderr.
pub fn assert_refused(o: &Output, code: i32, words: &str, what: &str) -> String {
    let err = stderr(o);
    assert_eq!(o.status.code(), Some(code), "{what}: {err}");
    assert!(
        err.contains(words),
        "{what}: stderr `{err}` lacks `{words}`"
    );
    assert!(!err.contains("panicked"), "{what} panicked: {err}");
    err
}

/// Runs `capsule` with these arguments, which must succeed (what it wrote in the message);
/// what it printed.
pub fn capsule_ok(args: &[&str]) -> String {
    let out = capsule(args);
    let text = String::from_utf8_lossy(&out.stdout).into_owned();
    assert!(out.status.success(), "{args:?}: {text}{}", stderr(&out));
    text
}

/// What a run that must succeed printed, parsed as JSON.
pub fn json_of(o: &Output) -> serde_json::Value {
    assert_ok(o);
    serde_json::from_slice(&o.stdout).unwrap_or_else(|e| panic!("not JSON: {e}"))
}

/// Asserts that `text` holds each of `words` (the text in the message).
pub fn assert_holds(text: &str, words: &[&str]) {
    for w in words {
        assert!(text.contains(w), "lacks `{w}`:\n{text}");
    }
}

/// Runs `capsule` with these arguments, which must succeed, and parses what it printed as JSON.
pub fn json(args: &[&str]) -> serde_json::Value {
    json_of(&capsule(args))
}

/// A command line written as one string (words split at white space), then `tail` (paths,
/// which may hold spaces) as they are.
pub fn line<'a>(words: &'a str, tail: &[&'a str]) -> Vec<&'a str> {
    words
        .split_whitespace()
        .chain(tail.iter().copied())
        .collect()
}

/// The entries of a folder, in name order.
pub fn files_in(dir: &Path) -> Vec<PathBuf> {
    let mut files: Vec<PathBuf> = std::fs::read_dir(dir)
        .unwrap_or_else(|e| panic!("{}: {e}", dir.display()))
        .filter_map(|e| e.ok().map(|e| e.path()))
        .collect();
    files.sort();
    files
}

/// A fresh directory of a test's own under the system temp dir, removed when it is dropped
/// (also when the test panics).
pub struct TempDir(PathBuf);

impl TempDir {
    /// `capsule_it_<tag>_<pid>`, emptied if an earlier run left it.
    pub fn new(tag: &str) -> Self {
        let d = std::env::temp_dir().join(format!("capsule_it_{tag}_{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&d);
        std::fs::create_dir_all(&d).unwrap_or_else(|e| panic!("{}: {e}", d.display()));
        Self(d)
    }

    /// A file in the directory (not created).
    pub fn file(&self, name: &str) -> PathBuf {
        self.0.join(name)
    }

    /// [`TempDir::file`] as a string, for a command line.
    pub fn arg(&self, name: &str) -> String {
        self.file(name).display().to_string()
    }
}

impl std::ops::Deref for TempDir {
    type Target = Path;

    /// The directory.
    fn deref(&self) -> &Path {
        &self.0
    }
}

impl Drop for TempDir {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.0);
    }
}

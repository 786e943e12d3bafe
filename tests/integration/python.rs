//! The Python package (`capsule_py`) through its own test suite: pytest against the installed
//! package (`bash .ci/python-setup.sh` builds and installs it) and the `capsule` command, one
//! test per pytest file so a failure names its area. The bindings are checked against the
//! command's JSON (the same numbers), the parameter studies on a real Dask cluster.

use crate::common::bin_dir;
use crate::root;
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

/// Runs `python3 -m pytest capsule_py/tests/FILE`, failing with its output (and the fix when
/// the package is not installed) unless every test passed; killed after `deadline`.
fn pytest(file: &str, deadline: Duration) {
    let dir = std::env::temp_dir().join(format!("capsule-pytest-{}-{file}", std::process::id()));
    let mut child = Command::new("python3")
        .args(["-m", "pytest", "-q", "-p", "no:cacheprovider", "--basetemp"])
        .arg(&dir)
        .arg(root().join("capsule_py/tests").join(file))
        .current_dir(root())
        .env("CAPSULE_BIN", bin_dir())
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap_or_else(|e| panic!("python3: {e} (run bash .ci/python-setup.sh)"));
    let t0 = Instant::now();
    while child.try_wait().ok().flatten().is_none() {
        if t0.elapsed() > deadline {
            let _ = child.kill();
            panic!("pytest {file} still running after {deadline:?}");
        }
        std::thread::sleep(Duration::from_millis(50));
    }
    let out = child
        .wait_with_output()
        .unwrap_or_else(|e| panic!("pytest {file}: {e}"));
    let _ = std::fs::remove_dir_all(&dir);
    let text = format!(
        "{}{}",
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(
        !text.contains("No module named"),
        "pytest {file}: a Python package is missing (run bash .ci/python-setup.sh):\n{text}"
    );
    assert!(out.status.success(), "pytest {file} failed:\n{text}");
    // pytest's closing line, e.g. "25 passed in 8.41s": something ran and nothing failed
    let last = text
        .lines()
        .rev()
        .find(|l| l.contains(" passed"))
        .unwrap_or("");
    assert!(
        !last.contains("failed") && !last.contains("error"),
        "pytest {file}: {last}"
    );
}

#[test]
fn bindings_agree_with_the_command() {
    pytest("test_bindings.py", Duration::from_secs(600));
}

#[test]
fn studies_survive_killed_workers_and_clients() {
    pytest("test_study.py", Duration::from_secs(600));
}

#[test]
fn the_fig19_notebook_runs() {
    pytest("test_notebook.py", Duration::from_secs(600));
}

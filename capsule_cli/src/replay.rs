//! `capsule replay ...` runs `capsule_replay` (package capsule_nodes) with the same arguments, as
//! `git foo` runs `git-foo`: replaying publishes on ROS 2, and the offline toolkit keeps DDS out
//! of its dependency tree.

use anyhow::{bail, Result};
use std::ffi::OsString;
use std::os::unix::process::CommandExt as _;
use std::path::PathBuf;

/// The replay binary's name.
const REPLAY: &str = "capsule_replay";

/// `capsule replay`'s arguments, handed over untouched (`--help` included).
#[derive(Debug, clap::Args)]
#[command(disable_help_flag = true)]
pub struct Args {
    /// capsule_replay's arguments (`capsule replay --help` lists them)
    #[arg(trailing_var_arg = true, allow_hyphen_values = true, num_args = 0..)]
    args: Vec<OsString>,
}

/// Where `capsule_replay` is: beside this executable (a cargo build or install puts both
/// there), else on `PATH`.
fn replay_binary() -> Option<PathBuf> {
    let beside = std::env::current_exe()
        .ok()
        .and_then(|exe| exe.parent().map(|dir| dir.join(REPLAY)))
        .filter(|p| p.is_file());
    beside.or_else(|| {
        std::env::var_os("PATH").and_then(|path| {
            std::env::split_paths(&path)
                .map(|dir| dir.join(REPLAY))
                .find(|p| p.is_file())
        })
    })
}

/// Replaces this process with `capsule_replay ARGS`; returns only if that cannot start.
pub fn main(args: Args) -> Result<()> {
    let Some(exe) = replay_binary() else {
        bail!(
            "capsule replay runs {REPLAY} (package capsule_nodes), found neither beside this \
             executable nor on PATH: cargo build -p capsule_nodes"
        );
    };
    let err = std::process::Command::new(&exe).args(&args.args).exec();
    bail!("cannot run {}: {err}", exe.display())
}

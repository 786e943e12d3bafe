//! `capsule`: the offline toolkit. Simulate a scene, sweep a parameter (bifurcation diagrams),
//! and benchmark the integrators.

mod bench;
mod offline_record;
mod record;
mod replay;
mod scene_args;
mod simulate;
mod svg;
mod sweep;

use clap::{Parser, Subcommand};

/// Offline toolkit for the vibro-impact capsule (Liu et al. 2014). All quantities are
/// non-dimensional, as in the paper.
#[derive(Debug, Parser)]
#[command(name = "capsule", version, about, long_about = None)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Debug, Subcommand)]
enum Command {
    /// Simulate one scene and report progression, period, impacts, efficiency.
    #[command(allow_negative_numbers = true)]
    Simulate(simulate::Args),
    /// Sweep one parameter over a range in parallel (the paper's bifurcation diagrams).
    #[command(allow_negative_numbers = true)]
    Sweep(sweep::Args),
    /// Time the integrators on the paper's scenes and print the figures.
    Bench(bench::Args),
    /// Look into a recorded run (info) or complete a cut one (recover).
    Record(record::Args),
    /// Publish a recording back onto ROS 2 at its pace, or check the controller against it.
    Replay(replay::Args),
}

fn main() -> std::process::ExitCode {
    // Like other Unix filters, end quietly when the reader goes away (`capsule ... | head`)
    // instead of panicking on a failed print.
    // SAFETY: restoring the default action of one signal before any thread starts.
    unsafe {
        libc::signal(libc::SIGPIPE, libc::SIG_DFL);
    }
    tracing_subscriber::fmt()
        .with_env_filter(
            tracing_subscriber::EnvFilter::try_from_default_env()
                .unwrap_or_else(|_| tracing_subscriber::EnvFilter::new("warn")),
        )
        .with_writer(std::io::stderr)
        .init();
    let result = match Cli::parse().command {
        Command::Simulate(a) => simulate::main(a),
        Command::Sweep(a) => sweep::main(a),
        Command::Bench(a) => bench::main(a),
        Command::Record(a) => record::main(a),
        Command::Replay(a) => replay::main(a),
    };
    match result {
        Ok(()) => std::process::ExitCode::SUCCESS,
        Err(e) => {
            // the chain of causes, without a backtrace: these are the user's errors to fix
            eprintln!("error: {e:#}");
            std::process::ExitCode::FAILURE
        }
    }
}

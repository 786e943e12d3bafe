//! `capsule`: the offline toolkit. Simulate a scene, sweep a parameter (bifurcation diagrams),
//! continue a periodic orbit, and benchmark the integrators.

mod basins;
mod bench;
#[path = "continue.rs"]
mod continuation;
mod emulate_device;
mod figures;
mod offline_record;
mod record;
mod refused;
mod replay;
mod robustness;
mod scene_args;
mod simulate;
mod simulate_device;
mod svg;
mod sweep;
mod switch;
mod work;

use clap::{CommandFactory, FromArgMatches, Parser, Subcommand};
// every command's refusals are `crate::Refused`
use refused::Refused;

/// Exit status 2 for refused input (a bad scene or flag, a run over its limits), 1 for a
/// failure while working.
fn exit_status(e: &anyhow::Error) -> u8 {
    let refused = e
        .chain()
        .any(|c| c.is::<Refused>() || c.is::<capsule_plant::scene::SceneError>());
    if refused {
        2
    } else {
        1
    }
}

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
    Simulate(simulate::Args),
    /// Sweep one parameter over a range in parallel (the paper's bifurcation diagrams).
    Sweep(sweep::Args),
    /// Basins of attraction on a plane of initial states (the paper's Figs 11, 18, 19).
    Basins(basins::Args),
    /// Move between coexisting attractors with a gain pulse (the paper's Fig 20).
    Switch(switch::Args),
    /// Continue a periodic orbit in one parameter (pseudo-arclength, bifurcations located).
    Continue(continuation::Args),
    /// Regenerate the paper's figures the model covers (SVG, PNG, a Markdown page).
    Figures(figures::Args),
    /// Time the integrators on the paper's scenes and print the figures.
    Bench(bench::Args),
    /// Look into a recorded run (info) or complete a cut one (recover).
    Record(record::Args),
    /// What a real capsule costs: the law closed around a simulated prototype (sensor noise,
    /// delay, quantisation, coil lag, a +-20 % plant mismatch), per mode; tables and heat maps.
    Robustness(robustness::Args),
    /// A prototype on a pseudo-terminal: the scene's capsule behind its sensor and actuator
    /// models, speaking the device protocol (for capsule_plant --source serial:PATH).
    EmulateDevice(emulate_device::Args),
    /// Publish a recording back onto ROS 2 at its pace, or check the controller against it
    /// (runs capsule_replay, from capsule_nodes).
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
    // every subcommand takes negative numbers as values (`--kp -0.1`)
    let matches = Cli::command()
        .mut_subcommands(|c| c.allow_negative_numbers(true))
        .get_matches();
    let cli = match Cli::from_arg_matches(&matches) {
        Ok(cli) => cli,
        Err(e) => e.exit(),
    };
    let result = match cli.command {
        Command::Simulate(a) => simulate::main(a),
        Command::Sweep(a) => sweep::main(a),
        Command::Basins(a) => basins::main(a),
        Command::Continue(a) => continuation::main(a),
        Command::Bench(a) => bench::main(a),
        Command::Figures(a) => figures::main(a),
        Command::Switch(a) => switch::main(a),
        Command::Record(a) => record::main(a),
        Command::Replay(a) => replay::main(a),
        Command::EmulateDevice(a) => emulate_device::main(a),
        Command::Robustness(a) => robustness::main(a),
    };
    match result {
        Ok(()) => std::process::ExitCode::SUCCESS,
        Err(e) => {
            // the chain of causes, without a backtrace: these are the user's errors to fix
            eprintln!("error: {e:#}");
            std::process::ExitCode::from(exit_status(&e))
        }
    }
}

//! `capsule`: the offline toolkit. Simulate a scene, sweep a parameter (bifurcation diagrams),
//! continue a periodic orbit, and benchmark the integrators.

mod basins;
mod bench;
#[path = "continue.rs"]
mod continuation;
mod emulate_device;
mod figures;
mod identify;
mod record;
mod refused;
mod replay;
mod robustness;
mod scene_args;
mod simulate;
mod simulate_device;
mod simulate_recording;
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

// `defer`: a subcommand's arguments are built only when it runs (building all eleven
// subcommands' arguments was a sixth of `capsule --version`'s time)
#[derive(Debug, Subcommand)]
#[command(defer = true)]
enum Command {
    /// Simulate one scene and report progression, period, impacts, efficiency.
    Simulate(Deferred<simulate::Args>),
    /// Sweep one parameter over a range in parallel (the paper's bifurcation diagrams).
    Sweep(Deferred<sweep::Args>),
    /// Basins of attraction on a plane of initial states (the paper's Figs 11, 18, 19).
    Basins(Deferred<basins::Args>),
    /// Move between coexisting attractors with a gain pulse (the paper's Fig 20).
    Switch(Deferred<switch::Args>),
    /// Continue a periodic orbit in one parameter (pseudo-arclength, bifurcations located).
    Continue(Deferred<continuation::Args>),
    /// Regenerate the paper's figures the model covers (SVG, PNG, a Markdown page).
    Figures(Deferred<figures::Args>),
    /// Time the integrators on the paper's scenes and print the figures.
    Bench(Deferred<bench::Args>),
    /// Look into a recorded run (info) or complete a cut one (recover).
    Record(Deferred<record::Args>),
    /// What a real capsule costs: the law closed around a simulated prototype (sensor noise,
    /// delay, quantisation, coil lag, a +-20 % plant mismatch), per mode; tables and heat maps.
    Robustness(Deferred<robustness::Args>),
    /// A prototype on a pseudo-terminal: the scene's capsule behind its sensor and actuator
    /// models, speaking the device protocol (for capsule_plant --source serial:PATH).
    EmulateDevice(Deferred<emulate_device::Args>),
    /// Fit a scene's numbers to a recorded run (a twin of the device), validate it on a run
    /// it did not see, write the fitted scene.
    Identify(Deferred<identify::Args>),
    /// Publish a recording back onto ROS 2 at its pace, or check the controller against it
    /// (runs capsule_replay, from capsule_nodes).
    Replay(Deferred<replay::Args>),
}

/// A subcommand's arguments, built when the subcommand runs (`defer`), under the about text of
/// its variant in [`Command`]: the arguments' own doc comment, applied after it once deferred,
/// would otherwise replace it in `capsule SUBCOMMAND --help`.
#[derive(Debug)]
struct Deferred<T>(T);

impl<T: clap::Args> clap::Args for Deferred<T> {
    fn group_id() -> Option<clap::Id> {
        T::group_id()
    }
    fn augment_args(cmd: clap::Command) -> clap::Command {
        keep_about(cmd, T::augment_args)
    }
    fn augment_args_for_update(cmd: clap::Command) -> clap::Command {
        keep_about(cmd, T::augment_args_for_update)
    }
}

/// `augment(cmd)` with `cmd`'s about texts.
fn keep_about(cmd: clap::Command, augment: fn(clap::Command) -> clap::Command) -> clap::Command {
    let (about, long) = (cmd.get_about().cloned(), cmd.get_long_about().cloned());
    let cmd = augment(cmd);
    let cmd = match about {
        Some(a) => cmd.about(a),
        None => cmd.about(None::<&str>),
    };
    match long {
        Some(l) => cmd.long_about(l),
        None => cmd.long_about(None::<&str>),
    }
}

impl<T: FromArgMatches> FromArgMatches for Deferred<T> {
    fn from_arg_matches(matches: &clap::ArgMatches) -> Result<Self, clap::Error> {
        T::from_arg_matches(matches).map(Deferred)
    }
    fn from_arg_matches_mut(matches: &mut clap::ArgMatches) -> Result<Self, clap::Error> {
        T::from_arg_matches_mut(matches).map(Deferred)
    }
    fn update_from_arg_matches(&mut self, matches: &clap::ArgMatches) -> Result<(), clap::Error> {
        self.0.update_from_arg_matches(matches)
    }
    fn update_from_arg_matches_mut(
        &mut self,
        matches: &mut clap::ArgMatches,
    ) -> Result<(), clap::Error> {
        self.0.update_from_arg_matches_mut(matches)
    }
}

/// The command line's parser: every subcommand takes negative numbers as values (`--kp -0.1`).
fn command() -> clap::Command {
    Cli::command().mut_subcommands(|c| c.allow_negative_numbers(true))
}

fn main() -> std::process::ExitCode {
    // Like other Unix filters, end quietly when the reader goes away (`capsule ... | head`)
    // instead of panicking on a failed print.
    use nix::sys::signal::{signal, SigHandler, Signal};
    // SAFETY: restoring the default action of one signal before any thread starts.
    let _ = unsafe { signal(Signal::SIGPIPE, SigHandler::SigDfl) };
    tracing_subscriber::fmt()
        .with_env_filter(
            tracing_subscriber::EnvFilter::try_from_default_env()
                .unwrap_or_else(|_| tracing_subscriber::EnvFilter::new("warn")),
        )
        .with_writer(std::io::stderr)
        .init();
    let matches = command().get_matches();
    let cli = match Cli::from_arg_matches(&matches) {
        Ok(cli) => cli,
        Err(e) => e.exit(),
    };
    let result = match cli.command {
        Command::Simulate(Deferred(a)) => simulate::main(a),
        Command::Sweep(Deferred(a)) => sweep::main(a),
        Command::Basins(Deferred(a)) => basins::main(a),
        Command::Continue(Deferred(a)) => continuation::main(a),
        Command::Bench(Deferred(a)) => bench::main(a),
        Command::Figures(Deferred(a)) => figures::main(a),
        Command::Switch(Deferred(a)) => switch::main(a),
        Command::Record(Deferred(a)) => record::main(a),
        Command::Replay(Deferred(a)) => replay::main(a),
        Command::EmulateDevice(Deferred(a)) => emulate_device::main(a),
        Command::Robustness(Deferred(a)) => robustness::main(a),
        Command::Identify(Deferred(a)) => identify::main(a),
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_deferred_subcommand_keeps_its_about_text_and_gets_its_arguments_when_built() {
        let top = command();
        let mut seen = 0;
        for sub in top.get_subcommands() {
            // what `capsule --help` lists, before the subcommand is built
            let listed = sub.get_about().map(ToString::to_string);
            assert!(listed.is_some(), "{} has no about text", sub.get_name());
            assert_eq!(
                sub.get_arguments().count(),
                0,
                "{} built early",
                sub.get_name()
            );
            let mut built = sub.clone();
            built.build();
            assert_eq!(
                built.get_about().map(ToString::to_string),
                listed,
                "capsule {} --help",
                sub.get_name()
            );
            assert!(built.get_arguments().count() > 0, "{}", sub.get_name());
            seen += 1;
        }
        assert_eq!(seen, 12);
    }

    #[test]
    fn deferred_arguments_parse_with_negative_values() {
        let argv = ["capsule", "simulate", "--kp", "-0.1", "--periods", "3"];
        let matches = command().try_get_matches_from(argv);
        let cli = matches.and_then(|m| Cli::from_arg_matches(&m));
        assert!(
            matches!(
                cli,
                Ok(Cli {
                    command: Command::Simulate(_)
                })
            ),
            "{cli:?}"
        );
        let refused = command().try_get_matches_from(["capsule", "simulate", "--no-such-flag"]);
        assert!(refused.is_err());
    }
}

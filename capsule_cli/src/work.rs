//! Bounds on the work a command may start: estimated up front from the scene, refused above a
//! documented limit unless the user raises it (`--max-work`, `--max-samples`), and a Ctrl-C
//! flag that long runs check between pieces of work.

use crate::Refused;
use capsule_args::ranges;
use capsule_plant::scene::Scene;
use capsule_plant::{Method, Snapshot};
use signal_hook::consts::SIGINT;
use std::path::Path;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Once;

/// Default of `--max-work`: estimated integration steps over the whole command (about a
/// minute on one core of the machine the README's figures come from).
pub const DEFAULT_MAX_WORK: f64 = 1e9;
/// Default of `--max-samples`: stored time-history samples of one run (a few hundred MB).
pub const DEFAULT_MAX_SAMPLES: u64 = 5_000_000;
/// Steps per drive period assumed for the exact and adaptive methods: the adaptive method on
/// the paper's scenes takes about 200 (tolerance 1e-10) to 3,600 (1e-13) per period
/// (`capsule simulate --json`, `work`), the exact method fewer.
pub const STEPS_PER_PERIOD_ESTIMATE: f64 = 1000.0;

/// The work limits of a command.
#[derive(Debug, Clone, Copy, clap::Args)]
pub struct WorkArgs {
    /// Largest estimated number of integration steps the command may start, over all its runs
    /// (fixed method: periods x period / step; exact and adaptive: 1000 per period), (0, 1e15].
    /// Above it the command is refused before it starts.
    #[arg(long, default_value_t = DEFAULT_MAX_WORK, value_parser = ranges::positive(1e15))]
    pub max_work: f64,
}

impl WorkArgs {
    /// Refuses `runs` runs of `scene` whose estimated steps exceed `--max-work`.
    pub fn check(&self, scene: &Scene, runs: usize) -> Result<(), Refused> {
        let per_run = steps(scene);
        let total = per_run * runs as f64;
        if total > self.max_work {
            return Err(Refused(format!(
                "this would take about {total:.3e} integration steps ({runs} run(s) of {} periods, \
                 {} method{}), more than --max-work {:e}: shorten the run, coarsen the method, \
                 or raise --max-work",
                scene.horizon.periods,
                scene.solver.method.name(),
                match scene.solver.method {
                    Method::Fixed => format!(" with step {:e}", scene.solver.step),
                    _ => String::new(),
                },
                self.max_work
            )));
        }
        Ok(())
    }
}

/// Estimated integration steps of one run of `scene`.
pub fn steps(scene: &Scene) -> f64 {
    let periods = f64::from(scene.horizon.periods);
    match scene.solver.method {
        Method::Fixed => periods * scene.drive.period() / scene.solver.step,
        Method::Exact | Method::Adaptive => periods * STEPS_PER_PERIOD_ESTIMATE,
    }
}

/// Refuses a time history of more than `max` samples (each a [`Snapshot`] in memory).
pub fn check_samples(scene: &Scene, per_period: u32, max: u64) -> Result<(), Refused> {
    let n = u64::from(scene.horizon.periods) * u64::from(per_period) + 1;
    if n > max {
        return Err(Refused(format!(
            "--samples-per-period {per_period} x {} periods = {n} samples ({:.1} MB in memory), \
             more than --max-samples {max}: fewer samples or periods, or raise --max-samples",
            scene.horizon.periods,
            n as f64 * std::mem::size_of::<Snapshot>() as f64 / 1e6
        )));
    }
    Ok(())
}

/// Refuses an output path whose directory does not exist (before any work starts).
pub fn check_parent(path: &Path) -> Result<(), Refused> {
    let parent = match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p,
        _ => Path::new("."),
    };
    if parent.is_dir() {
        Ok(())
    } else {
        Err(Refused(format!(
            "{}: directory {} does not exist",
            path.display(),
            parent.display()
        )))
    }
}

/// Set by a Ctrl-C caught after [`catch_ctrl_c`]: long runs check it between pieces of work.
static INTERRUPTED: AtomicBool = AtomicBool::new(false);
/// While set, Ctrl-C has its default action (it ends the process): before [`catch_ctrl_c`],
/// after [`release_ctrl_c`], and after a first Ctrl-C.
static DEFAULT_ACTION: AtomicBool = AtomicBool::new(true);
static HOOKED: Once = Once::new();

/// From now on the first Ctrl-C sets [`interrupted`] instead of ending the process (a second
/// one ends it as usual).
pub fn catch_ctrl_c() {
    HOOKED.call_once(|| {
        // signal-hook runs the actions in this order: the default action when it is armed,
        // else the flag, then arming the default action for the next one (atomic stores and
        // loads, safe in a signal handler)
        let hooked = signal_hook::flag::register_conditional_default(SIGINT, &DEFAULT_ACTION)
            .and_then(|_| signal_hook::flag::register(SIGINT, &INTERRUPTED))
            .and_then(|_| signal_hook::flag::register(SIGINT, &DEFAULT_ACTION));
        if let Err(e) = hooked {
            tracing::warn!("Ctrl-C keeps its default action (ends the run at once): {e}");
        }
    });
    DEFAULT_ACTION.store(false, Ordering::SeqCst);
}

/// Gives Ctrl-C its default action back (it ends the process) after [`catch_ctrl_c`].
pub fn release_ctrl_c() {
    DEFAULT_ACTION.store(true, Ordering::SeqCst);
}

/// Whether Ctrl-C was pressed since [`catch_ctrl_c`].
pub fn interrupted() -> bool {
    INTERRUPTED.load(Ordering::SeqCst)
}

/// The flag behind [`interrupted`], for work that checks an `AtomicBool` itself (the basins).
pub fn interrupt_flag() -> &'static AtomicBool {
    &INTERRUPTED
}

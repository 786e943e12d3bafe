//! What reaches the sample loop's thread from the node's: the lifecycle's steps (each
//! answered with its outcome) and the end of the run. The loop looks at them at least once per
//! sample, so no service waits on it for longer than that.

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;

use tokio::sync::{mpsc, oneshot, Notify};
use tracing::{error, info};

use super::lifecycle::{Outcome, Step};
use super::PlantCore;
use crate::hardware::CapsuleHardware;

/// A lifecycle step for the loop, and where its outcome goes.
pub(super) struct Request {
    /// What to do.
    pub(super) step: Step,
    /// The outcome (dropped: the loop has ended).
    pub(super) reply: oneshot::Sender<Outcome>,
}

/// Why a pacing loop returned.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) enum Exit {
    /// `--until-s` reached, or the node is ending (a signal): the run is over.
    Over,
    /// Cleaned up: unconfigured, waiting for a configure.
    CleanedUp,
}

/// The loop's side of the node: lifecycle requests and the end of the run.
pub(super) struct LoopControl {
    /// Set when the node ends (SIGINT, SIGTERM).
    pub(super) halt: Arc<AtomicBool>,
    /// Notified with `halt`.
    pub(super) woken: Arc<Notify>,
    /// The lifecycle's steps.
    pub(super) requests: mpsc::UnboundedReceiver<Request>,
    /// Lock-step: paused ([`crate::pause`]; `woken` is notified when it changes).
    pub(super) paused: Arc<AtomicBool>,
}

impl LoopControl {
    /// Whether the node is ending.
    pub(super) fn halted(&self) -> bool {
        self.halt.load(Ordering::SeqCst)
    }

    /// Whether the plant is paused.
    pub(super) fn paused(&self) -> bool {
        self.paused.load(Ordering::SeqCst)
    }

    /// Applies the lifecycle steps waiting, without waiting for any; `Some` when the pacing
    /// loop must return.
    pub(super) fn poll<H: CapsuleHardware>(&mut self, core: &mut PlantCore<H>) -> Option<Exit> {
        if self.halted() {
            return Some(Exit::Over);
        }
        while let Ok(r) = self.requests.try_recv() {
            if let Some(exit) = apply(core, r) {
                return Some(exit);
            }
        }
        None
    }
}

/// Applies one step while configured (inactive or active); `Some` when the loop must return.
pub(super) fn apply<H: CapsuleHardware>(core: &mut PlantCore<H>, r: Request) -> Option<Exit> {
    let (outcome, exit) = match r.step {
        Step::Activate => (done("activate", core.activate()), None),
        Step::Deactivate => (done("deactivate", core.deactivate()), None),
        Step::Cleanup => (done("cleanup", core.cleanup()), Some(Exit::CleanedUp)),
        Step::Shutdown => (done("shutdown", core.cleanup()), Some(Exit::Over)),
        // the machine never asks for it here
        Step::Configure => (Outcome::Failure, None),
    };
    let _ = r.reply.send(outcome);
    exit
}

/// Applies one step while unconfigured; `Some` when the run is over.
pub(super) fn apply_unconfigured<H: CapsuleHardware>(
    core: &mut PlantCore<H>,
    r: Request,
) -> Option<Exit> {
    let (outcome, exit) = match r.step {
        Step::Configure => match core.configure() {
            Ok(()) => (Outcome::Success, None),
            Err(e) => {
                error!("configure: {e}");
                // on_error: let go of whatever was opened
                let _ = core.cleanup();
                (Outcome::Error, Some(Exit::CleanedUp))
            }
        },
        Step::Shutdown => (Outcome::Success, Some(Exit::Over)),
        _ => (Outcome::Failure, Some(Exit::CleanedUp)),
    };
    let _ = r.reply.send(outcome);
    exit
}

fn done(what: &str, r: Result<(), crate::hardware::HardwareError>) -> Outcome {
    match r {
        Ok(()) => {
            info!("lifecycle: {what} done");
            Outcome::Success
        }
        Err(e) => {
            error!("{what}: {e}");
            Outcome::Error
        }
    }
}

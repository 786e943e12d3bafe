//! Measuring the capsule: one run of a scene under the paper's drive and feedback law, its
//! Poincaré section, period, impacts, progression and efficiency (eq. 4), and parameter sweeps
//! (the paper's bifurcation diagrams). Pure: no files, no terminal.

pub mod accuracy;
pub mod run;
pub mod sweep;

pub use run::{run, run_sampled, PaperLaw, RunReport};
pub use sweep::{sweep, sweep_following, Param, SweepPoint};

//! Measuring the capsule: one run of a scene under the paper's drive and feedback law, its
//! Poincaré section, period, impacts, progression and efficiency (eq. 4), and parameter sweeps
//! (the paper's bifurcation diagrams), and the stability of what it finds: Floquet multipliers
//! and Lyapunov exponents through the impacts and stick-slip events; a twin identified from a
//! recording (`identify`, `twin`, `twin_validation`). Pure: no files, no terminal.

pub mod accuracy;
pub mod attractor;
pub mod basin;
pub mod basin_cells;
pub mod basin_summary;
pub mod continuation;
pub mod cycle;
pub mod floquet;
pub mod identify;
pub mod identity;
pub mod linear;
pub mod lyapunov;
pub mod move_landing;
pub mod robustness;
pub mod run;
pub mod schedule;
pub mod stability;
pub mod sweep;
pub mod switch;
pub mod twin;
pub mod twin_validation;

pub use run::{run, run_sampled, run_scheduled, run_scheduled_until, RunReport};
pub use schedule::{GainSchedule, Pulse};
pub use sweep::{sweep, sweep_following, Param, SweepPoint};

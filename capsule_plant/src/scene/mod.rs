//! Scene files: a capsule, its friction, the drive and control, the start, the horizon, the solver.
//!
//! A scene is TOML, and every table and key is optional: what a scene leaves out takes the value
//! of [`Scene::default`] (below; `capsule simulate --print-scene` prints a scene with everything
//! filled in). Unknown keys, values of the wrong type, missing or non-finite numbers and
//! out-of-range values are refused with the file, the key and the reason ([`SceneError`]).
//! Parsing takes text, not a path: reading the file is the caller's business.
//!
//! ```toml
//! name = "Section 5.1 control point"   # default: the file name
//! [capsule]
//! gamma = 0.235   # m2 / m1          > 0      default 5
//! beta = 3.05     # k2 / k1          >= 0     default 15 (0: no secondary spring)
//! delta = 0.02    # gap              >= 0     default 0.02
//! xi = 0.05       # damping ratio    >= 0     default 0.01
//! [friction]
//! law = "coulomb" # default; or "viscous" (mu_v), "stribeck" (v_s),
//!                 # "seven-parameter" (mu_v, v_s, tau_d, k_s); a constant the law uses and
//!                 # the scene leaves out takes the paper's value (model::FRICTION_CONSTANTS)
//! [drive]
//! alpha = 1.6     # amplitude        >= 0     default 0.8
//! omega = 1.1     # frequency        > 0      default 0.95
//! [control]
//! kp = 0.0        # position feedback gain    default 0
//! [initial]
//! state = [0.0, 0.0, 0.0, 0.0]   # x1, y1, x2, y2 (exactly four)   default all zero
//! [horizon]
//! periods = 300   # whole number >= 1         default 300
//! transient = 200 # whole number < periods    default 200, or 2/3 of `periods` when only
//!                 #                           `periods` is given
//! [solver]
//! method = "exact" # default: the most accurate for the law (exact, else adaptive)
//! tol = 1e-10      # adaptive, in (0, 1)
//! step = 1e-3      # fixed, > 0
//! [physical]       # the SI scale used by the ROS nodes (each > 0)
//! m1_kg = 0.05
//! k1_n_per_m = 200.0
//! pf_n = 0.1
//! [node]           # the plant node's: read and checked by capsule_args::node_table, which
//!                  # every binary's scene reader runs; passed over here
//! rate_hz = 1000.0         # [1e-3, 1e6]
//! command_timeout_s = 0.1  # [1e-6, 1e6]
//! [device]         # a prototype's sensor and actuator (device::DeviceModel), SI; optional:
//!                  # without it the simulator is ideal and the device emulator takes
//!                  # DeviceModel::typical (the values below for this scale)
//! measured = ["displacement", "capsule_position"]  # or mass_velocity, capsule_velocity, contact
//! noise_m = 5e-6           # position noise, standard deviation   >= 0
//! noise_m_per_s = 3.2e-4   # velocity noise, standard deviation   >= 0
//! quantum_m = 1e-6         # position resolution (0: exact)       >= 0
//! latency_s = 0.002        # age of a measurement when sent       >= 0
//! jitter_s = 1e-4          # sample instant, standard deviation   >= 0
//! seed = 1                 # of the noise, 0 to 4294967295
//! max_force_n = 1.0        # actuator limit                       > 0
//! dead_band_n = 0.0        # smaller commands give no force       >= 0
//! lag_s = 5e-4             # coil current time constant           >= 0
//! max_travel_m = 0.01      # |x1 - x2| the mechanics allow        > 0
//! command_timeout_s = 0.1  # the device zeroes its force after   > 0
//! ```
//!
//! The files, one job each: `types.rs` (the validated scene), `file.rs` (the file as written
//! and what it means), `text.rs` (a scene from text and back), `toml_reader.rs` (TOML with the
//! key's path and line, also the nodes' `[node]` reader), `validate.rs`, `number.rs` (a number by its
//! key), `rule.rs` (what a number must be) and `error.rs` (why a scene is refused). The physical scale is
//! [`crate::physical`]'s.

mod error;
mod file;
mod number;
mod rule;
mod text;
mod toml_reader;
mod types;
mod validate;

pub use crate::physical::PhysicalScale;
pub use error::{Fault, Invalid, SceneError};
pub use number::KeyError;
pub use rule::{key_rule, Rule, KEY_RULES, MAX_DRIVE_ALPHA, MAX_MAGNITUDE};
pub use toml_reader::read_toml;
pub use types::{Control, Drive, Horizon, Scene};

#[cfg(test)]
mod tests;

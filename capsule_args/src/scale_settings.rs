//! The rows both nodes' tables hold: the physical scale of the scene's `[physical]` table, each
//! with that key's rule as its range. The controller gives them flags (it may run without a
//! scene); the plant takes them from its scene only.

use crate::settings::Setting;

/// Physical scale: inner mass.
pub const M1_KG: Setting = Setting::of_scene(
    "m1_kg",
    "Physical scale: inner mass m1 [kg]",
    "physical.m1_kg",
);
/// Physical scale: primary stiffness.
pub const K1_N_PER_M: Setting = Setting::of_scene(
    "k1_n_per_m",
    "Physical scale: primary stiffness k1 [N/m]",
    "physical.k1_n_per_m",
);
/// Physical scale: friction threshold.
pub const PF_N: Setting = Setting::of_scene(
    "pf_n",
    "Physical scale: friction threshold P_f [N]",
    "physical.pf_n",
);

//! The physical scale: SI units for the non-dimensional model (a scene's `[physical]` table).

use crate::scene::Invalid;
use serde::Serialize;

/// The physical scale that turns the non-dimensional model into SI units (paper sec. 2.1):
/// `Omega_0 = sqrt(k1 / m1)`, length `P_f / k1`, time `1 / Omega_0`, force `P_f`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct PhysicalScale {
    /// Inner mass `m1` in kg.
    pub m1_kg: f64,
    /// Primary spring stiffness `k1` in N/m.
    pub k1_n_per_m: f64,
    /// Coulomb friction threshold `P_f` in N.
    pub pf_n: f64,
}

impl Default for PhysicalScale {
    fn default() -> Self {
        PhysicalScale {
            m1_kg: 0.05,
            k1_n_per_m: 200.0,
            pf_n: 0.1,
        }
    }
}

impl PhysicalScale {
    /// Natural frequency `Omega_0` in rad/s.
    pub fn omega0(&self) -> f64 {
        (self.k1_n_per_m / self.m1_kg).sqrt()
    }
    /// Metres per unit of non-dimensional length.
    pub fn length_m(&self) -> f64 {
        self.pf_n / self.k1_n_per_m
    }
    /// Seconds per unit of non-dimensional time.
    pub fn time_s(&self) -> f64 {
        1.0 / self.omega0()
    }
    /// Metres per second per unit of non-dimensional velocity.
    pub fn velocity_m_per_s(&self) -> f64 {
        self.length_m() * self.omega0()
    }
    /// Newtons per unit of non-dimensional force.
    pub fn force_n(&self) -> f64 {
        self.pf_n
    }
    /// Checks every value (each finite and > 0: the scene's rules of these keys); the key is
    /// `physical.<name>`.
    pub fn validate(&self) -> Result<(), Invalid> {
        let values = [self.m1_kg, self.k1_n_per_m, self.pf_n];
        for ((key, rule), v) in SCALE_RULES.iter().zip(values) {
            rule.check(key, v)?;
        }
        Ok(())
    }
}

/// A scene key with its rule, looked up when compiled (a key without a rule does not compile).
const fn ruled(key: &'static str) -> (&'static str, crate::scene::Rule) {
    (key, crate::scene::key_rule(key))
}

/// The scale's keys and their rules, in the order of [`PhysicalScale::validate`]'s values.
const SCALE_RULES: [(&str, crate::scene::Rule); 3] = [
    ruled("physical.m1_kg"),
    ruled("physical.k1_n_per_m"),
    ruled("physical.pf_n"),
];

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn conversions_follow_the_papers_nondimensionalisation() {
        // Omega0 = sqrt(k1/m1), t = tau / Omega0, X = x P_f / k1, V = y Omega0 P_f / k1
        let s = PhysicalScale {
            m1_kg: 0.04,
            k1_n_per_m: 100.0,
            pf_n: 2.0,
        };
        assert!((s.omega0() - 50.0).abs() < 1e-12);
        assert!((s.length_m() - 0.02).abs() < 1e-15);
        assert!((s.velocity_m_per_s() - 1.0).abs() < 1e-12);
        assert!((s.time_s() - 0.02).abs() < 1e-15);
    }

    #[test]
    fn physical_scale_round_trips() {
        let p = PhysicalScale::default();
        assert!((p.omega0() - 63.245553203367585).abs() < 1e-12);
        assert!((p.length_m() - 5e-4).abs() < 1e-18);
        assert!((p.velocity_m_per_s() - p.length_m() / p.time_s()).abs() < 1e-15);
        assert!(PhysicalScale { m1_kg: -1.0, ..p }.validate().is_err());
        assert!(PhysicalScale {
            pf_n: f64::NAN,
            ..p
        }
        .validate()
        .is_err());
    }
}

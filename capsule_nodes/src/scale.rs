//! The physical scale between the paper's non-dimensional units and SI: the scene's
//! `[physical]` table, [`capsule_plant::scene::PhysicalScale`], under the nodes' name for it.
//!
//! With `Omega0 = sqrt(k1/m1)` (paper section 2): `t = tau / Omega0`, `X = x P_f / k1`,
//! `V = y Omega0 P_f / k1`, `F = f P_f`.

/// `m1`, `k1` and the friction threshold `P_f`, which fix every SI conversion.
pub type Scale = capsule_plant::scene::PhysicalScale;

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn conversions_follow_the_papers_nondimensionalisation() {
        let s = Scale {
            m1_kg: 0.04,
            k1_n_per_m: 100.0,
            pf_n: 2.0,
        };
        assert!((s.omega0() - 50.0).abs() < 1e-12);
        assert!((s.length_m() - 0.02).abs() < 1e-15);
        assert!((s.velocity_m_per_s() - 1.0).abs() < 1e-12);
        assert!((s.time_s() - 0.02).abs() < 1e-15);
    }
}

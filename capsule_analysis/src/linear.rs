//! The small dense linear algebra of the analyses, through nalgebra: a square solve that refuses
//! a (nearly) singular matrix (Newton's steps, the continuation's tangent) and the eigenvalues of
//! a 3 x 3 matrix (the Floquet multipliers). The eigenvalues come from a real Schur
//! decomposition, not from the roots of the characteristic polynomial: those are
//! ill-conditioned where two multipliers nearly coincide, which is where the continuation looks
//! for bifurcations.

use nalgebra::{DMatrix, DVector, Matrix3, Schur};

/// Most QR sweeps of the Schur decomposition (a 3 x 3 matrix needs a handful).
const SCHUR_SWEEPS: usize = 1000;

/// `a x = b` by LU with partial pivoting; `None` if a pivot of `U` is at most `rel_tol` times
/// `a`'s largest entry (0: only an exactly singular `a`) or the solution is not finite.
pub fn solve<const N: usize>(a: [[f64; N]; N], b: [f64; N], rel_tol: f64) -> Option<[f64; N]> {
    // a dynamic matrix: nalgebra's LU of a const-generic size needs type-level bounds, and a
    // 4 x 4 allocation is nothing next to the Poincaré maps these systems come from
    let m = DMatrix::<f64>::from_fn(N, N, |i, k| a[i][k]);
    let scale = m.amax();
    let lu = m.lu();
    let u = lu.u();
    if (0..N).any(|i| u[(i, i)].abs() <= rel_tol * scale || u[(i, i)] == 0.0) {
        return None;
    }
    let x = lu.solve(&DVector::<f64>::from_column_slice(&b))?;
    let out: [f64; N] = std::array::from_fn(|i| x[i]);
    out.iter().all(|v| v.is_finite()).then_some(out)
}

/// The eigenvalues of a real 3 x 3 matrix as `[re, im]`, in the order the Schur form holds
/// them; NaN if the decomposition does not converge (not seen on a 3 x 3 matrix).
pub fn eigenvalues3(m: &[[f64; 3]; 3]) -> [[f64; 2]; 3] {
    let a = Matrix3::<f64>::from_fn(|i, k| m[i][k]);
    match Schur::try_new(a, f64::EPSILON, SCHUR_SWEEPS) {
        Some(s) => {
            let e = s.complex_eigenvalues();
            std::array::from_fn(|i| [e[i].re, e[i].im])
        }
        None => [[f64::NAN; 2]; 3],
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn modulus(z: &[f64; 2]) -> f64 {
        z[0].hypot(z[1])
    }

    #[test]
    fn solves_and_refuses_singular() {
        let a = [[2.0, 1.0, 0.0], [1.0, 3.0, 1.0], [0.0, 1.0, 4.0]];
        let x = solve(a, [3.0, 5.0, 5.0], 0.0).unwrap_or_else(|| panic!("singular"));
        for (g, w) in x.iter().zip([1.0, 1.0, 1.0]) {
            assert!((g - w).abs() < 1e-12, "{x:?}");
        }
        let singular = [[1.0, 2.0, 3.0], [2.0, 4.0, 6.0], [0.0, 0.0, 1.0]];
        assert_eq!(solve(singular, [1.0; 3], 0.0), None);
        // nearly singular: refused under a relative threshold, solved without one
        let near = [[1.0, 1.0], [1.0, 1.0 + 1e-15]];
        assert_eq!(solve(near, [1.0, 2.0], 1e-13), None);
        assert!(solve(near, [1.0, 2.0], 0.0).is_some());
        // a 4 x 4 system whose first pivot needs a row swap
        let a = [
            [0.0, 2.0, 1.0, 0.0],
            [1.0, 0.0, 0.0, 3.0],
            [2.0, 1.0, 0.0, 0.0],
            [0.0, 0.0, 1.0, 1.0],
        ];
        let want = [1.0, -2.0, 0.5, 3.0];
        let b: [f64; 4] = std::array::from_fn(|i| (0..4).map(|k| a[i][k] * want[k]).sum());
        let got = solve(a, b, 1e-13).unwrap_or_else(|| panic!("singular?"));
        for (g, w) in got.iter().zip(want) {
            assert!((g - w).abs() < 1e-14, "{got:?}");
        }
    }

    #[test]
    fn eigenvalues_of_known_matrices() {
        // triangular: the diagonal
        let m = [[0.5, 1.0, 2.0], [0.0, -0.3, 4.0], [0.0, 0.0, 0.0]];
        let mut e: Vec<f64> = eigenvalues3(&m).iter().map(|z| z[0]).collect();
        e.sort_by(f64::total_cmp);
        for (got, want) in e.iter().zip([-0.3, 0.0, 0.5]) {
            assert!((got - want).abs() < 1e-14, "{e:?}");
        }
        // a rotation by 0.3 scaled by 0.9, and 0.2
        let (c, s) = (0.9 * 0.3f64.cos(), 0.9 * 0.3f64.sin());
        let m = [[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 0.2]];
        let e = eigenvalues3(&m);
        let mut mods: Vec<f64> = e.iter().map(modulus).collect();
        mods.sort_by(f64::total_cmp);
        assert!(
            (mods[0] - 0.2).abs() < 1e-14 && (mods[2] - 0.9).abs() < 1e-14,
            "{e:?}"
        );
        assert!(e.iter().any(|z| (z[1] - s).abs() < 1e-14), "{e:?}");
    }

    #[test]
    fn nearly_repeated_eigenvalues_keep_their_accuracy() {
        // eigenvalues -1 + 1e-7, -1 - 1e-7 and 0.3 (a period-doubling's neighbourhood) under a
        // similarity that mixes them: the roots of the characteristic polynomial (the method
        // before nalgebra) are off by 1.2e-9 here, the Schur form by 7e-16
        let d = [-1.0 + 1e-7, -1.0 - 1e-7, 0.3];
        let p = [[1.0, 0.3, -0.2], [0.1, 1.0, 0.4], [-0.3, 0.2, 1.0]];
        let pinv = {
            let m = Matrix3::<f64>::from_fn(|i, k| p[i][k]);
            m.try_inverse().unwrap_or_else(|| panic!("P singular"))
        };
        let m: [[f64; 3]; 3] = std::array::from_fn(|i| {
            std::array::from_fn(|k| (0..3).map(|j| p[i][j] * d[j] * pinv[(j, k)]).sum())
        });
        let mut e: Vec<f64> = eigenvalues3(&m).iter().map(|z| z[0]).collect();
        e.sort_by(f64::total_cmp);
        let mut want = d;
        want.sort_by(f64::total_cmp);
        for (got, w) in e.iter().zip(want) {
            assert!((got - w).abs() < 1e-12, "{e:?} vs {want:?}");
        }
        assert!(eigenvalues3(&m).iter().all(|z| z[1] == 0.0), "{e:?}");
    }
}

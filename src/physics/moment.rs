//! The inverse L = M⁻¹ of a particle's first moment M = Σ_j V_j (x_j − x_i) ⊗ ∇_i W_ij (–),
//! shared by the renormalised density gradient ([`super::delta`], [`super::pairs`]) and the
//! difference form of the pressure term ([`super::fluid::PressureDifference`]). Where M is
//! ill-conditioned (a free surface, a sparse neighbourhood) L falls back to the identity.

use crate::Matrix;

/// Relative determinant below which L_i falls back to the identity.
const ILL_CONDITIONED: f64 = 1e-3;

/// Inverse of a 2×2 or 3×3 matrix if well-conditioned relative to its scale.
pub fn inverse_or_identity<const D: usize>(m: &Matrix<D>) -> Matrix<D> {
    let det = determinant(m);
    let scale = (0..D).map(|a| m[(a, a)].abs()).sum::<f64>() / D as f64;
    // NaN-safe: anything not clearly well-conditioned falls back to the identity
    let well_conditioned = det.is_finite() && det.abs() > ILL_CONDITIONED * scale.powi(D as i32);
    if !well_conditioned {
        return Matrix::identity();
    }
    let mut inv = Matrix::<D>::zeros();
    if D == 2 {
        inv[(0, 0)] = m[(1, 1)] / det;
        inv[(0, 1)] = -m[(0, 1)] / det;
        inv[(1, 0)] = -m[(1, 0)] / det;
        inv[(1, 1)] = m[(0, 0)] / det;
    } else {
        for r in 0..3 {
            for c in 0..3 {
                // cofactor of (c, r) for the adjugate
                let (r1, r2) = ((c + 1) % 3, (c + 2) % 3);
                let (c1, c2) = ((r + 1) % 3, (r + 2) % 3);
                inv[(r, c)] = (m[(r1, c1)] * m[(r2, c2)] - m[(r1, c2)] * m[(r2, c1)]) / det;
            }
        }
    }
    inv
}

fn determinant<const D: usize>(m: &Matrix<D>) -> f64 {
    if D == 2 {
        m[(0, 0)] * m[(1, 1)] - m[(0, 1)] * m[(1, 0)]
    } else {
        m[(0, 0)] * (m[(1, 1)] * m[(2, 2)] - m[(1, 2)] * m[(2, 1)])
            - m[(0, 1)] * (m[(1, 0)] * m[(2, 2)] - m[(1, 2)] * m[(2, 0)])
            + m[(0, 2)] * (m[(1, 0)] * m[(2, 1)] - m[(1, 1)] * m[(2, 0)])
    }
}

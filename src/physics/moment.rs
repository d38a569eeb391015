//! A particle's first moment M = Σ_j V_j (x_j − x_i) ⊗ ∇_i W_ij (–), summed by [`FirstMoment`],
//! and its inverse L = M⁻¹, shared by the renormalised density gradient ([`super::delta`],
//! [`super::pairs`]) and the difference form of the pressure term
//! ([`super::fluid::PressureDifference`]). Where M is ill-conditioned (a free surface, a sparse
//! neighbourhood) L falls back to the identity.

use crate::{Matrix, Vector};

/// The first moment M_i = Σ_j V_j (x_j − x_i) ⊗ ∇_i W_ij (–) summed over a particle's
/// neighbours. With ∇_i W_ij = x_ij (1/r) dW/dr, each term is −w x_ij ⊗ x_ij, w = V_j (1/r)
/// dW/dr: symmetric, so only the upper triangle is accumulated.
#[derive(Debug, Clone, Copy)]
pub struct FirstMoment<const D: usize> {
    /// M's upper triangle, M[r][c] for r ≤ c (the lower is not written).
    upper: [[f64; D]; D],
}

impl<const D: usize> Default for FirstMoment<D> {
    fn default() -> Self {
        FirstMoment { upper: [[0.0; D]; D] }
    }
}

impl<const D: usize> FirstMoment<D> {
    /// Add neighbour j's term −w x_ij ⊗ x_ij, x_ij = x_i − x_j (m), w = V_j (1/r) dW/dr
    /// (m⁻²).
    #[inline(always)]
    pub fn add(&mut self, xij: &Vector<D>, w: f64) {
        for r in 0..D {
            let wr = xij[r] * w;
            for c in r..D {
                self.upper[r][c] -= wr * xij[c];
            }
        }
    }

    /// M[r][c] for r ≤ c.
    #[inline(always)]
    pub fn upper(&self, r: usize, c: usize) -> f64 {
        self.upper[r][c]
    }

    /// The whole symmetric M.
    pub fn matrix(&self) -> Matrix<D> {
        Matrix::<D>::from_fn(|r, c| {
            if r <= c {
                self.upper[r][c]
            } else {
                self.upper[c][r]
            }
        })
    }

    /// L = M⁻¹, or the identity where M is ill-conditioned ([`inverse_or_identity`]).
    pub fn inverse(&self) -> Matrix<D> {
        inverse_or_identity(&self.matrix())
    }
}

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

#[cfg(test)]
mod tests {
    use super::*;

    /// The upper-triangle sum is the full −Σ w x ⊗ x (nalgebra's outer products), and its
    /// inverse is M⁻¹ (M L = I to round-off) for a well-conditioned 3D moment.
    #[test]
    fn the_first_moment_is_the_sum_of_outer_products_and_inverts() {
        let xs = [
            Vector::<3>::new(0.3, -0.2, 0.1),
            Vector::<3>::new(-0.1, 0.4, 0.25),
            Vector::<3>::new(0.05, 0.15, -0.35),
            Vector::<3>::new(-0.3, -0.1, -0.2),
        ];
        let ws = [-2.0, -1.5, -3.0, -0.5];
        let mut m = FirstMoment::<3>::default();
        let mut full = Matrix::<3>::zeros();
        for (x, w) in xs.iter().zip(ws) {
            m.add(x, w);
            full -= x * x.transpose() * w;
        }
        assert!(
            (m.matrix() - full).amax() <= 1e-15 * full.amax(),
            "{}",
            m.matrix() - full
        );
        let residual = (m.matrix() * m.inverse() - Matrix::<3>::identity()).amax();
        assert!(residual < 1e-13, "M L − I: {residual:e}");
    }
}

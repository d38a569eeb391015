//! Renormalised density gradient for Antuono's δ-SPH (docs/methods.md §2).
//!
//! ⟨∇ρ⟩_i^L = L_i Σ_j (ρ_j − ρ_i) ∇_i W_ij V_j,  L_i = [Σ_j V_j ∇_i W_ij ⊗ (x_j − x_i)]⁻¹,
//! over fluid neighbours j (V_j = m_j/ρ_j). With this order the gradient of a linear field is
//! exact wherever the matrix is invertible; where it is ill-conditioned (free surface, sparse
//! neighbourhoods) L_i falls back to the identity.

use super::batch::{batched, itself};
use super::Model;
use crate::cells::Neighbours;
use crate::particles::Particles;
use crate::{Matrix, Vector};
use rayon::prelude::*;

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

/// Renormalised gradient of the field `f` at owned fluid particles (zero for others).
pub fn renormalised_gradient_of<const D: usize, N: Neighbours>(
    p: &Particles<D>,
    nl: &N,
    model: &Model<D>,
    f: &[f64],
    out: &mut [Vector<D>],
) {
    renormalised_gradient_with(p, nl, model, f, &super::fluid::volumes(p), out);
}

/// [`renormalised_gradient_of`] with the volumes `vol` (m³) of every particle given.
fn renormalised_gradient_with<const D: usize, N: Neighbours>(
    p: &Particles<D>,
    nl: &N,
    model: &Model<D>,
    f: &[f64],
    vol: &[f64],
    out: &mut [Vector<D>],
) {
    crate::with_pair_kernel!(model.varying(), model.kernel, D, kern => {
        out.par_iter_mut().enumerate().for_each(|(i, g)| {
            if !nl.visits(i) {
                return;
            }
            *g = Vector::zeros();
            if !p.kind[i].is_fluid() {
                return;
            }
            // −Σ_j V_j f_ij x_ij ⊗ x_ij is symmetric: accumulate the upper triangle only
            let mut a = [[0.0f64; D]; D];
            let mut s = Vector::<D>::zeros();
            let (xi, fi) = (p.x[i], f[i]);
            let r2_of = |j: usize| (xi - p.x[j]).norm_squared();
            batched(&kern, &p.h, i, nl.iter(i), itself, r2_of, |_, j, fij| {
                // the phase's own particles ([`super::fluid::diffuses`])
                if !super::fluid::diffuses(p, i, j) {
                    return;
                }
                let xij = xi - p.x[j];
                // ∇_i W_ij V_j = x_ij (1/r) dW/dr V_j
                let w = fij * vol[j];
                for r in 0..D {
                    let wr = xij[r] * w;
                    for c in r..D {
                        a[r][c] -= wr * xij[c]; // ∇W ⊗ (x_j − x_i)
                    }
                }
                s += xij * (w * (f[j] - fi));
            });
            let m = Matrix::<D>::from_fn(|r, c| if r <= c { a[r][c] } else { a[c][r] });
            *g = inverse_or_identity(&m) * s;
        })
    });
}

/// ⟨∇ρ⟩^L of every owned fluid particle, written to `p.grad_rho`; `vol` is scratch (kept by
/// the caller).
pub fn renormalised_gradient<const D: usize, N: Neighbours>(
    p: &mut Particles<D>,
    nl: &N,
    model: &Model<D>,
    vol: &mut Vec<f64>,
) {
    let n = p.n_owned;
    let mut out = std::mem::take(&mut p.grad_rho);
    super::fluid::volumes_into(p, vol);
    renormalised_gradient_with(p, nl, model, &p.rho, vol, &mut out[..n]);
    p.grad_rho = out;
}

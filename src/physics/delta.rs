//! Renormalised density gradient for Antuono's δ-SPH (docs/methods.md §2).
//!
//! ⟨∇ρ⟩_i^L = L_i Σ_j (ρ_j − ρ_i) ∇_i W_ij V_j,  L_i = [Σ_j V_j ∇_i W_ij ⊗ (x_j − x_i)]⁻¹,
//! over fluid neighbours j (V_j = m_j/ρ_j). With this order the gradient of a linear field is
//! exact wherever the matrix is invertible; where it is ill-conditioned (free surface, sparse
//! neighbourhoods) L_i falls back to the identity.

use super::batch::{batched, itself};
use super::moment::FirstMoment;
use super::Model;
use crate::cells::Neighbours;
use crate::particles::Particles;
use crate::Vector;
use rayon::prelude::*;

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
            let mut moment = FirstMoment::<D>::default();
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
                moment.add(&xij, w);
                s += xij * (w * (f[j] - fi));
            });
            *g = moment.inverse() * s;
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

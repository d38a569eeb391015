//! Dummy wall particles (Adami, Hu & Adams 2012, J. Comput. Phys. 231, 7057).
//!
//! Pressure (their eq. 27), with r_wf = x_w − x_f:
//!   p_w = [Σ_f p_f W_wf + (g − a_w) · Σ_f ρ_f r_wf W_wf] / Σ_f W_wf,
//! density from the EOS inverse, and the velocity the fluid sees in viscous terms:
//!   ṽ_w = Σ_f v_f W_wf / Σ_f W_wf;  no-slip: v_w = 2 u_wall − ṽ_w;  free-slip: v_w = ṽ_w.
//! A wall particle with no fluid neighbour keeps p = 0, ρ = ρ0, v_w = u_wall.

use crate::cells::Neighbours;
use crate::kernel::Kernel;
use crate::material::MaterialModel;
use crate::particles::{Kind, Particles};
use crate::Vector;
use rayon::prelude::*;

/// What the extrapolation reads besides the particles (the physics model lends it).
pub struct DummyWalls<'a, const D: usize> {
    /// The smoothing kernel.
    pub kernel: &'a Kernel,
    /// Material models by material index (the EOS inverse gives ρ_w from p_w).
    pub materials: &'a [MaterialModel],
    /// Body force g (m/s²).
    pub g: Vector<D>,
    /// Acceleration a_w of each wall body (m/s²), by body index.
    pub wall_acc: &'a [Vector<D>],
    /// No-slip (`true`) or free-slip walls, by body index.
    pub no_slip: &'a [bool],
}

/// Extrapolate p, ρ and v_w onto every owned dummy wall particle.
pub fn extrapolate<const D: usize, N: Neighbours>(p: &mut Particles<D>, nl: &N, model: &DummyWalls<D>) {
    let n = p.n_owned;
    let k = &model.kernel;
    let out: Vec<(f64, f64, Vector<D>)> = {
        let p = &*p;
        (0..n)
            .into_par_iter()
            .map(|w| {
                if p.kind[w] != Kind::Dummy {
                    return (p.p[w], p.rho[w], p.vw[w]);
                }
                let body = p.body[w] as usize;
                let mat = &model.materials[p.mat[w] as usize];
                let u_wall = p.v[w];
                let (mut sw, mut sp) = (0.0, 0.0);
                let mut srx = Vector::<D>::zeros();
                let mut sv = Vector::<D>::zeros();
                for f in nl.iter(w) {
                    let f = f as usize;
                    if !p.kind[f].is_fluid() {
                        continue;
                    }
                    let r_wf = p.x[w] - p.x[f];
                    let wgt = k.w(r_wf.norm());
                    sw += wgt;
                    sp += p.p[f] * wgt;
                    srx += r_wf * (p.rho[f] * wgt);
                    sv += p.v[f] * wgt;
                }
                if sw <= 0.0 {
                    return (0.0, mat.rho0(), u_wall);
                }
                let pw = (sp + (model.g - model.wall_acc[body]).dot(&srx)) / sw;
                let vt = sv / sw;
                let vw = if model.no_slip[body] {
                    2.0 * u_wall - vt
                } else {
                    vt
                };
                (pw, mat.density(pw), vw)
            })
            .collect()
    };
    for (w, (pw, rw, vw)) in out.into_iter().enumerate() {
        p.p[w] = pw;
        p.rho[w] = rw;
        p.vw[w] = vw;
    }
}

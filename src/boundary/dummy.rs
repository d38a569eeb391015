//! Dummy wall particles (Adami, Hu & Adams 2012, J. Comput. Phys. 231, 7057).
//!
//! Pressure (their eq. 27), with r_wf = x_w − x_f:
//!   p_w = [Σ_f p_f W_wf + (g − a_w) · Σ_f ρ_f r_wf W_wf] / Σ_f W_wf,
//! density from the EOS inverse, and the velocity the fluid sees in viscous terms:
//!   ṽ_w = Σ_f v_f W_wf / Σ_f W_wf;  no-slip: v_w = 2 u_wall − ṽ_w;  free-slip: v_w = ṽ_w.
//! A wall particle with no fluid neighbour keeps p = 0, ρ = ρ0, v_w = u_wall.

use super::WallContext;
use crate::particles::Particles;
use crate::Vector;

/// Adami's p_w, ρ_w and v_w of dummy wall particle `w` from its `neighbours` (the fluid among
/// them counts).
#[inline]
pub fn extrapolated<const D: usize>(
    p: &Particles<D>,
    w: usize,
    neighbours: impl Iterator<Item = u32>,
    c: &WallContext<D>,
    kern: impl crate::kernel::sizes::PairKernel,
) -> (f64, f64, Vector<D>) {
    let body = p.body[w] as usize;
    let mat = &c.materials[p.mat[w] as usize];
    let u_wall = p.v[w];
    let (mut sw, mut sp) = (0.0, 0.0);
    let mut srx = Vector::<D>::zeros();
    let mut sv = Vector::<D>::zeros();
    for f in neighbours {
        let f = f as usize;
        if !p.kind[f].is_fluid() {
            continue;
        }
        let r_wf = p.x[w] - p.x[f];
        let wgt = kern.of(&p.h, w, f).w(r_wf.norm());
        sw += wgt;
        sp += p.p[f] * wgt;
        srx += r_wf * (p.rho[f] * wgt);
        sv += p.v[f] * wgt;
    }
    if sw <= 0.0 {
        return (0.0, mat.rho0(), u_wall);
    }
    let pw = (sp + (c.g - c.wall_acc[body]).dot(&srx)) / sw;
    let vt = sv / sw;
    let vw = if c.no_slip[body] { 2.0 * u_wall - vt } else { vt };
    (pw, mat.density(pw), vw)
}

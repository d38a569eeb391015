//! Particle shifting (`[physics] shifting = "delta_plus"`): after each step every fluid
//! particle moves a small distance down the gradient of the particle concentration, which keeps
//! the particles near a uniform arrangement where shear and stagnation points would line them up
//! in chains or clumps. The displacement is δ⁺-SPH's (Sun, Colagrossi, Marrone & Zhang 2017,
//! Comput. Methods Appl. Mech. Engrg. 315, 25, eq. 18):
//!
//!   δr_i = −β (2h)² Σ_j [1 + R (W_ij / W(Δx))ⁿ] ∇_i W_ij V_j,   β = CFL · Ma,  R = 0.2,  n = 4,
//!
//! over every neighbour (fluid and wall particles, so a wall counts as filled space), with
//! Ma = U/c0 from the scene's expected speed U (the speed `hsph check` prints: a lid, a
//! prescribed field, √(2gH) under gravity) and the largest c0; the R term repels close pairs
//! (against the tensile instability). |δr| is capped at [`CAP`]·Δx (ours, against a rare large
//! step near a corner).
//!
//! Free surface (Lind et al. 2012; the divergence of position of Lee et al. 2008):
//! ∇·r_i = Σ_j (x_j − x_i)·∇_i W_ij V_j is the dimension D in a full support and about half of
//! it at a free surface. Below [`SURFACE`]·D a particle is on the surface and does not move;
//! below [`NEAR_SURFACE`]·D only the component tangent to the surface is kept, the normal being
//! n = ∇C/|∇C| with ∇C_i = Σ_j ∇_i W_ij V_j.
//!
//! The particle carries its fields to the new position by a first-order Taylor expansion
//! (Xu, Stansby & Laurence 2009; Lind et al. 2012): ρ ← ρ + δr·∇ρ, v ← v + (∇v) δr, with
//! ∇f_i = Σ_j (f_j − f_i) ∇_i W_ij V_j over fluid neighbours; the pressure follows from the EOS.
//! Without that correction a shifted particle keeps the density of the place it left, which
//! biases the pressure wherever the density varies (a hydrostatic column, a vortex core).

use super::Model;
use crate::cells::Neighbours;
use crate::particles::Particles;
use crate::Vector;
use rayon::prelude::*;

/// R of the anti-clumping term.
pub const R: f64 = 0.2;
/// Its exponent n.
pub const N: i32 = 4;
/// Largest displacement per step, in lattice spacings Δx.
pub const CAP: f64 = 0.2;
/// ∇·r below this fraction of D: a free-surface particle (1.5 in 2D; 2.4 in 3D is Lee et
/// al.'s, 0.8 D, used for both).
pub const SURFACE: f64 = 0.75;
/// ∇·r below this fraction of D: near the free surface (tangential shift only).
pub const NEAR_SURFACE: f64 = 0.9;
/// In the set-up relaxation, ∇·r below this fraction of the lattice's own (a full support,
/// [`lattice_divergence`]): the support is cut by the free surface, and the particle stays
/// where it is (without the anti-clumping term the push is ∇C itself, all of it normal).
pub const RELAX_NEAR: f64 = 0.99;

/// The shifting of a model: β (2h)² (m²) and W(Δx).
#[derive(Debug, Clone, Copy)]
pub struct Shifting {
    /// β (2h)² (m²).
    pub coefficient: f64,
    /// W(Δx) (1/m^D).
    pub w_dx: f64,
    /// Cap on |δr| (m).
    pub cap: f64,
    /// R of the anti-clumping term ([`R`]; 0 in the set-up relaxation).
    pub repel: f64,
    /// ∇·r below this fraction of D: near the free surface, the shift tangent to it
    /// ([`NEAR_SURFACE`] in a step; [`RELAX_NEAR`] × the lattice's in the relaxation).
    pub near: f64,
}

impl Shifting {
    /// Shifting for kernel radius `h` (m), spacing `dx` (m), CFL number `cfl`, expected speed
    /// `u` (m/s) and sound speed `c0` (m/s); `w_dx` is W(dx) of the kernel.
    pub fn new(h: f64, dx: f64, cfl: f64, u: f64, c0: f64, w_dx: f64) -> Self {
        Shifting {
            coefficient: cfl * (u / c0) * 4.0 * h * h,
            w_dx,
            cap: CAP * dx,
            repel: R,
            near: NEAR_SURFACE,
        }
    }

    /// The set-up relaxation's step (`discretisation.relax`): δr = −β_r (2h)² Σ_j ∇_i W_ij V_j
    /// with β_r = [`RELAX_BETA`] and no anti-clumping term, so that the particles settle where
    /// the zeroth moment Σ_j V_j ∇_i W_ij vanishes (the residual that multiplies the pressure in
    /// the momentum equation); `w_dx` is W(dx) of the kernel, the cap as in a step.
    ///
    /// Near a free surface the zeroth moment does not vanish in a full lattice either (the
    /// support is cut), and a shift along it pushes the rows below the surface up into the
    /// surface rows, and the whole column after them: in the refined still water of
    /// docs/refinement.md §2 the column stretched by 0.2 % in 50 iterations and kept growing
    /// with more, and the box's upper interface took a pressure step of 20 Pa. So every
    /// particle whose support the surface cuts stays where it is (the tangential rule of a
    /// step, with no anti-clumping term, leaves nothing of δr ∝ ∇C_i): ∇·r below
    /// `near`·D, where `near` is [`RELAX_NEAR`] times the smallest ∇·r/D of the scene's
    /// lattices in a full support ([`lattice_divergence`]), which is not D on a lattice
    /// (0.9992 for Wendland C2 at h = 2 dx in 2D, 0.964 at h = 1.2 dx). A step's threshold
    /// ([`NEAR_SURFACE`], 0.9) leaves the rows whose support is cut by a few per cent free.
    pub fn relaxation(h: f64, dx: f64, w_dx: f64, near: f64) -> Self {
        Shifting {
            coefficient: RELAX_BETA * 4.0 * h * h,
            w_dx,
            cap: CAP * dx,
            repel: 0.0,
            near,
        }
    }
}

/// ∇·r/D of a particle in a full support on the square (cubic) lattice of spacing `dx` (m),
/// dimension `dim`: Σ_j (x_j − x_i)·∇_i W_ij V_j = −Σ_j r_ij² (1/r) dW/dr dxᴰ over the lattice
/// offsets within the support, divided by D. It is 1 in the continuum and differs from it by
/// the kernel's discretisation error on the lattice (summed in a fixed order: the same bits
/// everywhere).
pub fn lattice_divergence(kernel: &crate::kernel::Kernel, dx: f64, dim: usize) -> f64 {
    let reach = (kernel.support / dx).ceil() as i64;
    let side = (2 * reach + 1) as usize;
    let cells = side.pow(dim as u32);
    let mut sum = 0.0;
    for c in 0..cells {
        let mut rest = c;
        let mut r2 = 0.0;
        for _ in 0..dim {
            let k = (rest % side) as i64 - reach;
            rest /= side;
            r2 += (k as f64 * dx).powi(2);
        }
        let r = r2.sqrt();
        if r > 0.0 && r < kernel.support {
            sum -= r2 * kernel.dw_dr_over_r(r);
        }
    }
    sum * dx.powi(dim as i32) / dim as f64
}

/// β_r of the set-up relaxation (–): with Wendland C2 at h = 2 dx a particle displaced from a
/// uniform lattice returns by about a quarter of its offset per iteration.
pub const RELAX_BETA: f64 = 0.1;

/// What shifting does to one particle: displacement δr (m) and the Taylor increments of its
/// density (kg/m³) and velocity (m/s).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Shift<const D: usize> {
    /// δr.
    pub dr: Vector<D>,
    /// δr·∇ρ.
    pub drho: f64,
    /// (∇v) δr.
    pub dv: Vector<D>,
}

impl<const D: usize> Default for Shift<D> {
    fn default() -> Self {
        Shift {
            dr: Vector::zeros(),
            drho: 0.0,
            dv: Vector::zeros(),
        }
    }
}

/// The shift of every owned particle into `out` (resized to the owned count; zero for all but
/// fluid particles), from the current positions, densities and velocities of owned particles
/// and ghosts. `vol` is a kept buffer for the volumes V_j = m_j/ρ_j (m³): the pass allocates
/// nothing once the buffers have grown to the run's size.
pub fn shifts<const D: usize, N: Neighbours>(
    p: &Particles<D>,
    nl: &N,
    model: &Model<D>,
    s: &Shifting,
    (vol, out): (&mut Vec<f64>, &mut Vec<Shift<D>>),
) {
    super::fluid::volumes_into(p, vol);
    out.clear();
    out.resize(p.n_owned, Shift::default());
    let vol = &vol[..];
    crate::with_pair_kernel!(model.varying(), model.kernel, D, kern => {
        out.par_iter_mut().enumerate().for_each(|(i, o)| {
            if nl.visits(i) {
                *o = shift_of(p, nl, model, kern, s, vol, i);
            }
        })
    });
}

/// One particle's [`Shift`] (see the module docs).
fn shift_of<const D: usize, N: Neighbours, K: crate::kernel::sizes::PairKernel>(
    p: &Particles<D>,
    nl: &N,
    model: &Model<D>,
    kern: K,
    s: &Shifting,
    vol: &[f64],
    i: usize,
) -> Shift<D> {
    if !p.kind[i].is_fluid() {
        return Shift::default();
    }
    let (xi, rhoi, vi) = (p.x[i], p.rho[i], p.v[i]);
    let mut push = Vector::<D>::zeros(); // Σ [1 + R (W/W(Δx))ⁿ] ∇W V
    let mut grad_c = Vector::<D>::zeros(); // Σ ∇W V
    let mut div_r = 0.0;
    let mut grad_rho = Vector::<D>::zeros();
    let mut grad_v = [[0.0f64; D]; D]; // grad_v[a][b] = ∂v_a/∂x_b
    for j in nl.iter(i) {
        let j = j as usize;
        let xij = xi - p.x[j];
        let r = xij.norm();
        let k = kern.of(&p.h, i, j);
        if r <= 0.0 || r >= k.support {
            continue;
        }
        let g = xij * (k.dw_dr_over_r(r) * vol[j]); // ∇_i W_ij V_j
        let ratio = k.w(r) / model.pair_w_dp(p, i, j, &k, s.w_dx);
        push += g * (1.0 + s.repel * ratio.powi(N));
        grad_c += g;
        div_r -= xij.dot(&g);
        if p.kind[j].is_fluid() {
            grad_rho += g * (p.rho[j] - rhoi);
            let dv = p.v[j] - vi;
            for a in 0..D {
                for b in 0..D {
                    grad_v[a][b] += dv[a] * g[b];
                }
            }
        }
    }
    let d = D as f64;
    if div_r < SURFACE * d {
        return Shift::default();
    }
    // β(2h_i)² and the cap ∝ Δp_i follow particle i's size (1 in a scene of one size)
    let scale = 1.0 / f64::from(1u32 << model.level(p, i));
    let hs = match model.varying() {
        None => 1.0,
        Some(_) => p.h[i] / model.kernel.h,
    };
    let mut dr = push * -(s.coefficient * hs * hs);
    if div_r < s.near * d && grad_c.norm() > 0.0 {
        let n = grad_c.normalize();
        dr -= n * n.dot(&dr);
    }
    let len = dr.norm();
    let cap = s.cap * scale;
    if len > cap {
        dr *= cap / len;
    }
    let dv = Vector::<D>::from_fn(|a, _| (0..D).map(|b| grad_v[a][b] * dr[b]).sum());
    Shift {
        dr,
        drho: grad_rho.dot(&dr),
        dv,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::kernel::{Kernel, KernelKind};

    /// ∇·r/D of a full lattice against an independent evaluation (Python, the kernels' shapes
    /// written out, σ from a numerical integral of W over the plane or space; 2026-11-29), and
    /// its continuum limit 1 when the support spans many spacings.
    #[test]
    fn lattice_divergence_matches_an_independent_sum_and_tends_to_one() {
        let cases = [
            (KernelKind::WendlandC2, 2, 2.0, 0.99920),
            (KernelKind::WendlandC2, 2, 1.2, 0.96385),
            (KernelKind::WendlandC2, 3, 1.3, 0.97890),
            (KernelKind::CubicSpline, 2, 1.3, 1.01054),
            (KernelKind::CubicSpline, 3, 1.2, 0.98169),
            (KernelKind::QuinticSpline, 2, 1.0, 1.00080),
        ];
        for (kind, dim, h_over_dx, want) in cases {
            let dx = 0.01;
            let got = lattice_divergence(&Kernel::new(kind, h_over_dx * dx, dim), dx, dim);
            assert!(
                (got - want).abs() < 2e-5,
                "{kind:?} {dim}D h = {h_over_dx} dx: {got} against {want}"
            );
        }
        for kind in [
            KernelKind::WendlandC2,
            KernelKind::CubicSpline,
            KernelKind::QuinticSpline,
        ] {
            let got = lattice_divergence(&Kernel::new(kind, 0.08, 2), 0.01, 2);
            assert!((got - 1.0).abs() < 1e-4, "{kind:?} at h = 8 dx: {got}");
        }
    }
}

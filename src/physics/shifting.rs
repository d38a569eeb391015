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
        }
    }

    /// The set-up relaxation's step (`discretisation.relax`): δr = −β_r (2h)² Σ_j ∇_i W_ij V_j
    /// with β_r = [`RELAX_BETA`] and no anti-clumping term, so that the particles settle where
    /// the zeroth moment Σ_j V_j ∇_i W_ij vanishes (the residual that multiplies the pressure in
    /// the momentum equation); `w_dx` is W(dx) of the kernel, the cap as in a step.
    pub fn relaxation(h: f64, dx: f64, w_dx: f64) -> Self {
        Shifting {
            coefficient: RELAX_BETA * 4.0 * h * h,
            w_dx,
            cap: CAP * dx,
            repel: 0.0,
        }
    }
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

/// The shift of every owned particle into `out` (zero for all but fluid particles), from the
/// current positions, densities and velocities of owned particles and ghosts.
pub fn shifts<const D: usize, N: Neighbours>(
    p: &Particles<D>,
    nl: &N,
    model: &Model<D>,
    s: &Shifting,
    out: &mut [Shift<D>],
) {
    let vol = super::fluid::volumes(p);
    crate::with_pair_kernel!(model.varying(), model.kernel, D, kern => {
        out.par_iter_mut().enumerate().for_each(|(i, o)| {
            if nl.visits(i) {
                *o = shift_of(p, nl, model, kern, s, &vol, i);
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
    if div_r < NEAR_SURFACE * d && grad_c.norm() > 0.0 {
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

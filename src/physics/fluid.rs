//! Rates of change of fluid particles: continuity with δ-SPH diffusion, pressure gradient,
//! Morris laminar viscosity, Monaghan artificial viscosity, repulsive walls and body force.
//!
//! For fluid particle i and neighbours j (docs/methods.md §1–2), with x_ij = x_i − x_j,
//! ∇_i W_ij = (dW/dr) x_ij / r, V_j = m_j/ρ_j:
//! - continuity (with the δ-SPH term on fluid neighbours j only):
//!   dρ_i/dt = Σ_j m_j (v_i − v_j)·∇_i W_ij + δ h c0 Σ_j ψ_ij·∇_i W_ij V_j, where
//!   ψ_ij = 2(ρ_j − ρ_i) x_ji/|x_ij|² − (⟨∇ρ⟩_i^L + ⟨∇ρ⟩_j^L) for Antuono, without the
//!   gradients for Molteni;
//! - momentum: dv_i/dt = P_i + V_i + g, with the pressure and artificial-viscosity part
//!   P_i = −Σ_j m_j (p_i/ρ_i² + p_j/ρ_j² + Π_ij) ∇_i W_ij and the laminar part
//!   V_i = Σ_j m_j (μ_i + μ_j) / (ρ_i ρ_j) · (1/r) ∂W/∂r · v_ij (μ = ρν, Pa·s);
//!   Π_ij = −α h c0 μ_ij / ρ̄_ij for v_ij·x_ij < 0, μ_ij = v_ij·x_ij/(r² + 0.01h²).
//!   The viscous term is Morris et al.'s x_ij·∇_i W_ij / (r² + η²) with η = 0: for every
//!   kernel here ∂W/∂r ∝ r near r = 0, so (1/r) ∂W/∂r is bounded and needs no
//!   regularisation, while η² = 0.01h² lowers the effective viscosity by about 0.01h²/⟨r²⟩,
//!   a bias that does not shrink with dx (Poiseuille error stalls near 0.65 %;
//!   docs/validation.md);
//! - repulsive wall particles (Monaghan 1994) add D[(r0/r)¹² − (r0/r)⁴] x_ij/r² for r < r0
//!   and take part in nothing else.
//!
//! Dummy wall neighbours enter with their extrapolated p, ρ and, in the viscous terms, their
//! velocity v_w; in continuity they move with the wall. A wall pushes and never pulls: for a
//! dummy neighbour the pressure part p_i/ρ_i² + p_w/ρ_w² is clamped at ≥ 0. Without the clamp
//! a thin film left on a no-slip wall goes into tension (p < 0 at the free surface), the
//! extrapolated wall pressure follows it below zero and the wall draws the film in: in the
//! shipped dam break with no-slip walls particles sat 0.6 dx inside the upstream wall at
//! t = 0.3 s (tests/fidelity.rs).

use super::batch::{batched, itself};
use super::moment::FirstMoment;
use super::Model;
use crate::cells::Neighbours;
use crate::particles::{Kind, Particles};

use crate::kernel::sizes::PairKernel;
use crate::scene::DensityDiffusion;
use crate::Vector;
use rayon::prelude::*;

/// Continuity pass: `p.drho` of every owned fluid particle (zero for walls), from the current
/// velocities and densities (eq. in the module docs, with the δ-SPH term), at the pair's
/// separation at the middle of the drift that just ended,
/// x_ij − ½ dt v_ij (dt in s; 0 at the set-up): see [`continuity_of`].
/// `vol` is scratch (kept by the caller, so the step loop does not allocate).
pub fn continuity<const D: usize, N: Neighbours>(
    p: &mut Particles<D>,
    nl: &N,
    model: &Model<D>,
    dt: f64,
    vol: &mut Vec<f64>,
) {
    let n = p.n_owned;
    let mut drho = std::mem::take(&mut p.drho);
    {
        let p = &*p;
        volumes_into(p, vol);
        let vol = &*vol;
        crate::with_pair_kernel!(model.varying(), model.kernel, D, k => {
            drho[..n].par_iter_mut().enumerate().for_each(|(i, dr)| {
                if nl.visits(i) {
                    *dr = continuity_of(p, nl, model, k, vol, 0.5 * dt, i);
                }
            })
        });
    }
    p.drho = drho;
}

/// Momentum pass: `p.acc` of every owned fluid particle (zero for walls), from the current
/// positions, velocities, densities and pressures; `p_rho2` is scratch (kept by the caller).
pub fn momentum<const D: usize, N: Neighbours>(
    p: &mut Particles<D>,
    nl: &N,
    model: &Model<D>,
    p_rho2: &mut Vec<f64>,
) {
    let n = p.n_owned;
    let mut acc = std::mem::take(&mut p.acc);
    {
        let p = &*p;
        // p_j/ρ_j² once per particle rather than once per pair
        p_rho2.resize(p.len(), 0.0);
        p_rho2
            .par_iter_mut()
            .zip(p.p.par_iter().zip(p.rho.par_iter()))
            .for_each(|(q, (&pj, &rj))| *q = pj / (rj * rj));
        crate::with_pair_kernel!(model.varying(), model.kernel, D, k => {
            acc[..n].par_iter_mut().enumerate().for_each(|(i, a)| {
                if nl.visits(i) {
                    *a = momentum_of(p, nl, model, k, p_rho2, i);
                }
            })
        });
    }
    p.acc = acc;
}

/// Volumes V_j = m_j/ρ_j of every particle (owned and ghost), computed once per pass.
pub(crate) fn volumes<const D: usize>(p: &Particles<D>) -> Vec<f64> {
    let mut vol = Vec::new();
    volumes_into(p, &mut vol);
    vol
}

/// [`volumes`] into a kept buffer (m³).
pub(crate) fn volumes_into<const D: usize>(p: &Particles<D>, vol: &mut Vec<f64>) {
    vol.resize(p.len(), 0.0);
    vol.par_iter_mut()
        .zip(p.mass.par_iter().zip(p.rho.par_iter()))
        .for_each(|(v, (&m, &r))| *v = m / r);
}

/// δ-SPH diffusion term D_i alone (for the conservation test Σ V_i D_i = 0), evaluated like
/// the continuity pass evaluates it.
pub fn diffusion_term<const D: usize, N: Neighbours>(
    p: &Particles<D>,
    nl: &N,
    model: &Model<D>,
    i: usize,
) -> f64 {
    let k = &model.kernel;
    let c0 = model.materials[p.mat[i] as usize].c0();
    let coef = model.diffusion.coefficient(model.delta, k.h, c0);
    let corr = Correction::of(model);
    let mut s = 0.0;
    for j in nl.iter(i) {
        let j = j as usize;
        if !diffuses(p, i, j) {
            continue;
        }
        let xij = p.x[i] - p.x[j];
        let kij = model.pair_kernel(p, i, j);
        let f = kij.dw_dr_over_r(xij.norm());
        let coef = if model.varying().is_none() {
            coef
        } else {
            model.diffusion.coefficient(model.delta, kij.h, c0)
        };
        s += coef * psi_dot_grad(p, model, corr, i, j, &xij, f) * (p.mass[j] / p.rho[j]);
    }
    s
}

/// True if the δ-SPH term (and Antuono's gradient that corrects it) pairs particle i, a fluid
/// particle, with j: j is fluid **of the same material**. Between fluids of different rest
/// densities ρ_j − ρ_i is the interface's jump, not a numerical gradient to be smoothed:
/// diffused, it moves mass across the interface and the pressure with it (a stratified still
/// tank gained 27 % of its energy in 0.3 s), so multiphase δ-SPH keeps the term within each
/// phase. A scene of one fluid material is unchanged.
#[inline(always)]
pub(crate) fn diffuses<const D: usize>(p: &Particles<D>, i: usize, j: usize) -> bool {
    p.kind[j].is_fluid() && p.mat[j] == p.mat[i]
}

/// What the δ-SPH term takes from a pair's density difference (`docs/methods.md` §2), chosen
/// once per pass from the scene's `density_diffusion`.
#[derive(Debug, Clone, Copy)]
pub(crate) enum Correction<const D: usize> {
    /// Molteni & Colagrossi: nothing.
    None,
    /// Antuono et al.: the renormalised gradients, (⟨∇ρ⟩_i + ⟨∇ρ⟩_j)·x_ji.
    Gradients,
    /// Fourtakas et al.: the hydrostatic part of ρ_j − ρ_i under the body force g (m/s²).
    Hydrostatic(Vector<D>),
    /// The Riemann solver's density dissipation: Fourtakas's difference times the pair's
    /// distance r (the coefficient is c0/2 instead of δ h c0).
    Riemann(Vector<D>),
}

impl<const D: usize> Correction<D> {
    /// The correction of `model`'s density diffusion.
    pub(crate) fn of(model: &Model<D>) -> Self {
        match model.diffusion {
            DensityDiffusion::Antuono => Correction::Gradients,
            DensityDiffusion::Fourtakas => Correction::Hydrostatic(model.g),
            DensityDiffusion::Riemann => Correction::Riemann(model.g),
            DensityDiffusion::None | DensityDiffusion::Molteni => Correction::None,
            #[cfg(test)]
            DensityDiffusion::Toy => Correction::None,
        }
    }
}

/// The run's description of its density diffusion (`None`: no term); `lagged`: Antuono's
/// gradient is the previous step's.
pub(crate) fn diffusion_line(diffusion: DensityDiffusion, delta: f64, lagged: bool) -> Option<String> {
    match diffusion {
        DensityDiffusion::None => None,
        DensityDiffusion::Molteni => Some(format!("δ-SPH Molteni–Colagrossi, δ = {delta}")),
        #[cfg(test)]
        DensityDiffusion::Toy => Some(format!("δ-SPH toy (Molteni's term), δ = {delta}")),
        DensityDiffusion::Fourtakas => {
            Some(format!("δ-SPH Fourtakas (hydrostatic part removed), δ = {delta}"))
        }
        DensityDiffusion::Riemann => Some(
            "Riemann-solver density dissipation (Zhang, Hu & Adams 2017; hydrostatic part removed)"
                .to_string(),
        ),
        DensityDiffusion::Antuono => Some(format!(
            "δ-SPH Antuono (renormalised gradient{}), δ = {delta}",
            if lagged {
                " of the previous step, with the momentum pass"
            } else {
                ""
            },
        )),
    }
}

/// ψ_ij·∇_i W_ij of the δ-SPH term, with ∇_i W_ij = f x_ij (f = (1/r) dW/dr) and
/// x_ji·x_ij/r² = −1:
/// - Molteni, ψ_ij = 2(ρ_j − ρ_i) x_ji/r²: ψ_ij·∇_i W_ij = −2f (ρ_j − ρ_i);
/// - Antuono, ψ_ij less ⟨∇ρ⟩_i + ⟨∇ρ⟩_j: f [−2(ρ_j − ρ_i) − (⟨∇ρ⟩_i + ⟨∇ρ⟩_j)·x_ij];
/// - Fourtakas, ψ_ij = 2(ρ_j − ρ_i − ρ^H_ji) x_ji/r² with the hydrostatic difference
///   ρ^H_ji = ρ̄ g·x_ji / c²(ρ̄), ρ̄ = (ρ_i + ρ_j)/2, c² = dp/dρ of i's material: the pressure
///   difference ρ̄ g·x_ji of still water over the pair (midpoint rule) turned into a density
///   difference by the EOS's slope at the pair's mean density. Exact to second order in the
///   pair's height difference, so still water diffuses nothing; antisymmetric in i and j
///   (one material), so Σ_i V_i D_i = 0. Fourtakas et al. (2019) take ρ0 and the EOS at ρ0
///   relative to particle i, exact only near the surface (1.5 % of the correction off at
///   the foot of a 2 m column at c0 = 88 m/s).
/// - Riemann, Fourtakas's bracket times r = |x_ij|: with the coefficient c0/2 the term is
///   (1/c0) Σ_j V_j (p_i − p_j − ρ̄ g·x_ij) ∂W/∂r to first order in the density difference,
///   the linearised Riemann solver's interface velocity U* = Ū + (p_i − p_j)/(2 ρ0 c0) in
///   dρ_i/dt = 2 ρ_i Σ_j V_j (v_i − v*)·∇_i W_ij (Zhang, Hu & Adams 2017) with ρ_i/ρ0 → 1,
///   which keeps Σ_i V_i D_i = 0.
#[inline(always)]
pub(crate) fn psi_dot_grad<const D: usize>(
    p: &Particles<D>,
    model: &Model<D>,
    corr: Correction<D>,
    i: usize,
    j: usize,
    xij: &Vector<D>,
    f: f64,
) -> f64 {
    let base = -2.0 * (p.rho[j] - p.rho[i]);
    let t = match corr {
        Correction::None => base,
        Correction::Gradients => base - (p.grad_rho[i] + p.grad_rho[j]).dot(xij),
        Correction::Hydrostatic(g) => base + 2.0 * hydrostatic(p, model, g, i, j, xij),
        Correction::Riemann(g) => (base + 2.0 * hydrostatic(p, model, g, i, j, xij)) * xij.norm(),
    };
    f * t
}

/// ρ^H_ji = ρ̄ g·x_ji / c²(ρ̄) (kg/m³), the hydrostatic part of ρ_j − ρ_i under the body force
/// g (m/s²) at the pair's mean density ([`psi_dot_grad`]).
#[inline(always)]
fn hydrostatic<const D: usize>(
    p: &Particles<D>,
    model: &Model<D>,
    g: Vector<D>,
    i: usize,
    j: usize,
    xij: &Vector<D>,
) -> f64 {
    let rho = 0.5 * (p.rho[i] + p.rho[j]);
    // x_ji = −x_ij, with ρ̄/c² in one division
    -g.dot(xij) * model.materials[p.mat[i] as usize].density_over_sound_speed2(rho)
}

/// The dissipative part of the Riemann solver's interface pressure as a pressure factor
/// (m⁵ kg⁻¹ s⁻², added to p_i/ρ_i² + p_j/ρ_j²) for a pair with v_ij·x_ij = `vx` (m²/s) at
/// squared distance `r2` (m²), densities `rho_i`, `rho_j` (kg/m³) and mean sound speed `c`
/// (m/s): 2 · ½ ρ̄ β ΔU / (ρ_i ρ_j) with ΔU = −vx/r and β = min(3ΔU, c) for an approaching
/// pair, zero for a receding one (`scene::PressureGradient::Riemann`). Symmetric in i and j.
#[inline(always)]
pub(crate) fn riemann_dissipation(vx: f64, r2: f64, rho_i: f64, rho_j: f64, c: f64) -> f64 {
    if vx >= 0.0 {
        return 0.0;
    }
    let du = -vx / r2.sqrt();
    let beta = (3.0 * du).min(c);
    0.5 * (rho_i + rho_j) * beta * du / (rho_i * rho_j)
}

/// dρ_i/dt = Σ_j m_j (v_i − v_j)·∇_i W_ij + δ h c0 Σ_j ψ_ij·∇_i W_ij V_j (fluid j only).
///
/// Both terms are evaluated at the pair's separation at the middle of the drift,
/// x_ij − `half_dt` v_ij (the midpoint rule over x_n → x_{n+1} with v_{n+½}). Evaluated at the
/// end of the drift instead, ρ_{n+1} − ρ_n misses the kernel-sum change by a one-signed
/// O(dt²) per step, and the mean density in a closed periodic box climbed in proportion to
/// dt: +3.4 % in 0.14 s for a 2 m/s Taylor–Green vortex at CFL 0.2, +1.5 % at 0.1, +0.7 % at
/// 0.05 (docs/equations.md §2.1). One kernel evaluation serves both terms.
#[inline]
fn continuity_of<const D: usize, N: Neighbours, K: PairKernel>(
    p: &Particles<D>,
    nl: &N,
    model: &Model<D>,
    kern: K,
    vol: &[f64],
    half_dt: f64,
    i: usize,
) -> f64 {
    if !p.kind[i].is_fluid() {
        return 0.0;
    }
    let k = &model.kernel;
    let c0 = model.materials[p.mat[i] as usize].c0();
    let diffusion = model.diffusion.diffuses();
    let corr = Correction::of(model);
    let delta_coef = model.diffusion.coefficient(model.delta, k.h, c0);
    let (xi, vi) = (p.x[i], p.v[i]);
    // walls enter with their own (prescribed) velocity
    let mid_of = |j: usize| (xi - p.x[j]) - (vi - p.v[j]) * half_dt;
    let mut drho = 0.0;
    batched(
        &kern,
        &p.h,
        i,
        nl.iter(i),
        itself,
        |j| mid_of(j).norm_squared(),
        |_, j, f| {
            let kind_j = p.kind[j];
            if !kind_j.is_smoothed() || kind_j.is_solid() {
                return;
            }
            let vij = vi - p.v[j];
            let mid = mid_of(j);
            let kij = kern.of(&p.h, i, j);
            drho += p.mass[j] * (f * vij.dot(&mid));
            if diffusion && diffuses(p, i, j) {
                let coef = if K::VARIES {
                    model.diffusion.coefficient(model.delta, kij.h, c0)
                } else {
                    delta_coef
                };
                drho += coef * psi_dot_grad(p, model, corr, i, j, &mid, f) * vol[j];
            }
        },
    );
    drho
}

/// dv_i/dt: pressure gradient, Monaghan artificial viscosity, Morris laminar viscosity,
/// Monaghan repulsive wall force and the body force.
#[inline]
fn momentum_of<const D: usize, N: Neighbours, K: PairKernel>(
    p: &Particles<D>,
    nl: &N,
    model: &Model<D>,
    kern: K,
    p_rho2: &[f64],
    i: usize,
) -> Vector<D> {
    if !p.kind[i].is_fluid() {
        return Vector::zeros();
    }
    let terms = PairTerms::of(p, model, i, p_rho2[i]);
    let mut acc = Vector::<D>::zeros();
    let r2_of = |j: usize| (terms.x - p.x[j]).norm_squared();
    if K::VARIES && model.difference_pressure {
        let mut diff = PressureDifference::new(p, i);
        batched(&kern, &p.h, i, nl.iter(i), itself, r2_of, |_, j, f| {
            if !p.kind[j].is_solid() {
                acc += pair_acceleration_with(p, model, kern, &terms, p_rho2[j], j, f);
                diff.add(p, &terms, p_rho2[j], j, f);
            }
        });
        return acc + diff.correction(terms.rho) + model.g;
    }
    batched(&kern, &p.h, i, nl.iter(i), itself, r2_of, |_, j, f| {
        // fluids and solids are not coupled (yet)
        if !p.kind[j].is_solid() {
            acc += pair_acceleration_with(p, model, kern, &terms, p_rho2[j], j, f);
        }
    });
    acc + model.g
}

/// p_i/ρ_i² + p_j/ρ_j² of the symmetric pressure term (m⁵ kg⁻¹ s⁻²) from its two halves,
/// clamped at ≥ 0 for a dummy wall j: walls push, never pull (module docs).
#[inline(always)]
fn pressure_factor(pi_term: f64, pj_term: f64, dummy: bool) -> f64 {
    let pij = pi_term + pj_term;
    if dummy {
        pij.max(0.0)
    } else {
        pij
    }
}

/// Largest |M_rr − 1| of a support that counts as full for [`PressureDifference`]: on a
/// lattice M = I to about 1e-3 (Wendland C2, h = 2 dx), and a free surface that cuts a fifth of
/// the support lowers the normal entry by more than this.
const FULL_SUPPORT: f64 = 0.1;

/// The renormalised difference form of the pressure term (`physics.pressure_gradient =
/// "difference"`, docs/refinement.md §1), for a fluid particle i whose support holds particles
/// of several smoothing lengths and is full (each diagonal entry of M_i within
/// [`FULL_SUPPORT`] of 1):
///
/// a_i^p = −(1/ρ_i) L_i Σ_j V_j (p_j − p_i) ∇_i W_ij,  L_i = M_i⁻¹,
/// M_i = Σ_j V_j (x_j − x_i) ⊗ ∇_i W_ij
///
/// (m/s²; Bonet & Lok 1999, CMAME 180:97; Oger et al. 2007, JCP 225:1472). For a linear
/// pressure it is −∇p/ρ_i exactly, where the symmetric form leaves −2 (p_i/ρ_i) Σ_j V_j ∇_i W_ij,
/// which the mean-h kernel makes non-zero where h varies even on a perfect lattice (the current
/// of docs/refinement.md §1). It is not antisymmetric, so momentum is not conserved across
/// those pairs. Two kinds of support keep the symmetric form:
/// - one that a free surface cuts: the form does not build in p = 0 there and lacks the
///   symmetric form's regularising push (with it, the refined still tank threw its surface
///   particles out within 0.3 s);
/// - one that holds a dummy wall particle: the symmetric wall term, clamped at ≥ 0, pushes
///   whatever approaches the wall, the difference form only by the extrapolated pressure's
///   difference (with it, the adaptive solitary wave's run-up fell from 2.6 % to 8.0 % error).
///
/// Solids and repulsive particles do not enter.
pub(crate) struct PressureDifference<const D: usize> {
    /// The symmetric pressure parts the pair sum already holds, −Σ_j m_j (p_i/ρ_i² + p_j/ρ_j²)
    /// ∇_i W_ij (m/s²), replaced where the form applies.
    symmetric: Vector<D>,
    /// M_i (–).
    moment: FirstMoment<D>,
    /// Σ_j V_j (p_j − p_i) ∇_i W_ij (Pa/m).
    sum: Vector<D>,
    /// h_i (m) and p_i (Pa).
    h: f64,
    p: f64,
    /// Some neighbour's h differs from h_i.
    mixed: bool,
    /// Some neighbour is a dummy wall particle.
    walled: bool,
}

impl<const D: usize> PressureDifference<D> {
    /// Empty sums for fluid particle `i`.
    pub(crate) fn new(p: &Particles<D>, i: usize) -> Self {
        PressureDifference {
            symmetric: Vector::zeros(),
            moment: FirstMoment::default(),
            sum: Vector::zeros(),
            h: p.h[i],
            p: p.p[i],
            mixed: false,
            walled: false,
        }
    }

    /// Neighbour j (not a solid) with (1/r) dW/dr `f` (m⁻ᴰ⁻²) and p_j/ρ_j² `pj_term`.
    #[inline(always)]
    pub(crate) fn add(&mut self, p: &Particles<D>, terms: &PairTerms<D>, pj_term: f64, j: usize, f: f64) {
        let kind = p.kind[j];
        if !kind.is_smoothed() {
            return;
        }
        let xij = terms.x - p.x[j];
        let mj = p.mass[j];
        let dummy = kind == Kind::Dummy;
        self.symmetric += xij * (-f * mj * pressure_factor(terms.p_rho2, pj_term, dummy));
        self.mixed |= p.h[j] != self.h;
        self.walled |= dummy;
        // ∇_i W_ij V_j = x_ij (1/r) dW/dr V_j
        let w = f * mj / p.rho[j];
        self.moment.add(&xij, w);
        self.sum += xij * (w * (p.p[j] - self.p));
    }

    /// What to add to the pair sum (m/s²): the difference form less the symmetric parts where
    /// the form applies (several h, a full support, no wall), else zero.
    pub(crate) fn correction(&self, rho_i: f64) -> Vector<D> {
        let full = (0..D).all(|r| (self.moment.upper(r, r) - 1.0).abs() < FULL_SUPPORT);
        if !self.mixed || !full || self.walled {
            return Vector::zeros();
        }
        -(self.moment.inverse() * self.sum) / rho_i - self.symmetric
    }
}

/// Fluid particle i as [`pair_acceleration`] needs it, loaded once per particle.
pub struct PairTerms<const D: usize> {
    /// Position x_i (m).
    pub(crate) x: Vector<D>,
    /// Velocity v_i (m/s).
    pub(crate) v: Vector<D>,
    /// Density ρ_i (kg/m³).
    pub(crate) rho: f64,
    /// p_i/ρ_i² (m⁵ kg⁻¹ s⁻²).
    pub(crate) p_rho2: f64,
    /// −2 α h c0 of particle i's material (m²/s): Π_ij = av_coef v_ij·x_ij / ((r² + η²)(ρ_i + ρ_j)).
    pub(crate) av_coef: f64,
    /// η² = 0.01 h² (m²), the artificial viscosity's regularisation.
    pub(crate) eta2: f64,
    /// Lattice moment L_i (–) if the viscous operator is renormalised, else 1.
    pub(crate) lap: f64,
    /// −2 α c0 of particle i's material (m/s): `av_coef` over h, for pairs of two sizes.
    pub(crate) av_c0: f64,
    /// c0 of particle i's material (m/s).
    pub(crate) c0: f64,
    /// Index of particle i.
    pub(crate) i: usize,
}

impl<const D: usize> PairTerms<D> {
    /// The terms of fluid particle `i`, whose p/ρ² is `p_rho2`.
    pub fn of(p: &Particles<D>, model: &Model<D>, i: usize, p_rho2: f64) -> Self {
        let h = model.kernel.h;
        let c0 = model.materials[p.mat[i] as usize].c0();
        PairTerms {
            x: p.x[i],
            v: p.v[i],
            rho: p.rho[i],
            p_rho2,
            av_coef: -2.0 * model.alpha * c0 * h,
            eta2: 0.01 * h * h,
            lap: if model.viscous.renormalised { p.lap[i] } else { 1.0 },
            av_c0: -2.0 * model.alpha * c0,
            c0,
            i,
        }
    }
}

/// The acceleration (m/s²) of fluid particle i (`terms`) due to neighbour j, the body force
/// excluded: pressure and artificial viscosity −m_j (p_i/ρ_i² + p_j/ρ_j² + Π_ij) ∇_i W_ij (the
/// pressure part clamped at ≥ 0 for a dummy wall j) plus the laminar term for a smoothed j, the
/// repulsive force for a repulsive wall j. `pj_term` is p_j/ρ_j² (m⁵ kg⁻¹ s⁻²). The force
/// probe sums m_i times this over a wall's particles, reversed.
#[inline(always)]
pub fn pair_acceleration<const D: usize, K: PairKernel>(
    p: &Particles<D>,
    model: &Model<D>,
    kern: K,
    terms: &PairTerms<D>,
    pj_term: f64,
    j: usize,
) -> Vector<D> {
    let r = (terms.x - p.x[j]).norm_squared().sqrt();
    let f = kern.of(&p.h, terms.i, j).dw_dr_over_r(r);
    pair_acceleration_with(p, model, kern, terms, pj_term, j, f)
}

/// [`pair_acceleration`] with the pair's (1/r) dW/dr `f` (m⁻ᴰ⁻²) given (the pair loops of both
/// modes evaluate a batch of them at once, `physics/batch.rs`); `f` is not read for a
/// repulsive j.
#[inline(always)]
pub fn pair_acceleration_with<const D: usize, K: PairKernel>(
    p: &Particles<D>,
    model: &Model<D>,
    kern: K,
    terms: &PairTerms<D>,
    pj_term: f64,
    j: usize,
    f: f64,
) -> Vector<D> {
    let xij = terms.x - p.x[j];
    let r2 = xij.norm_squared();
    let kind_j = p.kind[j];
    if !kind_j.is_smoothed() {
        return model
            .repulsive
            .acceleration(&xij, r2, r2.sqrt())
            .unwrap_or_else(Vector::zeros);
    }
    let k = kern.of(&p.h, terms.i, j);
    let (av_coef, eta2) = if K::VARIES {
        (terms.av_c0 * k.h, 0.01 * k.h * k.h)
    } else {
        (terms.av_coef, terms.eta2)
    };
    let (rhoi, mj, rhoj) = (terms.rho, p.mass[j], p.rho[j]);
    let dummy = kind_j == Kind::Dummy;
    // viscous terms see the extrapolated velocity of dummy walls
    let vij = terms.v - if dummy { p.vw[j] } else { p.v[j] };
    let mut pij = pressure_factor(terms.p_rho2, pj_term, dummy);
    let vx = vij.dot(&xij);
    if model.alpha > 0.0 && vx < 0.0 {
        pij += av_coef * vx / ((r2 + eta2) * (rhoi + rhoj));
    }
    if model.riemann_dissipation {
        pij += riemann_dissipation(vx, r2, rhoi, rhoj, terms.c0);
    }
    let mut acc = xij * (-f * mj * pij);
    if model.nu > 0.0 {
        // μ_i + μ_j = ν (ρ_i + ρ_j); x_ij·∇_i W_ij / r² = (1/r) ∂W/∂r (m⁻ᴰ⁻²)
        let mu_sum = model.nu * (rhoi + rhoj);
        let vij = model.viscous.difference(p, &model.wall_shift, terms, j, vij);
        acc += vij * (mj * mu_sum * f / (rhoi * rhoj));
    }
    acc
}

#[cfg(test)]
mod tests {
    use crate::comm::serial::SerialComm;
    use crate::scene::DensityDiffusion;
    use crate::sim::Simulation;

    /// The dam break of `inputs/dam_break_2d.toml` with `physics.density_diffusion = term`,
    /// after 30 steps: the densities in id order.
    fn densities(term: &str) -> Vec<u64> {
        let text = std::fs::read_to_string("inputs/dam_break_2d.toml").unwrap();
        let set = [format!("physics.density_diffusion=\"{term}\"")];
        let scene = crate::scene::load_scene_str(&text, std::path::Path::new("toy.toml"), "toy", &set)
            .unwrap()
            .0;
        let comm = SerialComm::new();
        let mut sim = Simulation::<2>::new(&scene, &comm).unwrap();
        for _ in 0..30 {
            sim.advance(&comm).unwrap();
        }
        let mut rho: Vec<(u64, u64)> = (0..sim.p.n_owned)
            .map(|i| (sim.p.id[i] as u64, sim.p.rho[i].to_bits()))
            .collect();
        rho.sort_unstable();
        rho.into_iter().map(|r| r.1).collect()
    }

    /// A density term added by its recipe's two files (`scene/mod.rs`, this file) is selected
    /// by a scene key, runs in the continuity pass (it changes the densities of a run without
    /// diffusion) and gives, as Molteni's term under another name, Molteni's bits.
    #[test]
    fn a_density_term_added_in_its_files_runs_from_a_scene() {
        assert!(DensityDiffusion::Toy.diffuses());
        assert!(super::diffusion_line(DensityDiffusion::Toy, 0.1, false).is_some());
        let toy = densities("toy");
        assert_eq!(toy, densities("molteni"));
        assert_ne!(toy, densities("none"));
    }
}

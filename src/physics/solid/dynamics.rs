//! The passes of elastic–plastic solids (Libersky et al. 1993; Gray, Monaghan & Swift 2001),
//! gather loops over owned solid particles like the fluid passes. Solid particles interact with
//! solid neighbours only (fluids and solids are not coupled yet).
//!
//! With x_ij = x_i − x_j, v_ij = v_i − v_j, ∇_i W_ij = (1/r)(dW/dr) x_ij, the total stress
//! σ = −p I + S (S the deviator), and sums over solid neighbours j:
//!
//! - velocity gradient  L_i = −(1/ρ_i) Σ_j m_j v_ij ⊗ ∇_i W_ij                           (S1)
//! - continuity         dρ_i/dt = −ρ_i tr L_i = Σ_j m_j v_ij·∇_i W_ij                    (S2)
//! - deviatoric stress  dS_i/dt = 2G(ε̇ − ⅓tr ε̇ I) + Ω S − S Ω  (Jaumann, [`jaumann_rate`]) (S3)
//! - energy             de_i/dt = (p_i/ρ_i²) Σ_j m_j v_ij·∇_i W_ij + (1/ρ_i) S_i:ε̇_i
//!   + ½ Σ_j m_j [Π_ij v_ij·∇_i W_ij − v_ij·(R_i + R_j) f_ijⁿ ∇_i W_ij]                 (S4)
//! - momentum           dv_i/dt = Σ_j m_j [σ_i/ρ_i² + σ_j/ρ_j² − Π_ij I + (R_i + R_j) f_ijⁿ] ∇_i W_ij + g   (S5)
//!
//! (S4) is the work of (S5)'s stress, viscosity and artificial-stress terms, so kinetic plus
//! internal energy Σ m (½v² + e) is conserved by the semi-discrete equations: the elastic
//! shear energy is part of e. The velocity gradient and the stress terms are corrected with
//! B_i = M_i⁻¹, M_i = −(1/ρ_i) Σ_j m_j x_ij ⊗ ∇_i W_ij ([`correction`]; exact for linear
//! fields up to free surfaces): L_i uses B_i ∇_i W_ij and (S5) the duals σ_i B_i/ρ_i² +
//! σ_j B_j/ρ_j², which keeps both conservation laws (the pair term stays antisymmetric). Artificial viscosity (Monaghan & Gingold 1983):
//! Π_ij = (−α c̄ μ_ij + β μ_ij²)/ρ̄_ij for v_ij·x_ij < 0, μ_ij = h v_ij·x_ij/(r² + 0.01h²),
//! c̄, ρ̄ the pair means, c the bulk sound speed of the EOS at the particle's (ρ, e).
//! Artificial stress (Gray, Monaghan & Swift 2001, eqs. 4.5–4.8): in the principal frame of
//! σ_i, R'_aa = −ε σ'_aa/ρ_i² where σ'_aa > 0 (tension) and 0 otherwise, rotated back;
//! f_ij = W(r)/W(Δp) with Δp the lattice spacing, n = 4.
//!
//! As in the fluid continuity, (S1)–(S4) use the pair's separation at the middle of the drift
//! (x_ij − ½dt v_ij), and the update ([`update`]) advances ρ, S and e by dt, returns S to the
//! Johnson–Cook surface, computes p(ρ, e) and applies the failure criteria. Units: SI.

use crate::cells::Neighbours;
use crate::kernel::sizes::PairKernel;
use crate::kernel::Kernel;
use crate::material::strength::{jaumann_rate, radial_return, rate_and_spin, temperature};
use crate::particles::{Particles, Sym};
use crate::physics::Model;
use crate::{Tensor, Vector};
use rayon::prelude::*;

/// Per-step scratch of the solid passes: owned-particle rates and per-particle (owned and
/// ghost) terms computed once rather than per pair. Kept between steps so nothing is
/// allocated in the step loop once the sizes have settled.
#[derive(Clone, Default)]
pub struct SolidScratch<const D: usize> {
    /// [`work_stride`]`(D)` values per particle, holding in turn ([`Holds`]) what two passes
    /// never need at once, as the schedule runs rates → update → momentum:
    /// - the rates pass's results for owned particles until the update reads them: dS/dt
    ///   (Pa/s; symmetric, as the Jaumann rate 2G ε̇' + ΩS − SΩ of a symmetric S is, to the
    ///   bit: (ΩS − SΩ)_ab and _ba add the same two products), its D(D+1)/2 distinct
    ///   components, then de/dt (W/kg) and the equivalent strain rate √(⅔ ε̇_dev:ε̇_dev) (1/s),
    ///   the Johnson–Cook rate;
    /// - the momentum pass's σ_j B_j/ρ_j² of every particle (the corrected stress term of
    ///   eq. S5), a D×D tensor in column order.
    ///
    /// One buffer instead of four: 64 B a particle less in 3D.
    work: Vec<f64>,
    /// What `work` holds now.
    holds: Holds,
    /// Artificial stress R_j of every particle (same units as `sig`): symmetric to the bit
    /// ([`artificial_stress`]), so its D(D+1)/2 distinct components.
    pub(super) rs: Vec<Sym<D>>,
    /// R_j ≠ 0 (a tensile principal stress) for every particle: a pair of two particles
    /// without one skips the artificial-stress term, whose (R_i + R_j) f_ijⁿ is then exactly
    /// zero (most particles of an impact are in compression most of the time).
    pub(super) tensile: Vec<bool>,
    /// Bulk sound speed c_j of every particle (m/s).
    pub(super) c: Vec<f64>,
}

/// The values the scratch holds, not what its shared buffer is holding them for (`holds`):
/// a pass over a part of the particles with none in it changes no value, though the buffer
/// then stands for that pass's results (`sim::step`'s split-pass test compares these).
impl<const D: usize> std::fmt::Debug for SolidScratch<D> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("SolidScratch")
            .field("work", &self.work)
            .field("rs", &self.rs)
            .field("tensile", &self.tensile)
            .field("c", &self.c)
            .finish()
    }
}

/// What [`SolidScratch`]'s shared buffer holds.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub(super) enum Holds {
    /// Nothing yet.
    #[default]
    Nothing,
    /// The rates pass's results for owned particles.
    Rates,
    /// σ_j B_j/ρ_j² of every particle.
    Sig,
}

/// Values per particle of [`SolidScratch`]'s shared buffer: the larger of a D×D tensor (σB/ρ²)
/// and the rates (D(D+1)/2 components of dS/dt, de/dt, the strain rate): 9 in 3D, 5 in 2D.
pub const fn work_stride(d: usize) -> usize {
    let (tensor, rates) = (d * d, d * (d + 1) / 2 + 2);
    if tensor > rates {
        tensor
    } else {
        rates
    }
}

impl<const D: usize> SolidScratch<D> {
    /// Values per particle of the shared buffer.
    const STRIDE: usize = work_stride(D);

    /// Bytes this scratch holds per solid particle once sized (B; the memory estimate): the
    /// shared buffer, a symmetric tensor (R), a scalar (c) and a flag.
    pub const BYTES_PER_PARTICLE: usize = Self::STRIDE * std::mem::size_of::<f64>()
        + std::mem::size_of::<Sym<D>>()
        + std::mem::size_of::<f64>()
        + 1;

    /// Bytes this scratch holds, by capacity.
    pub fn bytes_held(&self) -> usize {
        use crate::cells::held;
        held(&self.work) + held(&self.rs) + held(&self.c) + held(&self.tensile)
    }

    /// Write one particle's rates into its row: dS/dt's upper triangle, de/dt, the strain rate.
    #[inline]
    pub(super) fn put_rates(row: &mut [f64], (ds, de, rate): (Sym<D>, f64, f64)) {
        let mut k = 0;
        for r in 0..D {
            for c in r..D {
                row[k] = ds.get(r, c);
                k += 1;
            }
        }
        row[k] = de;
        row[k + 1] = rate;
    }

    /// Owned particle `i`'s rates (dS/dt, de/dt, strain rate) as the rates pass left them;
    /// zero before any rates pass (the set-up's update at dt = 0).
    #[inline]
    fn rates_at(&self, i: usize) -> (Sym<D>, f64, f64) {
        if self.holds != Holds::Rates {
            return (Sym::default(), 0.0, 0.0);
        }
        let row = &self.work[i * Self::STRIDE..][..Self::STRIDE];
        let mut t = Tensor::<D>::zeros();
        let mut k = 0;
        for r in 0..D {
            for c in r..D {
                t[(r, c)] = row[k];
                k += 1;
            }
        }
        (Sym::from_upper(&t), row[k], row[k + 1])
    }

    /// The rows of the first `n` particles of the shared buffer, which will hold `now`
    /// ([`rows_of`]).
    pub(super) fn rows(&mut self, now: Holds, n: usize) -> &mut [f64] {
        rows_of::<D>(&mut self.work, &mut self.holds, now, n)
    }

    /// σ_j B_j/ρ_j² of every particle, as the momentum pass's [`stress_terms`] left them.
    pub(super) fn sig(&self) -> Sig<'_, D> {
        debug_assert_eq!(
            self.holds,
            Holds::Sig,
            "σB/ρ² read before the momentum pass wrote it"
        );
        Sig(&self.work)
    }
}

/// The rows of the first `n` particles of [`SolidScratch`]'s shared buffer (`work`), which
/// will hold `now`: the rates pass's results (each row filled by [`SolidScratch::put_rates`];
/// a row not filled is not read) or σ_j B_j/ρ_j².
pub(super) fn rows_of<'a, const D: usize>(
    work: &'a mut Vec<f64>,
    holds: &mut Holds,
    now: Holds,
    n: usize,
) -> &'a mut [f64] {
    let len = n * work_stride(D);
    if work.len() < len {
        work.resize(len, 0.0);
    }
    *holds = now;
    &mut work[..len]
}

/// σ_j B_j/ρ_j² of every particle (the corrected stress term of eq. S5), read from
/// [`SolidScratch`]'s shared buffer.
#[derive(Clone, Copy)]
pub(super) struct Sig<'a, const D: usize>(&'a [f64]);

impl<const D: usize> Sig<'_, D> {
    /// Particle `j`'s σ_j B_j/ρ_j².
    #[inline(always)]
    pub(super) fn at(&self, j: usize) -> Tensor<D> {
        Tensor::<D>::from_column_slice(&self.0[j * work_stride(D)..][..D * D])
    }
}

/// The artificial stress R_j of every particle and whether it is non-zero
/// ([`SolidScratch`]'s `rs` and `tensile`).
pub(super) type Artificial<'a, const D: usize> = (&'a [Sym<D>], &'a [bool]);

/// The artificial-viscosity constants of a pass.
#[derive(Clone, Copy)]
pub(super) struct Viscosity {
    alpha: f64,
    beta: f64,
    h: f64,
    eta2: f64,
    /// Particles of several sizes: h and η² are the pair kernel's.
    sized: bool,
}

impl Viscosity {
    pub(super) fn of<const D: usize>(model: &Model<D>) -> Self {
        let h = model.kernel.h;
        Viscosity {
            alpha: model.alpha,
            beta: model.beta,
            h,
            eta2: 0.01 * h * h,
            sized: model.varying().is_some(),
        }
    }

    /// Π_ij (m⁵ kg⁻¹ s⁻²) for a pair approaching (v_ij·x_ij < 0), else 0; `k` is the pair's
    /// kernel (its h is the pair's mean where particles have several sizes).
    #[inline(always)]
    #[allow(clippy::too_many_arguments)]
    pub(super) fn pi(&self, k: &Kernel, vx: f64, r2: f64, ci: f64, cj: f64, rhoi: f64, rhoj: f64) -> f64 {
        if vx >= 0.0 {
            return 0.0;
        }
        let (h, eta2) = if self.sized {
            (k.h, 0.01 * k.h * k.h)
        } else {
            (self.h, self.eta2)
        };
        let mu = h * vx / (r2 + eta2);
        (-self.alpha * 0.5 * (ci + cj) * mu + self.beta * mu * mu) / (0.5 * (rhoi + rhoj))
    }
}

/// ½(T + Tᵀ): exactly symmetric (float addition commutes, so both off-diagonal entries get
/// the same bits).
#[inline]
fn symmetric<const D: usize>(t: &Tensor<D>) -> Tensor<D> {
    Tensor::<D>::from_fn(|a, b| 0.5 * (t[(a, b)] + t[(b, a)]))
}

/// Bulk sound speed of every solid particle (owned and ghost) into `scratch.c`.
pub(super) fn sound_speeds<const D: usize>(p: &Particles<D>, model: &Model<D>, c: &mut Vec<f64>) {
    c.resize(p.len(), 0.0);
    c.par_iter_mut().enumerate().for_each(|(j, c)| {
        *c = match model.materials[p.mat[j] as usize].solid() {
            Some(s) if p.kind[j].is_solid() => s.eos.sound_speed(p.rho[j], p.energy[j]),
            _ => 0.0,
        }
    });
}

/// Correction pass: B_i = M_i⁻¹, M_i = −(1/ρ_i) Σ_j m_j x_ij ⊗ ∇_i W_ij over solid neighbours,
/// for every owned solid particle at the current positions (the identity where M is
/// singular: an isolated particle or a line of them).
pub fn correction<const D: usize, N: Neighbours>(p: &mut Particles<D>, nl: &N, model: &Model<D>) {
    let n = p.n_owned;
    let mut out = std::mem::take(&mut p.correction);
    {
        let p = &*p;
        crate::with_pair_kernel!(model.varying(), model.kernel, D, kern => {
            out[..n].par_iter_mut().enumerate().for_each(|(i, b)| {
                if !p.kind[i].is_solid() || !nl.visits(i) {
                    return;
                }
                let xi = p.x[i];
                let mut m = Tensor::<D>::zeros();
                for j in nl.iter(i) {
                    let j = j as usize;
                    if !p.kind[j].is_solid() {
                        continue;
                    }
                    let xij = xi - p.x[j];
                    let f = kern.of(&p.h, i, j).dw_dr_over_r(xij.norm());
                    m += (xij * xij.transpose()) * (p.mass[j] * f);
                }
                *b = Sym::from_upper(&inverse_moment(m, p.rho[i]));
            })
        });
    }
    p.correction = out;
}

/// B = M⁻¹ from the sum Σ_j m_j x_ij ⊗ ∇_i W_ij (`sum`) and ρ_i (kg/m³): M = −sum/ρ_i; the
/// identity where M is singular or ill-conditioned.
pub(super) fn inverse_moment<const D: usize>(sum: Tensor<D>, rho: f64) -> Tensor<D> {
    let m = sum * (-1.0 / rho);
    // a well-conditioned M only: sparse neighbourhoods (a correction of more than 10×) keep the
    // plain gradient; symmetric to the last bit: ghosts receive the upper triangle only
    match m.try_inverse() {
        Some(inv) if inv.amax() <= 10.0 => symmetric(&inv),
        _ => Tensor::identity(),
    }
}

/// Rates pass: dρ/dt into `p.drho`, dS/dt, de/dt and the equivalent strain rate into
/// `scratch`, for every owned solid particle (zero for the others), eqs. (S1)–(S4), at the
/// mid-drift separation for a step of `dt` (s; 0 at the set-up).
pub fn rates<const D: usize, N: Neighbours>(
    p: &mut Particles<D>,
    nl: &N,
    model: &Model<D>,
    dt: f64,
    scratch: &mut SolidScratch<D>,
) {
    let n = p.n_owned;
    sound_speeds(p, model, &mut scratch.c);
    if model.artificial_stress > 0.0 {
        stress_terms(p, model, scratch, false);
    }
    let mut drho = std::mem::take(&mut p.drho);
    {
        let p = &*p;
        let SolidScratch {
            work,
            holds,
            c,
            rs,
            tensile,
        } = scratch;
        let rows = rows_of::<D>(work, holds, Holds::Rates, n);
        let (c, rs) = (&c[..], (&rs[..], &tensile[..]));
        let visc = Viscosity::of(model);
        let half_dt = 0.5 * dt;
        crate::with_pair_kernel!(model.varying(), model.kernel, D, kern => {
            drho[..n]
                .par_iter_mut()
                .zip(rows.par_chunks_mut(SolidScratch::<D>::STRIDE))
                .enumerate()
                .for_each(|(i, (dr, row))| {
                    // a fluid particle keeps the continuity pass's dρ/dt (a scene may hold both)
                    if nl.visits(i) && p.kind[i].is_solid() {
                        let (div, ds, de, rate) = rates_of(p, nl, model, kern, (c, rs), &visc, half_dt, i);
                        *dr = div;
                        SolidScratch::<D>::put_rates(row, (ds, de, rate));
                    }
                })
        });
    }
    p.drho = drho;
}

/// (S1)–(S4) for owned particle `i`: (dρ/dt, dS/dt, de/dt, equivalent strain rate).
#[inline]
#[allow(clippy::too_many_arguments)]
fn rates_of<const D: usize, N: Neighbours, K: PairKernel>(
    p: &Particles<D>,
    nl: &N,
    model: &Model<D>,
    kern: K,
    (c, (rs, tensile)): (&[f64], Artificial<'_, D>),
    visc: &Viscosity,
    half_dt: f64,
    i: usize,
) -> (f64, Sym<D>, f64, f64) {
    let (xi, vi, rhoi) = (p.x[i], p.v[i], p.rho[i]);
    let mut grad = Tensor::<D>::zeros(); // Σ m_j v_ij ⊗ ∇W
    let mut visc_work = 0.0; // Σ m_j Π_ij v_ij·∇W
    let mut stress_work = 0.0; // Σ m_j v_ij·(R_i + R_j) f_ijⁿ ∇W
    let stress_art = model.artificial_stress > 0.0;
    let w_dp = model.kernel.w(model.dx);
    for j in nl.iter(i) {
        let j = j as usize;
        if !p.kind[j].is_solid() {
            continue;
        }
        let xij = xi - p.x[j];
        let vij = vi - p.v[j];
        let mid = xij - vij * half_dt;
        let r2 = mid.norm_squared();
        let k = kern.of(&p.h, i, j);
        let gw = mid * k.dw_dr_over_r(r2.sqrt());
        let mj = p.mass[j];
        grad += (vij * mj) * gw.transpose();
        let pi = visc.pi(&k, vij.dot(&mid), r2, c[i], c[j], rhoi, p.rho[j]);
        visc_work += mj * pi * vij.dot(&gw);
        if stress_art && (tensile[i] || tensile[j]) {
            let fn4 = model.artificial_factor(p, i, j, &k, r2.sqrt(), w_dp);
            stress_work += mj * fn4 * vij.dot(&((rs[i] + rs[j]).tensor() * gw));
        }
    }
    rates_from(p, model, i, grad, visc_work, stress_work)
}

/// (S1)–(S4) for owned particle `i` from its sums Σ_j m_j v_ij ⊗ ∇_i W_ij (`grad`), Σ_j m_j
/// Π_ij v_ij·∇_i W_ij (`visc_work`) and Σ_j m_j v_ij·(R_i + R_j) f_ijⁿ ∇_i W_ij
/// (`stress_work`): (dρ/dt, dS/dt, de/dt, equivalent strain rate); zero for a particle of a
/// material without a solid's law.
pub(super) fn rates_from<const D: usize>(
    p: &Particles<D>,
    model: &Model<D>,
    i: usize,
    grad: Tensor<D>,
    visc_work: f64,
    stress_work: f64,
) -> (f64, Sym<D>, f64, f64) {
    let Some(solid) = model.materials[p.mat[i] as usize].solid() else {
        return (0.0, Sym::default(), 0.0, 0.0);
    };
    let rhoi = p.rho[i];
    let l = grad * p.correction[i].tensor() * (-1.0 / rhoi);
    let div = -rhoi * l.trace();
    let (eps, _) = rate_and_spin(&l);
    let s = p.stress[i].tensor();
    let failed = p.failed[i] != 0;
    let ds = if failed {
        Sym::default()
    } else {
        Sym::from_upper(&jaumann_rate(&s, &l, solid.shear))
    };
    let dev = eps - Tensor::<D>::identity() * (eps.trace() / 3.0);
    // plane strain: ε̇_zz = 0, so the deviator has −tr/3 out of plane too
    let out_of_plane = if D == 2 { eps.trace() / 3.0 } else { 0.0 };
    let rate = ((2.0 / 3.0) * (dev.component_mul(&dev).sum() + out_of_plane * out_of_plane)).sqrt();
    let de =
        (p.p[i] / (rhoi * rhoi)) * div + s.component_mul(&eps).sum() / rhoi + 0.5 * (visc_work - stress_work);
    (div, ds, de, rate)
}

/// Update pass (no neighbours) for every owned solid particle: ρ ← ρ exp(dt (dρ/dt)/ρ), e += dt de/dt,
/// S += dt dS/dt; radial return to the Johnson–Cook surface at the particle's plastic strain,
/// strain rate and temperature (T = T_room + e/c_v), adding the plastic strain; p = p(ρ, e);
/// then the failure criteria: a failed particle keeps S = 0 and p ≥ 0.
pub fn update<const D: usize>(p: &mut Particles<D>, model: &Model<D>, dt: f64, scratch: &SolidScratch<D>) {
    let n = p.n_owned;
    let kind = &p.kind[..n];
    let mat = &p.mat[..n];
    let drho = &p.drho[..n];
    let mass = &p.mass[..n];
    let w0 = model.kernel.w(0.0);
    let own_h = &p.h;
    let mut out = std::mem::take(&mut p.stress);
    p.rho[..n]
        .par_iter_mut()
        .zip(p.p[..n].par_iter_mut())
        .zip(out[..n].par_iter_mut())
        .zip(
            p.energy[..n]
                .par_iter_mut()
                .zip(p.plastic[..n].par_iter_mut())
                .zip(p.failed[..n].par_iter_mut()),
        )
        .enumerate()
        .for_each(|(i, (((rho, pr), s), ((e, eps_p), failed)))| {
            if !kind[i].is_solid() {
                return;
            }
            let Some(solid) = model.materials[mat[i] as usize].solid() else {
                return;
            };
            let mut st = s.tensor();
            let (ds, de, rate) = scratch.rates_at(i);
            if dt > 0.0 {
                // d ln ρ/dt = −tr L integrated exactly over the step: the same to first order
                // as ρ += dt dρ/dt, and positive however fast a fragment expands (an explicit
                // update took a debris particle to ρ < 0 in the oblique impact)
                *rho *= (dt * drho[i] / *rho).exp();
                // never below the particle's own kernel contribution m W(0), the density an
                // isolated particle has by summation: a receding pair of debris particles
                // otherwise drives its continuity density to 0 (L ∝ 1/ρ) and the run to NaN
                let w0 = match model.varying() {
                    None => w0,
                    Some(z) => z.kernel::<D>(own_h[i], own_h[i]).w(0.0),
                };
                *rho = rho.max(mass[i] * w0);
                *e += dt * de;
                // the Jaumann rate is symmetric only up to rounding: keep S symmetric to the
                // last bit, as ghosts receive its upper triangle
                st = symmetric(&(st + ds.tensor() * dt));
            }
            if *failed != 0 {
                st = Tensor::zeros();
            } else if let Some(jc) = &solid.strength {
                let t = temperature(*e, solid.specific_heat, solid.t_room);
                let y = jc.flow_stress(*eps_p, rate, t);
                *eps_p += radial_return(&mut st, y, solid.shear);
            }
            *pr = solid.eos.pressure(*rho, *e);
            if let Some(f) = &solid.failure {
                if *failed == 0 && f.fails(*eps_p, *pr) {
                    *failed = 1;
                    st = Tensor::zeros();
                }
            }
            if *failed != 0 {
                *pr = pr.max(0.0);
            }
            // exactly symmetric (the sum above is made so, the return scales it): its upper
            // triangle is the whole
            *s = Sym::from_upper(&st);
        });
    p.stress = out;
}

/// Momentum pass: `p.acc` of every owned solid particle, eq. (S5), from the current state.
pub fn momentum<const D: usize, N: Neighbours>(
    p: &mut Particles<D>,
    nl: &N,
    model: &Model<D>,
    scratch: &mut SolidScratch<D>,
) {
    let n = p.n_owned;
    sound_speeds(p, model, &mut scratch.c);
    stress_terms(p, model, scratch, true);
    let w_dp = model.kernel.w(model.dx);
    let mut acc = std::mem::take(&mut p.acc);
    {
        let p = &*p;
        let visc = Viscosity::of(model);
        let (sig, rs, c) = (
            scratch.sig(),
            (&scratch.rs[..], &scratch.tensile[..]),
            &scratch.c[..],
        );
        crate::with_pair_kernel!(model.varying(), model.kernel, D, kern => {
            acc[..n].par_iter_mut().enumerate().for_each(|(i, a)| {
                if p.kind[i].is_solid() && nl.visits(i) {
                    *a = momentum_of(p, nl, model, kern, &visc, (sig, rs, c), w_dp, i);
                }
            })
        });
    }
    p.acc = acc;
}

/// σ_j B_j/ρ_j² (with `with_sig`) and the artificial stress R_j of every solid particle (owned
/// and ghost), once per particle rather than per pair.
pub(super) fn stress_terms<const D: usize>(
    p: &Particles<D>,
    model: &Model<D>,
    scratch: &mut SolidScratch<D>,
    with_sig: bool,
) {
    let eps = model.artificial_stress;
    let total = |j: usize| p.stress[j].tensor() - Tensor::<D>::identity() * p.p[j];
    let SolidScratch {
        work,
        holds,
        rs,
        tensile,
        ..
    } = scratch;
    if with_sig {
        // σ_j B_j/ρ_j² once per particle, not a matrix product per pair
        let rows = rows_of::<D>(work, holds, Holds::Sig, p.len());
        rows.par_chunks_mut(SolidScratch::<D>::STRIDE)
            .enumerate()
            .for_each(|(j, row)| {
                if p.kind[j].is_solid() {
                    let sig = (total(j) / (p.rho[j] * p.rho[j])) * p.correction[j].tensor();
                    row[..D * D].copy_from_slice(sig.as_slice());
                }
            });
    }
    rs.resize(p.len(), Sym::default());
    tensile.resize(p.len(), false);
    rs.par_iter_mut()
        .zip(tensile.par_iter_mut())
        .enumerate()
        .for_each(|(j, (rs, tensile))| {
            if !p.kind[j].is_solid() {
                *tensile = false;
                return;
            }
            *rs = if eps > 0.0 {
                Sym::from_upper(&artificial_stress(&total(j), eps / (p.rho[j] * p.rho[j])))
            } else {
                Sym::default()
            };
            *tensile = *rs != Sym::default();
        });
}

/// Eq. (S5) for owned solid particle `i`.
#[inline]
#[allow(clippy::too_many_arguments)]
fn momentum_of<const D: usize, N: Neighbours, K: PairKernel>(
    p: &Particles<D>,
    nl: &N,
    model: &Model<D>,
    kern: K,
    visc: &Viscosity,
    (sig, (rs, tensile), c): (Sig<'_, D>, Artificial<'_, D>, &[f64]),
    w_dp: f64,
    i: usize,
) -> Vector<D> {
    let (xi, vi, rhoi) = (p.x[i], p.v[i], p.rho[i]);
    let stress_art = model.artificial_stress > 0.0;
    let sig_bi = sig.at(i);
    let mut a = Vector::<D>::zeros();
    for j in nl.iter(i) {
        let j = j as usize;
        if !p.kind[j].is_solid() {
            continue;
        }
        let xij = xi - p.x[j];
        let r2 = xij.norm_squared();
        let r = r2.sqrt();
        let k = kern.of(&p.h, i, j);
        let gw = xij * k.dw_dr_over_r(r);
        let vij = vi - p.v[j];
        let pi = visc.pi(&k, vij.dot(&xij), r2, c[i], c[j], rhoi, p.rho[j]);
        // corrected stress terms (the duals of the corrected velocity gradient), plain
        // viscosity and artificial stress
        let mut t = sig_bi + sig.at(j) - Tensor::<D>::identity() * pi;
        if stress_art && (tensile[i] || tensile[j]) {
            t += (rs[i] + rs[j]).tensor() * model.artificial_factor(p, i, j, &k, r, w_dp);
        }
        a += (t * gw) * p.mass[j];
    }
    a + model.g
}

/// Artificial stress R (Gray, Monaghan & Swift 2001): in the principal frame of σ, each
/// tensile principal stress σ'_aa > 0 gives R'_aa = −`eps_rho2` σ'_aa (`eps_rho2` = ε/ρ²),
/// compressive ones 0; rotated back (R in Pa·m³/kg² when σ is in Pa). In closed form in 2D
/// ([`artificial_stress_2d`]) and 3D ([`artificial_stress_3d`]); [`artificial_stress_eigen`]
/// is the eigen-decomposition they are tested against. Deterministic for a given tensor.
pub fn artificial_stress<const D: usize>(sigma: &Tensor<D>, eps_rho2: f64) -> Tensor<D> {
    // Gershgorin: every eigenvalue lies within a disc σ_aa ± Σ_b≠a |σ_ab|; with all discs at
    // or below zero no principal stress is tensile and the decomposition is skipped
    let tensile = (0..D).any(|a| {
        let off: f64 = (0..D).filter(|&b| b != a).map(|b| sigma[(a, b)].abs()).sum();
        sigma[(a, a)] + off > 0.0
    });
    if !tensile {
        return Tensor::zeros();
    }
    if D == 2 {
        let r = artificial_stress_2d([sigma[(0, 0)], sigma[(0, 1)], sigma[(1, 1)]], eps_rho2);
        return Tensor::<D>::from_fn(|a, b| r[a + b]);
    }
    if D == 3 {
        let s = nalgebra::Matrix3::<f64>::from_fn(|a, b| sigma[(a, b)]);
        let r = artificial_stress_3d(&s, eps_rho2);
        return Tensor::<D>::from_fn(|a, b| r[(a, b)]);
    }
    artificial_stress_eigen(sigma, eps_rho2)
}

/// The eigenvalues λ1 ≥ λ2 ≥ λ3 of a symmetric 3×3 tensor, in closed form (Smith 1961): with
/// q = tr σ/3, p² = |σ − qI|²/6 and r = det((σ − qI)/p)/2 ∈ [−1, 1], φ = arccos(r)/3,
/// λ1 = q + 2p cos φ, λ3 = q + 2p cos(φ + 2π/3), λ2 = 3q − λ1 − λ3.
pub fn principal_3d(s: &nalgebra::Matrix3<f64>) -> [f64; 3] {
    let q = s.trace() / 3.0;
    let off = s[(0, 1)] * s[(0, 1)] + s[(0, 2)] * s[(0, 2)] + s[(1, 2)] * s[(1, 2)];
    let (a, b, c) = (s[(0, 0)] - q, s[(1, 1)] - q, s[(2, 2)] - q);
    let p2 = (a * a + b * b + c * c + 2.0 * off) / 6.0;
    if p2 <= 0.0 {
        return [q; 3];
    }
    let p = p2.sqrt();
    let m = (s - nalgebra::Matrix3::identity() * q) / p;
    let r = (0.5 * m.determinant()).clamp(-1.0, 1.0);
    let phi = r.acos() / 3.0;
    let l1 = q + 2.0 * p * phi.cos();
    let l3 = q + 2.0 * p * (phi + 2.0 * std::f64::consts::FRAC_PI_3).cos();
    [l1, 3.0 * q - l1 - l3, l3]
}

/// [`artificial_stress`] of a 3D tensor without an eigen-decomposition. With the principal
/// stresses λ1 ≥ λ2 ≥ λ3 ([`principal_3d`]) and Sylvester's projectors
/// P_k = Π_{m≠k} (σ − λ_m I)/(λ_k − λ_m):
/// - all three tensile: R = −ε/ρ² σ; none: 0;
/// - λ1 alone: R = −ε/ρ² λ1 P1, whose denominator (λ1 − λ2)(λ1 − λ3) ≥ λ1² > 0;
/// - λ1 and λ2: R = −ε/ρ² (σ − λ3 P3), whose denominator (λ1 − λ3)(λ2 − λ3) ≥ λ1 λ2 > 0.
///
/// The split at zero separates the eigenvalues it divides by, so repeated principal stresses
/// need no special case, and R depends on a repeated pair only through its sum and product,
/// which the closed form gives to round-off (the pair's members only to √ε|σ|). So R agrees
/// with the decomposition's to round-off of |σ|·ε/ρ², except where a tensile and a
/// compressive principal stress lie within √ε|σ| of each other: there the closed form may put
/// both on one side of zero, and R (continuous in σ, of their size) differs by up to about
/// 10⁻⁸|σ|·ε/ρ². Symmetric to the last bit.
pub fn artificial_stress_3d(s: &nalgebra::Matrix3<f64>, eps_rho2: f64) -> nalgebra::Matrix3<f64> {
    let [l1, l2, l3] = principal_3d(s);
    let id = nalgebra::Matrix3::<f64>::identity();
    let r = if l3 > 0.0 {
        *s * -eps_rho2
    } else if l1 <= 0.0 {
        return nalgebra::Matrix3::zeros();
    } else if l2 <= 0.0 {
        let p1 = (s - id * l2) * (s - id * l3) / ((l1 - l2) * (l1 - l3));
        p1 * (-eps_rho2 * l1)
    } else {
        let p3 = (s - id * l1) * (s - id * l2) / ((l3 - l1) * (l3 - l2));
        (s - p3 * l3) * -eps_rho2
    };
    nalgebra::Matrix3::from_fn(|a, b| 0.5 * (r[(a, b)] + r[(b, a)]))
}

/// [`artificial_stress`] of the 2D tensor [[a, b], [b, c]] = `[a, b, c]`, returned the same
/// way. Principal stresses λ± = (a + c)/2 ± √(((a − c)/2)² + b²); with both tensile R = −ε/ρ² σ,
/// with λ+ alone R = −ε/ρ² λ+ (σ − λ− I)/(λ+ − λ−) (the projector on λ+'s axis; λ+ − λ− ≥
/// λ+ > 0), with neither 0. It replaces a 3×3 eigen-decomposition per particle and step,
/// 14 % of the oscillating plate's run.
pub fn artificial_stress_2d([a, b, c]: [f64; 3], eps_rho2: f64) -> [f64; 3] {
    let mean = 0.5 * (a + c);
    let rad = (0.5 * (a - c)).hypot(b);
    let (hi, lo) = (mean + rad, mean - rad);
    if lo > 0.0 {
        return [-eps_rho2 * a, -eps_rho2 * b, -eps_rho2 * c];
    }
    if hi <= 0.0 {
        return [0.0; 3];
    }
    let f = -eps_rho2 * hi / (hi - lo);
    [f * (a - lo), f * b, f * (c - lo)]
}

/// [`artificial_stress`] through nalgebra's symmetric eigen-decomposition of σ embedded in
/// 3×3 (a 2D tensor gets a zero z row and column, whose eigenvalue 0 adds nothing).
pub fn artificial_stress_eigen<const D: usize>(sigma: &Tensor<D>, eps_rho2: f64) -> Tensor<D> {
    let mut m = nalgebra::Matrix3::<f64>::zeros();
    for a in 0..D {
        for b in 0..D {
            m[(a, b)] = sigma[(a, b)];
        }
    }
    let eig = m.symmetric_eigen();
    let mut r = nalgebra::Matrix3::<f64>::zeros();
    for a in 0..3 {
        let l = eig.eigenvalues[a];
        if l > 0.0 {
            let q = eig.eigenvectors.column(a);
            r += (q * q.transpose()) * (-eps_rho2 * l);
        }
    }
    Tensor::<D>::from_fn(|a, b| r[(a, b)])
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn artificial_stress_acts_on_tension_only_and_in_its_principal_frame() {
        // σ = diag(+2, −3) rotated by 30°: R = −ε/ρ² · 2 q qᵀ along the tensile axis
        let th: f64 = 30f64.to_radians();
        let q = nalgebra::Matrix2::new(th.cos(), -th.sin(), th.sin(), th.cos());
        let s = q * nalgebra::Matrix2::new(2.0, 0.0, 0.0, -3.0) * q.transpose();
        let r = artificial_stress::<2>(&s, 0.5);
        let axis = q.column(0);
        let want = (axis * axis.transpose()) * (-0.5 * 2.0);
        assert!((r - want).abs().max() < 1e-12, "{r} vs {want}");
        // pure compression: no artificial stress
        let c = nalgebra::Matrix3::new(-1.0, 0.2, 0.0, 0.2, -2.0, 0.1, 0.0, 0.1, -0.5);
        assert_eq!(artificial_stress::<3>(&c, 0.3), Tensor::<3>::zeros());
    }

    #[test]
    fn the_2d_closed_form_equals_the_eigen_decomposition() {
        // both tensile, one, neither, equal principal stresses, pure shear, zero
        let cases = [
            [3.0e6, 1.0e6, 2.0e6],
            [2.0e5, -4.0e5, -1.0e6],
            [-1.0, 0.3, -2.0],
            [5.0, 0.0, 5.0],
            [-5.0, 0.0, -5.0],
            [0.0, 7.0, 0.0],
            [1.0e-3, 2.0e-3, -4.0e6],
            [0.0, 0.0, 0.0],
        ];
        for [a, b, c] in cases {
            let s = nalgebra::Matrix2::new(a, b, b, c);
            let want = artificial_stress_eigen::<2>(&s, 0.3);
            let got = artificial_stress::<2>(&s, 0.3);
            let scale = s.abs().max().max(1e-300);
            assert!((got - want).abs().max() <= 1e-13 * scale, "{s}: {got} vs {want}");
            assert_eq!(got, got.transpose());
        }
    }

    /// The 3D closed form against the decomposition: every sign pattern of the principal
    /// stresses, repeated and zero ones, in frames from a fixed sequence of rotations, and
    /// stresses at the scale of the impact's (GPa).
    #[test]
    fn the_3d_closed_form_equals_the_eigen_decomposition() {
        let frames = (0..24).map(|k| {
            let k = f64::from(k);
            nalgebra::Rotation3::from_euler_angles(0.37 * k, 1.1 * k + 0.2, -0.53 * k).into_inner()
        });
        let diagonals = [
            [3.0, 2.0, 1.0],
            [3.0, 2.0, -1.0],
            [3.0, -2.0, -1.0],
            [-3.0, -2.0, -1.0],
            [2.0, 2.0, -1.0],
            [2.0, -1.0, -1.0],
            [1.0, 1.0, 1.0],
            [-1.0, -1.0, -1.0],
            [1.0, 0.0, -1.0],
            [1.0, 0.0, 0.0],
            [0.0, 0.0, -1.0],
            [1.0, 1e-9, -1.0],
            [1e-9, -1e-9, -1.0],
            [0.0, 0.0, 0.0],
        ];
        for (q, d) in frames.zip(diagonals.iter().cycle()) {
            for scale in [1.0, 3.0e9] {
                let s = q
                    * nalgebra::Matrix3::from_diagonal(&nalgebra::Vector3::from(*d))
                    * q.transpose()
                    * scale;
                // exactly symmetric, as the particles' stresses are
                let s = nalgebra::Matrix3::from_fn(|a, b| 0.5 * (s[(a, b)] + s[(b, a)]));
                let l = principal_3d(&s);
                let mut want_l = *d;
                want_l.sort_by(|a, b| b.total_cmp(a));
                // a repeated eigenvalue comes out to √ε (the arc cosine's slope at ±1), the
                // sum of a repeated pair and every other one to round-off; R depends on a
                // repeated pair only through its sum and product, so it is at round-off
                for k in 0..3 {
                    assert!((l[k] - want_l[k] * scale).abs() <= 1e-7 * scale, "{d:?}: {l:?}");
                }
                assert!((l.iter().sum::<f64>() - d.iter().sum::<f64>() * scale).abs() <= 1e-14 * scale);
                let want = artificial_stress_eigen::<3>(&s, 0.3);
                let got = artificial_stress::<3>(&s, 0.3);
                // round-off, except where a tensile and a compressive principal stress lie
                // within √ε|σ| of each other: then the √ε of the pair's eigenvalues decides
                // which side of zero they fall, and R (continuous, of their size) moves by as much
                let straddles =
                    (0..3).any(|a| (0..3).any(|b| d[a] > 0.0 && d[b] <= 0.0 && d[a] - d[b] < 1e-6));
                let tol = if straddles { 1e-8 } else { 1e-13 };
                assert!((got - want).abs().max() <= tol * scale, "{d:?}: {got} vs {want}");
                assert_eq!(got, got.transpose());
            }
        }
    }

    #[test]
    fn viscosity_is_zero_for_receding_pairs_and_matches_the_formula_for_approaching() {
        let k = Kernel::new(crate::kernel::KernelKind::WendlandC2, 0.1, 3);
        for sized in [false, true] {
            // with particles of several sizes h and η² come from the pair's kernel (h = 0.1)
            let v = Viscosity {
                alpha: 1.0,
                beta: 2.0,
                h: if sized { 7.0 } else { 0.1 },
                eta2: 1e-4,
                sized,
            };
            assert_eq!(v.pi(&k, 0.5, 0.01, 10.0, 10.0, 1.0, 1.0), 0.0);
            let mu = 0.1 * -0.5 / (0.01 + 1e-4);
            let want = -10.0 * mu + 2.0 * mu * mu;
            assert!((v.pi(&k, -0.5, 0.01, 8.0, 12.0, 0.5, 1.5) - want).abs() < 1e-12);
        }
    }
}

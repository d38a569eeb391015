//! Solids in pair mode (`[performance] interactions = "pairs"`): the correction, rates and
//! momentum passes of [`super::dynamics`] visit each pair of solid particles once, over the
//! canonical half lists of [`crate::cells::HalfPairs`] (a solid's partners are solids), and
//! give both particles their share. A solid then stores half a list (or none with
//! `neighbours = "cells"`) and each pair's kernel is evaluated once.
//!
//! With x_ab = x_a − x_b, v_ab = v_a − v_b and F_ab = (1/r) dW/dr, symmetric in the pair,
//! ∇_a W_ab = F_ab x_ab = −∇_b W_ba. Each pass computes one pair term and hands it to both:
//! - correction: x_ab ⊗ ∇_a W_ab = x_ba ⊗ ∇_b W_ba (two signs flip), so a adds m_b F x_ab ⊗ x_ab
//!   and b adds m_a times the same; M = −sum/ρ and B = M⁻¹ per particle afterwards
//!   ([`dynamics::inverse_moment`]);
//! - rates (S1)–(S4): v_ab ⊗ ∇_a W_ab, Π_ab v_ab·∇_a W_ab and v_ab·(R_a + R_b) f_abⁿ ∇_a W_ab are
//!   even in the pair for the same reason (Π and R_a + R_b are symmetric in it, to the bit:
//!   each is a sum or product of the two sides' values in either order), so each side adds
//!   its partner's mass times them; B_a, 1/ρ_a and the constitutive rates follow per particle
//!   ([`dynamics::rates_from`], as in gather mode);
//! - momentum (S5): T_ab = σ_a B_a/ρ_a² + σ_b B_b/ρ_b² − Π_ab I + (R_a + R_b) f_abⁿ is symmetric
//!   in the pair, so a adds m_b T ∇_a W_ab and b adds −m_a T ∇_a W_ab: momentum is conserved to
//!   round-off.
//!
//! The schedule is [`crate::cells::HalfView::run`]'s (no locks, no atomics): the same bits on
//! any number of ranks and threads; they differ from gather mode's by the order of the sums.
//! As in gather mode, the rates use the mid-drift separation x_ab − ½ dt v_ab, and pairs of
//! Verlet lists beyond the support add exact zeros (every term carries F).

use super::dynamics::{self, work_stride, Holds, Sig, SolidScratch, Viscosity};
use crate::cells::{HalfView, Window};
use crate::kernel::sizes::PairKernel;
use crate::particles::{Particles, Sym};
use crate::physics::batch::{batched, slot_of};
use crate::physics::pairs::{run_homes, Home, PairScratch};
use crate::physics::Model;
use crate::{Tensor, Vector};
use rayon::prelude::*;

/// Add `m` times the D×D tensor `t` to the first D² values of `out` (column-major, as
/// nalgebra stores it).
#[inline(always)]
fn add_tensor<const D: usize>(out: &mut [f64], t: &Tensor<D>, m: f64) {
    for (o, x) in out.iter_mut().zip(t.iter()) {
        *o += x * m;
    }
}

/// The D×D tensor in the first D² values of `acc`.
#[inline(always)]
fn tensor_at<const D: usize>(acc: &[f64]) -> Tensor<D> {
    Tensor::<D>::from_column_slice(&acc[..D * D])
}

/// The correction pass in pair mode: `p.correction` of every owned solid particle, as
/// [`dynamics::correction`].
pub fn correction<const D: usize>(
    p: &mut Particles<D>,
    half: &HalfView<'_, D>,
    model: &Model<D>,
    s: &mut PairScratch<D>,
) {
    crate::with_pair_kernel!(model.varying(), model.kernel, D, k => {
        let pass = Correction { kern: k, p: &*p, half };
        run_homes(half, s.flat(), D * D, 0.0, true, &pass);
    });
    let n = p.n_owned;
    let mut out = std::mem::take(&mut p.correction);
    {
        let (acc, p) = (&*s.flat(), &*p);
        out[..n].par_iter_mut().enumerate().for_each(|(i, b)| {
            if p.kind[i].is_solid() {
                let sum = tensor_at::<D>(&acc[half.entry(i) * D * D..]);
                *b = Sym::from_upper(&dynamics::inverse_moment(sum, p.rho[i]));
            }
        });
    }
    p.correction = out;
}

/// The correction pass's inputs.
struct Correction<'a, 'h, const D: usize, K> {
    kern: K,
    p: &'a Particles<D>,
    half: &'a HalfView<'h, D>,
}

impl<const D: usize, K: PairKernel> Home<f64> for Correction<'_, '_, D, K> {
    #[inline]
    fn home<I: Iterator<Item = u32>>(&self, k: usize, w: &mut Window<'_, f64>, partners: I) {
        let p = self.p;
        let order = self.half.order();
        let a = order[k] as usize;
        let xa = p.x[a];
        let mut sum = Tensor::<D>::zeros();
        batched(
            &self.kern,
            &p.h,
            a,
            partners,
            slot_of(order),
            |b| (xa - p.x[b]).norm_squared(),
            |t, b, f| {
                let xab = xa - p.x[b];
                let outer = (xab * xab.transpose()) * f;
                sum += outer * p.mass[b];
                add_tensor(w.at(t), &outer, p.mass[a]);
            },
        );
        add_tensor(w.at(k), &sum, 1.0);
    }
}

/// Values per solid slot of the rates pass: Σ m v ⊗ ∇W (D²), the viscous work and the
/// artificial stress's work.
const fn rates_stride(d: usize) -> usize {
    d * d + 2
}

/// The rates pass in pair mode: dρ/dt into `p.drho`, dS/dt, de/dt and the equivalent strain
/// rate into `scratch`, for every owned solid particle, as [`dynamics::rates`].
pub fn rates<const D: usize>(
    p: &mut Particles<D>,
    half: &HalfView<'_, D>,
    model: &Model<D>,
    dt: f64,
    scratch: &mut SolidScratch<D>,
    s: &mut PairScratch<D>,
) {
    let n = p.n_owned;
    dynamics::sound_speeds(p, model, &mut scratch.c);
    if model.artificial_stress > 0.0 {
        dynamics::stress_terms(p, model, scratch, false);
    }
    let stride = rates_stride(D);
    crate::with_pair_kernel!(model.varying(), model.kernel, D, k => {
        let pass = Rates {
            kern: k,
            p: &*p,
            half,
            model,
            c: &scratch.c,
            rs: &scratch.rs,
            tensile: &scratch.tensile,
            visc: Viscosity::of(model),
            half_dt: 0.5 * dt,
        };
        run_homes(half, s.flat(), stride, 0.0, true, &pass);
    });
    let mut drho = std::mem::take(&mut p.drho);
    {
        let (acc, p) = (&*s.flat(), &*p);
        let rows = scratch.rows(Holds::Rates, n);
        drho[..n]
            .par_iter_mut()
            .zip(rows.par_chunks_mut(work_stride(D)))
            .enumerate()
            .for_each(|(i, (dr, row))| {
                // a fluid particle keeps the continuity pass's dρ/dt
                if p.kind[i].is_solid() {
                    let v = &acc[half.entry(i) * stride..][..stride];
                    let grad = tensor_at::<D>(v);
                    let (div, ds, de, rate) = dynamics::rates_from(p, model, i, grad, v[D * D], v[D * D + 1]);
                    *dr = div;
                    SolidScratch::<D>::put_rates(row, (ds, de, rate));
                }
            });
    }
    p.drho = drho;
}

/// The rates pass's inputs.
struct Rates<'a, 'h, const D: usize, K> {
    kern: K,
    p: &'a Particles<D>,
    half: &'a HalfView<'h, D>,
    model: &'a Model<D>,
    /// Bulk sound speed of every particle (m/s).
    c: &'a [f64],
    /// Artificial stress R of every particle, and whether it is non-zero.
    rs: &'a [Sym<D>],
    tensile: &'a [bool],
    visc: Viscosity,
    /// Half the step (s), for the mid-drift separation.
    half_dt: f64,
}

impl<const D: usize, K: PairKernel> Home<f64> for Rates<'_, '_, D, K> {
    #[inline]
    fn home<I: Iterator<Item = u32>>(&self, k: usize, w: &mut Window<'_, f64>, partners: I) {
        let (p, model) = (self.p, self.model);
        let order = self.half.order();
        let a = order[k] as usize;
        let (xa, va, ma, rhoa) = (p.x[a], p.v[a], p.mass[a], p.rho[a]);
        let stress_art = model.artificial_stress > 0.0;
        let w_dp = model.kernel.w(model.dx);
        let mid_of = |b: usize| (xa - p.x[b]) - (va - p.v[b]) * self.half_dt;
        let mut grad = Tensor::<D>::zeros();
        let (mut visc_work, mut stress_work) = (0.0, 0.0);
        batched(
            &self.kern,
            &p.h,
            a,
            partners,
            slot_of(order),
            |b| mid_of(b).norm_squared(),
            |t, b, f| {
                let vab = va - p.v[b];
                let mid = mid_of(b);
                let r2 = mid.norm_squared();
                let kab = self.kern.of(&p.h, a, b);
                let gw = mid * f;
                let outer = vab * gw.transpose();
                let vdot = vab.dot(&gw);
                let pi = self
                    .visc
                    .pi(&kab, vab.dot(&mid), r2, self.c[a], self.c[b], rhoa, p.rho[b]);
                let visc = pi * vdot;
                let art = if stress_art && (self.tensile[a] || self.tensile[b]) {
                    let fn4 = model.artificial_factor(p, a, b, &kab, r2.sqrt(), w_dp);
                    fn4 * vab.dot(&((self.rs[a] + self.rs[b]).tensor() * gw))
                } else {
                    0.0
                };
                let mb = p.mass[b];
                grad += outer * mb;
                visc_work += mb * visc;
                stress_work += mb * art;
                let r = w.at(t);
                add_tensor(r, &outer, ma);
                r[D * D] += ma * visc;
                r[D * D + 1] += ma * art;
            },
        );
        let r = w.at(k);
        add_tensor(r, &grad, 1.0);
        r[D * D] += visc_work;
        r[D * D + 1] += stress_work;
    }
}

/// The momentum pass in pair mode: `p.acc` of every owned solid particle, eq. (S5), as
/// [`dynamics::momentum`].
pub fn momentum<const D: usize>(
    p: &mut Particles<D>,
    half: &HalfView<'_, D>,
    model: &Model<D>,
    scratch: &mut SolidScratch<D>,
    s: &mut PairScratch<D>,
) {
    dynamics::sound_speeds(p, model, &mut scratch.c);
    dynamics::stress_terms(p, model, scratch, true);
    crate::with_pair_kernel!(model.varying(), model.kernel, D, k => {
        let pass = Momentum {
            kern: k,
            p: &*p,
            half,
            model,
            c: &scratch.c,
            sig: scratch.sig(),
            rs: &scratch.rs,
            tensile: &scratch.tensile,
            visc: Viscosity::of(model),
        };
        run_homes(half, s.flat(), D, 0.0, true, &pass);
    });
    let n = p.n_owned;
    let (acc, kind, g) = (&*s.flat(), &p.kind, model.g);
    p.acc[..n].par_iter_mut().enumerate().for_each(|(i, a)| {
        if kind[i].is_solid() {
            *a = Vector::<D>::from_column_slice(&acc[half.entry(i) * D..][..D]) + g;
        }
    });
}

/// The momentum pass's inputs.
struct Momentum<'a, 'h, const D: usize, K> {
    kern: K,
    p: &'a Particles<D>,
    half: &'a HalfView<'h, D>,
    model: &'a Model<D>,
    /// Bulk sound speed of every particle (m/s).
    c: &'a [f64],
    /// σ B/ρ² of every particle.
    sig: Sig<'a, D>,
    /// Artificial stress R of every particle, and whether it is non-zero.
    rs: &'a [Sym<D>],
    tensile: &'a [bool],
    visc: Viscosity,
}

impl<const D: usize, K: PairKernel> Home<f64> for Momentum<'_, '_, D, K> {
    #[inline]
    fn home<I: Iterator<Item = u32>>(&self, k: usize, w: &mut Window<'_, f64>, partners: I) {
        let (p, model) = (self.p, self.model);
        let order = self.half.order();
        let a = order[k] as usize;
        let (xa, va, ma, rhoa) = (p.x[a], p.v[a], p.mass[a], p.rho[a]);
        let stress_art = model.artificial_stress > 0.0;
        let w_dp = model.kernel.w(model.dx);
        let mut sum = Vector::<D>::zeros();
        batched(
            &self.kern,
            &p.h,
            a,
            partners,
            slot_of(order),
            |b| (xa - p.x[b]).norm_squared(),
            |t, b, f| {
                let xab = xa - p.x[b];
                let r2 = xab.norm_squared();
                let kab = self.kern.of(&p.h, a, b);
                let gw = xab * f;
                let vab = va - p.v[b];
                let pi = self
                    .visc
                    .pi(&kab, vab.dot(&xab), r2, self.c[a], self.c[b], rhoa, p.rho[b]);
                let mut tt = self.sig.at(a) + self.sig.at(b) - Tensor::<D>::identity() * pi;
                if stress_art && (self.tensile[a] || self.tensile[b]) {
                    tt += (self.rs[a] + self.rs[b]).tensor()
                        * model.artificial_factor(p, a, b, &kab, r2.sqrt(), w_dp);
                }
                let tg = tt * gw;
                sum += tg * p.mass[b];
                for (o, x) in w.at(t).iter_mut().zip(tg.iter()) {
                    *o -= x * ma;
                }
            },
        );
        for (o, x) in w.at(k).iter_mut().zip(sum.iter()) {
            *o += x;
        }
    }
}

//! Pair mode (`[performance] interactions = "pairs"`, `--interactions pairs`): the fluid pair
//! passes — Antuono's renormalised density gradient, continuity and momentum — visit each
//! pair of owned fluid particles once, over half lists (`cells::Wants::Half`), and give
//! both particles their share. A pair with a ghost, a wall or another kind is visited from
//! the owned fluid side only, as in gather mode (the ghost's owner computes its own side).
//!
//! The equations are those of [`super::fluid`] and [`super::delta`]; each contribution is
//! computed with the same operations as there, so that pair and gather mode differ only in
//! the order of the sums (round-off). For the pair (i, j) with x_ji = −x_ij, the j side is:
//! - continuity: m_i f v_ji·x̃_ji = m_i f v_ij·x̃_ij (x̃ the mid-drift separation), plus j's
//!   δ-SPH term with ψ_ji;
//! - momentum: −m_i (p_i/ρ_i² + p_j/ρ_j² + Π_ji) ∇_j W + the laminar term, equal and opposite to
//!   i's times m_i/m_j when both have one material (Π_ji uses c0 of j's material);
//! - gradient: the matrix term V_i f x_ij ⊗ x_ij and −x_ij V_i f (ρ_i − ρ_j).
//!
//! **No locks, no atomics, deterministic.** The owned particles are cut into one contiguous
//! range per rayon thread, with about equal list entries each; task t adds every
//! contribution of its range's pairs — to i and to j, wherever j lies — into its own
//! accumulator, and the accumulators are then summed per particle in task order. Which task
//! handles which pair depends only on the lists and the thread count, so a run gives the
//! same bits for a fixed layout (ranks, their blocks) and thread count; it does not across
//! thread or rank counts (gather mode does).

use super::delta::inverse_or_identity;
use super::fluid::{pair_acceleration, psi_dot_grad, PairTerms};
use super::Model;
use crate::cells::Neighbours;
use crate::particles::Particles;
use crate::scene::DensityDiffusion;
use crate::{Matrix, Vector};
use rayon::prelude::*;
use std::ops::Range;

/// Per-task accumulators and per-particle scratch, kept between steps (no allocation once
/// the particle count has settled).
#[derive(Debug, Default)]
pub struct PairScratch<const D: usize> {
    /// Scalar accumulators (dρ/dt, or the gradient's matrix and vector, flattened).
    flat: Vec<Vec<f64>>,
    /// Vector accumulators (dv/dt).
    vector: Vec<Vec<Vector<D>>>,
    /// V_j = m_j/ρ_j of every particle.
    vol: Vec<f64>,
    /// p_j/ρ_j² of every particle.
    p_rho2: Vec<f64>,
    /// The tasks' ranges of owned particles.
    ranges: Vec<Range<usize>>,
}

impl<const D: usize> PairScratch<D> {
    /// Bytes held (for the memory report).
    pub fn bytes(&self) -> usize {
        self.flat.iter().map(|b| b.capacity() * 8).sum::<usize>()
            + self.vector.iter().map(|b| b.capacity() * 8 * D).sum::<usize>()
            + (self.vol.capacity() + self.p_rho2.capacity()) * 8
    }

    /// One range of owned particles per rayon thread, cut where the running count of list
    /// entries (particles, without stored lists) passes t/T of the total.
    fn split<N: Neighbours>(&mut self, nl: &N, n: usize) {
        let tasks = rayon::current_num_threads().max(1);
        let total = nl.work_before(n);
        self.ranges.clear();
        let mut lo = 0;
        for t in 1..=tasks {
            let hi = if t == tasks {
                n
            } else {
                let target = total * t / tasks;
                partition(nl, n, target).max(lo)
            };
            self.ranges.push(lo..hi);
            lo = hi;
        }
    }

    /// V_j of every particle into `vol`.
    fn volumes(&mut self, p: &Particles<D>) {
        self.vol.resize(p.len(), 0.0);
        self.vol
            .par_iter_mut()
            .zip(p.mass.par_iter().zip(p.rho.par_iter()))
            .for_each(|(v, (&m, &r))| *v = m / r);
    }
}

/// The first owned particle whose list entries before it reach `target` (bisection).
fn partition<N: Neighbours>(nl: &N, n: usize, target: usize) -> usize {
    let (mut lo, mut hi) = (0, n);
    while lo < hi {
        let mid = (lo + hi) / 2;
        if nl.work_before(mid) < target {
            lo = mid + 1;
        } else {
            hi = mid;
        }
    }
    lo
}

/// Run `body(range, accumulator)` for every task's range, each accumulator `len` zeros.
fn accumulate<A: Copy + Send + Sync>(
    bufs: &mut Vec<Vec<A>>,
    ranges: &[Range<usize>],
    len: usize,
    zero: A,
    body: impl Fn(Range<usize>, &mut [A]) + Sync,
) {
    bufs.resize_with(ranges.len(), Vec::new);
    bufs.par_iter_mut().zip(ranges.par_iter()).for_each(|(b, r)| {
        b.clear();
        b.resize(len, zero);
        body(r.clone(), b);
    });
}

/// Entry `k` of every accumulator summed in task order.
#[inline]
fn total<A: Copy + std::ops::Add<Output = A>>(bufs: &[Vec<A>], k: usize) -> A {
    let mut s = bufs[0][k];
    for b in &bufs[1..] {
        s = s + b[k];
    }
    s
}

/// Continuity in pair mode: `p.drho` of every owned fluid particle (zero for the others);
/// see [`super::fluid::continuity`] for the equation and the mid-drift separation.
pub fn continuity<const D: usize, N: Neighbours>(
    p: &mut Particles<D>,
    nl: &N,
    model: &Model<D>,
    dt: f64,
    s: &mut PairScratch<D>,
) {
    let n = p.n_owned;
    s.volumes(p);
    s.split(nl, n);
    {
        let (p, vol) = (&*p, &s.vol);
        accumulate(&mut s.flat, &s.ranges, n, 0.0, |r, acc| {
            for i in r {
                continuity_of(p, nl, model, vol, 0.5 * dt, i, acc);
            }
        });
    }
    let bufs = &s.flat;
    p.drho[..n]
        .par_iter_mut()
        .enumerate()
        .for_each(|(i, d)| *d = total(bufs, i));
}

/// Particle i's pairs of the continuity pass: its own sum, and its share to each owned fluid
/// neighbour of its half list.
fn continuity_of<const D: usize, N: Neighbours>(
    p: &Particles<D>,
    nl: &N,
    model: &Model<D>,
    vol: &[f64],
    half_dt: f64,
    i: usize,
    acc: &mut [f64],
) {
    if !p.kind[i].is_fluid() {
        return;
    }
    let n = p.n_owned;
    let k = &model.kernel;
    let diffusion = model.diffusion != DensityDiffusion::None;
    let antuono = model.diffusion == DensityDiffusion::Antuono;
    let coef = |m: u16| model.delta * k.h * model.materials[m as usize].c0();
    let coef_i = coef(p.mat[i]);
    let (xi, vi) = (p.x[i], p.v[i]);
    let mut di = 0.0;
    for j in nl.iter(i) {
        let j = j as usize;
        let kind_j = p.kind[j];
        if !kind_j.is_smoothed() || kind_j.is_solid() {
            continue;
        }
        let xij = xi - p.x[j];
        let vij = vi - p.v[j];
        let mid = xij - vij * half_dt;
        let f = k.dw_dr_over_r(mid.norm());
        let vdot = f * vij.dot(&mid);
        di += p.mass[j] * vdot;
        let fluid_j = kind_j.is_fluid();
        if diffusion && fluid_j {
            di += coef_i * psi_dot_grad(p, antuono, i, j, &mid, f) * vol[j];
        }
        if fluid_j && j < n {
            acc[j] += p.mass[i] * vdot;
            if diffusion {
                let coef_j = if p.mat[j] == p.mat[i] {
                    coef_i
                } else {
                    coef(p.mat[j])
                };
                acc[j] += coef_j * psi_dot_grad(p, antuono, j, i, &-mid, f) * vol[i];
            }
        }
    }
    acc[i] += di;
}

/// Momentum in pair mode: `p.acc` of every owned fluid particle (zero for the others); see
/// [`super::fluid::momentum`].
pub fn momentum<const D: usize, N: Neighbours>(
    p: &mut Particles<D>,
    nl: &N,
    model: &Model<D>,
    s: &mut PairScratch<D>,
) {
    let n = p.n_owned;
    s.p_rho2.resize(p.len(), 0.0);
    s.p_rho2
        .par_iter_mut()
        .zip(p.p.par_iter().zip(p.rho.par_iter()))
        .for_each(|(q, (&pj, &rj))| *q = pj / (rj * rj));
    s.split(nl, n);
    {
        let (p, p_rho2) = (&*p, &s.p_rho2);
        accumulate(&mut s.vector, &s.ranges, n, Vector::zeros(), |r, acc| {
            for i in r {
                momentum_of(p, nl, model, p_rho2, i, acc);
            }
        });
    }
    let (bufs, kind, g) = (&s.vector, &p.kind, model.g);
    p.acc[..n].par_iter_mut().enumerate().for_each(|(i, a)| {
        *a = if kind[i].is_fluid() {
            total(bufs, i) + g
        } else {
            Vector::zeros()
        };
    });
}

/// Particle i's pairs of the momentum pass.
fn momentum_of<const D: usize, N: Neighbours>(
    p: &Particles<D>,
    nl: &N,
    model: &Model<D>,
    p_rho2: &[f64],
    i: usize,
    acc: &mut [Vector<D>],
) {
    if !p.kind[i].is_fluid() {
        return;
    }
    let n = p.n_owned;
    let ti = PairTerms::of(p, model, i, p_rho2[i]);
    let mut ai = Vector::<D>::zeros();
    for j in nl.iter(i) {
        let j = j as usize;
        let kind_j = p.kind[j];
        if kind_j.is_solid() {
            continue;
        }
        if kind_j.is_fluid() && j < n {
            let (a_i, a_j) = fluid_pair(p, model, &ti, p_rho2, i, j);
            ai += a_i;
            acc[j] += a_j;
        } else {
            ai += pair_acceleration(p, model, &ti, p_rho2[j], j);
        }
    }
    acc[i] += ai;
}

/// Both sides of the momentum pair of fluid particles i (`ti`) and j: (dv_i, dv_j) without
/// the body force, each computed as [`pair_acceleration`] computes it from its side.
#[inline(always)]
fn fluid_pair<const D: usize>(
    p: &Particles<D>,
    model: &Model<D>,
    ti: &PairTerms<D>,
    p_rho2: &[f64],
    i: usize,
    j: usize,
) -> (Vector<D>, Vector<D>) {
    let xij = ti.x - p.x[j];
    let r2 = xij.norm_squared();
    let f = model.kernel.dw_dr_over_r(r2.sqrt());
    let (rhoi, rhoj) = (ti.rho, p.rho[j]);
    let (mi, mj) = (p.mass[i], p.mass[j]);
    let vij = ti.v - p.v[j];
    let base = ti.p_rho2 + p_rho2[j];
    let (mut pi, mut pj) = (base, base);
    let vx = vij.dot(&xij);
    if model.alpha > 0.0 && vx < 0.0 {
        let av_j = if p.mat[j] == p.mat[i] {
            ti.av_coef
        } else {
            -2.0 * model.alpha * model.materials[p.mat[j] as usize].c0() * model.kernel.h
        };
        let den = (r2 + ti.eta2) * (rhoi + rhoj);
        pi += ti.av_coef * vx / den;
        pj += av_j * vx / den;
    }
    let mut a_i = xij * (-f * mj * pi);
    let mut a_j = xij * (-f * mi * pj);
    if model.nu > 0.0 {
        let mu_sum = model.nu * (rhoi + rhoj);
        let rr = rhoi * rhoj;
        a_i += vij * (mj * mu_sum * f / rr);
        a_j += vij * (mi * mu_sum * f / rr);
    }
    (a_i, -a_j)
}

/// Index of (r, c), r ≤ c, in the upper triangle of a D×D matrix stored row by row.
#[inline(always)]
fn tri<const D: usize>(r: usize, c: usize) -> usize {
    r * D - r * (r + 1) / 2 + c
}

/// Antuono's ⟨∇ρ⟩^L in pair mode, written to `p.grad_rho` (zero for all but owned fluid
/// particles); see [`super::delta::renormalised_gradient_of`].
pub fn renormalised_gradient<const D: usize, N: Neighbours>(
    p: &mut Particles<D>,
    nl: &N,
    model: &Model<D>,
    s: &mut PairScratch<D>,
) {
    let n = p.n_owned;
    // per particle: the upper triangle of −Σ V_j ∇W ⊗ x_ij, then Σ V_j (ρ_j − ρ_i) ∇W
    let m = D * (D + 1) / 2;
    let stride = m + D;
    s.volumes(p);
    s.split(nl, n);
    {
        let (p, vol) = (&*p, &s.vol);
        accumulate(&mut s.flat, &s.ranges, n * stride, 0.0, |r, acc| {
            for i in r {
                gradient_of(p, nl, model, vol, i, stride, acc);
            }
        });
    }
    let (bufs, kind) = (&s.flat, &p.kind);
    p.grad_rho[..n].par_iter_mut().enumerate().for_each(|(i, g)| {
        *g = Vector::zeros();
        if !kind[i].is_fluid() {
            return;
        }
        let at = |k: usize| total(bufs, i * stride + k);
        let mat = Matrix::<D>::from_fn(|r, c| {
            if r <= c {
                at(tri::<D>(r, c))
            } else {
                at(tri::<D>(c, r))
            }
        });
        let v = Vector::<D>::from_fn(|a, _| at(m + a));
        *g = inverse_or_identity(&mat) * v;
    });
}

/// Particle i's pairs of the gradient pass (fluid neighbours only).
fn gradient_of<const D: usize, N: Neighbours>(
    p: &Particles<D>,
    nl: &N,
    model: &Model<D>,
    vol: &[f64],
    i: usize,
    stride: usize,
    acc: &mut [f64],
) {
    if !p.kind[i].is_fluid() {
        return;
    }
    let n = p.n_owned;
    let m = D * (D + 1) / 2;
    let k = &model.kernel;
    let (xi, rhoi) = (p.x[i], p.rho[i]);
    let mut a = [[0.0f64; D]; D];
    let mut si = Vector::<D>::zeros();
    for j in nl.iter(i) {
        let j = j as usize;
        if !p.kind[j].is_fluid() {
            continue;
        }
        let xij = xi - p.x[j];
        let f = k.dw_dr_over_r(xij.norm());
        let w = f * vol[j];
        for r in 0..D {
            let wr = xij[r] * w;
            for c in r..D {
                a[r][c] -= wr * xij[c];
            }
        }
        si += xij * (w * (p.rho[j] - rhoi));
        if j < n {
            let wj = f * vol[i];
            let base = j * stride;
            for r in 0..D {
                let wr = xij[r] * wj;
                for c in r..D {
                    acc[base + tri::<D>(r, c)] -= wr * xij[c];
                }
            }
            let sj = -(xij * (wj * (rhoi - p.rho[j])));
            for c in 0..D {
                acc[base + m + c] += sj[c];
            }
        }
    }
    let base = i * stride;
    for r in 0..D {
        for c in r..D {
            acc[base + tri::<D>(r, c)] += a[r][c];
        }
    }
    for c in 0..D {
        acc[base + m + c] += si[c];
    }
}

//! Pair mode (`[performance] interactions = "pairs"`, `--interactions pairs`): the fluid pair
//! passes — Antuono's renormalised density gradient, continuity and momentum — visit each
//! pair once, over the canonical half lists of [`crate::cells::HalfPairs`], and give both
//! particles their share (only fluid particles receive any; the solids' pairs are
//! [`crate::physics::solid::pairs`]'s).
//!
//! The equations are those of [`super::fluid`] and [`super::delta`]; each contribution is
//! computed with the same operations as there, so that pair and gather mode differ only in
//! the order of the sums (round-off). For the pair (a, b) with x_ba = −x_ab, b's side is:
//! - continuity: m_a f v_ba·x̃_ba = m_a f v_ab·x̃_ab (x̃ the mid-drift separation, whose
//!   sign flips exactly), plus b's δ-SPH term with ψ_ba;
//! - momentum: −m_a (p_a/ρ_a² + p_b/ρ_b² + Π_ba) ∇_b W + the laminar term, equal and opposite to
//!   a's times m_a/m_b when both have one material (Π_ba uses c0 of b's material); a wall or
//!   repulsive home gives its fluid partner [`pair_acceleration`] from the partner's side;
//! - gradient: the matrix term V_a f x_ab ⊗ x_ab and −x_ab V_a f (ρ_a − ρ_b).
//!
//! **No locks, no atomics, the same bits on any number of ranks and threads.** A pair's
//! home is its particle of lower slot (a global order); the homes run in the two-phase
//! schedule of [`HalfView::run`], so every particle's contributions arrive in an order fixed
//! by the global cell grid and the particles' keys. A pair of an owned particle and a ghost
//! is computed on each rank that owns one of them, from the same home and with the same
//! operations. The bits differ from gather mode's (another order of the sums), not between
//! layouts or thread counts.

use super::batch::{batched, slot_of};
use super::fluid::{
    diffuses, pair_acceleration_with, psi_dot_grad, riemann_dissipation, Correction, PairTerms,
};
use super::moment::{inverse_or_identity, FirstMoment};
use super::Model;
use crate::cells::{HalfView, Window};
use crate::kernel::sizes::PairKernel;
use crate::particles::Kind;
use crate::particles::Particles;
use crate::{Matrix, Vector};
use rayon::prelude::*;

/// Accumulators and per-particle scratch, kept between steps (no allocation once the
/// particle count has settled).
#[derive(Debug, Default)]
pub struct PairScratch<const D: usize> {
    /// Accumulators per fluid slot, flattened: dρ/dt, dv/dt (D values), the lattice moment, or
    /// the gradient's matrix and vector (one buffer: the passes run one after the other).
    flat: Vec<f64>,
    /// V_j = m_j/ρ_j of every particle.
    vol: Vec<f64>,
    /// p_j/ρ_j² of every particle.
    p_rho2: Vec<f64>,
    /// The shifting pass's displacements and Taylor increments of owned particles
    /// ([`crate::physics::shifting::shifts`]).
    shift: Vec<crate::physics::shifting::Shift<D>>,
}

impl<const D: usize> PairScratch<D> {
    /// Bytes these accumulators hold, by capacity.
    pub fn bytes_held(&self) -> usize {
        use crate::cells::held;
        held(&self.flat) + held(&self.vol) + held(&self.p_rho2) + held(&self.shift)
    }

    /// The shifting pass's kept buffers: the volumes (the gather passes' buffer) and the
    /// shifts.
    pub fn shift_buffers(&mut self) -> (&mut Vec<f64>, &mut Vec<crate::physics::shifting::Shift<D>>) {
        (&mut self.vol, &mut self.shift)
    }

    /// The pair passes' accumulators (the solids' pair passes share them:
    /// [`crate::physics::solid::pairs`]).
    pub(super) fn flat(&mut self) -> &mut Vec<f64> {
        &mut self.flat
    }

    /// A per-particle buffer for the gather passes (the pair passes' volumes; the two modes
    /// never share a pass).
    pub fn buffer(&mut self) -> &mut Vec<f64> {
        &mut self.vol
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

/// One pair pass's work at a home slot: its pairs with the partners `partners` (slots,
/// ascending), written into the window.
pub(super) trait Home<A>: Sync {
    fn home<I: Iterator<Item = u32>>(&self, k: usize, w: &mut Window<'_, A>, partners: I);
}

/// Run `pass` at every home in the schedule of [`HalfView::run`], over the stored lists or
/// the list-free scan. Verlet lists (`cells::verlet`) also hold pairs that lie beyond the
/// support now: every pair kernel here is a multiple of W′(r) (the `f` of each kernel), which
/// is exactly 0 there, so such a pair adds exact zeros and no filter is needed (a filter per
/// partner made the passes 25 % slower, docs/benchmark-log.md, "Verlet lists").
///
/// A solid home's partners are solids: the solid passes (`solids`,
/// [`crate::physics::solid::pairs`]) visit those homes only, the fluid passes the others.
pub(super) fn run_homes<const D: usize, A: Copy + Send + Sync>(
    half: &HalfView<'_, D>,
    acc: &mut Vec<A>,
    stride: usize,
    zero: A,
    solids: bool,
    pass: &impl Home<A>,
) {
    half.run(acc, stride, zero, |k, w| {
        if half.solid(k) != solids {
            return;
        }
        match half.stored(k) {
            Some(list) => pass.home(k, w, list),
            None => pass.home(k, w, half.scan(k)),
        }
    });
}

/// Continuity in pair mode: `p.drho` of every owned fluid particle (zero for the others);
/// see [`super::fluid::continuity`] for the equation and the mid-drift separation.
pub fn continuity<const D: usize>(
    p: &mut Particles<D>,
    half: &HalfView<'_, D>,
    model: &Model<D>,
    dt: f64,
    s: &mut PairScratch<D>,
) {
    s.volumes(p);
    crate::with_pair_kernel!(model.varying(), model.kernel, D, k => {
        let pass = Continuity {
            kern: k,
            p: &*p,
            half,
            model,
            vol: &s.vol,
            half_dt: 0.5 * dt,
        };
        run_homes(half, &mut s.flat, 1, 0.0, false, &pass);
    });
    let n = p.n_owned;
    let (acc, kind) = (&s.flat, &p.kind);
    p.drho[..n].par_iter_mut().enumerate().for_each(|(i, d)| {
        *d = if kind[i].is_fluid() {
            acc[half.entry(i)]
        } else {
            0.0
        };
    });
}

/// The continuity pass's inputs.
struct Continuity<'a, 'h, const D: usize, K> {
    /// The kernel of each pair.
    kern: K,
    p: &'a Particles<D>,
    half: &'a HalfView<'h, D>,
    model: &'a Model<D>,
    /// V_j of every particle (m³).
    vol: &'a [f64],
    /// Half the step (s), for the mid-drift separation.
    half_dt: f64,
}

impl<const D: usize, K: PairKernel> Home<f64> for Continuity<'_, '_, D, K> {
    /// Home slot k's pairs (walls enter with their own velocity, solids and repulsive walls
    /// not at all).
    #[inline]
    fn home<I: Iterator<Item = u32>>(&self, k: usize, w: &mut Window<'_, f64>, partners: I) {
        let (p, model, vol) = (self.p, self.model, self.vol);
        let order = self.half.order();
        let a = order[k] as usize;
        let kind_a = p.kind[a];
        if !kind_a.is_smoothed() {
            return;
        }
        let fluid_a = kind_a.is_fluid();
        let kern = &model.kernel;
        let diffusion = model.diffusion.diffuses();
        let corr = Correction::of(model);
        let coef = |m: u16| {
            model
                .diffusion
                .coefficient(model.delta, kern.h, model.materials[m as usize].c0())
        };
        let coef_a = coef(p.mat[a]);
        let (xa, va, ma) = (p.x[a], p.v[a], p.mass[a]);
        let mid_of = |b: usize| (xa - p.x[b]) - (va - p.v[b]) * self.half_dt;
        let mut da = 0.0;
        batched(
            &self.kern,
            &p.h,
            a,
            partners,
            slot_of(order),
            |b| mid_of(b).norm_squared(),
            |t, b, f| {
                let kind_b = p.kind[b];
                if !kind_b.is_smoothed() {
                    return;
                }
                let fluid_b = kind_b.is_fluid();
                let vab = va - p.v[b];
                let mid = mid_of(b);
                let kab = self.kern.of(&p.h, a, b);
                let vdot = f * vab.dot(&mid);
                // δ h c0 with the pair's mean h where particles have several sizes
                let sized = |m: u16| {
                    model
                        .diffusion
                        .coefficient(model.delta, kab.h, model.materials[m as usize].c0())
                };
                // fluids of one material only ([`diffuses`]): then a's δ h c0 is b's
                let diffused = diffusion && fluid_a && diffuses(p, a, b);
                // ψ_ba·∇_b W = −ψ_ab·∇_a W to the bit for one material (every sum and difference
                // in it changes sign exactly), so one evaluation serves both sides
                let psi = if diffused {
                    psi_dot_grad(p, model, corr, a, b, &mid, f)
                } else {
                    0.0
                };
                if fluid_a {
                    da += p.mass[b] * vdot;
                    if diffused {
                        let coef_a = if K::VARIES { sized(p.mat[a]) } else { coef_a };
                        da += coef_a * psi * vol[b];
                    }
                }
                if fluid_b {
                    let r = w.one(t);
                    *r += ma * vdot;
                    if diffused {
                        let coef_b = if K::VARIES { sized(p.mat[b]) } else { coef_a };
                        *r += coef_b * -psi * vol[a];
                    }
                }
            },
        );
        if fluid_a {
            *w.one(k) += da;
        }
    }
}

/// Momentum in pair mode: `p.acc` of every owned fluid particle (zero for the others); see
/// [`super::fluid::momentum`].
pub fn momentum<const D: usize>(
    p: &mut Particles<D>,
    half: &HalfView<'_, D>,
    model: &Model<D>,
    s: &mut PairScratch<D>,
) {
    momentum_pass::<D, false>(p, half, model, s);
}

/// Momentum in pair mode with Antuono's ⟨∇ρ⟩^L of the same state (`physics.density_gradient
/// = "lagged"`): `p.acc` as [`momentum`] and `p.grad_rho` as [`renormalised_gradient`], to
/// the bit, in one visit of each pair (the kernel derivative and separation serve both).
pub fn momentum_with_gradient<const D: usize>(
    p: &mut Particles<D>,
    half: &HalfView<'_, D>,
    model: &Model<D>,
    s: &mut PairScratch<D>,
) {
    momentum_pass::<D, true>(p, half, model, s);
}

/// [`momentum`], and with `G` the gradient's matrix and vector after each slot's D values.
fn momentum_pass<const D: usize, const G: bool>(
    p: &mut Particles<D>,
    half: &HalfView<'_, D>,
    model: &Model<D>,
    s: &mut PairScratch<D>,
) {
    s.p_rho2.resize(p.len(), 0.0);
    s.p_rho2
        .par_iter_mut()
        .zip(p.p.par_iter().zip(p.rho.par_iter()))
        .for_each(|(q, (&pj, &rj))| *q = pj / (rj * rj));
    if G {
        s.volumes(p);
    }
    let stride = if G { D + gradient_stride::<D>() } else { D };
    crate::with_pair_kernel!(model.varying(), model.kernel, D, k => {
        let pass = Momentum::<D, _, G> {
            kern: k,
            p: &*p,
            half,
            model,
            p_rho2: &s.p_rho2,
            vol: &s.vol,
        };
        run_homes(half, &mut s.flat, stride, 0.0, false, &pass);
    });
    let n = p.n_owned;
    let (acc, kind, g) = (&s.flat, &p.kind, model.g);
    p.acc[..n].par_iter_mut().enumerate().for_each(|(i, a)| {
        *a = if kind[i].is_fluid() {
            Vector::<D>::from_column_slice(&acc[half.entry(i) * stride..][..D]) + g
        } else {
            Vector::zeros()
        };
    });
    if G {
        gradients_from(p, half, &s.flat, stride, D);
    }
}

/// The momentum pass's inputs.
struct Momentum<'a, 'h, const D: usize, K, const G: bool> {
    /// The kernel of each pair.
    kern: K,
    p: &'a Particles<D>,
    half: &'a HalfView<'h, D>,
    model: &'a Model<D>,
    /// p_j/ρ_j² of every particle (m⁵ kg⁻¹ s⁻²).
    p_rho2: &'a [f64],
    /// V_j of every particle (m³), with `G` (the gradient) only.
    vol: &'a [f64],
}

/// Add `v` to the D values `out` (one slot's dv/dt in the flat accumulator).
#[inline(always)]
fn add<const D: usize>(out: &mut [f64], v: &Vector<D>) {
    for (o, x) in out.iter_mut().zip(v.iter()) {
        *o += x;
    }
}

impl<const D: usize, K: PairKernel, const G: bool> Home<f64> for Momentum<'_, '_, D, K, G> {
    /// Home slot k's pairs.
    #[inline]
    fn home<I: Iterator<Item = u32>>(&self, k: usize, w: &mut Window<'_, f64>, partners: I) {
        let (p, model, p_rho2) = (self.p, self.model, self.p_rho2);
        let order = self.half.order();
        let a = order[k] as usize;
        if p.kind[a] != Kind::Fluid {
            // a wall home: only its fluid partners receive (the lists hold no other pair),
            // and no gradient (walls do not diffuse)
            // |x_b − x_a|² is |x_a − x_b|² to the bit (negation is exact)
            let xa = p.x[a];
            let r2_of = |b: usize| (xa - p.x[b]).norm_squared();
            batched(&self.kern, &p.h, a, partners, slot_of(order), r2_of, |t, b, f| {
                let tb = PairTerms::of(p, model, b, p_rho2[b]);
                add(
                    w.at(t),
                    &pair_acceleration_with(p, model, self.kern, &tb, p_rho2[a], a, f),
                );
            });
            return;
        }
        let ta = PairTerms::of(p, model, a, p_rho2[a]);
        let mut sum = Vector::<D>::zeros();
        let mut grad = GradientSum::<D>::default();
        let r2_of = |b: usize| (ta.x - p.x[b]).norm_squared();
        batched(&self.kern, &p.h, a, partners, slot_of(order), r2_of, |t, b, f| {
            if p.kind[b].is_fluid() {
                let (d_a, d_b) = fluid_pair(p, model, self.kern, &ta, p_rho2, a, b, f);
                sum += d_a;
                let out = w.at(t);
                add(out, &d_b);
                if G && diffuses(p, a, b) {
                    let xab = ta.x - p.x[b];
                    grad.pair(
                        &xab,
                        f,
                        (self.vol[a], self.vol[b]),
                        (ta.rho, p.rho[b]),
                        &mut out[D..],
                    );
                }
            } else {
                sum += pair_acceleration_with(p, model, self.kern, &ta, p_rho2[b], b, f);
            }
        });
        let out = w.at(k);
        add(out, &sum);
        if G {
            grad.flush(&mut out[D..]);
        }
    }
}

/// Both sides of the momentum pair of fluid particles i (`ti`) and j with the pair's (1/r)
/// dW/dr `f` (m^-(D+2)): (dv_i, dv_j) without the body force, each computed as
/// [`pair_acceleration`] computes it from its side.
#[allow(clippy::too_many_arguments)]
#[inline(always)]
fn fluid_pair<const D: usize, K: PairKernel>(
    p: &Particles<D>,
    model: &Model<D>,
    kern: K,
    ti: &PairTerms<D>,
    p_rho2: &[f64],
    i: usize,
    j: usize,
    f: f64,
) -> (Vector<D>, Vector<D>) {
    let xij = ti.x - p.x[j];
    let r2 = xij.norm_squared();
    let k = kern.of(&p.h, i, j);
    let (av_i, eta2) = if K::VARIES {
        (ti.av_c0 * k.h, 0.01 * k.h * k.h)
    } else {
        (ti.av_coef, ti.eta2)
    };
    let (rhoi, rhoj) = (ti.rho, p.rho[j]);
    let (mi, mj) = (p.mass[i], p.mass[j]);
    let vij = ti.v - p.v[j];
    let base = ti.p_rho2 + p_rho2[j];
    let (mut pi, mut pj) = (base, base);
    let vx = vij.dot(&xij);
    if model.alpha > 0.0 && vx < 0.0 {
        let den = (r2 + eta2) * (rhoi + rhoj);
        let pi_i = av_i * vx / den;
        pi += pi_i;
        // one material: Π_ji is Π_ij, the same operations, so one division serves both
        pj += if p.mat[j] == p.mat[i] {
            pi_i
        } else {
            -2.0 * model.alpha * model.materials[p.mat[j] as usize].c0() * k.h * vx / den
        };
    }
    if model.riemann_dissipation {
        // symmetric in i and j with the pair's mean sound speed, so both sides add one value
        let c = 0.5 * (ti.c0 + model.materials[p.mat[j] as usize].c0());
        let d = riemann_dissipation(vx, r2, rhoi, rhoj, c);
        pi += d;
        pj += d;
    }
    let mut a_i = xij * (-f * mj * pi);
    let mut a_j = xij * (-f * mi * pj);
    if model.nu > 0.0 {
        let mut mu_sum = model.nu * (rhoi + rhoj);
        if model.viscous.renormalised {
            // the same factor as super::viscous::Viscous::difference, both sides
            mu_sum *= 2.0 / (ti.lap + p.lap[j]);
        }
        // against a Morris mirror image, each side sees Morris's velocity difference
        // (super::viscous::Viscous::mirror_difference); one of the two at most is an image
        let v = &model.viscous;
        let (mut vi, mut vj) = (vij, vij);
        if v.any_mirror_morris {
            vi = v.mirror_difference(p, &ti.x, &ti.v, j).unwrap_or(vij);
            vj = v.mirror_difference(p, &p.x[j], &p.v[j], i).map_or(vij, |m| -m);
        }
        let rr = rhoi * rhoj;
        a_i += vi * (mj * mu_sum * f / rr);
        a_j += vj * (mi * mu_sum * f / rr);
    }
    (a_i, -a_j)
}

/// Index of (r, c), r ≤ c, in the upper triangle of a D×D matrix stored row by row.
#[inline(always)]
fn tri<const D: usize>(r: usize, c: usize) -> usize {
    r * D - r * (r + 1) / 2 + c
}

/// Values per slot of the gradient's accumulator: the upper triangle of −Σ V_j f x_ij ⊗ x_ij
/// (D(D+1)/2), then Σ V_j f (ρ_j − ρ_i) x_ij (D).
const fn gradient_stride<const D: usize>() -> usize {
    D * (D + 1) / 2 + D
}

/// Antuono's ⟨∇ρ⟩^L in pair mode, written to `p.grad_rho` (zero for all but owned fluid
/// particles); see [`super::delta::renormalised_gradient_of`].
pub fn renormalised_gradient<const D: usize>(
    p: &mut Particles<D>,
    half: &HalfView<'_, D>,
    model: &Model<D>,
    s: &mut PairScratch<D>,
) {
    let stride = gradient_stride::<D>();
    s.volumes(p);
    crate::with_pair_kernel!(model.varying(), model.kernel, D, k => {
        let pass = Gradient {
            kern: k,
            p: &*p,
            half,
            vol: &s.vol,
        };
        run_homes(half, &mut s.flat, stride, 0.0, false, &pass);
    });
    gradients_from(p, half, &s.flat, stride, 0);
}

/// `p.grad_rho` of every owned particle from the accumulator `acc` (`stride` values per fluid
/// slot, the gradient's from `offset` on): L⁻¹ times the vector for fluid particles, zero for
/// the others.
fn gradients_from<const D: usize>(
    p: &mut Particles<D>,
    half: &HalfView<'_, D>,
    acc: &[f64],
    stride: usize,
    offset: usize,
) {
    let m = D * (D + 1) / 2;
    let n = p.n_owned;
    let kind = &p.kind;
    p.grad_rho[..n].par_iter_mut().enumerate().for_each(|(i, g)| {
        *g = Vector::zeros();
        if !kind[i].is_fluid() {
            return;
        }
        let at = &acc[half.entry(i) * stride + offset..][..m + D];
        let mat = Matrix::<D>::from_fn(|r, c| {
            if r <= c {
                at[tri::<D>(r, c)]
            } else {
                at[tri::<D>(c, r)]
            }
        });
        let v = Vector::<D>::from_fn(|a, _| at[m + a]);
        *g = inverse_or_identity(&mat) * v;
    });
}

/// A home's own side of the gradient's sums, accumulated over its pairs and written once
/// ([`GradientSum::flush`]); each partner's side goes straight to its window.
struct GradientSum<const D: usize> {
    /// −Σ V_b f x_ab ⊗ x_ab.
    mat: FirstMoment<D>,
    /// Σ V_b f (ρ_b − ρ_a) x_ab.
    vec: Vector<D>,
}

impl<const D: usize> Default for GradientSum<D> {
    fn default() -> Self {
        GradientSum {
            mat: FirstMoment::default(),
            vec: Vector::zeros(),
        }
    }
}

impl<const D: usize> GradientSum<D> {
    /// The pair (a, b) of separation `xab` = x_a − x_b, (1/r) dW/dr `f`, volumes (V_a, V_b)
    /// and densities (ρ_a, ρ_b): a's side here, b's into `out` (its slot's gradient values).
    #[inline(always)]
    fn pair(
        &mut self,
        xab: &Vector<D>,
        f: f64,
        (va, vb): (f64, f64),
        (rhoa, rhob): (f64, f64),
        out: &mut [f64],
    ) {
        let m = D * (D + 1) / 2;
        let wa = f * vb;
        self.mat.add(xab, wa);
        self.vec += xab * (wa * (rhob - rhoa));
        let wb = f * va;
        for r in 0..D {
            let wr = xab[r] * wb;
            for c in r..D {
                out[tri::<D>(r, c)] -= wr * xab[c];
            }
        }
        let sb = -(xab * (wb * (rhoa - rhob)));
        for c in 0..D {
            out[m + c] += sb[c];
        }
    }

    /// Add the home's side to its own slot's gradient values `out`.
    #[inline(always)]
    fn flush(&self, out: &mut [f64]) {
        let m = D * (D + 1) / 2;
        for r in 0..D {
            for c in r..D {
                out[tri::<D>(r, c)] += self.mat.upper(r, c);
            }
        }
        for c in 0..D {
            out[m + c] += self.vec[c];
        }
    }
}

/// The gradient pass's inputs.
struct Gradient<'a, 'h, const D: usize, K> {
    /// The kernel of each pair.
    kern: K,
    p: &'a Particles<D>,
    half: &'a HalfView<'h, D>,
    /// V_j of every particle (m³).
    vol: &'a [f64],
}

impl<const D: usize, K: PairKernel> Home<f64> for Gradient<'_, '_, D, K> {
    /// Home slot k's pairs (fluid pairs only).
    #[inline]
    fn home<I: Iterator<Item = u32>>(&self, k: usize, w: &mut Window<'_, f64>, partners: I) {
        let (p, vol) = (self.p, self.vol);
        let order = self.half.order();
        let a = order[k] as usize;
        if !p.kind[a].is_fluid() {
            return;
        }
        let (xa, rhoa) = (p.x[a], p.rho[a]);
        let mut sum = GradientSum::<D>::default();
        let r2_of = |b: usize| (xa - p.x[b]).norm_squared();
        batched(&self.kern, &p.h, a, partners, slot_of(order), r2_of, |t, b, f| {
            if diffuses(p, a, b) {
                let xab = xa - p.x[b];
                sum.pair(&xab, f, (vol[a], vol[b]), (rhoa, p.rho[b]), w.at(t));
            }
        });
        sum.flush(w.at(k));
    }
}

/// The viscous operator's lattice moment in pair mode, written to `p.lap` (1 for all but
/// owned fluid particles); see [`super::viscous::lattice_moment`].
pub fn lattice_moment<const D: usize>(
    p: &mut Particles<D>,
    half: &HalfView<'_, D>,
    model: &Model<D>,
    s: &mut PairScratch<D>,
) {
    s.volumes(p);
    crate::with_pair_kernel!(model.varying(), model.kernel, D, k => {
        let pass = Moment {
            kern: k,
            p: &*p,
            half,
            vol: &s.vol,
        };
        run_homes(half, &mut s.flat, 1, 0.0, false, &pass);
    });
    let n = p.n_owned;
    let (acc, kind) = (&s.flat, &p.kind);
    p.lap[..n].par_iter_mut().enumerate().for_each(|(i, l)| {
        *l = if kind[i].is_fluid() {
            super::viscous::moment_of::<D>(acc[half.entry(i)])
        } else {
            1.0
        };
    });
}

/// The lattice-moment pass's inputs.
struct Moment<'a, 'h, const D: usize, K> {
    /// The kernel of each pair.
    kern: K,
    p: &'a Particles<D>,
    half: &'a HalfView<'h, D>,
    /// V_j of every particle (m³).
    vol: &'a [f64],
}

impl<const D: usize, K: PairKernel> Home<f64> for Moment<'_, '_, D, K> {
    /// Home slot k's pairs: Σ V r² (1/r) W′ over smoothed partners, to each fluid side.
    #[inline]
    fn home<I: Iterator<Item = u32>>(&self, k: usize, w: &mut Window<'_, f64>, partners: I) {
        let (p, vol) = (self.p, self.vol);
        let order = self.half.order();
        let a = order[k] as usize;
        if !p.kind[a].is_smoothed() {
            return;
        }
        let fluid_a = p.kind[a].is_fluid();
        let xa = p.x[a];
        let mut sa = 0.0;
        for t in partners {
            let t = t as usize;
            let b = order[t] as usize;
            if !p.kind[b].is_smoothed() {
                continue;
            }
            let r2 = (xa - p.x[b]).norm_squared();
            let g = r2 * self.kern.of(&p.h, a, b).dw_dr_over_r(r2.sqrt());
            if fluid_a {
                sa += vol[b] * g;
            }
            if p.kind[b].is_fluid() {
                *w.one(t) += vol[a] * g;
            }
        }
        if fluid_a {
            *w.one(k) += sa;
        }
    }
}

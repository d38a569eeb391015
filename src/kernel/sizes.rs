//! Particles of several sizes (`[[refine]]`, docs/refinement.md §1): the kernel of a pair of
//! particles of different smoothing lengths.
//!
//! A particle of level ℓ has spacing Δp_ℓ = dx / 2^ℓ (its mass ρ Δp_ℓ^D) and a smoothing
//! length h_i of its own: h_ℓ = (h/dx) Δp_ℓ in the core of its region, rising linearly to the
//! scene's h over the region's transition band, so that h is continuous where the spacing
//! jumps (docs/refinement.md §1). A pair (i, j) is evaluated with one kernel of a pair
//! smoothing length h_ij, by default the **mean** (h_i + h_j) / 2, or the **larger**
//! max(h_i, h_j) ([`PairH`], `[discretisation] pair_h`):
//!
//! - W_ij = W(|x_ij|, h_ij) is symmetric in i and j, so ∇_i W_ij = −∇_j W_ij: every pairwise
//!   force stays antisymmetric and linear momentum is conserved to round-off across a size
//!   interface (mass is carried by the particles and never changes);
//! - one kernel evaluation per pair (the mean of the two kernels, the other symmetric form,
//!   takes two), and for two particles of one h it is that h's kernel, bit for bit;
//! - zeroth-order consistency: Σ_j V_j ∇_i W_ij vanishes in a uniform lattice of any spacing
//!   and stays small where the spacing jumps under a continuous h (the transition band puts
//!   the jump in h elsewhere and spreads it); a jump of h itself would break it by a large
//!   fraction of a free surface's value (measured in docs/refinement.md §1), which is why h
//!   is not simply the spacing's.
//!
//! The larger h keeps every pair a coarse particle has within its own support, so its
//! Σ_j V_j ∇_i W_ij is that of its own kernel whatever the sizes of its neighbours (a coarse
//! fluid particle beside a finely sampled wall sees the whole wall it would see at its own h);
//! the mean h shrinks that support to the pair's mean, and a wall finer than the fluid then
//! holds the fluid back less (docs/pressure.md §2e). Both are symmetric in i and j.
//!
//! Terms that scale with a length (artificial viscosity α h_ij c0, δ-SPH δ h_ij c0, shifting's
//! β(2h)²) use the pair's or the particle's h; the artificial stress's reference W_ij(Δp_ij)
//! the mean spacing of the pair. The cell grid stays that of the largest support; the
//! neighbour lists keep a pair only within its own support, r_i + r_j (mean) or max(r_i, r_j)
//! (larger) of per-particle reaches (`crate::cells::NeighbourList::with_sizes`,
//! [`PairH::reach_per_support`]), beyond which its kernel is zero.

use super::{Kernel, KernelKind, BATCH};
use serde::{Deserialize, Serialize};

/// The smoothing length of a pair of particles of two sizes (`[discretisation] pair_h`).
///
/// | rule | h_ij | support | momentum | a coarse particle's Σ_j V_j ∇W_ij beside finer ones |
/// |---|---|---|---|---|
/// | `mean` | (h_i + h_j)/2 | κ h_ij | conserved (W_ij symmetric) | from a support shrunk toward the finer h |
/// | `max` | max(h_i, h_j) | κ h_ij | conserved (W_ij symmetric) | its own kernel's, whole |
///
/// Both give one h's kernel bit for bit for particles of one h; a scene of one h never reads it.
#[derive(Debug, Clone, Copy, Serialize, Deserialize, PartialEq, Eq, Default)]
#[serde(rename_all = "snake_case")]
pub enum PairH {
    /// The mean, (h_i + h_j)/2 (docs/refinement.md §1).
    #[default]
    Mean,
    /// The larger, max(h_i, h_j) (docs/pressure.md §2e).
    Max,
}

impl PairH {
    /// The pair's smoothing length h_ij (m) of `hi`, `hj` (m).
    #[inline(always)]
    pub fn of(self, hi: f64, hj: f64) -> f64 {
        match self {
            PairH::Mean => 0.5 * (hi + hj),
            PairH::Max => hi.max(hj),
        }
    }

    /// Each particle's list reach per unit of κ h_i: the pair's support κ h_ij is then r_i + r_j
    /// (mean) or max(r_i, r_j) (max) (`crate::cells::NeighbourList::with_sizes`).
    pub fn reach_per_support(self) -> f64 {
        match self {
            PairH::Mean => 0.5,
            PairH::Max => 1.0,
        }
    }

    /// True for [`PairH::Mean`], the default (scene files leave it out).
    pub fn is_mean(&self) -> bool {
        *self == PairH::Mean
    }
}

/// Levels a scene may hold: 0 (the scene's dx) to [`crate::scene::refine::MAX_LEVEL`] (3).
pub const LEVELS: usize = 4;

/// What the passes need to know of a scene's particle sizes.
#[derive(Debug, Clone)]
pub struct Sizes {
    /// The kernel's family.
    pub kind: KernelKind,
    /// Spacing Δp_ℓ per level (m).
    pub dx: [f64; LEVELS],
    /// Smoothing length h_ℓ of the core of each level (m).
    pub h: [f64; LEVELS],
    /// Finest level whose particles take its own h (0: every particle has the scene's h).
    pub finest_h: u16,
    /// Some particles' h differs from the scene's (`finest_h` > 0): pairs take the kernel of
    /// their pair h ([`Sizes::pair_h`]).
    pub varies_h: bool,
    /// The rule of a pair's h.
    pub pair_h: PairH,
}

impl Sizes {
    /// The sizes of kernel `kind`, the scene's spacing `dx` (m) and `h_over_dx`, with levels
    /// up to `finest_h` taking their own h.
    pub fn new(kind: KernelKind, dx: f64, h_over_dx: f64, finest_h: u16) -> Self {
        Sizes {
            kind,
            dx: std::array::from_fn(|l| dx / f64::from(1u32 << l)),
            h: std::array::from_fn(|l| h_over_dx * dx / f64::from(1u32 << l)),
            finest_h,
            varies_h: finest_h > 0,
            pair_h: PairH::Mean,
        }
    }

    /// These sizes with pairs taking the h of `rule`.
    pub fn with_pair_h(mut self, rule: PairH) -> Self {
        self.pair_h = rule;
        self
    }

    /// The smallest smoothing length a particle may have (m): the core h of the finest level
    /// that takes its own (a transition band rises from it to the scene's h).
    pub fn smallest_h(&self) -> f64 {
        self.h[self.finest_h as usize]
    }

    /// The kernel of a pair of smoothing lengths `hi`, `hj` (m): W(r, h_ij) ([`PairH::of`]).
    #[inline(always)]
    pub fn kernel<const D: usize>(&self, hi: f64, hj: f64) -> Kernel {
        Kernel::new(self.kind, self.pair_h.of(hi, hj), D)
    }

    /// The mean spacing of a pair of levels (m).
    #[inline(always)]
    pub fn spacing(&self, li: u16, lj: u16) -> f64 {
        0.5 * (self.dx[li as usize] + self.dx[lj as usize])
    }

    /// The load of a particle of level `level` and smoothing length `h` (m) in a `D`-dimensional
    /// scene, for the initial split under `balance.load = "pairs"` (docs/refinement.md §5): 1 + its
    /// expected list length. A body's particle lists the sites of its own spacing Δp_ℓ within its
    /// support, V_D(κh) / Δp_ℓ^D (V_2(r) = π r², V_3(r) = 4/3 π r³): with the scene's h a particle
    /// of level ℓ weighs about 2^(ℓD) coarse ones, with its level's h about one (its lists keep a
    /// pair within the pair's own support), more in the transition band where h rises. A dummy wall
    /// particle (`wall`) lists only the fluid in its support: over a wall as thick as the support
    /// that is on average the share of a support beyond a plane at a uniformly distributed
    /// distance, 2/(3π) in 2D and 3/16 in 3D. A function of the site alone, so every rank weighs a
    /// particle alike.
    pub fn site_load<const D: usize>(&self, level: u16, h: f64, wall: bool) -> u64 {
        use std::f64::consts::PI;
        let r = self.kind.support_factor() * h / self.dx[level as usize];
        let (v, beyond_face) = if D == 2 {
            (PI * r * r, 2.0 / (3.0 * PI))
        } else {
            (4.0 / 3.0 * PI * r * r * r, 3.0 / 16.0)
        };
        1 + (if wall { beyond_face * v } else { v }).round() as u64
    }
}

/// How a pass finds the kernel of each pair, chosen once per pass ([`OneKernel`] or
/// [`VariedH`]) and monomorphised, so that a scene of one size pays nothing per pair for
/// particles of several. `h` is the particles' smoothing-length field (empty, and never read,
/// in a scene of one size).
pub trait PairKernel: Copy + Send + Sync {
    /// True if pairs may differ in h (terms scaling with h take the pair's).
    const VARIES: bool;
    /// The kernel of the pair (i, j).
    fn of(&self, h: &[f64], i: usize, j: usize) -> Kernel;

    /// (1/r) dW/dr (m⁻ᴰ⁻²) of the pairs (i, `js[n]`) at squared separations `r2[n]` (m²), each
    /// to the bit what `self.of(h, i, js[n]).dw_dr_over_r(r2[n].sqrt())` gives.
    #[inline(always)]
    fn dw_dr_over_r_batch(
        &self,
        h: &[f64],
        i: usize,
        js: &[usize; BATCH],
        r2: &[f64; BATCH],
        out: &mut [f64; BATCH],
    ) {
        for ((o, &j), &r2) in out.iter_mut().zip(js).zip(r2) {
            *o = self.of(h, i, j).dw_dr_over_r(r2.sqrt());
        }
    }
}

/// One kernel for every pair (a scene of one smoothing length).
#[derive(Debug, Clone, Copy)]
pub struct OneKernel(pub Kernel);

impl PairKernel for OneKernel {
    const VARIES: bool = false;
    #[inline(always)]
    fn of(&self, _h: &[f64], _i: usize, _j: usize) -> Kernel {
        self.0
    }

    /// One kernel: the vectorised batch ([`Kernel::dw_dr_over_r_batch`]).
    #[inline(always)]
    fn dw_dr_over_r_batch(
        &self,
        _h: &[f64],
        _i: usize,
        _js: &[usize; BATCH],
        r2: &[f64; BATCH],
        out: &mut [f64; BATCH],
    ) {
        self.0.dw_dr_over_r_batch(r2, out);
    }
}

/// The kernel of the pair's smoothing length, W(r, h_ij) ([`PairH::of`]).
#[derive(Debug, Clone, Copy)]
pub struct VariedH<'a> {
    /// The scene's sizes.
    pub sizes: &'a Sizes,
    /// Dimension (2 or 3).
    pub dim: usize,
    /// The kernel of each level's core h, made once: most pairs take one of them.
    cores: [Kernel; LEVELS],
}

impl<'a> VariedH<'a> {
    /// The pair kernel of a scene of `sizes` in `dim` dimensions.
    pub fn new(sizes: &'a Sizes, dim: usize) -> Self {
        VariedH {
            sizes,
            dim,
            cores: std::array::from_fn(|l| Kernel::new(sizes.kind, sizes.h[l], dim)),
        }
    }
}

impl PairKernel for VariedH<'_> {
    const VARIES: bool = true;
    /// The kernel of h_ij ([`PairH::of`]): a level's core kernel when h_ij is that level's h
    /// (the same bits as making it: [`Kernel::new`] is a function of h alone), else made here
    /// (two divisions).
    #[inline(always)]
    fn of(&self, h: &[f64], i: usize, j: usize) -> Kernel {
        let hij = self.sizes.pair_h.of(h[i], h[j]);
        for k in &self.cores {
            if k.h == hij {
                return *k;
            }
        }
        Kernel::new(self.sizes.kind, hij, self.dim)
    }

    /// The pairs' kernels side by side ([`super::dw_dr_over_r_lanes`]), not one [`Kernel`]
    /// made per pair: the same bits.
    #[inline(always)]
    fn dw_dr_over_r_batch(
        &self,
        h: &[f64],
        i: usize,
        js: &[usize; BATCH],
        r2: &[f64; BATCH],
        out: &mut [f64; BATCH],
    ) {
        let hi = h[i];
        let rule = self.sizes.pair_h;
        let hij: [f64; BATCH] = std::array::from_fn(|n| rule.of(hi, h[js[n]]));
        super::dw_dr_over_r_lanes(self.sizes.kind, self.dim, &hij, r2, out);
    }
}

/// `with_pair_kernel!(sizes, kernel, dim, k => body)`: `body` with `k` the [`PairKernel`] of a
/// scene (`sizes`: `Option<&Sizes>` of a scene whose h varies, `kernel` its one [`Kernel`]),
/// compiled once per case.
#[macro_export]
macro_rules! with_pair_kernel {
    ($sizes:expr, $kernel:expr, $dim:expr, $k:ident => $body:expr) => {{
        #[allow(unused_imports)]
        use $crate::kernel::sizes::PairKernel as _;
        match $sizes {
            None => {
                let $k = $crate::kernel::sizes::OneKernel($kernel);
                $body
            }
            Some(s) => {
                let $k = $crate::kernel::sizes::VariedH::new(s, $dim);
                $body
            }
        }
    }};
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::PI;

    /// The pair kernel is symmetric and, for one h, that h's kernel bit for bit.
    #[test]
    fn pair_kernels_are_symmetric_and_exact_for_one_size() {
        let s = Sizes::new(KernelKind::WendlandC2, 0.01, 1.3, 3);
        for (a, b) in [(0.013, 0.0065), (0.0091, 0.013), (0.0013, 0.0017)] {
            assert_eq!(s.kernel::<2>(a, b).w(0.004), s.kernel::<2>(b, a).w(0.004));
            assert_eq!(s.kernel::<3>(a, b).dw_dr(0.002), s.kernel::<3>(b, a).dw_dr(0.002));
            let own = Kernel::new(KernelKind::WendlandC2, a, 2);
            assert_eq!(s.kernel::<2>(a, a).w(0.003).to_bits(), own.w(0.003).to_bits());
        }
        assert!((s.h[1] - 0.0065).abs() < 1e-15 && (s.h[3] - 0.001625).abs() < 1e-15);
        assert!((s.spacing(0, 1) - 0.0075).abs() < 1e-15);
        // the larger h: symmetric, the larger of the two, one h's kernel for one h
        let m = s.clone().with_pair_h(PairH::Max);
        assert_eq!(m.kernel::<2>(0.013, 0.0065).h, 0.013);
        assert_eq!(m.kernel::<3>(0.0065, 0.013).h, 0.013);
        assert_eq!(
            m.kernel::<2>(0.0091, 0.0091).w(0.003).to_bits(),
            s.kernel::<2>(0.0091, 0.0091).w(0.003).to_bits()
        );
    }

    /// The batch of pairs of several sizes gives each pair's (1/r) dW/dr to the bit: pairs of
    /// one level's core h, of the mean of two levels, of a transition band's h, inside, at and
    /// beyond the support and at r = 0, for every kernel in 2D and 3D and both pair rules.
    #[test]
    fn the_batch_of_several_sizes_gives_each_pairs_bits() {
        use crate::kernel::KernelKind::*;
        for (kind, rule) in [WendlandC2, CubicSpline, QuinticSpline]
            .into_iter()
            .flat_map(|k| [(k, PairH::Mean), (k, PairH::Max)])
        {
            for dim in [2usize, 3] {
                let s = Sizes::new(kind, 0.02, 2.0, 2).with_pair_h(rule);
                let h = [0.04, 0.02, 0.01, 0.0337, 0.02875, 0.0123, 0.04, 0.019, 0.0299];
                let k = VariedH::new(&s, dim);
                for i in 0..h.len() {
                    let js: [usize; BATCH] = std::array::from_fn(|n| (i + n) % h.len());
                    let r2: [f64; BATCH] = std::array::from_fn(|n| {
                        let hij = rule.of(h[i], h[js[n]]);
                        let q = [0.0, 0.3, 1.0, 1.7, 2.0, 2.5, 2.999, 3.2][n];
                        (q * hij) * (q * hij)
                    });
                    let mut out = [f64::NAN; BATCH];
                    k.dw_dr_over_r_batch(&h, i, &js, &r2, &mut out);
                    for n in 0..BATCH {
                        let one = k.of(&h, i, js[n]).dw_dr_over_r(r2[n].sqrt());
                        assert_eq!(
                            out[n].to_bits(),
                            one.to_bits(),
                            "{kind:?} {rule:?} {dim}D pair {i}-{}",
                            js[n]
                        );
                    }
                }
            }
        }
    }

    /// A coarse particle (h_c = 1.3 dx) beside a half-plane of particles four times finer
    /// (spacing dx/4, h_c/4), as beside a wall refined twice: Σ_j V_j ∇_i W_ij, which vanishes in
    /// a uniform lattice, stays within 3 % of a free surface's value (the coarse half alone)
    /// with the larger h at the interface and within 5 % one site back, and errs at least
    /// twice as much with the mean h at the interface (measured 2.2 % and 4.6 % against 6.1 %
    /// and 7.7 %).
    #[test]
    fn the_larger_h_keeps_a_coarse_particle_consistent_beside_finer_ones() {
        let dx = 0.01;
        let hc = 1.3 * dx;
        let (hf, sf) = (hc / 4.0, dx / 4.0);
        // x-component of Σ_j V_j ∇_i W_ij of the coarse particle `back` sites from the
        // interface at x = dx/2: (with the fine half, the coarse half alone)
        let sum = |rule: PairH, back: i32| {
            let s = Sizes::new(KernelKind::WendlandC2, dx, 1.3, 2).with_pair_h(rule);
            let xi = -f64::from(back) * dx;
            let grad = |x: f64, y: f64, hj: f64| {
                let (rx, r) = (xi - x, (xi - x).hypot(y));
                if r == 0.0 {
                    return 0.0;
                }
                s.kernel::<2>(hc, hj).dw_dr(r) * rx / r
            };
            let coarse: f64 = (-8..=0)
                .flat_map(|k| (-8..=8).map(move |n| (f64::from(k) * dx, f64::from(n) * dx)))
                .map(|(x, y)| dx * dx * grad(x, y, hc))
                .sum();
            let fine: f64 = (0..32)
                .flat_map(|m| (-32..32).map(move |n| (m, n)))
                .map(|(m, n)| {
                    let x = 0.5 * dx + (f64::from(m) + 0.5) * sf;
                    sf * sf * grad(x, (f64::from(n) + 0.5) * sf, hf)
                })
                .sum();
            (coarse + fine, coarse)
        };
        let free_surface = sum(PairH::Max, 0).1.abs();
        let err = |rule, back| sum(rule, back).0.abs() / free_surface;
        for back in [0, 1] {
            assert!(
                err(PairH::Max, back) < 0.05,
                "max, {back} back: {}",
                err(PairH::Max, back)
            );
        }
        assert!(err(PairH::Max, 0) < 0.03, "{}", err(PairH::Max, 0));
        assert!(
            err(PairH::Mean, 0) > 2.0 * err(PairH::Max, 0),
            "{}",
            err(PairH::Mean, 0)
        );
        assert!(
            err(PairH::Mean, 1) > err(PairH::Max, 1),
            "{}",
            err(PairH::Mean, 1)
        );
    }

    /// The initial split's load of a site: 1 + π (κh/Δp)² sites in 2D (h = 2 dx, κ = 2:
    /// 1 + round(16π) = 51); a fine particle with the scene's h lists 2^(ℓD) times as many,
    /// one with its level's h as many; a dummy wall particle 2/(3π) of them (3D: 3/16).
    #[test]
    fn site_loads_count_the_sites_in_the_support() {
        let s = Sizes::new(KernelKind::WendlandC2, 0.02, 2.0, 1);
        assert_eq!(s.site_load::<2>(0, s.h[0], false), 51);
        assert_eq!(s.site_load::<2>(1, s.h[0], false), 1 + (64.0 * PI).round() as u64);
        assert_eq!(s.site_load::<2>(1, s.h[1], false), 51);
        assert_eq!(
            s.site_load::<2>(0, s.h[0], true),
            1 + (16.0 * PI * 2.0 / (3.0 * PI)).round() as u64
        );
        let v3 = 4.0 / 3.0 * PI * 64.0;
        assert_eq!(s.site_load::<3>(0, s.h[0], false), 1 + v3.round() as u64);
        assert_eq!(
            s.site_load::<3>(0, s.h[0], true),
            1 + (v3 * 3.0 / 16.0).round() as u64
        );
    }
}

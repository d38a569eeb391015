//! Smoothing kernels W(r, h) and their radial derivatives (docs/methods.md §1b).
//!
//! `q = r/h`; every kernel is normalised so that ∫W dV = 1 in `D` dimensions (checked
//! numerically in the tests). Units: W in m⁻ᴰ, dW/dr in m⁻ᴰ⁻¹.

pub mod sizes;

use serde::{Deserialize, Serialize};
use std::f64::consts::PI;
use std::hint::select_unpredictable;

/// The kernels a scene can choose.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum KernelKind {
    /// Wendland C2: (1 − q/2)⁴ (2q + 1), support 2h.
    WendlandC2,
    /// Cubic B-spline (M4), support 2h.
    CubicSpline,
    /// Quintic spline of Morris et al. (1997), support 3h.
    QuinticSpline,
}

/// A kernel bound to a smoothing length and a dimension.
#[derive(Debug, Clone, Copy)]
pub struct Kernel {
    /// Which kernel.
    pub kind: KernelKind,
    /// Smoothing length h (m).
    pub h: f64,
    /// Support radius κh (m): pairs with r < support interact.
    pub support: f64,
    sigma: f64,
    inv_h: f64,
}

impl KernelKind {
    /// Support radius in units of h.
    pub fn support_factor(self) -> f64 {
        match self {
            KernelKind::WendlandC2 | KernelKind::CubicSpline => 2.0,
            KernelKind::QuinticSpline => 3.0,
        }
    }

    /// Normalisation σ_D for h = 1 (docs/methods.md §1b table).
    pub fn sigma(self, dim: usize) -> f64 {
        match (self, dim) {
            (KernelKind::CubicSpline, 2) => 10.0 / (7.0 * PI),
            (KernelKind::CubicSpline, _) => 1.0 / PI,
            (KernelKind::WendlandC2, 2) => 7.0 / (4.0 * PI),
            (KernelKind::WendlandC2, _) => 21.0 / (16.0 * PI),
            (KernelKind::QuinticSpline, 2) => 7.0 / (478.0 * PI),
            (KernelKind::QuinticSpline, _) => 1.0 / (120.0 * PI),
        }
    }

    /// Scene-file name of the kernel.
    pub fn name(self) -> &'static str {
        match self {
            KernelKind::WendlandC2 => "wendland_c2",
            KernelKind::CubicSpline => "cubic_spline",
            KernelKind::QuinticSpline => "quintic_spline",
        }
    }
}

impl Kernel {
    /// Kernel `kind` with smoothing length `h` (m) in `dim` dimensions.
    pub fn new(kind: KernelKind, h: f64, dim: usize) -> Self {
        Kernel {
            kind,
            h,
            support: kind.support_factor() * h,
            sigma: normalisation(kind, h, dim),
            inv_h: 1.0 / h,
        }
    }

    /// W(r, h) (m⁻ᴰ).
    #[inline]
    pub fn w(&self, r: f64) -> f64 {
        let q = r * self.inv_h;
        self.sigma * shape(self.kind, q)
    }

    /// dW/dr (m⁻ᴰ⁻¹); negative inside the support.
    #[inline]
    pub fn dw_dr(&self, r: f64) -> f64 {
        let q = r * self.inv_h;
        self.sigma * self.inv_h * dshape(self.kind, q)
    }

    /// (1/r) dW/dr (m⁻ᴰ⁻²), finite at r = 0 for every kernel here (dW/dr ∝ r near the
    /// origin): x_ij·∇_i W_ij / r² = (1/r) dW/dr without any regularisation.
    #[inline]
    pub fn dw_dr_over_r(&self, r: f64) -> f64 {
        let q = r * self.inv_h;
        self.sigma * self.inv_h * self.inv_h * dshape_over_q(self.kind, q)
    }

    /// (1/r) dW/dr (m⁻ᴰ⁻²) of [`BATCH`] squared separations `r2` (m²) into `out`: for each,
    /// to the bit what [`Kernel::dw_dr_over_r`] gives of `r2.sqrt()`. Written without a
    /// branch, every piece of the kernel computed and one selected, so that the compiler
    /// evaluates the square roots and divisions of several pairs in one instruction and no
    /// branch on q is mispredicted (a pair pass's kernel evaluations were a quarter of the 3D
    /// dam break's step, docs/benchmark-log.md, "Mispredicted branches in the pair passes").
    #[inline(always)]
    pub fn dw_dr_over_r_batch(&self, r2: &[f64; BATCH], out: &mut [f64; BATCH]) {
        let s = self.sigma * self.inv_h * self.inv_h;
        let inv_h = self.inv_h;
        match self.kind {
            KernelKind::CubicSpline => {
                for (o, &r2) in out.iter_mut().zip(r2) {
                    let q = r2.sqrt() * inv_h;
                    let a = 2.0 - q;
                    // the pieces of `dshape_over_q`, each in its own order of operations
                    let near = -3.0 + 2.25 * q;
                    let far = -0.75 * a * a / q;
                    let d = if q < 1.0 {
                        near
                    } else if q < 2.0 {
                        far
                    } else {
                        0.0
                    };
                    *o = s * d;
                }
            }
            KernelKind::WendlandC2 => {
                for (o, &r2) in out.iter_mut().zip(r2) {
                    let q = r2.sqrt() * inv_h;
                    let a = (1.0 - 0.5 * q).max(0.0);
                    *o = s * (0.0 - 5.0 * a * a * a);
                }
            }
            KernelKind::QuinticSpline => {
                for (o, &r2) in out.iter_mut().zip(r2) {
                    *o = self.dw_dr_over_r(r2.sqrt());
                }
            }
        }
    }
}

/// σ_D / hᴰ (m⁻ᴰ) of kernel `kind` with smoothing length `h` (m) in `dim` dimensions. h·h and
/// h·(h·h) are h.powi(2) and h.powi(3) bit for bit (powi multiplies by repeated squaring),
/// without the library call per pair of several sizes.
#[inline(always)]
fn normalisation(kind: KernelKind, h: f64, dim: usize) -> f64 {
    kind.sigma(dim)
        / match dim {
            2 => h * h,
            3 => h * (h * h),
            _ => h.powi(dim as i32),
        }
}

/// (1/r) dW/dr (m⁻ᴰ⁻²) of [`BATCH`] pairs of one kernel family, each of its own smoothing
/// length `h[n]` (m), at squared separations `r2[n]` (m²), into `out`: for each, to the bit what
/// `Kernel::new(kind, h[n], dim).dw_dr_over_r(r2[n].sqrt())` gives (the same operations in
/// the same order). The pairs of two sizes (`sizes::VariedH`) made a kernel per pair, two
/// divisions each, one pair at a time: in the adaptive solitary wave with a 0.96 m band, where
/// most pairs mix two h, that was 18 % of the run (docs/benchmark-log.md, "The kernels of pairs of
/// two sizes side by side"). Here the lanes are computed side by side for Wendland C2, whose
/// branch-free shape the compiler vectorises once kind and dimension are constants in the loop (one
/// loop over any kind ran the 0.4 s segment 1.12 × as long); the splines' lanes one at a time.
#[inline(always)]
pub fn dw_dr_over_r_lanes(
    kind: KernelKind,
    dim: usize,
    h: &[f64; BATCH],
    r2: &[f64; BATCH],
    out: &mut [f64; BATCH],
) {
    let lanes = |kind: KernelKind, dim: usize, out: &mut [f64; BATCH]| {
        for ((o, &h), &r2) in out.iter_mut().zip(h).zip(r2) {
            let inv_h = 1.0 / h;
            let q = r2.sqrt() * inv_h;
            *o = normalisation(kind, h, dim) * inv_h * inv_h * dshape_over_q(kind, q);
        }
    };
    match (kind, dim) {
        (KernelKind::WendlandC2, 2) => lanes(KernelKind::WendlandC2, 2, out),
        (KernelKind::WendlandC2, 3) => lanes(KernelKind::WendlandC2, 3, out),
        _ => lanes(kind, dim, out),
    }
}

/// Pairs per batch of [`Kernel::dw_dr_over_r_batch`]: four vector registers' worth of f64 at
/// SSE2's two lanes, two at AVX's four.
pub const BATCH: usize = 8;

/// Dimensionless shape f(q), W = σ_D/hᴰ · f(q).
#[inline]
fn shape(kind: KernelKind, q: f64) -> f64 {
    match kind {
        KernelKind::WendlandC2 => {
            // a = 0 beyond the support: no branch (stored Verlet lists hold pairs beyond it)
            let a = (1.0 - 0.5 * q).max(0.0);
            let a2 = a * a;
            a2 * a2 * (2.0 * q + 1.0)
        }
        KernelKind::CubicSpline => {
            if q < 1.0 {
                1.0 - 1.5 * q * q + 0.75 * q * q * q
            } else if q < 2.0 {
                let a = 2.0 - q;
                0.25 * a * a * a
            } else {
                0.0
            }
        }
        KernelKind::QuinticSpline => {
            let p5 = |a: f64| if a > 0.0 { a * a * a * a * a } else { 0.0 };
            p5(3.0 - q) - 6.0 * p5(2.0 - q) + 15.0 * p5(1.0 - q)
        }
    }
}

/// df/dq.
#[inline]
fn dshape(kind: KernelKind, q: f64) -> f64 {
    match kind {
        KernelKind::WendlandC2 => {
            // d/dq[(1-q/2)^4 (2q+1)] = -5 q (1-q/2)^3, selected rather than branched on
            // (`dshape_over_q`); −0.0 at q = 0 as the branch gave
            let a = 1.0 - 0.5 * q;
            select_unpredictable(q < 2.0, -5.0 * q * a * a * a, 0.0)
        }
        KernelKind::CubicSpline => {
            if q < 1.0 {
                -3.0 * q + 2.25 * q * q
            } else if q < 2.0 {
                let a = 2.0 - q;
                -0.75 * a * a
            } else {
                0.0
            }
        }
        KernelKind::QuinticSpline => {
            let p4 = |a: f64| if a > 0.0 { a * a * a * a } else { 0.0 };
            -5.0 * (p4(3.0 - q) - 6.0 * p4(2.0 - q) + 15.0 * p4(1.0 - q))
        }
    }
}

/// (1/q) df/dq in closed form, finite as q → 0.
#[inline]
fn dshape_over_q(kind: KernelKind, q: f64) -> f64 {
    match kind {
        KernelKind::WendlandC2 => {
            // Without a branch: a = 0 beyond the support, where 0 − 5a³ is +0.0 as the
            // branch gave, and inside it 0 − 5a³ is −5a³ to the bit (negation is exact).
            // Verlet lists hold pairs up to the skin beyond the support, whose outcome a
            // branch predicts badly.
            let a = (1.0 - 0.5 * q).max(0.0);
            0.0 - 5.0 * a * a * a
        }
        KernelKind::CubicSpline => {
            // Branches, not a select of both pieces: the select removed 40 % of a 3D run's
            // mispredicted branches (q < 1 for an eighth of the support) but added 3 % of its
            // instructions (both pieces and a division for every pair); no time difference
            // could be resolved on this machine (docs/benchmark-log.md, "Mispredicted branches in the
            // pair passes"), so the code stays as it was.
            if q < 1.0 {
                -3.0 + 2.25 * q
            } else {
                dshape(kind, q) / q
            }
        }
        KernelKind::QuinticSpline => {
            if q < 1.0 {
                // f(q) = 66 − 60q² + 30q⁴ − 10q⁵ for q < 1
                -120.0 + 120.0 * q * q - 50.0 * q * q * q
            } else {
                dshape(kind, q) / q
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const ALL: [KernelKind; 3] = [
        KernelKind::WendlandC2,
        KernelKind::CubicSpline,
        KernelKind::QuinticSpline,
    ];

    /// The batch gives each pair's (1/r) dW/dr to the bit, inside, at and beyond the support
    /// (Verlet lists hold pairs beyond it), at the pieces' joints and at r = 0.
    #[test]
    fn the_batch_gives_each_pairs_bits() {
        for kind in ALL {
            for dim in [2usize, 3] {
                let k = Kernel::new(kind, 0.0147, dim);
                let mut r: Vec<f64> = (0..4001).map(|i| 1.25 * k.support * i as f64 / 4000.0).collect();
                r.extend([0.0, k.h, 2.0 * k.h, 3.0 * k.h, k.support, k.h * (1.0 + 1e-16)]);
                for chunk in r.chunks(BATCH) {
                    let mut r2 = [0.0; BATCH];
                    for (a, b) in r2.iter_mut().zip(chunk) {
                        *a = b * b;
                    }
                    let mut out = [f64::NAN; BATCH];
                    k.dw_dr_over_r_batch(&r2, &mut out);
                    for (o, r2) in out.iter().zip(r2) {
                        let one = k.dw_dr_over_r(r2.sqrt());
                        assert_eq!(o.to_bits(), one.to_bits(), "{kind:?} {dim}D r² = {r2}");
                    }
                }
            }
        }
    }

    /// ∫W dV = 1, by the midpoint rule in polar (2D) and spherical (3D) shells.
    #[test]
    fn kernels_are_normalised() {
        for kind in ALL {
            for dim in [2usize, 3] {
                let k = Kernel::new(kind, 0.37, dim);
                let n = 20_000;
                let dr = k.support / n as f64;
                let mut s = 0.0;
                for i in 0..n {
                    let r = (i as f64 + 0.5) * dr;
                    let shell = if dim == 2 { 2.0 * PI * r } else { 4.0 * PI * r * r };
                    s += k.w(r) * shell * dr;
                }
                assert!((s - 1.0).abs() < 1e-7, "{kind:?} {dim}D integrates to {s}");
            }
        }
    }

    /// dW/dr agrees with a central difference of W and vanishes at and beyond the support.
    #[test]
    fn derivative_matches_finite_difference() {
        for kind in ALL {
            let k = Kernel::new(kind, 0.5, 3);
            for i in 1..60 {
                let r = i as f64 * k.support / 61.0;
                let e = 1e-6;
                let fd = (k.w(r + e) - k.w(r - e)) / (2.0 * e);
                assert!(
                    (fd - k.dw_dr(r)).abs() < 1e-5 * k.w(0.0).abs() / k.h,
                    "{kind:?} r={r}"
                );
            }
            assert_eq!(k.w(k.support), 0.0);
            assert_eq!(k.dw_dr(k.support), 0.0);
            assert_eq!(k.dw_dr_over_r(k.support), 0.0);
            // (1/r) dW/dr: the closed form agrees with the quotient and stays finite at r = 0
            for i in 1..60 {
                let r = i as f64 * k.support / 61.0;
                let q = k.dw_dr(r) / r;
                assert!((k.dw_dr_over_r(r) - q).abs() < 1e-10 * q.abs().max(1.0 / k.h.powi(5)));
            }
            let tiny = 1e-7 * k.h;
            let at0 = k.dw_dr_over_r(0.0);
            assert!(at0 < 0.0 && at0.is_finite());
            assert!((k.dw_dr_over_r(tiny) - at0).abs() < 1e-6 * at0.abs(), "{kind:?}");
            assert_eq!(k.w(1.5 * k.support), 0.0);
        }
    }

    /// The shapes as piecewise branches: Wendland C2's form before its branch was removed.
    fn piecewise(kind: KernelKind, q: f64) -> [f64; 3] {
        match kind {
            KernelKind::WendlandC2 if q < 2.0 => {
                let a = 1.0 - 0.5 * q;
                [
                    (a * a) * (a * a) * (2.0 * q + 1.0),
                    -5.0 * q * a * a * a,
                    -5.0 * a * a * a,
                ]
            }
            KernelKind::CubicSpline if q < 1.0 => [
                1.0 - 1.5 * q * q + 0.75 * q * q * q,
                -3.0 * q + 2.25 * q * q,
                -3.0 + 2.25 * q,
            ],
            KernelKind::CubicSpline if q < 2.0 => {
                let a = 2.0 - q;
                [0.25 * a * a * a, -0.75 * a * a, -0.75 * a * a / q]
            }
            _ => [0.0; 3],
        }
    }

    /// The branch-free Wendland C2 (and the cubic spline) give the piecewise definition's
    /// bits, the sign of zero included, on both sides of every break point, at it and far
    /// beyond the support (where Verlet lists hold pairs).
    #[test]
    fn branch_free_shapes_equal_the_piecewise_definition_to_the_bit() {
        let mut qs: Vec<f64> = (0..=4000).map(|i| i as f64 * 1e-3).collect();
        for b in [1.0f64, 2.0] {
            qs.extend([b, b.next_down(), b.next_up()]);
        }
        qs.extend([1e-300, 7.5, 1e6]);
        for kind in [KernelKind::WendlandC2, KernelKind::CubicSpline] {
            for &q in &qs {
                let got = [shape(kind, q), dshape(kind, q), dshape_over_q(kind, q)];
                let want = piecewise(kind, q);
                for (g, w) in got.iter().zip(want) {
                    assert_eq!(
                        g.to_bits(),
                        w.to_bits(),
                        "{kind:?} q = {q:e}: {g:e} against {w:e}"
                    );
                }
            }
        }
    }
}

//! Two refinements of Morris et al. (1997)'s laminar viscous term, each a scene switch.
//!
//! The term (module docs of [`super::fluid`]) is, for fluid i and neighbour j,
//!   dv_i/dt ⊃ Σ_j m_j (μ_i + μ_j)/(ρ_i ρ_j) (1/r) W′(r) v_ij.
//! For u = x² it returns 2 L instead of 2, where the lattice moment
//!   L_i = −(1/D) Σ_j V_j r_ij W′(r_ij)   (–, V_j = m_j/ρ_j, over smoothed neighbours j)
//! is 1 for the continuous integral but not on a lattice: 0.964 for Wendland C2 at h = 1.2 dx
//! on the square lattice, which makes the viscosity 3.6 % low and Poiseuille's peak speed
//! 3.7 % high whatever the resolution (docs/validation.md §4).
//!
//! - **`physics.viscous_operator = "renormalised"`** multiplies the pair's term by
//!   2/(L_i + L_j) (symmetric, so momentum stays conserved; 1/L_i against a dummy wall j),
//!   which makes the operator exact for quadratic fields wherever the support is full. L_i
//!   is clamped at ≥ [`MIN_MOMENT`]: near a free surface the support is truncated and L
//!   falls towards ½, where renormalising would only amplify the truncation.
//! - **`wall[].no_slip = "morris"`** replaces Adami's extrapolated wall velocity in the
//!   laminar term by Morris's distance ratio, v_i − v_w = β (v_i − u_wall), β = 1 + d_w/d_i
//!   ([`crate::boundary::geometry`]): exact for a linear profile, where Adami's kernel-weighted
//!   mean puts the no-slip point O(h) off the surface. On a mirror wall it replaces the
//!   reflected velocity of an image j′ (v_j′ = 2 u_w − v_j) by the same ratio with d_j′ the
//!   image's depth behind the face: both are exact for a linear profile, but the reflection
//!   drops a quadratic profile's curvature, 2b d_j′² for u − u_w = a d + b d², where Morris's
//!   ratio drops b d_j′ (d_i + d_j′), less for the images deeper than the particle. A steady
//!   lattice model of the channel gives 0.59 → 0.47 % (cubic, h = 2 dx, n = 25; measured the
//!   same, docs/validation.md §4). A corner image, reflected on two axes, keeps the reflection.
//!
//! Both are exact for the flows they target on a steady lattice; together they bring every
//! kernel and h/dx of the Poiseuille sweep within 0.5 % at 25 rows (docs/validation.md §4).

use super::fluid::PairTerms;
use super::Model;
use crate::boundary::geometry::{morris_beta, WallSurface};
use crate::boundary::mirror::{planes_of, MirrorPlane};
use crate::cells::Neighbours;
use crate::particles::{Kind, Particles, IMAGE_BITS};
use crate::scene::{NoSlipMethod, Scene, Slip, ViscousOperator};
use crate::Vector;
use rayon::prelude::*;

/// Smallest lattice moment the renormalised operator divides by (–).
pub const MIN_MOMENT: f64 = 0.5;

/// The scene's choices for the laminar term.
#[derive(Debug, Clone, Default)]
pub struct Viscous<const D: usize> {
    /// `physics.viscous_operator = "renormalised"`.
    pub renormalised: bool,
    /// Per wall body, its surface where `no_slip = "morris"` applies.
    pub morris: Vec<Option<WallSurface<D>>>,
    /// True if some dummy wall uses Morris's no-slip.
    pub any_morris: bool,
    /// Every mirror plane of the scene (to find the one an image was reflected across).
    pub planes: Vec<MirrorPlane<D>>,
    /// True if some mirror plane uses Morris's no-slip.
    pub any_mirror_morris: bool,
    /// Smallest fluid depth d_i in β (m): half a spacing.
    pub floor: f64,
}

impl<const D: usize> Viscous<D> {
    /// The choices of scene `s`.
    pub fn new(s: &Scene) -> Self {
        let morris: Vec<Option<WallSurface<D>>> = s
            .walls
            .iter()
            .map(|w| {
                let on = w.no_slip == NoSlipMethod::Morris
                    && w.method.takes_morris_no_slip()
                    && w.slip == Slip::NoSlip;
                on.then(|| WallSurface::new(w))
            })
            .collect();
        let planes: Vec<MirrorPlane<D>> = planes_of(s);
        Viscous {
            renormalised: s.physics.viscous_operator == ViscousOperator::Renormalised,
            any_morris: morris.iter().any(Option::is_some),
            morris,
            any_mirror_morris: planes.iter().any(|pl| pl.morris),
            planes,
            floor: 0.5 * s.discretisation.dx,
        }
    }

    /// The velocity difference (m/s) the laminar term of fluid particle i (`ti`: its position,
    /// velocity and lattice moment) applies to smoothed neighbour j, given Adami's difference
    /// `vij` (v_i − v_w for a dummy wall, v_i − v_j otherwise), times the renormalisation
    /// 2/(L_i + L_j) when it is on.
    #[inline(always)]
    pub fn difference(
        &self,
        p: &Particles<D>,
        wall_shift: &[Vector<D>],
        ti: &PairTerms<D>,
        j: usize,
        vij: Vector<D>,
    ) -> Vector<D> {
        let dummy = p.kind[j] == Kind::Dummy;
        let mut d = vij;
        if self.any_morris || self.any_mirror_morris {
            d = self.morris_difference(p, wall_shift, ti, j, vij);
        }
        if self.renormalised {
            let lj = if dummy { ti.lap } else { p.lap[j] };
            d *= 2.0 / (ti.lap + lj);
        }
        d
    }
}

impl<const D: usize> Viscous<D> {
    /// [`Self::difference`] before renormalisation where some wall uses Morris's no-slip:
    /// Morris's difference against a dummy particle of such a wall or an image across such
    /// a mirror plane, `vij` otherwise. Kept out of line, so that scenes without it keep
    /// their laminar loop as it was.
    #[inline(never)]
    fn morris_difference(
        &self,
        p: &Particles<D>,
        wall_shift: &[Vector<D>],
        ti: &PairTerms<D>,
        j: usize,
        vij: Vector<D>,
    ) -> Vector<D> {
        if p.kind[j] == Kind::Dummy {
            let body = p.body[j] as usize;
            if let Some(surface) = &self.morris[body] {
                if let Some((di, dj)) = surface.depths(&ti.x, &p.x[j], &wall_shift[body]) {
                    return (ti.v - p.v[j]) * morris_beta(di, dj, self.floor);
                }
            }
            return vij;
        }
        self.mirror_difference(p, &ti.x, &ti.v, j).unwrap_or(vij)
    }

    /// Morris's v_a − v_b′ = β (v_a − u_w), β = 1 + d_b′/d_a, for particle a (at `xa`, moving
    /// at `va`) against neighbour b when b is the image of a fluid particle across a single
    /// mirror plane with `no_slip = "morris"`; `None` otherwise (the caller keeps the
    /// reflected velocity). The plane is read from b's sort key (the axis and which side it
    /// reflected) and, among the planes of that axis and side, the one between a and b
    /// nearest to a.
    #[inline]
    pub fn mirror_difference(
        &self,
        p: &Particles<D>,
        xa: &Vector<D>,
        va: &Vector<D>,
        b: usize,
    ) -> Option<Vector<D>> {
        if !self.any_mirror_morris {
            return None;
        }
        let code = p.key[b] & ((1u64 << IMAGE_BITS) - 1);
        if code == 0 {
            return None;
        }
        // the axis reflected (code 3: across a lower face, 4: an upper one; AxisOp::code)
        let mut reflected = None;
        for a in 0..D {
            let c = (code >> (3 * a)) & 7;
            if c == 3 || c == 4 {
                if reflected.is_some() {
                    return None;
                }
                reflected = Some((a, c == 3));
            }
        }
        let (axis, lower) = reflected?;
        let xb = &p.x[b];
        let between = |pl: &&MirrorPlane<D>| {
            pl.axis == axis
                && pl.fluid_above == lower
                && if lower {
                    xa[axis] >= pl.at && xb[axis] <= pl.at
                } else {
                    xa[axis] <= pl.at && xb[axis] >= pl.at
                }
        };
        let plane = self
            .planes
            .iter()
            .filter(between)
            .min_by(|u, v| (xa[axis] - u.at).abs().total_cmp(&(xa[axis] - v.at).abs()))?;
        if !plane.morris {
            return None;
        }
        let (da, db) = ((xa[axis] - plane.at).abs(), (xb[axis] - plane.at).abs());
        Some((va - plane.wall_velocity) * morris_beta(da, db, self.floor))
    }
}

/// L_i of every owned fluid particle into `p.lap` (the others get 1), over smoothed
/// neighbours other than solids; `vol` is scratch (kept by the caller).
pub fn lattice_moment<const D: usize, N: Neighbours>(
    p: &mut Particles<D>,
    nl: &N,
    model: &Model<D>,
    vol: &mut Vec<f64>,
) {
    let n = p.n_owned;
    let mut lap = std::mem::take(&mut p.lap);
    {
        let p = &*p;
        super::fluid::volumes_into(p, vol);
        let vol = &*vol;
        crate::with_pair_kernel!(model.varying(), model.kernel, D, kern => {
            lap[..n].par_iter_mut().enumerate().for_each(|(i, l)| {
                if !nl.visits(i) {
                    return;
                }
                *l = 1.0;
                if !p.kind[i].is_fluid() {
                    return;
                }
                let mut s = 0.0;
                for j in nl.iter(i) {
                    let j = j as usize;
                    if !p.kind[j].is_smoothed() || p.kind[j].is_solid() {
                        continue;
                    }
                    let r2 = (p.x[i] - p.x[j]).norm_squared();
                    s += vol[j] * r2 * kern.of(&p.h, i, j).dw_dr_over_r(r2.sqrt());
                }
                *l = moment_of::<D>(s);
            })
        });
    }
    p.lap = lap;
}

/// L from the sum Σ_j V_j r² (1/r) W′ (m² · m⁻²), clamped at ≥ [`MIN_MOMENT`].
#[inline]
pub fn moment_of<const D: usize>(sum: f64) -> f64 {
    (-sum / D as f64).max(MIN_MOMENT)
}

//! Ghost particles of this rank: periodic images and mirror images of owned particles.
//!
//! A ghost is an owned particle seen through an image operation: per axis, nothing, a periodic
//! shift by ±L, or a reflection across a mirror wall plane. The plan (who is copied under which
//! operation) is built when particles are re-binned and reused by [`GhostPlan::refresh`] after
//! every pass that changes fields the next pass reads. The parallel engine (issue 3) adds
//! ghosts received from other ranks through the same image operations, so a periodic
//! neighbour is always a shifted image, on one rank or many.

use crate::particles::{Kind, Particles, IMAGE_BITS};
use crate::Vector;

/// A mirror wall plane: the inner face of a container with `method = "mirror"`.
#[derive(Debug, Clone)]
pub struct MirrorPlane<const D: usize> {
    /// Axis normal to the plane.
    pub axis: usize,
    /// Plane position along the axis (m).
    pub at: f64,
    /// True if the fluid lies on the + side (the plane is a lower face).
    pub fluid_above: bool,
    /// Surface velocity of the wall (m/s).
    pub wall_velocity: Vector<D>,
    /// No-slip (reflect the whole velocity about the wall's) or free-slip (normal only).
    pub no_slip: bool,
}

/// What happens to a particle along one axis to make an image.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum AxisOp {
    /// Unchanged.
    Keep,
    /// Periodic shift by this amount (m).
    Shift(f64),
    /// Reflection across mirror plane number `usize`.
    Mirror(usize),
}

impl AxisOp {
    /// Image code of this axis operation (3 bits) in a sort key.
    pub fn code(self, planes: &[impl HasSide]) -> u64 {
        match self {
            AxisOp::Keep => 0,
            AxisOp::Shift(s) if s > 0.0 => 1,
            AxisOp::Shift(_) => 2,
            AxisOp::Mirror(k) => {
                if planes[k].above() {
                    3
                } else {
                    4
                }
            }
        }
    }
}

/// A mirror plane's side (which side the fluid is on).
pub trait HasSide {
    /// True if the fluid lies above the plane.
    fn above(&self) -> bool;
}
impl<const D: usize> HasSide for MirrorPlane<D> {
    fn above(&self) -> bool {
        self.fluid_above
    }
}

/// Periodic box and mirror planes: the geometry ghosts are made from.
#[derive(Debug, Clone)]
pub struct ImageSpace<const D: usize> {
    /// Domain lower corner (m).
    pub min: Vector<D>,
    /// Domain upper corner (m).
    pub max: Vector<D>,
    /// Periodic axes.
    pub periodic: [bool; D],
    /// Mirror planes.
    pub planes: Vec<MirrorPlane<D>>,
}

impl<const D: usize> ImageSpace<D> {
    /// Wrap a position into the periodic box (in place).
    #[inline]
    pub fn wrap(&self, x: &mut Vector<D>) {
        for a in 0..D {
            if self.periodic[a] {
                let l = self.max[a] - self.min[a];
                if x[a] >= self.max[a] {
                    x[a] -= l;
                } else if x[a] < self.min[a] {
                    x[a] += l;
                }
                if x[a] >= self.max[a] {
                    x[a] = self.min[a];
                }
            }
        }
    }

    /// True if `x` lies inside the domain on every non-periodic axis.
    #[inline]
    pub fn contains(&self, x: &Vector<D>) -> bool {
        (0..D).all(|a| self.periodic[a] || (x[a] >= self.min[a] && x[a] <= self.max[a]))
    }
}

/// Which owned particle each ghost copies, under which operation.
#[derive(Debug, Clone, Default)]
pub struct GhostPlan<const D: usize> {
    /// Source (owned) index of each ghost, in ghost order.
    pub src: Vec<u32>,
    /// Image operation of each ghost.
    pub ops: Vec<[AxisOp; D]>,
}

impl<const D: usize> GhostPlan<D> {
    /// Rebuild all ghosts of `p` for kernel support `support`: drops old ghosts, appends new
    /// ones with positions set; call [`GhostPlan::refresh`] before reading their fields.
    pub fn build(&mut self, p: &mut Particles<D>, space: &ImageSpace<D>, support: f64) {
        p.truncate_ghosts();
        self.src.clear();
        self.ops.clear();
        let mut options: Vec<Vec<AxisOp>> = vec![Vec::with_capacity(3); D];
        for i in 0..p.n_owned {
            let x = p.x[i];
            let mut any = false;
            for (a, opts) in options.iter_mut().enumerate() {
                opts.clear();
                opts.push(AxisOp::Keep);
                if space.periodic[a] {
                    let l = space.max[a] - space.min[a];
                    if x[a] - space.min[a] < support {
                        opts.push(AxisOp::Shift(l));
                    }
                    if space.max[a] - x[a] <= support {
                        opts.push(AxisOp::Shift(-l));
                    }
                }
                if p.kind[i] == Kind::Fluid {
                    for (k, pl) in space.planes.iter().enumerate() {
                        let d = x[a] - pl.at;
                        if pl.axis == a
                            && ((pl.fluid_above && d >= 0.0) || (!pl.fluid_above && d <= 0.0))
                            && d.abs() < support
                        {
                            opts.push(AxisOp::Mirror(k));
                        }
                    }
                }
                any |= opts.len() > 1;
            }
            if !any {
                continue;
            }
            // every combination except all-Keep, in a fixed order
            let total: usize = options.iter().map(|o| o.len()).product();
            for combo in 1..total {
                let mut r = combo;
                let mut ops = [AxisOp::Keep; D];
                for a in (0..D).rev() {
                    let n = options[a].len();
                    ops[a] = options[a][r % n];
                    r /= n;
                }
                let mut xg = x;
                let mut code = 0u64;
                for a in 0..D {
                    match ops[a] {
                        AxisOp::Keep => {}
                        AxisOp::Shift(s) => xg[a] += s,
                        AxisOp::Mirror(k) => xg[a] = 2.0 * space.planes[k].at - xg[a],
                    }
                    code |= ops[a].code(&space.planes) << (3 * a);
                }
                debug_assert!(code < (1 << IMAGE_BITS));
                p.push_ghost(i, xg, (p.id[i] << IMAGE_BITS) | code);
                self.src.push(i as u32);
                self.ops.push(ops);
            }
        }
    }

    /// Number of ghosts.
    pub fn len(&self) -> usize {
        self.src.len()
    }

    /// True if there are no ghosts.
    pub fn is_empty(&self) -> bool {
        self.src.is_empty()
    }

    /// Copy the current fields of each source onto its ghost, transformed by the image
    /// operation (velocities and gradients reflect across mirror planes).
    pub fn refresh(&self, p: &mut Particles<D>, space: &ImageSpace<D>) {
        let n = p.n_owned;
        for (g, (&s, ops)) in self.src.iter().zip(&self.ops).enumerate() {
            let s = s as usize;
            let gi = n + g;
            let mut v = p.v[s];
            let mut grad = p.grad_rho[s];
            for (a, op) in ops.iter().enumerate() {
                if let AxisOp::Mirror(k) = *op {
                    let pl = &space.planes[k];
                    if pl.no_slip {
                        v = 2.0 * pl.wall_velocity - v;
                    } else {
                        v[a] = 2.0 * pl.wall_velocity[a] - v[a];
                    }
                    grad[a] = -grad[a];
                }
            }
            p.v[gi] = v;
            p.grad_rho[gi] = grad;
            p.rho[gi] = p.rho[s];
            p.p[gi] = p.p[s];
            p.mass[gi] = p.mass[s];
            p.vw[gi] = p.vw[s];
        }
    }
}

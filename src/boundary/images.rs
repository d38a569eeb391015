//! Image geometry, in one place: the periodic box and mirror planes ([`ImageSpace`]), the
//! per-axis image operations ([`AxisOp`]) whose codes make up a ghost's sort key, which images
//! a particle has ([`images_of`]) and how each field looks through one ([`Image`]).
//! [`crate::halo`] builds and refreshes the ghosts themselves, on one rank or many, through the
//! same path; the periodic and mirror specifics are in [`super::periodic`] and
//! [`super::mirror`].

pub use super::axis_op::AxisOp;
use super::mirror::MirrorPlane;
use crate::particles::{Imager, IMAGE_BITS};
use crate::{Tensor, Vector};

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

    /// Position and sort-key image code of `x` under `ops`.
    #[inline]
    pub fn apply(&self, x: &Vector<D>, ops: &[AxisOp; D]) -> (Vector<D>, u64) {
        let mut xg = *x;
        let mut code = 0u64;
        for a in 0..D {
            match ops[a] {
                AxisOp::Keep => {}
                AxisOp::Shift(s) => xg[a] += s,
                AxisOp::Mirror(k) => xg[a] = self.planes[k].reflect(xg[a]),
            }
            code |= self::code(ops[a], &self.planes) << (3 * a);
        }
        debug_assert!(code < (1 << IMAGE_BITS));
        (xg, code)
    }

    /// One image operation of particle `id`, ready to transform its fields.
    #[inline]
    pub fn image<'a>(&'a self, id: u64, ops: &'a [AxisOp; D]) -> Image<'a, D> {
        Image { space: self, ops, id }
    }
}

/// Image code of axis operation `op` (3 bits) in a sort key.
fn code<const D: usize>(op: AxisOp, planes: &[MirrorPlane<D>]) -> u64 {
    match op {
        AxisOp::Keep => 0,
        AxisOp::Shift(s) if s > 0.0 => 1,
        AxisOp::Shift(_) => 2,
        AxisOp::Mirror(k) => {
            if planes[k].fluid_above {
                3
            } else {
                4
            }
        }
    }
}

/// True if `ops` leaves a particle where it is (the plain particle, not an image).
#[inline]
pub fn is_plain<const D: usize>(ops: &[AxisOp; D]) -> bool {
    ops.iter().all(|o| *o == AxisOp::Keep)
}

/// The image operations of a particle at `x` (the plain one first), in a fixed order: per axis
/// keep, then the periodic shifts ([`super::periodic::shifts`]), then — for particles that
/// have mirror images (fluid) — the reflections ([`super::mirror::reflections`]); every
/// combination over the axes, last axis fastest. `options` is scratch space.
pub fn images_of<const D: usize>(
    x: &Vector<D>,
    mirrored: bool,
    space: &ImageSpace<D>,
    support: f64,
    options: &mut [Vec<AxisOp>],
    out: &mut Vec<[AxisOp; D]>,
) {
    out.clear();
    for (a, opts) in options.iter_mut().enumerate() {
        opts.clear();
        opts.push(AxisOp::Keep);
        if space.periodic[a] {
            super::periodic::shifts(x[a], space.min[a], space.max[a], support, opts);
        }
        if mirrored {
            super::mirror::reflections(x, a, &space.planes, support, opts);
        }
    }
    let total: usize = options.iter().map(|o| o.len()).product();
    for combo in 0..total {
        let mut r = combo;
        let mut ops = [AxisOp::Keep; D];
        for a in (0..D).rev() {
            let n = options[a].len();
            ops[a] = options[a][r % n];
            r /= n;
        }
        out.push(ops);
    }
}

/// One image operation of one particle: transforms its fields by their [`crate::particles::ImageRule`].
pub struct Image<'a, const D: usize> {
    space: &'a ImageSpace<D>,
    ops: &'a [AxisOp; D],
    id: u64,
}

impl<const D: usize> Imager<D> for Image<'_, D> {
    #[inline]
    fn key(&self) -> u64 {
        (self.id << IMAGE_BITS) | self.space.apply(&Vector::zeros(), self.ops).1
    }

    #[inline]
    fn position(&self, x: &Vector<D>) -> Vector<D> {
        self.space.apply(x, self.ops).0
    }

    #[inline]
    fn velocity(&self, v: &Vector<D>) -> Vector<D> {
        let mut v = *v;
        for op in self.ops.iter() {
            if let AxisOp::Mirror(k) = *op {
                v = self.space.planes[k].reflect_velocity(&v);
            }
        }
        v
    }

    #[inline]
    fn vector(&self, v: &Vector<D>) -> Vector<D> {
        let mut v = *v;
        for (a, op) in self.ops.iter().enumerate() {
            if let AxisOp::Mirror(_) = *op {
                v[a] = -v[a];
            }
        }
        v
    }

    #[inline]
    fn tensor(&self, t: &Tensor<D>) -> Tensor<D> {
        let mut t = *t;
        for (a, op) in self.ops.iter().enumerate() {
            if let AxisOp::Mirror(_) = *op {
                for b in 0..D {
                    if b != a {
                        t[(a, b)] = -t[(a, b)];
                        t[(b, a)] = -t[(b, a)];
                    }
                }
            }
        }
        t
    }
}

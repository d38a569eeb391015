//! Image geometry of ghost particles: the periodic box and mirror wall planes, and the
//! per-axis image operations (keep, periodic shift, mirror reflection) whose codes make up a
//! ghost's sort key. [`crate::halo`] builds and refreshes the ghosts themselves, on one rank or
//! many, through the same path.

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

//! Periodic boundaries: positions wrap into the box, and a particle within the support of a
//! periodic face gets an image shifted by ±L along that axis (L = max − min).

use super::images::{AxisOp, ImageSpace};
use crate::Vector;

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
}

/// Periodic image shifts of `x` along axis `a`: +L within the support of the lower face
/// (strictly), −L within the support of the upper face (inclusive), appended to `out`.
#[inline]
pub fn shifts<const D: usize>(
    x: &Vector<D>,
    a: usize,
    space: &ImageSpace<D>,
    support: f64,
    out: &mut Vec<AxisOp>,
) {
    if space.periodic[a] {
        let l = space.max[a] - space.min[a];
        if x[a] - space.min[a] < support {
            out.push(AxisOp::Shift(l));
        }
        if space.max[a] - x[a] <= support {
            out.push(AxisOp::Shift(-l));
        }
    }
}

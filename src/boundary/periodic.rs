//! Periodic boundaries: a particle within the support of a periodic face gets an image
//! shifted by ±L along that axis (L = max − min); positions wrap into the box
//! (`ImageSpace::wrap`).

use super::axis_op::AxisOp;

/// Periodic image shifts of a particle at coordinate `x` (m) along a periodic axis spanning
/// `[lo, hi)`: +L within the support of the lower face (strictly), −L within the support of
/// the upper face (inclusive), appended to `out`.
#[inline]
pub fn shifts(x: f64, lo: f64, hi: f64, support: f64, out: &mut Vec<AxisOp>) {
    let l = hi - lo;
    if x - lo < support {
        out.push(AxisOp::Shift(l));
    }
    if hi - x <= support {
        out.push(AxisOp::Shift(-l));
    }
}

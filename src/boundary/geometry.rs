//! The surface of a wall body, for boundary conditions that need distances to it: Morris,
//! Fox & Zhu (1997)'s no-slip condition at dummy walls (`wall[].no_slip = "morris"`).
//!
//! Their construction (§3.2): at the point c of the wall surface nearest the fluid particle
//! f, take the tangent plane; d_f is f's distance to it and d_w the depth of the wall particle
//! w behind it. The fluid then sees w moving with
//!   v_w = u_wall − (d_w/d_f) (v_f − u_wall),  so  v_f − v_w = β (v_f − u_wall),  β = 1 + d_w/d_f,
//! which continues a linear velocity profile through the wall exactly. Walls are axis-aligned
//! boxes (a solid block, or a container's inner box), so c, the plane and both depths are
//! exact and cheap. A wall that moves rigidly carries its surface along (the shift).

use crate::scene::{WallBody, WallShape};
use crate::Vector;

/// One wall body's surface.
#[derive(Debug, Clone, PartialEq)]
pub struct WallSurface<const D: usize> {
    /// Lower corner of the block, or of the container's inner box, at rest (m).
    lo: Vector<D>,
    /// Upper corner (m).
    hi: Vector<D>,
    /// `Some(closed)` for a container, with closed[a][0] (lower face) and closed[a][1] (upper
    /// face) of each axis; `None` for a block.
    container: Option<[[bool; 2]; D]>,
}

impl<const D: usize> WallSurface<D> {
    /// The surface of wall `w` (validated: `min` and `max` have D components).
    pub fn new(w: &WallBody) -> Self {
        let lo = Vector::<D>::from_fn(|a, _| w.min[a]);
        let hi = Vector::<D>::from_fn(|a, _| w.max[a]);
        let container = (w.shape == WallShape::Container).then(|| {
            let mut closed = [[true; 2]; D];
            for o in &w.open {
                if let Some((a, up)) = crate::scene::face_of(o, D) {
                    closed[a][usize::from(up)] = false;
                }
            }
            closed
        });
        WallSurface { lo, hi, container }
    }

    /// (d_f, d_w) in metres: the fluid particle at `xf`'s distance to the tangent plane at its
    /// nearest surface point and the wall particle at `xw`'s depth behind that plane (negative
    /// in front of it), with the wall shifted by `shift` from rest. `None` if `xf` is not on
    /// the fluid side of the surface (inside a block, outside a container's inner box) or the
    /// container has no closed face.
    pub fn depths(&self, xf: &Vector<D>, xw: &Vector<D>, shift: &Vector<D>) -> Option<(f64, f64)> {
        let (lo, hi) = (self.lo + shift, self.hi + shift);
        match &self.container {
            None => {
                // nearest point of the block: xf clamped into it
                let c = Vector::<D>::from_fn(|a, _| xf[a].clamp(lo[a], hi[a]));
                let n = xf - c;
                let df = n.norm();
                (df > 0.0).then(|| (df, (c - xw).dot(&n) / df))
            }
            Some(closed) => {
                // the nearest closed inner face; the fluid must be inside the inner box
                let mut best: Option<(f64, usize, bool)> = None;
                for a in 0..D {
                    for (up, d) in [(false, xf[a] - lo[a]), (true, hi[a] - xf[a])] {
                        if closed[a][usize::from(up)] && best.is_none_or(|(b, _, _)| d < b) {
                            best = Some((d, a, up));
                        }
                    }
                }
                let (df, a, up) = best?;
                let dw = if up { xw[a] - hi[a] } else { lo[a] - xw[a] };
                (df > 0.0).then_some((df, dw))
            }
        }
    }
}

/// β = 1 + d_w/d_f of Morris et al. (1997), with d_f no less than `floor` (m; half a
/// particle spacing, where the lattice puts the first fluid row) so that a fluid particle
/// pressed against the wall does not get an unbounded factor, and d_w no less than 0 (a wall
/// particle in front of the tangent plane, at a corner, moves with the wall).
#[inline]
pub fn morris_beta(df: f64, dw: f64, floor: f64) -> f64 {
    1.0 + dw.max(0.0) / df.max(floor)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn wall(shape: WallShape, min: [f64; 2], max: [f64; 2], open: &[&str]) -> WallBody {
        let shape = if shape == WallShape::Block {
            "block"
        } else {
            "container"
        };
        let open: Vec<String> = open.iter().map(|o| format!("\"{o}\"")).collect();
        toml::from_str(&format!(
            "name = \"w\"\nshape = \"{shape}\"\nmin = {min:?}\nmax = {max:?}\nopen = [{}]",
            open.join(", ")
        ))
        .unwrap()
    }

    #[test]
    fn a_plate_gives_the_depths_on_either_side_of_its_face() {
        // the channel's lower plate: y in [-0.2, 0], the fluid above
        let s = WallSurface::<2>::new(&wall(WallShape::Block, [0.0, -0.2], [0.6, 0.0], &[]));
        let z = Vector::<2>::zeros();
        let (df, dw) = s
            .depths(&Vector::<2>::new(0.3, 0.05), &Vector::<2>::new(0.35, -0.15), &z)
            .unwrap();
        assert!(
            (df - 0.05).abs() < 1e-15 && (dw - 0.15).abs() < 1e-15,
            "{df} {dw}"
        );
        // a periodic image of a wall particle beyond the block's end is behind the same plane
        let (_, dw) = s
            .depths(&Vector::<2>::new(0.01, 0.05), &Vector::<2>::new(-0.02, -0.05), &z)
            .unwrap();
        assert!((dw - 0.05).abs() < 1e-15);
        // the plate moved up by 0.01
        let up = Vector::<2>::new(0.0, 0.01);
        let (df, dw) = s
            .depths(&Vector::<2>::new(0.3, 0.05), &Vector::<2>::new(0.35, -0.15), &up)
            .unwrap();
        assert!(
            (df - 0.04).abs() < 1e-15 && (dw - 0.16).abs() < 1e-15,
            "{df} {dw}"
        );
        // fluid inside the block has no depth
        assert!(s
            .depths(&Vector::<2>::new(0.3, -0.05), &Vector::<2>::new(0.3, -0.1), &z)
            .is_none());
    }

    #[test]
    fn a_container_uses_its_nearest_closed_face() {
        let s = WallSurface::<2>::new(&wall(WallShape::Container, [0.0, 0.0], [1.0, 1.0], &["y+"]));
        let z = Vector::<2>::zeros();
        // nearest the floor
        let (df, dw) = s
            .depths(&Vector::<2>::new(0.5, 0.1), &Vector::<2>::new(0.5, -0.05), &z)
            .unwrap();
        assert!((df - 0.1).abs() < 1e-15 && (dw - 0.05).abs() < 1e-15);
        // nearest the right side; a floor particle is in front of that side's plane
        let (df, dw) = s
            .depths(&Vector::<2>::new(0.95, 0.5), &Vector::<2>::new(0.9, -0.05), &z)
            .unwrap();
        assert!((df - 0.05).abs() < 1e-15 && (dw + 0.1).abs() < 1e-15, "{df} {dw}");
        assert_eq!(morris_beta(df, dw, 0.01), 1.0);
        // the open top is not a surface: a particle near it measures to the sides or floor
        let (df, _) = s
            .depths(&Vector::<2>::new(0.3, 0.99), &Vector::<2>::new(-0.05, 0.9), &z)
            .unwrap();
        assert!((df - 0.3).abs() < 1e-15);
        // outside the inner box: none
        assert!(s
            .depths(&Vector::<2>::new(-0.01, 0.5), &Vector::<2>::new(-0.05, 0.5), &z)
            .is_none());
    }

    #[test]
    fn beta_is_exact_for_a_linear_profile_and_bounded_at_the_wall() {
        // u = γ y with the wall at y = 0: the wall particle at −d_w continues it, u_w = −γ d_w
        let (gamma, df, dw) = (3.0, 0.5, 1.5);
        let (uf, uw) = (gamma * df, -gamma * dw);
        assert!((morris_beta(df, dw, 0.5) * uf - (uf - uw)).abs() < 1e-15);
        assert_eq!(morris_beta(0.0, 1.0, 0.5), 3.0);
    }
}

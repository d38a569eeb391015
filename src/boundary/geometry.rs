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
    /// Per axis: the wall spans the whole domain along it, so its faces have no edge there (a
    /// plate along a periodic axis); set by [`WallSurface::spanning`].
    span: [bool; D],
    /// A polygon wall's outline (2D), its vertices counter-clockwise (m); `None` for a box.
    outline: Option<Vec<[f64; 2]>>,
    /// A mesh wall's surface (3D); `None` for a box.
    mesh: Option<std::sync::Arc<crate::scene::mesh::Mesh>>,
}

/// Where a moving wall is during one drift: its displacement from rest before and after it,
/// and its velocity after it (m, m, m/s).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct WallMove<const D: usize> {
    /// Displacement from rest at the start of the drift (m).
    pub from: Vector<D>,
    /// Displacement from rest at its end (m).
    pub to: Vector<D>,
    /// The wall's velocity at its end (m/s).
    pub u: Vector<D>,
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
        let outline = (w.shape == WallShape::Polygon).then(|| {
            let mut v: Vec<[f64; 2]> = w.vertices.iter().map(|p| [p[0], p[1]]).collect();
            if crate::scene::polygon::signed_area(&w.vertices) < 0.0 {
                v.reverse();
            }
            v
        });
        let mesh = (w.shape == WallShape::Mesh).then(|| w.mesh.clone()).flatten();
        WallSurface {
            lo,
            hi,
            container,
            span: [false; D],
            outline,
            mesh,
        }
    }

    /// The same surface, its faces unbounded along every axis on which the wall covers the
    /// domain `[min, max]` (m): a particle that a drift carries past the domain's end, before
    /// it is wrapped, still meets the face.
    pub fn spanning(mut self, min: &[f64], max: &[f64]) -> Self {
        // an outline's edges end at its vertices, whatever its box spans
        let boxed = self.outline.is_none() && self.mesh.is_none();
        self.span = std::array::from_fn(|a| boxed && self.lo[a] <= min[a] && self.hi[a] >= max[a]);
        self
    }

    /// A fluid particle that a drift carried from `old` to `x` through a face of this wall —
    /// into a block, or out of a container's inner box through a closed face — bounces back:
    /// its position is reflected across the face it crossed first and its normal velocity
    /// about the wall's, v_n ← 2u_n − v_n (a specular bounce; the tangential velocity is
    /// kept). The crossing is found in the wall's frame (`m`: where the wall was before and
    /// after the drift), so a moving wall that sweeps over a particle bounces it too. Dummy
    /// particles push fluid back through its pressure; where that push falls short (a jet
    /// faster than the wall's pressure builds, or the spurious force where the smoothing
    /// length varies, `docs/refinement.md` §1) the fluid would pass through the wall and be
    /// lost. Returns true if it bounced.
    pub fn bounce(&self, old: &Vector<D>, x: &mut Vector<D>, v: &mut Vector<D>, m: &WallMove<D>) -> bool {
        let (o, mut n) = (old - m.from, *x - m.to);
        if let Some(outline) = &self.outline {
            let bounced = bounce_outline(outline, (&o, &mut n), v, m);
            if bounced {
                *x = n + m.to;
            }
            return bounced;
        }
        if let Some(mesh) = &self.mesh {
            let bounced = bounce_mesh(mesh, (&o, &mut n), v, m);
            if bounced {
                *x = n + m.to;
            }
            return bounced;
        }
        let mut first: Option<(f64, usize, f64)> = None;
        for a in 0..D {
            for up in [false, true] {
                let f = if up { self.hi[a] } else { self.lo[a] };
                let crossed = match &self.container {
                    // out of the inner box through a closed face
                    Some(closed) => {
                        closed[a][usize::from(up)]
                            && if up {
                                o[a] < f && n[a] >= f
                            } else {
                                o[a] > f && n[a] <= f
                            }
                    }
                    // into the block
                    None => {
                        if up {
                            o[a] >= f && n[a] < f
                        } else {
                            o[a] <= f && n[a] > f
                        }
                    }
                };
                if !crossed {
                    continue;
                }
                // where the path meets the face's plane; it must meet the face itself
                let s = (f - o[a]) / (n[a] - o[a]);
                let on_face = (0..D).all(|b| {
                    let c = o[b] + s * (n[b] - o[b]);
                    b == a || self.span[b] || (self.lo[b]..=self.hi[b]).contains(&c)
                });
                if on_face && first.is_none_or(|(s0, _, _)| s < s0) {
                    first = Some((s, a, f));
                }
            }
        }
        let Some((_, a, f)) = first else {
            return false;
        };
        n[a] = 2.0 * f - n[a];
        *x = n + m.to;
        v[a] = 2.0 * m.u[a] - v[a];
        true
    }

    /// (d_f, d_w) in metres: the fluid particle at `xf`'s distance to the tangent plane at its
    /// nearest surface point and the wall particle at `xw`'s depth behind that plane (negative
    /// in front of it), with the wall shifted by `shift` from rest. `None` if `xf` is not on
    /// the fluid side of the surface (inside a block, outside a container's inner box) or the
    /// container has no closed face.
    pub fn depths(&self, xf: &Vector<D>, xw: &Vector<D>, shift: &Vector<D>) -> Option<(f64, f64)> {
        // Morris's condition is refused on polygon walls (`scene/walls.rs`)
        (self.outline.is_none() && self.mesh.is_none()).then_some(())?;
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

/// [`WallSurface::bounce`] at a polygon's outline (counter-clockwise vertices, m): the first
/// edge the path `o` → `n` (the wall's frame) crosses from outside its line to inside, within
/// the edge, reflects n across that line and the velocity's normal part about the wall's,
/// v ← v − 2((v − u)·n̂) n̂ with n̂ the edge's outward normal. Returns true if it bounced.
fn bounce_outline<const D: usize>(
    outline: &[[f64; 2]],
    (o, n): (&Vector<D>, &mut Vector<D>),
    v: &mut Vector<D>,
    m: &WallMove<D>,
) -> bool {
    let k = outline.len();
    let mut first: Option<(f64, [f64; 2], f64)> = None;
    for i in 0..k {
        let (a, b) = (outline[i], outline[(i + 1) % k]);
        let e = [b[0] - a[0], b[1] - a[1]];
        let len = e[0].hypot(e[1]);
        if len == 0.0 {
            continue;
        }
        let nrm = [e[1] / len, -e[0] / len];
        let side = |p: &Vector<D>| (p[0] - a[0]) * nrm[0] + (p[1] - a[1]) * nrm[1];
        let (d_o, d_n) = (side(o), side(n));
        if !(d_o >= 0.0 && d_n < 0.0) {
            continue;
        }
        let s = d_o / (d_o - d_n);
        let c = [o[0] + s * (n[0] - o[0]), o[1] + s * (n[1] - o[1])];
        let t = ((c[0] - a[0]) * e[0] + (c[1] - a[1]) * e[1]) / (len * len);
        if (0.0..=1.0).contains(&t) && first.is_none_or(|(s0, _, _)| s < s0) {
            first = Some((s, nrm, d_n));
        }
    }
    let Some((_, nrm, d_n)) = first else {
        return false;
    };
    let vn = (v[0] - m.u[0]) * nrm[0] + (v[1] - m.u[1]) * nrm[1];
    for a in 0..2 {
        n[a] -= 2.0 * d_n * nrm[a];
        v[a] -= 2.0 * vn * nrm[a];
    }
    true
}

/// [`WallSurface::bounce`] at a closed mesh: the first triangle the path `o` → `n` (the
/// wall's frame) crosses from outside to inside reflects n across the triangle's plane and
/// the velocity's normal part about the wall's, v ← v − 2((v − u)·n̂) n̂, n̂ the outward unit
/// normal. A face normal to an axis reflects as a block's face does (n ← 2f − n, v ← 2u − v
/// along it), so a box given as a mesh bounces to the block's bits. Returns true if it
/// bounced.
fn bounce_mesh<const D: usize>(
    mesh: &crate::scene::mesh::Mesh,
    (o, n): (&Vector<D>, &mut Vector<D>),
    v: &mut Vector<D>,
    m: &WallMove<D>,
) -> bool {
    let Some((plane, nrm)) = mesh.crossing(o.as_slice(), n.as_slice()) else {
        return false;
    };
    if let Some(a) = (0..D).find(|&a| nrm[a].abs() == 1.0) {
        // the face's coordinate f: plane = ±f, exact
        n[a] = 2.0 * (nrm[a] * plane) - n[a];
        v[a] = 2.0 * m.u[a] - v[a];
        return true;
    }
    let (mut d_n, mut vn) = (-plane, 0.0);
    for a in 0..D {
        d_n += n[a] * nrm[a];
        vn += (v[a] - m.u[a]) * nrm[a];
    }
    for a in 0..D {
        n[a] -= 2.0 * d_n * nrm[a];
        v[a] -= 2.0 * vn * nrm[a];
    }
    true
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

    fn at_rest() -> WallMove<2> {
        WallMove {
            from: Vector::<2>::zeros(),
            to: Vector::<2>::zeros(),
            u: Vector::<2>::zeros(),
        }
    }

    #[test]
    fn a_container_bounces_fluid_back_through_its_closed_faces_only() {
        let s = WallSurface::<2>::new(&wall(WallShape::Container, [0.0, 0.0], [1.0, 1.0], &["y+"]));
        let m = at_rest();
        // through the floor: reflected across y = 0, the normal velocity reversed
        let (mut x, mut v) = (Vector::<2>::new(0.5, -0.004), Vector::<2>::new(0.3, -2.0));
        assert!(s.bounce(&Vector::<2>::new(0.49, 0.006), &mut x, &mut v, &m));
        assert!((x - Vector::<2>::new(0.5, 0.004)).norm() < 1e-15, "{x}");
        assert_eq!(v, Vector::<2>::new(0.3, 2.0));
        // through the open top: no bounce
        let (mut x, mut v) = (Vector::<2>::new(0.5, 1.01), Vector::<2>::new(0.0, 1.0));
        assert!(!s.bounce(&Vector::<2>::new(0.5, 0.99), &mut x, &mut v, &m));
        // into the corner through both faces: the face crossed first (x = 1 at s = 0.25)
        let (mut x, mut v) = (Vector::<2>::new(1.03, -0.01), Vector::<2>::new(4.0, -1.0));
        assert!(s.bounce(&Vector::<2>::new(0.99, 0.03), &mut x, &mut v, &m));
        assert!((x - Vector::<2>::new(0.97, -0.01)).norm() < 1e-15, "{x}");
        assert_eq!(v, Vector::<2>::new(-4.0, -1.0));
        // inside, or leaving beside the container (over the top of a side): nothing
        let (mut x, mut v) = (Vector::<2>::new(0.5, 0.5), Vector::<2>::zeros());
        assert!(!s.bounce(&Vector::<2>::new(0.4, 0.5), &mut x, &mut v, &m));
        let (mut x, mut v) = (Vector::<2>::new(1.01, 1.2), Vector::<2>::new(1.0, 0.0));
        assert!(!s.bounce(&Vector::<2>::new(0.99, 1.2), &mut x, &mut v, &m));
    }

    /// A wedge (vertices clockwise: the surface orients them) bounces a particle that crosses
    /// its slanted face back to the mirror image of where it went, with the normal velocity
    /// reversed; a path past its tip, and one that starts inside, do not bounce; a moving
    /// wedge bounces what it sweeps, at 2u_n − v_n.
    #[test]
    fn a_polygon_bounces_fluid_across_the_edge_it_crossed() {
        let w: WallBody = toml::from_str(
            "name = \"w\"\nshape = \"polygon\"\nmin = [0.0, 0.0]\nmax = [1.0, 1.0]\n\
             vertices = [[0.0, 0.0], [0.0, 1.0], [1.0, 0.0]]",
        )
        .unwrap();
        let s = WallSurface::<2>::new(&w);
        let m = at_rest();
        // the face x + y = 1, outward normal (1, 1)/√2; from (0.6, 0.6) to (0.45, 0.45)
        let (mut x, mut v) = (Vector::<2>::new(0.45, 0.45), Vector::<2>::new(-1.0, -1.0));
        assert!(s.bounce(&Vector::<2>::new(0.6, 0.6), &mut x, &mut v, &m));
        assert!((x - Vector::<2>::new(0.55, 0.55)).norm() < 1e-15, "{x}");
        assert!((v - Vector::<2>::new(1.0, 1.0)).norm() < 1e-15, "{v}");
        // tangential velocity is kept
        let (mut x, mut v) = (Vector::<2>::new(0.45, 0.45), Vector::<2>::new(1.0, -1.0));
        assert!(s.bounce(&Vector::<2>::new(0.55, 0.55), &mut x, &mut v, &m));
        assert!((v - Vector::<2>::new(1.0, -1.0)).norm() < 1e-15, "{v}");
        // beyond the tip at (1, 0), below the floor's line: no edge is crossed within it
        let (mut x, mut v) = (Vector::<2>::new(1.05, -0.01), Vector::<2>::new(0.0, -1.0));
        assert!(!s.bounce(&Vector::<2>::new(1.05, 0.01), &mut x, &mut v, &m));
        // inside to inside
        let (mut x, mut v) = (Vector::<2>::new(0.2, 0.2), Vector::<2>::new(0.0, -1.0));
        assert!(!s.bounce(&Vector::<2>::new(0.2, 0.3), &mut x, &mut v, &m));
        // the wedge moves +x by 0.01 at 1 m/s over a particle at rest 0.005/√2 in front of its
        // slanted face, which ends 0.005/√2 inside it: it is put that far outside, at
        // v = 2u_n n̂ = (1, 1)
        let m = WallMove {
            from: Vector::<2>::zeros(),
            to: Vector::<2>::new(0.01, 0.0),
            u: Vector::<2>::new(1.0, 0.0),
        };
        let (mut x, mut v) = (Vector::<2>::new(0.555, 0.45), Vector::<2>::zeros());
        assert!(s.bounce(&Vector::<2>::new(0.555, 0.45), &mut x, &mut v, &m));
        assert!((x - Vector::<2>::new(0.56, 0.455)).norm() < 1e-15, "{x}");
        assert!((v - Vector::<2>::new(1.0, 1.0)).norm() < 1e-15, "{v}");
        assert_eq!(s.depths(&x, &x, &Vector::<2>::zeros()), None);
    }

    #[test]
    fn a_block_bounces_fluid_that_enters_it_and_a_moving_one_what_it_sweeps() {
        let s = WallSurface::<2>::new(&wall(WallShape::Block, [0.4, 0.0], [0.6, 0.2], &[]));
        let m = at_rest();
        // onto its top
        let (mut x, mut v) = (Vector::<2>::new(0.5, 0.19), Vector::<2>::new(0.0, -1.0));
        assert!(s.bounce(&Vector::<2>::new(0.5, 0.21), &mut x, &mut v, &m));
        assert!((x[1] - 0.21).abs() < 1e-15 && v[1] == 1.0);
        // past its corner without touching it: nothing
        let (mut x, mut v) = (Vector::<2>::new(0.395, 0.19), Vector::<2>::new(0.0, -1.0));
        assert!(!s.bounce(&Vector::<2>::new(0.395, 0.21), &mut x, &mut v, &m));
        // a paddle moving +x by 0.01 at 1 m/s sweeps over a particle at rest 5 mm before it:
        // in the paddle's frame the particle entered 5 mm deep; it is put 5 mm in front, at
        // 2u - v = 2 m/s
        let m = WallMove {
            from: Vector::<2>::zeros(),
            to: Vector::<2>::new(0.01, 0.0),
            u: Vector::<2>::new(1.0, 0.0),
        };
        let (mut x, mut v) = (Vector::<2>::new(0.605, 0.1), Vector::<2>::zeros());
        assert!(s.bounce(&Vector::<2>::new(0.605, 0.1), &mut x, &mut v, &m));
        assert!((x - Vector::<2>::new(0.615, 0.1)).norm() < 1e-15, "{x}");
        assert_eq!(v, Vector::<2>::new(2.0, 0.0));
        // a plate over a periodic axis: its face has no end along that axis
        let plate = WallSurface::<2>::new(&wall(WallShape::Block, [0.0, -0.2], [1.0, 0.0], &[]))
            .spanning(&[0.0, -0.2], &[1.0, 1.0]);
        let (mut x, mut v) = (Vector::<2>::new(1.003, -0.001), Vector::<2>::new(1.0, -1.0));
        assert!(plate.bounce(&Vector::<2>::new(0.999, 0.001), &mut x, &mut v, &at_rest()));
        assert!((x[1] - 0.001).abs() < 1e-15, "{x}");
        let beside = WallSurface::<2>::new(&wall(WallShape::Block, [0.0, -0.2], [1.0, 0.0], &[]));
        let (mut x, mut v) = (Vector::<2>::new(1.003, -0.001), Vector::<2>::new(1.0, -1.0));
        assert!(!beside.bounce(&Vector::<2>::new(0.999, 0.001), &mut x, &mut v, &at_rest()));
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

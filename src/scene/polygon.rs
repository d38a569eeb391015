//! Closed polygons in the plane (`shape = "polygon"`, 2D scenes): which lattice sites lie
//! inside, the distance to the outline, the area, and the stretch of a ray inside.
//!
//! The vertices are taken in order and the last joins the first. Inside is decided by the
//! parity of the crossings of a ray along +x (the even–odd rule), so the orientation of the
//! outline does not matter. A site exactly on the outline is judged as if it were moved by
//! +ε along both axes, the rule of `[min, max)` for blocks: a rectangle given as a polygon
//! claims exactly the block's sites. The rule is applied symbolically (no ε is ever added), so
//! it is exact for the axis-aligned edges a block has.

/// True if the point (x, y) (m) lies inside the closed polygon `v` (vertices (m), each
/// `[x, y]`), the point moved by (+ε, +ε) if it lies on the outline.
pub fn contains(v: &[Vec<f64>], x: f64, y: f64) -> bool {
    let n = v.len();
    let mut inside = false;
    for i in 0..n {
        let (a, b) = (&v[i], &v[(i + 1) % n]);
        // below: the vertex lies at or below y, so strictly below y + ε
        let (below_a, below_b) = (a[1] <= y, b[1] <= y);
        if below_a == below_b {
            continue;
        }
        // the edge oriented upward, p its lower end, q its upper one
        let (p, q) = if below_a { (a, b) } else { (b, a) };
        // > 0: the point lies left of the upward edge, so a ray along +x crosses it
        let orient = (q[0] - p[0]) * (y - p[1]) - (q[1] - p[1]) * (x - p[0]);
        let left = if orient != 0.0 {
            orient > 0.0
        } else {
            // on the edge's line: the point moved by (ε, ε) changes orient by
            // ε((q.x − p.x) − (q.y − p.y))
            (q[0] - p[0]) - (q[1] - p[1]) > 0.0
        };
        if left {
            inside = !inside;
        }
    }
    inside
}

/// The polygon's signed area (m², the shoelace formula): positive if its vertices run
/// counter-clockwise.
pub fn signed_area(v: &[Vec<f64>]) -> f64 {
    let n = v.len();
    0.5 * (0..n)
        .map(|i| {
            let (a, b) = (&v[i], &v[(i + 1) % n]);
            a[0] * b[1] - b[0] * a[1]
        })
        .sum::<f64>()
}

/// Distance (m) from (x, y) to the nearest point of the outline.
pub fn distance(v: &[Vec<f64>], x: f64, y: f64) -> f64 {
    let n = v.len();
    (0..n)
        .map(|i| segment_distance(&v[i], &v[(i + 1) % n], x, y))
        .fold(f64::INFINITY, f64::min)
}

/// Distance (m) from (x, y) to the nearest point of the segment from `a` to `b` (m, each
/// `[x, y]`). A segment along an axis gives the offset across it exactly (the nearest
/// point's coordinate across is the segment's own), as a block's face distance.
pub(crate) fn segment_distance(a: &[f64], b: &[f64], x: f64, y: f64) -> f64 {
    let (ex, ey) = (b[0] - a[0], b[1] - a[1]);
    let len2 = ex * ex + ey * ey;
    let t = if len2 > 0.0 {
        (((x - a[0]) * ex + (y - a[1]) * ey) / len2).clamp(0.0, 1.0)
    } else {
        0.0
    };
    let (dx, dy) = (x - a[0] - t * ex, y - a[1] - t * ey);
    dx.hypot(dy)
}

/// The first stretch `(s0, s1)`, 0 ≤ s0 < s1 (m), of the ray (x, y) + s·u (s ≥ 0, u a unit
/// vector) that lies inside the polygon, if any.
pub fn chord(v: &[Vec<f64>], x: &[f64], u: &[f64]) -> Option<(f64, f64)> {
    let n = v.len();
    let mut cuts: Vec<f64> = Vec::new();
    for i in 0..n {
        let (a, b) = (&v[i], &v[(i + 1) % n]);
        let (ex, ey) = (b[0] - a[0], b[1] - a[1]);
        // x + s u = a + t e: solve by Cramer's rule
        let det = ex * u[1] - ey * u[0];
        if det == 0.0 {
            continue;
        }
        let (rx, ry) = (a[0] - x[0], a[1] - x[1]);
        let s = (ex * ry - ey * rx) / det;
        let t = (u[0] * ry - u[1] * rx) / det;
        if (0.0..1.0).contains(&t) && s > 0.0 {
            cuts.push(s);
        }
    }
    cuts.sort_by(f64::total_cmp);
    first_stretch(contains(v, x[0], x[1]), cuts)
}

/// The first stretch `(s0, s1)` inside a closed shape of a ray that starts `inside` it (or
/// not) and crosses its outline at the sorted distances `cuts` (all > 0).
pub(crate) fn first_stretch(inside: bool, cuts: Vec<f64>) -> Option<(f64, f64)> {
    let mut start = inside.then_some(0.0);
    for s in cuts {
        match start {
            Some(s0) if s > s0 => return Some((s0, s)),
            Some(_) => {}
            None => start = Some(s),
        }
    }
    None
}

/// The first pair of edges (indices) that cross each other other than at a shared vertex, if
/// any: a polygon that crosses itself has no consistent inside.
pub fn self_crossing(v: &[Vec<f64>]) -> Option<(usize, usize)> {
    let n = v.len();
    let cross =
        |o: &[f64], a: &[f64], b: &[f64]| (a[0] - o[0]) * (b[1] - o[1]) - (a[1] - o[1]) * (b[0] - o[0]);
    for i in 0..n {
        for j in i + 2..n {
            if i == 0 && j == n - 1 {
                continue; // neighbours through the closing edge
            }
            let (a, b) = (&v[i], &v[(i + 1) % n]);
            let (c, d) = (&v[j], &v[(j + 1) % n]);
            let (d1, d2) = (cross(a, b, c), cross(a, b, d));
            let (d3, d4) = (cross(c, d, a), cross(c, d, b));
            if d1 * d2 < 0.0 && d3 * d4 < 0.0 {
                return Some((i, j));
            }
        }
    }
    None
}

#[cfg(test)]
mod tests {
    use super::*;

    fn square() -> Vec<Vec<f64>> {
        vec![vec![0.0, 0.0], vec![1.0, 0.0], vec![1.0, 1.0], vec![0.0, 1.0]]
    }

    #[test]
    fn a_square_claims_the_sites_of_the_half_open_box() {
        let mut sq = square();
        for _ in 0..2 {
            for (x, y, inside) in [
                (0.0, 0.0, true),
                (0.5, 0.0, true),
                (0.0, 0.5, true),
                (1.0, 0.5, false),
                (0.5, 1.0, false),
                (1.0, 1.0, false),
                (0.0, 1.0, false),
                (1.0, 0.0, false),
                (0.5, 0.5, true),
                (-0.1, 0.5, false),
                (0.5, 1.1, false),
            ] {
                assert_eq!(contains(&sq, x, y), inside, "({x}, {y})");
            }
            // the orientation does not matter
            sq.reverse();
        }
    }

    #[test]
    fn sites_on_a_slanted_edge_follow_the_epsilon_rule() {
        // a triangle whose hypotenuse runs from (1, 0) to (0, 1)
        let t = vec![vec![0.0, 0.0], vec![1.0, 0.0], vec![0.0, 1.0]];
        // on the hypotenuse: moved by (ε, ε) the point leaves the triangle
        assert!(!contains(&t, 0.5, 0.5));
        // the triangle under y = x: a point on its right edge moved by (ε, ε) leaves it, one
        // on its floor enters it
        let u = vec![vec![0.0, 0.0], vec![1.0, 0.0], vec![1.0, 1.0]];
        assert!(contains(&u, 0.6, 0.3));
        assert!(!contains(&u, 0.3, 0.6));
        assert!(contains(&u, 0.5, 0.0));
        assert!(!contains(&u, 1.0, 0.5));
    }

    #[test]
    fn area_distance_and_chord_of_known_shapes() {
        assert_eq!(signed_area(&square()), 1.0);
        let mut cw = square();
        cw.reverse();
        assert_eq!(signed_area(&cw), -1.0);
        assert!((distance(&square(), 0.5, 0.25) - 0.25).abs() < 1e-15);
        assert!((distance(&square(), 2.0, 2.0) - 2f64.sqrt()).abs() < 1e-15);
        // a ray up through the square from below, and from inside
        let up = [0.0, 1.0];
        let (s0, s1) = chord(&square(), &[0.5, -1.0], &up).unwrap();
        assert!((s0 - 1.0).abs() < 1e-15 && (s1 - 2.0).abs() < 1e-15);
        let (s0, s1) = chord(&square(), &[0.5, 0.25], &up).unwrap();
        assert!(s0 == 0.0 && (s1 - 0.75).abs() < 1e-15);
        assert_eq!(chord(&square(), &[1.5, -1.0], &up), None);
        // a U: the ray through its left arm meets the arm, not the gap
        let u = vec![
            vec![0.0, 0.0],
            vec![3.0, 0.0],
            vec![3.0, 2.0],
            vec![2.0, 2.0],
            vec![2.0, 1.0],
            vec![1.0, 1.0],
            vec![1.0, 2.0],
            vec![0.0, 2.0],
        ];
        let (s0, s1) = chord(&u, &[1.5, -1.0], &up).unwrap();
        assert!((s0 - 1.0).abs() < 1e-15 && (s1 - 2.0).abs() < 1e-15);
        assert_eq!(signed_area(&u), 5.0);
    }

    #[test]
    fn a_bow_tie_crosses_itself_and_a_square_does_not() {
        assert_eq!(self_crossing(&square()), None);
        let bow = vec![vec![0.0, 0.0], vec![1.0, 1.0], vec![1.0, 0.0], vec![0.0, 1.0]];
        assert_eq!(self_crossing(&bow), Some((0, 2)));
    }
}

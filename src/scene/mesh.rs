//! Triangle meshes as shapes (`shape = "mesh"`, 3D): an STL file, binary or ASCII (read through
//! `stl_io`), placed by `scale`, `rotate` and `translate`, checked, and asked which lattice sites
//! it holds.
//!
//! **Inside.** A site is inside a closed mesh if the ray from it along +z crosses the surface an
//! odd number of times. Every site is judged as if moved by (ε, ε², ε³), ε → 0 (a symbolic
//! perturbation): a site exactly on a face, edge or vertex is inside exactly when the moved point
//! is. So a box-shaped mesh claims the sites of the block [min, max) (the `[min, max)` rule of
//! blocks, "+ε along every axis"), and a ray through an edge or vertex shared by several
//! triangles crosses exactly one of them. The projected tests use Shewchuk's exact orientation
//! predicate (`robust::orient2d`), so the tie rule is applied to exact signs.
//!
//! **Index.** Triangles are binned by their (x, y) box in a uniform grid of columns (about one
//! column per triangle), so a site tests only the triangles over its column: a 10⁶-triangle mesh
//! fills a 10⁶-site lattice in about a second (BENCHMARKS.md).

use crate::error::Result;
use crate::limits::file_error;
use robust::{orient2d, Coord};
use std::path::Path;

/// Where a mesh file's coordinates go: scaled by `scale`, rotated about x, then y, then z by
/// `rotate` (degrees, right-handed), then moved by `translate` (m).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Placement {
    /// Factor from the file's unit to metres (0.001 for a CAD file in mm).
    pub scale: f64,
    /// Rotations about x, y and z (degrees), applied in that order.
    pub rotate: [f64; 3],
    /// Translation (m), applied last.
    pub translate: [f64; 3],
    /// Reverse each triangle's corner order, turning its normal round (`flip = true`, for a
    /// file whose normals point inward).
    pub flip: bool,
}

impl Placement {
    /// The placed position (m) of the file's vertex `v`.
    pub fn apply(&self, v: [f32; 3]) -> [f64; 3] {
        let mut p = v.map(|c| c as f64 * self.scale);
        for (axis, &deg) in self.rotate.iter().enumerate() {
            if deg == 0.0 {
                continue;
            }
            let (s, c) = sin_cos_degrees(deg);
            let (i, j) = ((axis + 1) % 3, (axis + 2) % 3);
            let (a, b) = (p[i], p[j]);
            p[i] = c * a - s * b;
            p[j] = s * a + c * b;
        }
        for (a, t) in p.iter_mut().zip(self.translate) {
            *a += t;
        }
        p
    }
}

/// sin and cos of `deg` degrees, exact at multiples of 90° (so a quarter turn keeps a box's
/// faces on the planes they were on).
fn sin_cos_degrees(deg: f64) -> (f64, f64) {
    let q = deg / 90.0;
    if q == q.round() {
        return [(0.0, 1.0), (1.0, 0.0), (0.0, -1.0), (-1.0, 0.0)][q.rem_euclid(4.0) as usize];
    }
    deg.to_radians().sin_cos()
}

/// One triangle's corners (m).
type Tri = [[f64; 3]; 3];

/// A 2D scene's section of a 3D mesh (`slice = { axis, at }`): the plane x_axis = `at`, whose
/// other two axes, in their order, are the scene's (a y-section gives 2D (x, z)).
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Slice {
    /// The axis cut across: 0, 1 or 2.
    pub axis: usize,
    /// Where along it (m, placed coordinates).
    pub at: f64,
}

impl Slice {
    /// The two in-plane axes, in order.
    pub fn others(&self) -> [usize; 2] {
        match self.axis {
            0 => [1, 2],
            1 => [0, 2],
            _ => [0, 1],
        }
    }
}

/// A placed triangle mesh with its column index.
pub struct Mesh {
    tri: Vec<Tri>,
    /// Lower corner of the mesh's box (m).
    pub lo: [f64; 3],
    /// Upper corner of the mesh's box (m).
    pub hi: [f64; 3],
    cols: Columns,
    /// The triangles binned in 3D, for distances and crossings.
    grid: Grid,
    /// +1 if the corners' order makes the normals point outward (positive signed volume), −1
    /// if inward: a closed mesh is oriented by its volume, so no `flip` is needed.
    outward: f64,
    /// SHA-256 of the file's bytes, hex.
    pub sha256: String,
    /// `binary` or `ASCII`.
    pub format: &'static str,
    /// In a 2D scene, the plane cut and the section's segments in its two axes (m), each
    /// directed so that the body lies on its left (an outline counter-clockwise).
    section: Option<(Slice, Vec<[[f64; 2]; 2]>)>,
    /// In a 2D scene, per triangle the index of its segment of the section (`u32::MAX` for a
    /// triangle the plane does not cut), for in-plane distances; empty in 3D.
    segment_of: Vec<u32>,
    /// A body filled as a shell (`fill = "shell"`): the depth (m) inside the surface its sites
    /// lie within; `None` fills the whole inside.
    shell: Option<f64>,
}

/// How a mesh body is filled (`fill`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Fill {
    /// Every lattice site inside the closed surface.
    Inside,
    /// The sites inside within `layers` × dx of the surface (a hollow body: a shield, a tank's
    /// skin), ids unchanged.
    Shell,
}

impl std::fmt::Debug for Mesh {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "Mesh({} triangles, sha256 {})", self.tri.len(), self.sha256)
    }
}

impl PartialEq for Mesh {
    fn eq(&self, other: &Self) -> bool {
        self.tri == other.tri
    }
}

/// What [`Mesh::topology`] finds wrong with a surface, if anything.
#[derive(Debug, Clone, PartialEq)]
pub enum Defect {
    /// Edges used by an odd number of triangles (a hole's rim): how many, and the first one's
    /// triangle (1-based, file order) and ends (m).
    Open(usize, usize, [f64; 3], [f64; 3]),
    /// Edges two triangles run the same way (one of them faces inward): how many, and the first
    /// one's two triangles (1-based).
    Misoriented(usize, usize, usize),
}

impl Defect {
    /// The defect as a sentence with its remedy.
    pub fn message(&self) -> String {
        match self {
            Defect::Open(n, t, a, b) => format!(
                "the mesh is not closed: {n} open edge(s), the first of triangle {t} from {a:?} to \
                 {b:?}; an inside fill needs a watertight surface (repair the mesh, e.g. close its \
                 holes in the CAD export)"
            ),
            Defect::Misoriented(n, t, u) => format!(
                "the mesh's normals are inconsistent: {n} edge(s) run the same way in both their \
                 triangles, the first shared by triangles {t} and {u}; re-orient the faces \
                 consistently (e.g. \"unify normals\" in the CAD or mesh tool)"
            ),
        }
    }
}

impl Mesh {
    /// A mesh of the placed triangles `tri` (at least one).
    pub fn new(tri: Vec<Tri>, sha256: String, format: &'static str) -> Self {
        let mut lo = [f64::INFINITY; 3];
        let mut hi = [f64::NEG_INFINITY; 3];
        for v in tri.iter().flatten() {
            for a in 0..3 {
                lo[a] = lo[a].min(v[a]);
                hi[a] = hi[a].max(v[a]);
            }
        }
        let cols = Columns::new(&tri, [lo[0], lo[1]], [hi[0], hi[1]]);
        let grid = Grid::new(&tri, lo, hi);
        let mut m = Mesh {
            tri,
            lo,
            hi,
            cols,
            grid,
            outward: 1.0,
            sha256,
            format,
            section: None,
            segment_of: Vec::new(),
            shell: None,
        };
        m.outward = if m.signed_volume() < 0.0 { -1.0 } else { 1.0 };
        m
    }

    /// Distance (m) from `p` to the nearest point of the surface: the grid's cells in shells
    /// of growing Chebyshev radius k round p's cell, until the nearest found is no farther
    /// than k cells (any triangle not yet seen has its nearest point in a cell beyond).
    pub fn distance(&self, p: &[f64]) -> f64 {
        let p = &self.lift(p);
        let g = &self.grid;
        let c0 = [0, 1, 2].map(|a| g.cell(a, p[a]) as i64);
        let mut best = f64::INFINITY;
        let reach = *g.n.iter().max().unwrap_or(&1) as i64;
        for k in 0..=reach {
            g.shell(c0, k, |t| {
                best = best.min(point_triangle(&self.tri[t as usize], p));
            });
            if best <= k as f64 * g.size {
                break;
            }
        }
        best
    }

    /// True if some point of the surface lies closer than `r` (m) to `p`: the cells within
    /// ⌈r / cell⌉ + 1 of p's, stopping at the first such triangle (a site deep inside a large
    /// mesh costs a few cells, where [`Mesh::distance`] would search out to the surface). For a
    /// 2D point of a sliced mesh, the surface is the section's outline in its plane
    /// ([`Mesh::distance_capped`]): a face parallel to the plane, near it but not on it, does
    /// not thicken a shell.
    pub fn within(&self, p: &[f64], r: f64) -> bool {
        if p.len() == 2 && self.section.is_some() {
            return self.distance_capped(p, r) < r;
        }
        let p = &self.lift(p);
        let g = &self.grid;
        let c0 = [0, 1, 2].map(|a| g.cell(a, p[a]) as i64);
        let reach = ((r / g.size).ceil() as i64 + 1).min(*g.n.iter().max().unwrap_or(&1) as i64);
        let c = (c0[0] as usize * g.n[1] + c0[1] as usize) * g.n[2] + c0[2] as usize;
        if (g.far[c] as i64) > reach {
            return false;
        }
        let mut near = false;
        for k in 0..=reach {
            g.shell(c0, k, |t| {
                near = near || point_triangle(&self.tri[t as usize], p) < r;
            });
            if near {
                return true;
            }
        }
        false
    }

    /// The distance (m) from `p` to the nearest point of the surface, or `cap` (m, ≥ 0) if
    /// that is farther: min(distance, cap), exact below `cap`. In 2D, `p` lies in the
    /// section's plane and the distance is to the section's outline in that plane (faces
    /// parallel to the plane do not count), as a polygon's. Only the grid's cells within
    /// ⌈cap / cell⌉ + 1 of p's are searched, as by [`Mesh::within`], so a site deep inside a
    /// large mesh costs a few cells where [`Mesh::distance`] would search out to the surface;
    /// an infinite `cap` searches the whole grid and gives the distance itself.
    pub fn distance_capped(&self, p: &[f64], cap: f64) -> f64 {
        let q = &self.lift(p);
        let g = &self.grid;
        let c0 = [0, 1, 2].map(|a| g.cell(a, q[a]) as i64);
        let cells = *g.n.iter().max().unwrap_or(&1) as i64;
        let reach = match cap / g.size {
            r if r < cells as f64 => r.ceil() as i64 + 1,
            _ => cells,
        };
        let c = (c0[0] as usize * g.n[1] + c0[1] as usize) * g.n[2] + c0[2] as usize;
        if (g.far[c] as i64) > reach {
            return cap;
        }
        let section = (self.section.as_ref())
            .filter(|_| p.len() == 2)
            .map(|(_, segs)| segs);
        let mut best = cap;
        for k in 0..=reach {
            g.shell(c0, k, |t| {
                let d = match section {
                    // a triangle's segment lies on it: no nearer than the triangle, so the
                    // shells' bound holds for it too
                    Some(segs) => match self.segment_of[t as usize] {
                        u32::MAX => f64::INFINITY,
                        i => {
                            let [a, b] = &segs[i as usize];
                            super::polygon::segment_distance(a, b, p[0], p[1])
                        }
                    },
                    None => point_triangle(&self.tri[t as usize], q),
                };
                best = best.min(d);
            });
            // every triangle not yet seen lies in a cell k + 1 or more away: k cells or farther
            if best <= k as f64 * g.size {
                break;
            }
        }
        best
    }

    /// The first triangle the path `o` → `n` (m) crosses from the outside of the surface to
    /// its inside: its plane x·n̂ = c, as (c, n̂) with n̂ the outward unit normal (a face normal
    /// to axis a has n̂ = ±e_a exactly, and c = ±its coordinate).
    pub fn crossing(&self, o: &[f64], n: &[f64]) -> Option<(f64, [f64; 3])> {
        let (c, nrm) = self.crossing_3d(&self.lift(o), &self.lift(n))?;
        let Some((cut, _)) = &self.section else {
            return Some((c, nrm));
        };
        // in the section's plane: x_u n_u + x_v n_v = c − at n_w, normalised in 2D
        let [u, v] = cut.others();
        let len = nrm[u].hypot(nrm[v]);
        if len == 0.0 {
            return None;
        }
        let c2 = (c - cut.at * nrm[cut.axis]) / len;
        Some((c2, [nrm[u] / len, nrm[v] / len, 0.0]))
    }

    /// [`Mesh::crossing`] in the mesh's own 3D coordinates.
    fn crossing_3d(&self, o: &[f64; 3], n: &[f64; 3]) -> Option<(f64, [f64; 3])> {
        let d = [n[0] - o[0], n[1] - o[1], n[2] - o[2]];
        let mut first: Option<(f64, f64, [f64; 3])> = None;
        let lo = [0, 1, 2].map(|a| o[a].min(n[a]));
        let hi = [0, 1, 2].map(|a| o[a].max(n[a]));
        self.grid.in_box(lo, hi, |t| {
            let t = &self.tri[t as usize];
            let [a, b, c] = t;
            let e = cross(
                &[b[0] - a[0], b[1] - a[1], b[2] - a[2]],
                &[c[0] - a[0], c[1] - a[1], c[2] - a[2]],
            );
            let len = dot(&e, &e).sqrt();
            if len == 0.0 {
                return;
            }
            let nrm = e.map(|x| self.outward * x / len);
            let side = |p: &[f64]| (p[0] - a[0]) * nrm[0] + (p[1] - a[1]) * nrm[1] + (p[2] - a[2]) * nrm[2];
            let (d_o, d_n) = (side(o), side(n));
            if !(d_o >= 0.0 && d_n < 0.0) {
                return;
            }
            let s = d_o / (d_o - d_n);
            let x = [o[0] + s * d[0], o[1] + s * d[1], o[2] + s * d[2]];
            // on the triangle, to a rounding of its size
            if point_triangle(t, &x) <= 1e-12 * len.sqrt() && first.is_none_or(|(s0, _, _)| s < s0) {
                // an axis's normal: the plane's coordinate itself, exact
                let c = match (0..3).find(|&k| nrm[k].abs() == 1.0) {
                    Some(k) => nrm[k] * a[k],
                    None => dot(a, &nrm),
                };
                first = Some((s, c, nrm));
            }
        });
        first.map(|(_, c, nrm)| (c, nrm))
    }

    /// The mesh filled as a shell `depth` (m) deep inside its surface.
    pub fn with_shell(mut self, depth: f64) -> Self {
        self.shell = Some(depth);
        self
    }

    /// The shell's depth (m), for a body filled as a shell.
    pub fn shell_depth(&self) -> Option<f64> {
        self.shell
    }

    /// True if a body of this mesh claims the site `p` (m): inside the surface
    /// ([`Mesh::contains`]) and, for a shell, within its depth of the surface.
    pub fn claims(&self, p: &[f64]) -> bool {
        self.contains(p) && self.shell.is_none_or(|r| self.within(p, r))
    }

    /// The 3D point (m) of a scene position: itself in 3D, on the section's plane in 2D.
    fn lift(&self, p: &[f64]) -> [f64; 3] {
        match &self.section {
            Some((cut, _)) if p.len() == 2 => {
                let mut q = [cut.at; 3];
                let [u, v] = cut.others();
                (q[u], q[v]) = (p[0], p[1]);
                q
            }
            _ => [p[0], p[1], p[2]],
        }
    }

    /// The mesh cut by `cut` for a 2D scene: the section's segments, one per triangle that
    /// the plane separates (a corner on the plane counts as above it, so the segments close
    /// up), directed with the body on their left. `None` if the plane misses the mesh.
    pub fn sliced(mut self, cut: Slice) -> Option<Self> {
        let [u, v] = cut.others();
        // e_u × e_v, the plane's normal that makes (u, v) counter-clockwise
        let e = |k: usize| [0, 1, 2].map(|a| (a == k) as u8 as f64);
        let w = cross(&e(u), &e(v));
        let mut segs = Vec::new();
        let mut segment_of = vec![u32::MAX; self.tri.len()];
        for (k, t) in self.tri.iter().enumerate() {
            let h = t.map(|p| p[cut.axis] - cut.at);
            let cuts: Vec<[f64; 3]> = (0..3)
                .filter(|&i| (h[i] >= 0.0) != (h[(i + 1) % 3] >= 0.0))
                .map(|i| {
                    let (p, q) = (&t[i], &t[(i + 1) % 3]);
                    let s = h[i] / (h[i] - h[(i + 1) % 3]);
                    [0, 1, 2].map(|a| {
                        if a == cut.axis {
                            cut.at
                        } else {
                            p[a] + s * (q[a] - p[a])
                        }
                    })
                })
                .collect();
            if cuts.len() != 2 {
                continue;
            }
            let nrm = normal(t).map(|x| x * self.outward);
            let d = [0, 1, 2].map(|a| cuts[1][a] - cuts[0][a]);
            let (a, b) = if dot(&cross(&d, &w), &nrm) >= 0.0 {
                (0, 1)
            } else {
                (1, 0)
            };
            segment_of[k] = segs.len() as u32;
            segs.push([[cuts[a][u], cuts[a][v]], [cuts[b][u], cuts[b][v]]]);
        }
        if segs.is_empty() {
            return None;
        }
        self.section = Some((cut, segs));
        self.segment_of = segment_of;
        Some(self)
    }

    /// The box of the body in the scene's dimensions (m): the mesh's, or in 2D the section's.
    pub fn bounds(&self) -> (Vec<f64>, Vec<f64>) {
        match &self.section {
            None => (self.lo.to_vec(), self.hi.to_vec()),
            Some((_, segs)) => {
                let mut lo = vec![f64::INFINITY; 2];
                let mut hi = vec![f64::NEG_INFINITY; 2];
                for p in segs.iter().flatten() {
                    for a in 0..2 {
                        lo[a] = lo[a].min(p[a]);
                        hi[a] = hi[a].max(p[a]);
                    }
                }
                (lo, hi)
            }
        }
    }

    /// The body's measure: the signed volume (m³), or in 2D the section's signed area (m²),
    /// ½ Σ (u₁ v₂ − u₂ v₁) over its segments; positive when the normals point outward.
    pub fn measure(&self) -> f64 {
        match &self.section {
            None => self.signed_volume(),
            Some((_, segs)) => segs
                .iter()
                .map(|[a, b]| 0.5 * (a[0] * b[1] - b[0] * a[1]))
                .fold(0.0, |s, x| s + x),
        }
    }

    /// Number of triangles.
    pub fn triangles(&self) -> usize {
        self.tri.len()
    }

    /// Bytes the mesh and its index take in memory.
    pub fn bytes(&self) -> u64 {
        let index =
            self.cols.start.len() + self.cols.items.len() + self.grid.start.len() + self.grid.items.len();
        let index = index + self.segment_of.len();
        (self.tri.len() * std::mem::size_of::<Tri>() + 4 * index + self.grid.far.len()) as u64
    }

    /// The signed volume Σ a·(b × c)/6 (m³), summed in file order: positive when the normals
    /// (by the right-hand rule on each triangle's corner order) point outward.
    pub fn signed_volume(&self) -> f64 {
        self.tri
            .iter()
            .map(|[a, b, c]| dot(a, &cross(b, c)) / 6.0)
            .fold(0.0, |s, v| s + v)
    }

    /// True if the site `p` (m), moved by (ε, ε², ε³), lies inside the surface (crossing parity
    /// of the ray along +z; module doc).
    pub fn contains(&self, p: &[f64]) -> bool {
        let p = &self.lift(p);
        if (0..3).any(|a| p[a] < self.lo[a] || p[a] >= self.hi[a]) {
            return false;
        }
        let mut odd = false;
        for &t in self.cols.over(p[0], p[1]) {
            let t = &self.tri[t as usize];
            if covers(t, p[0], p[1]) && above(t, p) {
                odd = !odd;
            }
        }
        odd
    }

    /// The first stretch `(s0, s1)`, 0 ≤ s0 < s1 (m), of the ray x + s·u (s ≥ 0, u a unit
    /// vector) inside the mesh, if any. Along ±z the column index answers; other directions
    /// test every triangle.
    pub fn chord(&self, x: &[f64], u: &[f64]) -> Option<(f64, f64)> {
        let mut cuts = Vec::new();
        if u[0] == 0.0 && u[1] == 0.0 {
            let inside_xy = (0..2).all(|a| x[a] >= self.lo[a] && x[a] < self.hi[a]);
            if inside_xy {
                for &t in self.cols.over(x[0], x[1]) {
                    let t = &self.tri[t as usize];
                    if covers(t, x[0], x[1]) {
                        cuts.push((height(t, x[0], x[1]) - x[2]) / u[2]);
                    }
                }
            }
        } else {
            cuts.extend(self.tri.iter().filter_map(|t| ray_hit(t, x, u)));
        }
        cuts.retain(|&s| s > 0.0);
        cuts.sort_by(f64::total_cmp);
        super::polygon::first_stretch(self.contains(x), cuts)
    }

    /// Whether the surface is closed and consistently wound, judged on shared corners (equal
    /// coordinates); triangles with two equal corners are left out.
    pub fn topology(&self) -> Option<Defect> {
        use std::collections::HashMap;
        let mut ids: HashMap<[u64; 3], u32> = HashMap::with_capacity(self.tri.len() / 2 + 3);
        let corners: Vec<[u32; 3]> = (self.tri.iter())
            .map(|t| {
                t.map(|v| {
                    let n = ids.len() as u32;
                    *ids.entry(v.map(|c| (c + 0.0).to_bits())).or_insert(n)
                })
            })
            .collect();
        // (+ 0.0 above: −0 and +0 are one corner)
        // per undirected edge: uses, and the balance of its two directions
        let mut edges: HashMap<(u32, u32), (u32, i32)> = HashMap::with_capacity(3 * self.tri.len() / 2 + 3);
        for c in &corners {
            for (a, b) in each_edge(*c) {
                let e = edges.entry((a.min(b), a.max(b))).or_insert((0, 0));
                e.0 += 1;
                e.1 += if a < b { 1 } else { -1 };
            }
        }
        let open = edges.values().filter(|e| e.0 % 2 == 1).count();
        let turned = edges.values().filter(|e| e.0 % 2 == 0 && e.1 != 0).count();
        // the first offending edge in file order
        let first = |bad: &dyn Fn(&(u32, i32)) -> bool| {
            (corners.iter().enumerate())
                .flat_map(|(t, c)| each_edge(*c).map(move |e| (t, e)))
                .find(|(_, (a, b))| bad(&edges[&((*a).min(*b), (*a).max(*b))]))
        };
        if open > 0 {
            let (t, (a, b)) = first(&|e| e.0 % 2 == 1)?;
            let at = |i: u32| self.tri[t][(0..3).find(|&k| corners[t][k] == i).unwrap_or(0)];
            return Some(Defect::Open(open, t + 1, at(a), at(b)));
        }
        if turned > 0 {
            let (t, (a, b)) = first(&|e| e.1 != 0)?;
            let other = (corners.iter().enumerate())
                .filter(|&(u, _)| u != t)
                .find(|(_, c)| each_edge(**c).any(|e| e == (a, b)))
                .map_or(t, |(u, _)| u);
            return Some(Defect::Misoriented(turned, t + 1, other + 1));
        }
        None
    }
}

impl Mesh {
    /// A pair of triangles (1-based, file order, the lower first) that cross each other, if
    /// any: an edge of one passes through the other's interior, by exact orientations
    /// (`robust::orient3d`). Triangles sharing a corner, and touching or coplanar pairs, are
    /// not counted (so surfaces that cross only along edges lying in each other's faces go
    /// unreported: a warning, not a proof). The pairs tried are those binned in one cell of the grid; cells are
    /// searched in parallel but the first crossing cell in order wins, so the pair reported
    /// is the same on every run and thread count.
    pub fn self_crossing(&self) -> Option<(usize, usize)> {
        use rayon::prelude::*;
        let g = &self.grid;
        (0..g.start.len() - 1).into_par_iter().find_map_first(|c| {
            let here = &g.items[g.start[c] as usize..g.start[c + 1] as usize];
            for (i, &a) in here.iter().enumerate() {
                for &b in &here[i + 1..] {
                    let (ta, tb) = (&self.tri[a as usize], &self.tri[b as usize]);
                    let apart = (0..3).any(|d| {
                        let (a, b) = (span(ta, d), span(tb, d));
                        a.0 > b.1 || b.0 > a.1
                    });
                    if apart || ta.iter().any(|v| tb.contains(v)) {
                        continue;
                    }
                    if pierces(ta, tb) || pierces(tb, ta) {
                        return Some((a.min(b) as usize + 1, a.max(b) as usize + 1));
                    }
                }
            }
            None
        })
    }
}

/// The least and greatest coordinate of triangle `t` along axis `d` (m).
fn span(t: &Tri, d: usize) -> (f64, f64) {
    (
        t[0][d].min(t[1][d]).min(t[2][d]),
        t[0][d].max(t[1][d]).max(t[2][d]),
    )
}

/// Whether an edge of triangle `e` passes through the interior of triangle `t`: its ends lie
/// strictly on opposite sides of t's plane, and it passes strictly inside t's three edges.
fn pierces(e: &Tri, t: &Tri) -> bool {
    use robust::{orient3d, Coord3D};
    let c = |v: &[f64; 3]| Coord3D {
        x: v[0],
        y: v[1],
        z: v[2],
    };
    let side = |p: &[f64; 3]| orient3d(c(&t[0]), c(&t[1]), c(&t[2]), c(p));
    (0..3).any(|k| {
        let (p, q) = (&e[k], &e[(k + 1) % 3]);
        // strictly opposite sides (a zero is a corner on the plane: touching, not crossing)
        let (sp, sq) = (side(p), side(q));
        if !(sp > 0.0 && sq < 0.0 || sp < 0.0 && sq > 0.0) {
            return false;
        }
        let s = [0, 1, 2].map(|j| orient3d(c(p), c(q), c(&t[j]), c(&t[(j + 1) % 3])));
        s.iter().all(|&x| x > 0.0) || s.iter().all(|&x| x < 0.0)
    })
}

/// The directed edges of a triangle of corner ids `c`; none if two corners coincide.
fn each_edge(c: [u32; 3]) -> impl Iterator<Item = (u32, u32)> {
    let ok = c[0] != c[1] && c[1] != c[2] && c[2] != c[0];
    (0..3).filter(move |_| ok).map(move |e| (c[e], c[(e + 1) % 3]))
}

/// a · b.
fn dot(a: &[f64; 3], b: &[f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

/// a × b.
fn cross(a: &[f64; 3], b: &[f64; 3]) -> [f64; 3] {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

/// The exact orientation of (a, b, p) projected on (x, y): +1 counter-clockwise, −1 clockwise;
/// on the line through a and b, the side the point p + (ε, ε²) lies on (never 0 for a ≠ b).
fn side(a: &[f64; 3], b: &[f64; 3], px: f64, py: f64) -> i8 {
    let o = orient2d(
        Coord { x: a[0], y: a[1] },
        Coord { x: b[0], y: b[1] },
        Coord { x: px, y: py },
    );
    if o != 0.0 {
        return if o > 0.0 { 1 } else { -1 };
    }
    // (b − a) × (p + (ε, ε²) − a) = (bx − ax) ε² − (by − ay) ε
    if b[1] != a[1] {
        if b[1] > a[1] {
            -1
        } else {
            1
        }
    } else if b[0] > a[0] {
        1
    } else {
        -1
    }
}

/// The exact orientation of a triangle's projection on (x, y) (0: seen edge-on from +z).
fn facing(t: &Tri) -> f64 {
    let c = |v: &[f64; 3]| Coord { x: v[0], y: v[1] };
    orient2d(c(&t[0]), c(&t[1]), c(&t[2]))
}

/// True if the projection of `t` on (x, y) covers (px + ε, py + ε²).
fn covers(t: &Tri, px: f64, py: f64) -> bool {
    let o = facing(t);
    if o == 0.0 {
        return false;
    }
    let s = if o > 0.0 { 1 } else { -1 };
    side(&t[0], &t[1], px, py) == s && side(&t[1], &t[2], px, py) == s && side(&t[2], &t[0], px, py) == s
}

/// The normal (b − a) × (c − a) of `t`, its z taken from the exact orientation's sign.
fn normal(t: &Tri) -> [f64; 3] {
    let [a, b, c] = t;
    let (u, v) = (
        [b[0] - a[0], b[1] - a[1], b[2] - a[2]],
        [c[0] - a[0], c[1] - a[1], c[2] - a[2]],
    );
    let n = cross(&u, &v);
    [n[0], n[1], facing(t)]
}

/// The height (m) of the plane of `t` over (px, py); exact for a horizontal triangle.
fn height(t: &Tri, px: f64, py: f64) -> f64 {
    let n = normal(t);
    let a = &t[0];
    a[2] - (n[0] * (px - a[0]) + n[1] * (py - a[1])) / n[2]
}

/// True if the plane of `t` (covering p) lies above p + (ε, ε², ε³).
fn above(t: &Tri, p: &[f64]) -> bool {
    let dz = height(t, p[0], p[1]) - p[2];
    if dz != 0.0 {
        return dz > 0.0;
    }
    // z(p + (ε, ε²)) − (pz + ε³) = −(nx/nz) ε − (ny/nz) ε² − ε³
    let n = normal(t);
    let lead = if n[0] != 0.0 { -n[0] } else { -n[1] };
    lead != 0.0 && (lead > 0.0) == (n[2] > 0.0)
}

/// The distance s (m) along x + s·u at which the ray meets `t`, if it does (Möller–Trumbore).
fn ray_hit(t: &Tri, x: &[f64], u: &[f64]) -> Option<f64> {
    let [a, b, c] = t;
    let e1 = [b[0] - a[0], b[1] - a[1], b[2] - a[2]];
    let e2 = [c[0] - a[0], c[1] - a[1], c[2] - a[2]];
    let u = [u[0], u[1], u[2]];
    let p = cross(&u, &e2);
    let det = dot(&e1, &p);
    if det == 0.0 {
        return None;
    }
    let r = [x[0] - a[0], x[1] - a[1], x[2] - a[2]];
    let bu = dot(&r, &p) / det;
    let q = cross(&r, &e1);
    let bv = dot(&u, &q) / det;
    (bu >= 0.0 && bv >= 0.0 && bu + bv < 1.0).then(|| dot(&e2, &q) / det)
}

/// Triangles binned by their (x, y) box in a uniform grid (compressed rows: `start[c]..start[c
/// + 1]` of `items` are column c's triangles). Triangles seen edge-on from +z are left out.
struct Columns {
    origin: [f64; 2],
    /// Columns per metre along x and y.
    inv: [f64; 2],
    n: [usize; 2],
    start: Vec<u32>,
    items: Vec<u32>,
}

impl Columns {
    fn new(tri: &[Tri], lo: [f64; 2], hi: [f64; 2]) -> Self {
        let seen: Vec<u32> = (0..tri.len() as u32)
            .filter(|&t| facing(&tri[t as usize]) != 0.0)
            .collect();
        // about one column per triangle, square in shape, at most 2048 a side
        let ext = [hi[0] - lo[0], hi[1] - lo[1]];
        let target = (seen.len() as f64).max(1.0);
        let side = if ext[0] > 0.0 && ext[1] > 0.0 {
            (ext[0] * ext[1] / target).sqrt()
        } else {
            ext[0].max(ext[1]).max(1e-300)
        };
        let n = ext.map(|e| ((e / side).ceil() as usize).clamp(1, 2048));
        let inv = [0, 1].map(|a| if ext[a] > 0.0 { n[a] as f64 / ext[a] } else { 0.0 });
        let mut cols = Columns {
            origin: lo,
            inv,
            n,
            start: vec![0; n[0] * n[1] + 1],
            items: Vec::new(),
        };
        let range = |c: &Columns, t: &Tri, a: usize| {
            let (mn, mx) = t.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |(m, x), v| {
                (m.min(v[a]), x.max(v[a]))
            });
            c.cell(a, mn)..=c.cell(a, mx)
        };
        for &t in &seen {
            let t = &tri[t as usize];
            for i in range(&cols, t, 0) {
                for j in range(&cols, t, 1) {
                    cols.start[i * n[1] + j + 1] += 1;
                }
            }
        }
        for c in 1..cols.start.len() {
            cols.start[c] += cols.start[c - 1];
        }
        let mut fill = cols.start.clone();
        cols.items = vec![0; *cols.start.last().unwrap_or(&0) as usize];
        for &k in &seen {
            let t = &tri[k as usize];
            for i in range(&cols, t, 0) {
                for j in range(&cols, t, 1) {
                    let c = i * n[1] + j;
                    cols.items[fill[c] as usize] = k;
                    fill[c] += 1;
                }
            }
        }
        cols
    }

    /// The column index along axis `a` of coordinate `x` (m): monotone in x, so a triangle
    /// whose box holds x is binned in x's column.
    fn cell(&self, a: usize, x: f64) -> usize {
        (((x - self.origin[a]) * self.inv[a]).floor().max(0.0) as usize).min(self.n[a] - 1)
    }

    /// The triangles binned over (x, y).
    fn over(&self, x: f64, y: f64) -> &[u32] {
        let c = self.cell(0, x) * self.n[1] + self.cell(1, y);
        &self.items[self.start[c] as usize..self.start[c + 1] as usize]
    }
}

/// Distance (m) from `p` to the triangle `t`: to its nearest point, found by the region of
/// the triangle's plane p projects into (a corner, an edge or the face; Ericson, Real-Time
/// Collision Detection, 2005, §5.1.5).
fn point_triangle(t: &Tri, p: &[f64]) -> f64 {
    let sub = |x: &[f64], y: &[f64; 3]| [x[0] - y[0], x[1] - y[1], x[2] - y[2]];
    let [a, b, c] = t;
    let (ab, ac, ap) = (sub(b, a), sub(c, a), sub(p, a));
    let dist = |q: [f64; 3]| ((p[0] - q[0]).powi(2) + (p[1] - q[1]).powi(2) + (p[2] - q[2]).powi(2)).sqrt();
    // o + s u + w v
    let at = |o: &[f64; 3], u: [f64; 3], s: f64, v: [f64; 3], w: f64| {
        [0, 1, 2].map(|k| o[k] + s * u[k] + w * v[k])
    };
    let (d1, d2) = (dot(&ab, &ap), dot(&ac, &ap));
    if d1 <= 0.0 && d2 <= 0.0 {
        return dist(*a);
    }
    let bp = sub(p, b);
    let (d3, d4) = (dot(&ab, &bp), dot(&ac, &bp));
    if d3 >= 0.0 && d4 <= d3 {
        return dist(*b);
    }
    let vc = d1 * d4 - d3 * d2;
    if vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0 {
        return dist(at(a, ab, d1 / (d1 - d3), ac, 0.0));
    }
    let cp = sub(p, c);
    let (d5, d6) = (dot(&ab, &cp), dot(&ac, &cp));
    if d6 >= 0.0 && d5 <= d6 {
        return dist(*c);
    }
    let vb = d5 * d2 - d1 * d6;
    if vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0 {
        return dist(at(a, ab, 0.0, ac, d2 / (d2 - d6)));
    }
    let va = d3 * d6 - d5 * d4;
    if va <= 0.0 && (d4 - d3) >= 0.0 && (d5 - d6) >= 0.0 {
        let w = (d4 - d3) / ((d4 - d3) + (d5 - d6));
        return dist(at(b, sub(c, b), w, [0.0; 3], 0.0));
    }
    let denom = 1.0 / (va + vb + vc);
    dist(at(a, ab, vb * denom, ac, vc * denom))
}

/// Triangles binned by their box in a uniform grid of cubic cells (compressed rows, as
/// [`Columns`]), for distances and crossings.
struct Grid {
    origin: [f64; 3],
    /// Cell edge (m).
    size: f64,
    n: [usize; 3],
    start: Vec<u32>,
    items: Vec<u32>,
    /// Per cell, the Chebyshev distance in cells to the nearest cell holding a triangle
    /// (at most 255): a site deeper than a shell's reach is answered without a search.
    far: Vec<u8>,
}

impl Grid {
    fn new(tri: &[Tri], lo: [f64; 3], hi: [f64; 3]) -> Self {
        // about one cell per triangle, at most 256 a side
        let ext = [0, 1, 2].map(|a| hi[a] - lo[a]);
        let widest = ext.iter().fold(0.0f64, |m, &e| m.max(e)).max(1e-300);
        let vol: f64 = ext.iter().map(|&e| e.max(widest / 256.0)).product();
        let size = (vol / tri.len().max(1) as f64).cbrt().max(widest / 256.0);
        let n = ext.map(|e| ((e / size).ceil() as usize).clamp(1, 256));
        let mut g = Grid {
            origin: lo,
            size,
            n,
            start: vec![0; n[0] * n[1] * n[2] + 1],
            items: Vec::new(),
            far: Vec::new(),
        };
        for t in tri {
            g.each_cell(t, |g, c| g.start[c + 1] += 1);
        }
        for c in 1..g.start.len() {
            g.start[c] += g.start[c - 1];
        }
        let mut fill = g.start.clone();
        g.items = vec![0; *g.start.last().unwrap_or(&0) as usize];
        for (k, t) in tri.iter().enumerate() {
            g.each_cell(t, |g, c| {
                g.items[fill[c] as usize] = k as u32;
                fill[c] += 1;
            });
        }
        g.far = g.distance_transform();
        g
    }

    /// [`Grid::far`]: 0 in cells holding a triangle, then the exact Chebyshev distance by two
    /// raster passes over the 26 neighbours (forward over the 13 before a cell, backward over
    /// the 13 after it).
    fn distance_transform(&self) -> Vec<u8> {
        let n = self.n.map(|x| x as i64);
        let idx = |i: i64, j: i64, k: i64| ((i * n[1] + j) * n[2] + k) as usize;
        let cells = self.start.len() - 1;
        let mut far: Vec<u8> = (0..cells)
            .map(|c| if self.start[c + 1] > self.start[c] { 0 } else { 255 })
            .collect();
        let before: Vec<[i64; 3]> = (0..27)
            .map(|q| [q / 9 - 1, q / 3 % 3 - 1, q % 3 - 1])
            .filter(|d| (d[0], d[1], d[2]) < (0, 0, 0))
            .collect();
        let pass = |far: &mut Vec<u8>, sign: i64, order: &mut dyn Iterator<Item = usize>| {
            for c in order {
                let (i, j, k) = (
                    (c as i64) / (n[1] * n[2]),
                    (c as i64) / n[2] % n[1],
                    (c as i64) % n[2],
                );
                for d in &before {
                    let (a, b, e) = (i + sign * d[0], j + sign * d[1], k + sign * d[2]);
                    if (0..n[0]).contains(&a) && (0..n[1]).contains(&b) && (0..n[2]).contains(&e) {
                        far[c] = far[c].min(far[idx(a, b, e)].saturating_add(1));
                    }
                }
            }
        };
        pass(&mut far, 1, &mut (0..cells));
        pass(&mut far, -1, &mut (0..cells).rev());
        far
    }

    /// `f(self, c)` for every cell c that the box of triangle `t` reaches.
    fn each_cell(&mut self, t: &Tri, mut f: impl FnMut(&mut Self, usize)) {
        let r = [0, 1, 2].map(|a| {
            let (mn, mx) = t.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |(m, x), v| {
                (m.min(v[a]), x.max(v[a]))
            });
            (self.cell(a, mn), self.cell(a, mx))
        });
        for i in r[0].0..=r[0].1 {
            for j in r[1].0..=r[1].1 {
                for k in r[2].0..=r[2].1 {
                    let c = (i * self.n[1] + j) * self.n[2] + k;
                    f(self, c);
                }
            }
        }
    }

    /// The cell index along axis `a` of coordinate `x` (m), clamped into the grid.
    fn cell(&self, a: usize, x: f64) -> usize {
        (((x - self.origin[a]) / self.size).floor().max(0.0) as usize).min(self.n[a] - 1)
    }

    /// The triangles of cell (i, j, k).
    fn at(&self, c: [usize; 3]) -> &[u32] {
        let c = (c[0] * self.n[1] + c[1]) * self.n[2] + c[2];
        &self.items[self.start[c] as usize..self.start[c + 1] as usize]
    }

    /// Every triangle of the cells at Chebyshev distance exactly `k` from cell `c0`, inside
    /// the grid (a triangle in several cells may come more than once).
    fn shell(&self, c0: [i64; 3], k: i64, mut f: impl FnMut(u32)) {
        let n = self.n.map(|x| x as i64);
        let (zlo, zhi) = ((c0[2] - k).max(0), (c0[2] + k).min(n[2] - 1));
        for i in (c0[0] - k).max(0)..=(c0[0] + k).min(n[0] - 1) {
            for j in (c0[1] - k).max(0)..=(c0[1] + k).min(n[1] - 1) {
                let rim = (i - c0[0]).abs() == k || (j - c0[1]).abs() == k;
                for z in zlo..=zhi {
                    if rim || (z - c0[2]).abs() == k {
                        self.at([i as usize, j as usize, z as usize])
                            .iter()
                            .for_each(|&t| f(t));
                    }
                }
            }
        }
    }

    /// Every triangle of the cells that the box [lo, hi] (m) reaches.
    fn in_box(&self, lo: [f64; 3], hi: [f64; 3], mut f: impl FnMut(u32)) {
        for i in self.cell(0, lo[0])..=self.cell(0, hi[0]) {
            for j in self.cell(1, lo[1])..=self.cell(1, hi[1]) {
                for k in self.cell(2, lo[2])..=self.cell(2, hi[2]) {
                    self.at([i, j, k]).iter().for_each(|&t| f(t));
                }
            }
        }
    }
}

/// How an STL file is laid out: binary with its triangle count, or ASCII.
fn layout(b: &[u8]) -> std::result::Result<Option<u64>, String> {
    let count = (b.len() >= 84).then(|| u32::from_le_bytes([b[80], b[81], b[82], b[83]]) as u64);
    if let Some(n) = count {
        if 84 + 50 * n == b.len() as u64 {
            return Ok(Some(n));
        }
    }
    if b.starts_with(b"solid") {
        return Ok(None);
    }
    Err(match count {
        None => format!(
            "{} bytes: too short for a binary STL (an 84-byte header and count) and not an ASCII STL \
             (which starts with `solid`)",
            b.len()
        ),
        Some(n) => format!(
            "its binary header counts {n} triangles, 84 + 50·{n} = {} bytes, but the file has {}: it \
             is truncated, or not an STL",
            84 + 50 * n,
            b.len()
        ),
    })
}

/// Read the STL file at `path` for key `key` (a scene's `…file`) and place it. Every defect
/// of the file is an input error naming it: not a regular file (checked before opening, a
/// FIFO would block), larger than [`crate::limits::MAX_MESH_BYTES`] (before reading), a
/// binary count that disagrees with the size or exceeds [`crate::limits::MAX_MESH_TRIANGLES`]
/// (before allocating), a malformed triangle, a non-finite coordinate, or no triangle.
pub fn read(path: &Path, key: &str, place: &Placement) -> Result<Mesh> {
    use crate::limits::{MAX_MESH_BYTES, MAX_MESH_TRIANGLES};
    let fail = |m: String| file_error(path, key, None, m);
    let meta = std::fs::metadata(path).map_err(|e| {
        fail(format!(
            "cannot be read: {e}; the path is relative to the scene file"
        ))
    })?;
    if !meta.is_file() {
        return Err(fail(
            "is not a regular file; name a binary or ASCII STL file".into(),
        ));
    }
    if meta.len() > MAX_MESH_BYTES {
        return Err(fail(format!(
            "{} bytes exceed the limit of {MAX_MESH_BYTES} for a mesh (src/limits.rs)",
            meta.len()
        )));
    }
    let mut bytes = std::fs::read(path).map_err(|e| fail(format!("cannot be read: {e}")))?;
    let sha256 = {
        use sha2::Digest;
        sha2::Sha256::digest(&bytes)
            .iter()
            .map(|b| format!("{b:02x}"))
            .collect::<String>()
    };
    let count = layout(&bytes).map_err(fail)?;
    match count {
        // the header is free text: blank it, so that the reader's probe does not take a
        // binary file whose header starts with `solid` for text
        Some(_) => bytes[..80].fill(b' '),
        // the reader wants `solid ` with its space
        None if bytes.get(5) != Some(&b' ') => bytes.insert(5, b' '),
        None => {}
    }
    let mut cursor = std::io::Cursor::new(bytes);
    let reader =
        stl_io::create_stl_reader(&mut cursor).map_err(|e| fail(format!("is not a readable STL: {e}")))?;
    let mut tri = Vec::with_capacity(count.unwrap_or(0) as usize);
    for (n, t) in reader.enumerate() {
        let t = t.map_err(|e| fail(format!("triangle {}: {e}", n + 1)))?;
        if n as u64 >= MAX_MESH_TRIANGLES {
            return Err(fail(format!(
                "more than {MAX_MESH_TRIANGLES} triangles (src/limits.rs)"
            )));
        }
        let v = t.vertices.map(|v| v.0);
        if v.iter().flatten().any(|c| !c.is_finite()) {
            return Err(fail(format!(
                "triangle {} has a coordinate that is not finite: {v:?}",
                n + 1
            )));
        }
        let v = if place.flip { [v[0], v[2], v[1]] } else { v };
        tri.push(v.map(|v| place.apply(v)));
    }
    if tri.is_empty() {
        return Err(fail("holds no triangle".into()));
    }
    let format = if count.is_some() { "binary" } else { "ASCII" };
    Ok(Mesh::new(tri, sha256, format))
}

/// Test meshes: a box and a sphere as triangles, outward.
#[cfg(test)]
pub(crate) mod shapes {
    use super::Tri;

    /// The 12 triangles of the box [lo, hi], normals outward.
    pub fn cuboid(lo: [f64; 3], hi: [f64; 3]) -> Vec<Tri> {
        let c = |i: usize| {
            [
                [lo[0], hi[0]][i & 1],
                [lo[1], hi[1]][(i >> 1) & 1],
                [lo[2], hi[2]][(i >> 2) & 1],
            ]
        };
        // faces as corner quads, counter-clockwise seen from outside
        let quads = [
            [0, 2, 3, 1],
            [4, 5, 7, 6],
            [0, 1, 5, 4],
            [2, 6, 7, 3],
            [0, 4, 6, 2],
            [1, 3, 7, 5],
        ];
        quads
            .iter()
            .flat_map(|q| [[c(q[0]), c(q[1]), c(q[2])], [c(q[0]), c(q[2]), c(q[3])]])
            .collect()
    }

    /// A UV sphere of `n` bands about `centre` with vertices on the radius `r`, outward.
    pub fn sphere(centre: [f64; 3], r: f64, n: usize) -> Vec<Tri> {
        let at = |i: usize, j: usize| {
            let th = std::f64::consts::PI * i as f64 / n as f64;
            let ph = 2.0 * std::f64::consts::PI * (j % (2 * n)) as f64 / (2 * n) as f64;
            if i == 0 || i == n {
                return [centre[0], centre[1], centre[2] + if i == 0 { r } else { -r }];
            }
            [
                centre[0] + r * th.sin() * ph.cos(),
                centre[1] + r * th.sin() * ph.sin(),
                centre[2] + r * th.cos(),
            ]
        };
        let mut out = Vec::new();
        for i in 0..n {
            for j in 0..2 * n {
                let (a, b, c, d) = (at(i, j), at(i + 1, j), at(i + 1, j + 1), at(i, j + 1));
                if i != 0 {
                    out.push([a, b, d]);
                }
                if i != n - 1 {
                    out.push([b, c, d]);
                }
            }
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::shapes::{cuboid, sphere};
    use super::*;

    fn mesh(t: Vec<Tri>) -> Mesh {
        Mesh::new(t, String::new(), "binary")
    }

    /// Sites of a lattice of spacing `dx` offset by `off` over [lo, hi)³.
    fn sites(lo: f64, hi: f64, dx: f64, off: f64) -> Vec<[f64; 3]> {
        let n = ((hi - lo) / dx).round() as usize;
        let c = |i: usize| lo + (i as f64 + off) * dx;
        (0..n * n * n)
            .map(|k| [c(k % n), c(k / n % n), c(k / (n * n))])
            .collect()
    }

    #[test]
    fn a_box_mesh_holds_exactly_the_sites_of_the_block_min_max_also_on_its_faces() {
        // faces on lattice lines (off = 0: sites on the faces, edges and corners) and between
        for off in [0.0, 0.5] {
            let (lo, hi) = ([0.25, 0.125, 0.375], [0.75, 0.5, 0.625]);
            let m = mesh(cuboid(lo, hi));
            for p in sites(0.0, 1.0, 0.0625, off) {
                let block = (0..3).all(|a| p[a] >= lo[a] && p[a] < hi[a]);
                assert_eq!(m.contains(&p), block, "site {p:?} (offset {off})");
            }
            assert_eq!(m.topology(), None);
            assert!((m.signed_volume() - 0.5 * 0.375 * 0.25).abs() < 1e-15);
        }
    }

    #[test]
    fn a_turned_box_is_the_box_turned_and_a_quarter_turn_is_exact() {
        let place = Placement {
            scale: 2.0,
            rotate: [90.0, 0.0, 180.0],
            translate: [1.0, 0.0, 0.0],
            flip: false,
        };
        // x then z: (x, y, z) -> (x, -z, y) -> (-x, z, y), scaled by 2, moved by +1 in x
        assert_eq!(place.apply([0.25, 0.5, 0.125]), [0.5, 0.25, 1.0]);
        let p = Placement {
            scale: 1.0,
            rotate: [0.0, 30.0, 0.0],
            translate: [0.0; 3],
            flip: false,
        };
        let q = p.apply([1.0, 0.0, 0.0]);
        let s = 0.5f64;
        assert!((q[0] - 3f64.sqrt() / 2.0).abs() < 1e-15 && q[1] == 0.0 && (q[2] + s).abs() < 1e-15);
    }

    #[test]
    fn a_fine_sphere_mesh_differs_from_the_sphere_only_within_half_a_spacing_of_its_surface() {
        // not r = 15 dx: 240 sites lie at r·√(899/900), inside the sphere by 0.008 dx and
        // outside any inscribed mesh of this fineness (sagitta 0.008 dx)
        let (c, r, dx) = ([0.5, 0.5, 0.5], 0.29, 0.02);
        let m = mesh(sphere(c, r, 48));
        assert_eq!(m.topology(), None);
        let exact = 4.0 / 3.0 * std::f64::consts::PI * r * r * r;
        assert!((m.signed_volume() - exact).abs() < 0.01 * exact);
        let (mut n_mesh, mut n_ball) = (0, 0);
        for p in sites(0.0, 1.0, dx, 0.5) {
            let d = ((0..3).map(|a| (p[a] - c[a]).powi(2)).sum::<f64>()).sqrt();
            let (inm, inb) = (m.contains(&p), d < r);
            n_mesh += inm as usize;
            n_ball += inb as usize;
            if inm != inb {
                assert!((d - r).abs() < 0.5 * dx, "site {p:?} at {d} from the centre");
            }
        }
        assert!(
            (n_mesh as f64 - n_ball as f64).abs() < 0.01 * n_ball as f64,
            "{n_mesh} against {n_ball}"
        );
    }

    #[test]
    fn rays_through_shared_edges_and_vertices_count_one_crossing() {
        // an octahedron's vertices and edges lie on lattice lines: every column through them
        let c = [0.5, 0.5, 0.5];
        let v = |a: usize, s: f64| {
            let mut p = c;
            p[a] += s * 0.25;
            p
        };
        let (px, nx, py, ny, pz, nz) = (v(0, 1.), v(0, -1.), v(1, 1.), v(1, -1.), v(2, 1.), v(2, -1.));
        let oct = vec![
            [px, py, pz],
            [py, nx, pz],
            [nx, ny, pz],
            [ny, px, pz],
            [py, px, nz],
            [nx, py, nz],
            [ny, nx, nz],
            [px, ny, nz],
        ];
        let m = mesh(oct);
        assert_eq!(m.topology(), None);
        assert!(m.signed_volume() > 0.0);
        // the moved point p + (ε, ε², ε³) is inside the open octahedron |x|₁ < 0.25 or, on its
        // surface, on the inner side: the perturbation decides, an ulp-free oracle
        for p in sites(0.0, 1.0, 0.03125, 0.0) {
            let d: [f64; 3] = [p[0] - c[0], p[1] - c[1], p[2] - c[2]];
            let l1 = d.iter().map(|x| x.abs()).sum::<f64>();
            // on the surface, |d + (ε, ε², ε³)|₁ − |d|₁ starts with ε·(sign dx, or +1 where
            // dx = 0): inside exactly when dx < 0
            let oracle = if l1 != 0.25 { l1 < 0.25 } else { d[0] < 0.0 };
            assert_eq!(m.contains(&p), oracle, "site {p:?}");
        }
    }

    #[test]
    fn distances_and_crossings_match_the_sphere_and_a_brute_force_oracle() {
        let m = mesh(sphere([0.5, 0.5, 0.5], 0.3, 24));
        let mut worst = 0.0f64;
        for p in sites(-0.5, 1.5, 0.125, 0.37) {
            let brute = m
                .tri
                .iter()
                .map(|t| point_triangle(t, &p))
                .fold(f64::INFINITY, f64::min);
            assert_eq!(m.distance(&p), brute, "{p:?}");
            for r in [0.01, 0.05, 0.2] {
                assert_eq!(m.within(&p, r), brute < r, "{p:?} {r}");
            }
            let r = ((0..3).map(|a| (p[a] - 0.5f64).powi(2)).sum::<f64>()).sqrt();
            worst = worst.max((brute - (r - 0.3).abs()).abs());
        }
        // the facets' sagitta: r (1 − cos(π/24)) = 2.6e-3 m
        assert!(worst < 3e-3, "{worst}");
        // a path into the ball along −x crosses near x = 0.8 with the outward normal near +x
        let (c, n) = m.crossing(&[0.9, 0.5, 0.5], &[0.7, 0.5, 0.5]).unwrap();
        assert!(
            (c - dot(&[0.8, 0.5, 0.5], &n)).abs() < 3e-3 && n[0] > 0.99,
            "{c} {n:?}"
        );
        // out of it, or outside it: none
        assert_eq!(m.crossing(&[0.7, 0.5, 0.5], &[0.9, 0.5, 0.5]), None);
        assert_eq!(m.crossing(&[0.95, 0.5, 0.5], &[0.9, 0.5, 0.5]), None);
        // a mesh wound inward is oriented by its volume
        let inward: Vec<Tri> = sphere([0.5, 0.5, 0.5], 0.3, 24)
            .into_iter()
            .map(|[a, b, c]| [a, c, b])
            .collect();
        let (_, n) = mesh(inward).crossing(&[0.9, 0.5, 0.5], &[0.7, 0.5, 0.5]).unwrap();
        assert!(n[0] > 0.99);
    }

    /// The capped distance is min(distance, cap) to the bit, inside, outside and beyond the
    /// grid, against a brute-force oracle over every triangle; in 2D over every segment of
    /// the section, in its plane.
    #[test]
    fn capped_distances_are_the_brute_force_distance_or_the_cap() {
        let m = mesh(sphere([0.5, 0.5, 0.5], 0.3, 24));
        for p in sites(-0.5, 1.5, 0.125, 0.37) {
            let brute = m
                .tri
                .iter()
                .map(|t| point_triangle(t, &p))
                .fold(f64::INFINITY, f64::min);
            for cap in [0.0, 0.01, 0.05, 0.2, 1.0, f64::INFINITY] {
                assert_eq!(m.distance_capped(&p, cap), brute.min(cap), "{p:?} {cap}");
            }
        }
        let cut = Slice { axis: 0, at: 0.55 };
        let m = mesh(sphere([0.5, 0.5, 0.5], 0.3, 24)).sliced(cut).unwrap();
        let Some((_, segs)) = &m.section else {
            panic!("no section")
        };
        for k in 0..400 {
            let p = [
                -0.5 + (k % 20) as f64 * 0.1 + 0.013,
                -0.5 + (k / 20) as f64 * 0.1 + 0.007,
            ];
            let brute = (segs.iter())
                .map(|[a, b]| crate::scene::polygon::segment_distance(a, b, p[0], p[1]))
                .fold(f64::INFINITY, f64::min);
            for cap in [0.01, 0.05, 0.2, f64::INFINITY] {
                assert_eq!(m.distance_capped(&p, cap), brute.min(cap), "{p:?} {cap}");
                assert_eq!(m.within(&p, cap), brute < cap, "{p:?} {cap}");
            }
        }
    }

    /// A shell of a box 2 cm thick across the slice plane claims, in the section, only the
    /// sites within its depth of the section's outline: the faces parallel to the plane, 1 cm
    /// from every site, do not count (a 3D distance would claim the whole section).
    #[test]
    fn a_thin_sliced_shell_claims_only_the_outline_s_band() {
        let cut = Slice { axis: 1, at: 0.0 };
        let m = mesh(cuboid([0.25, -0.01, 0.25], [0.75, 0.01, 0.75]))
            .sliced(cut)
            .unwrap()
            .with_shell(0.05);
        for k in 0..400 {
            let p = [
                0.2 + (k % 20) as f64 * 0.03 + 0.001,
                0.2 + (k / 20) as f64 * 0.03 + 0.002,
            ];
            let inside = (0.25..0.75).contains(&p[0]) && (0.25..0.75).contains(&p[1]);
            let to_edge = [p[0] - 0.25, 0.75 - p[0], p[1] - 0.25, 0.75 - p[1]]
                .into_iter()
                .fold(f64::INFINITY, f64::min);
            assert_eq!(m.claims(&p), inside && to_edge < 0.05, "{p:?}");
        }
    }

    #[test]
    fn crossing_surfaces_are_found_and_touching_ones_are_not() {
        let cube = |lo: [f64; 3], hi: [f64; 3]| cuboid(lo, hi);
        let two = |a: Vec<Tri>, b: Vec<Tri>| mesh(a.into_iter().chain(b).collect());
        assert_eq!(mesh(cube([0.0; 3], [1.0; 3])).self_crossing(), None);
        assert_eq!(mesh(sphere([0.5; 3], 0.4, 40)).self_crossing(), None);
        // apart, and sharing a face's plane (touching): no crossing
        assert_eq!(
            two(cube([0.0; 3], [1.0; 3]), cube([2.0; 3], [3.0; 3])).self_crossing(),
            None
        );
        assert_eq!(
            two(cube([0.0; 3], [1.0; 3]), cube([1.0, 0.2, 0.2], [2.0, 0.8, 0.8])).self_crossing(),
            None
        );
        // overlapping: the first box's x = 1 face (triangles 11, 12) is pierced by the second's
        // edges along x; a box through the middle of another crosses it too
        let hit = two(cube([0.0; 3], [1.0; 3]), cube([0.5, 0.2, 0.2], [1.5, 0.8, 0.8])).self_crossing();
        let (a, b) = hit.expect("overlapping boxes cross");
        assert!(a <= 12 && b > 12, "{a} {b}");
        assert!(
            two(cube([0.0; 3], [1.0; 3]), cube([0.3, 0.3, -1.0], [0.6, 0.6, 2.0]))
                .self_crossing()
                .is_some()
        );
        // a sphere through a box's face, and the same sphere wholly inside it (no crossing);
        // centred on the face, its meridian at φ = 90° would lie in the face's plane and meet
        // it only along edges (touching), so it sits a little off
        let b = cube([0.0; 3], [1.0; 3]);
        assert!(two(b.clone(), sphere([1.05, 0.5, 0.5], 0.3, 12))
            .self_crossing()
            .is_some());
        assert_eq!(two(b, sphere([0.5; 3], 0.3, 12)).self_crossing(), None);
    }

    #[test]
    fn holes_and_turned_faces_are_found_and_located() {
        let mut t = cuboid([0.0; 3], [1.0; 3]);
        t.remove(3);
        match mesh(t.clone()).topology() {
            Some(Defect::Open(n, _, _, _)) => assert_eq!(n, 3),
            d => panic!("{d:?}"),
        }
        let mut t = cuboid([0.0; 3], [1.0; 3]);
        t[5].swap(0, 1);
        match mesh(t).topology() {
            Some(Defect::Misoriented(n, a, b)) => {
                assert_eq!(n, 3);
                assert!(a == 6 || b == 6, "{a} {b}");
            }
            d => panic!("{d:?}"),
        }
    }

    #[test]
    fn chords_along_z_and_aslant_match_the_box() {
        let m = mesh(cuboid([0.0; 3], [1.0, 1.0, 2.0]));
        let close = |a: Option<(f64, f64)>, b: (f64, f64)| {
            let a = a.unwrap();
            assert!(
                (a.0 - b.0).abs() < 1e-12 && (a.1 - b.1).abs() < 1e-12,
                "{a:?} against {b:?}"
            );
        };
        close(m.chord(&[0.5, 0.5, -1.0], &[0.0, 0.0, 1.0]), (1.0, 3.0));
        close(m.chord(&[0.5, 0.5, 0.5], &[0.0, 0.0, 1.0]), (0.0, 1.5));
        close(m.chord(&[0.5, 0.5, 3.0], &[0.0, 0.0, -1.0]), (1.0, 3.0));
        assert_eq!(m.chord(&[1.5, 0.5, -1.0], &[0.0, 0.0, 1.0]), None);
        close(m.chord(&[0.2, 0.5, -1.0], &[0.6, 0.0, 0.8]), (1.25, 0.8 / 0.6));
    }

    #[test]
    fn bad_files_are_refused_before_allocation_with_the_reason() {
        let dir = std::env::temp_dir().join(format!("hsph-mesh-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let place = Placement {
            scale: 1.0,
            rotate: [0.0; 3],
            translate: [0.0; 3],
            flip: false,
        };
        let try_bytes = |name: &str, b: &[u8]| {
            let p = dir.join(name);
            std::fs::write(&p, b).unwrap();
            read(&p, "fluid[0].file", &place)
                .map(|m| m.triangles())
                .map_err(|e| e.to_string())
        };
        // a header counting 4·10⁹ triangles in a 134-byte file
        let mut b = vec![0u8; 134];
        b[80..84].copy_from_slice(&u32::MAX.to_le_bytes());
        assert!(try_bytes("huge.stl", &b).unwrap_err().contains("truncated"));
        assert!(try_bytes("short.stl", b"abc").unwrap_err().contains("too short"));
        // one triangle with a NaN
        let mut b = vec![0u8; 134];
        b[80] = 1;
        b[96..100].copy_from_slice(&f32::NAN.to_le_bytes());
        assert!(try_bytes("nan.stl", &b).unwrap_err().contains("not finite"));
        // a binary file whose header starts with `solid` is still binary
        let mut b = vec![0u8; 134];
        b[..6].copy_from_slice(b"solid ");
        b[80] = 1;
        b[100..104].copy_from_slice(&1f32.to_le_bytes());
        assert_eq!(try_bytes("solidbin.stl", &b), Ok(1));
        let ascii = "solid t\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex 1 0 0\nvertex 0 1 0\nendloop\nendfacet\nendsolid t\n";
        assert_eq!(try_bytes("a.stl", ascii.as_bytes()), Ok(1));
        assert!(try_bytes("cut.stl", &ascii.as_bytes()[..60]).is_err());
        assert!(read(&dir, "fluid[0].file", &place)
            .unwrap_err()
            .to_string()
            .contains("not a regular file"));
        std::fs::remove_dir_all(&dir).ok();
    }
}

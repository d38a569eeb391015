//! Where a scene's bodies fall on the global lattice, before any particle is built: the
//! lattice itself (sites at domain.min + (i + ½)·dx, a site's id its index), the sites each
//! body claims (counts for `hsph check`, the memory estimate and the id bound), the extents
//! the bodies are built at and the warnings when those differ from the scene's. `setup`
//! builds the particles on this lattice; the scene's validation refuses a body with no site.

use super::{Scene, WallShape};
use crate::error::{Error, Result};
use crate::Vector;

/// The global lattice of a scene.
#[derive(Debug, Clone)]
pub struct Lattice<const D: usize> {
    /// Lower corner of the domain (m).
    pub origin: Vector<D>,
    /// Spacing dx (m).
    pub dx: f64,
    /// Sites per axis.
    pub n: [u64; D],
    /// Id of the first site: the sites of the coarser levels come first (0 at level 0).
    pub offset: u64,
}

impl<const D: usize> Lattice<D> {
    /// The lattice covering the scene's domain.
    pub fn new(s: &Scene) -> Self {
        let dx = s.discretisation.dx;
        let mut n = [0u64; D];
        for (a, na) in n.iter_mut().enumerate() {
            *na = ((s.domain.max[a] - s.domain.min[a]) / dx + 1e-9).floor().max(1.0) as u64;
        }
        Lattice {
            origin: Vector::from_fn(|a, _| s.domain.min[a]),
            dx,
            n,
            offset: 0,
        }
    }

    /// The lattice of refinement level `level` (`[[refine]]`): spacing dx / 2^level, 2^level
    /// times the sites per axis, nested in the scene's (site i's cell lies in the cell of
    /// coarse site i >> level), its ids after those of every coarser level: id = Σ_{l<level}
    /// (sites of level l) + index. Ids stay unique and fixed by the scene alone.
    pub fn at_level(s: &Scene, level: u32) -> Self {
        let mut lat = Lattice::new(s);
        for _ in 0..level {
            lat.offset += lat.sites();
            lat.dx *= 0.5;
            lat.n = lat.n.map(|n| 2 * n);
        }
        lat
    }

    /// Number of sites.
    pub fn sites(&self) -> u64 {
        self.n.iter().product()
    }

    /// Site index range `[lo, hi)` along `axis` whose centres lie in `[min, max)`.
    pub fn range(&self, axis: usize, min: f64, max: f64) -> (u64, u64) {
        let t = 1e-9;
        let lo = ((min - self.origin[axis]) / self.dx - 0.5 - t).ceil().max(0.0) as u64;
        let hi = ((max - self.origin[axis]) / self.dx - 0.5 - t).ceil().max(0.0) as u64;
        (lo.min(self.n[axis]), hi.min(self.n[axis]))
    }

    /// Visit every site in the box `[min, max)`: `(site index per axis, id, centre)`, the last
    /// axis fastest.
    pub fn for_each_in(&self, min: &[f64], max: &[f64], f: impl FnMut(&[u64], u64, Vector<D>)) {
        self.for_each_in_except(min, max, None, f)
    }

    /// [`Lattice::for_each_in`] without the sites whose indices lie in `hole` (per axis `[lo,
    /// hi)`: a container's inner box), in the same order. A row of the last axis that crosses
    /// the hole jumps over it, so a container's walls cost their own sites, not its inside.
    pub fn for_each_in_except(
        &self,
        min: &[f64],
        max: &[f64],
        hole: Option<&[(u64, u64)]>,
        mut f: impl FnMut(&[u64], u64, Vector<D>),
    ) {
        let r: [(u64, u64); D] = std::array::from_fn(|a| self.range(a, min[a], max[a]));
        if r.iter().any(|(lo, hi)| hi <= lo) {
            return;
        }
        let last = D - 1;
        let mut idx: [u64; D] = std::array::from_fn(|a| r[a].0);
        loop {
            // the row's runs along the last axis: all of it, or the parts beside the hole
            let (lo, hi) = r[last];
            let runs = match hole {
                Some(hl) if (0..last).all(|a| idx[a] >= hl[a].0 && idx[a] < hl[a].1) => {
                    [(lo, hl[last].0.clamp(lo, hi)), (hl[last].1.clamp(lo, hi), hi)]
                }
                _ => [(lo, hi), (hi, hi)],
            };
            let mut row = 0u64;
            for (na, ia) in self.n.iter().zip(&idx).take(last) {
                row = row * na + ia;
            }
            for (a, b) in runs {
                for i in a..b {
                    idx[last] = i;
                    let id = self.offset + row * self.n[last] + i;
                    let x = Vector::from_fn(|a, _| self.origin[a] + (idx[a] as f64 + 0.5) * self.dx);
                    f(&idx, id, x);
                }
            }
            // odometer over the leading axes
            let mut a = last;
            loop {
                if a == 0 {
                    return;
                }
                a -= 1;
                idx[a] += 1;
                if idx[a] < r[a].1 {
                    break;
                }
                idx[a] = r[a].0;
            }
        }
    }
}

/// Exclusive bound of the particle ids of `s`: the number of sites of its lattices, from the
/// scene's to its finest refinement level (at most 585 times the scene's in 3D; validation
/// bounds the scene's lattice so that `id << IMAGE_BITS` fits in 64 bits).
pub fn id_bound<const D: usize>(s: &Scene) -> u64 {
    Lattice::<D>::at_level(s, s.finest_level() + 1).offset
}

/// Number of particles the scene's bodies hold, counted from the lattice ranges without
/// building them (exact unless two bodies overlap, which `setup::build_particles` rejects; a
/// sphere or cylinder counts the sites of its box).
pub fn count_particles<const D: usize>(s: &Scene) -> u64 {
    body_sites::<D>(s).iter().map(|b| b.sites).sum()
}

/// The lattice sites of one body, counted without building them.
#[derive(Debug, Clone)]
pub struct BodySites {
    /// `fluid[i]`, `solid[i]` or `wall[i]`.
    pub key: String,
    /// The body's name in the scene.
    pub name: String,
    /// Sites of its box (a container: of its walls, the outer box less the inner one), a
    /// refined coarse site counted as the 2^(ℓD) sites of level ℓ that replace it.
    pub sites: u64,
    /// The neighbour-list entries its refined sites add, in units of a coarse particle's
    /// (see [`refined`]).
    pub list_extra: f64,
    /// True if the body claims at least one site: its box has sites and, for a sphere or a
    /// cylinder, the site nearest its centre lies inside it.
    pub builds: bool,
    /// Smallest extent of its box (m; a container's inner box).
    pub smallest: f64,
    /// A container with every face open (no walls at any dx).
    pub all_open: bool,
    /// The body's box as the scene gives it (m; a container's inner box), D values each.
    pub min: Vec<f64>,
    /// Its upper corner (m).
    pub max: Vec<f64>,
}

/// The sites of every body that has particles (fluids, solids, then dummy and repulsive walls;
/// mirror walls have none), in the order `setup::SiteSource` adds them, from the lattice ranges
/// alone: O(1) per body whatever its size.
pub fn body_sites<const D: usize>(s: &Scene) -> Vec<BodySites> {
    let lat = Lattice::<D>::new(s);
    let dx = s.discretisation.dx;
    let ranges = |min: &[f64], max: &[f64]| -> Vec<(u64, u64)> {
        (0..D).map(|a| lat.range(a, min[a], max[a])).collect()
    };
    let sites = |r: &[(u64, u64)]| -> u64 { r.iter().map(|(lo, hi)| hi.saturating_sub(*lo)).product() };
    let smallest = |min: &[f64], max: &[f64]| (0..D).map(|a| max[a] - min[a]).fold(f64::INFINITY, f64::min);
    let mut out = Vec::new();
    let bodies = (s
        .fluids
        .iter()
        .enumerate()
        .map(|(i, f)| (format!("fluid[{i}]"), f)))
    .chain(
        s.solids
            .iter()
            .enumerate()
            .map(|(i, f)| (format!("solid[{i}]"), f)),
    );
    for (key, f) in bodies {
        let r = ranges(&f.min, &f.max);
        let (added, list_extra) = refined::<D>(s, &lat, &f.name, &r, None);
        let n = sites(&r) + added;
        // of the box's sites the one nearest the centre (per axis, so nearest overall) is
        // inside a sphere or cylinder if any is
        let builds = n > 0
            && match f.shape {
                super::BodyShape::Block => true,
                // no site is known to be inside if any is: the box's, until one is
                super::BodyShape::Polygon | super::BodyShape::Mesh => {
                    let mut any = false;
                    lat.for_each_in(&f.min, &f.max, |_, _, x| any = any || f.contains(x.as_slice()));
                    any
                }
                _ => {
                    let x: Vec<f64> = (0..D)
                        .map(|a| {
                            let i = ((f.centre[a] - lat.origin[a]) / dx - 0.5).round().max(0.0) as u64;
                            let i = i.clamp(r[a].0, r[a].1 - 1);
                            lat.origin[a] + (i as f64 + 0.5) * dx
                        })
                        .collect();
                    f.contains(&x)
                }
            };
        out.push(BodySites {
            key,
            name: f.name.clone(),
            sites: n,
            list_extra,
            builds,
            smallest: smallest(&f.min, &f.max),
            all_open: false,
            min: f.min.clone(),
            max: f.max.clone(),
        });
    }
    for (i, w) in s.walls.iter().enumerate() {
        if w.method.particle_kind().is_none() {
            continue;
        }
        // the wall's box and the hole in it (a dummy block's core, a container's inside)
        let (outer, hole) = match w.shape {
            WallShape::Block => (ranges(&w.min, &w.max), block_core(s, w, &lat)),
            WallShape::Container => {
                let (lo, hi) = container_outer(s, w);
                (ranges(&lo, &hi), Some(ranges(&w.min, &w.max)))
            }
            WallShape::Polygon | WallShape::Mesh => (ranges(&w.min, &w.max), None),
        };
        let n = match w.shape {
            // the sites of its outline, counted
            WallShape::Polygon | WallShape::Mesh => outline_sites(s, w, &lat),
            _ => sites(&outer).saturating_sub(hole.as_ref().map_or(0, |h| sites(h))),
        };
        // only refinable walls (dummy and dynamic) are built on the refined lattice
        let (added, list_extra) = if w.method.refinable() && !w.shape.outlined() {
            refined::<D>(s, &lat, &w.name, &outer, hole.as_deref())
        } else {
            (0, 0.0)
        };
        let n = n + added;
        let open = |a: usize, up: bool| w.open.iter().any(|o| super::face_of(o, D) == Some((a, up)));
        out.push(BodySites {
            key: format!("wall[{i}]"),
            name: w.name.clone(),
            sites: n,
            list_extra,
            builds: n > 0,
            smallest: smallest(&w.min, &w.max),
            all_open: w.shape == WallShape::Container && (0..D).all(|a| open(a, false) && open(a, true)),
            min: w.min.clone(),
            max: w.max.clone(),
        });
    }
    out
}

/// A polygon or mesh wall's surface and the depth (m) inside it within which it keeps its
/// sites (its shell rows × dx; infinite for a wall without shell rows).
#[derive(Debug, Clone)]
pub(crate) struct Shell {
    surface: Surface,
    depth: f64,
}

/// The surface of a [`Shell`].
#[derive(Debug, Clone)]
enum Surface {
    /// A polygon's vertices (m).
    Outline(Vec<Vec<f64>>),
    /// A closed mesh.
    Mesh(std::sync::Arc<super::mesh::Mesh>),
}

impl Shell {
    /// True if the site at `x` (m) lies inside the surface and within the depth of it.
    pub(crate) fn claims(&self, x: &[f64]) -> bool {
        let deep = self.depth.is_infinite();
        match &self.surface {
            Surface::Outline(v) => claims_outline(v, self.depth, x),
            Surface::Mesh(m) => m.contains(x) && (deep || m.within(x, self.depth)),
        }
    }

    /// The depth (m) within which the wall keeps its sites (infinite: all).
    pub(crate) fn depth(&self) -> f64 {
        self.depth
    }
}

/// A polygon or mesh wall's [`Shell`]; `None` for other walls.
pub(crate) fn wall_shell(s: &Scene, w: &super::WallBody) -> Option<Shell> {
    let dx = s.discretisation.dx;
    let depth = w
        .shell_rows(s.discretisation.support(), dx)
        .map_or(f64::INFINITY, |rows| rows as f64 * dx);
    let surface = match w.shape {
        WallShape::Polygon => Surface::Outline(w.vertices.clone()),
        WallShape::Mesh => Surface::Mesh(w.mesh.clone()?),
        _ => return None,
    };
    Some(Shell { surface, depth })
}

/// The sites of the scene's lattice `lat` a polygon or mesh wall `w` claims (0 for others).
fn outline_sites<const D: usize>(s: &Scene, w: &super::WallBody, lat: &Lattice<D>) -> u64 {
    let Some(shell) = wall_shell(s, w) else {
        return 0;
    };
    let mut n = 0u64;
    lat.for_each_in(&w.min, &w.max, |_, _, x| n += shell.claims(x.as_slice()) as u64);
    n
}

/// True if a polygon wall of `outline` keeping the sites within `depth` (m) of it claims the
/// site at `x` (m).
#[inline]
pub(crate) fn claims_outline(outline: &[Vec<f64>], depth: f64, x: &[f64]) -> bool {
    super::polygon::contains(outline, x[0], x[1])
        && (depth.is_infinite() || super::polygon::distance(outline, x[0], x[1]) < depth)
}

/// The lattice ranges (of `lat`, the scene's lattice) of wall `w`'s core: for a dummy block,
/// the sites more than [`super::WallBody::shell_rows`] rows inside every face (`None` for other
/// walls or a block too thin to have one). A dummy block is built as the shell around it.
pub(crate) fn block_core<const D: usize>(
    s: &Scene,
    w: &super::WallBody,
    lat: &Lattice<D>,
) -> Option<Vec<(u64, u64)>> {
    let rows = w.shell_rows(s.discretisation.support(), s.discretisation.dx)?;
    (0..D)
        .map(|a| {
            let (lo, hi) = lat.range(a, w.min[a], w.max[a]);
            (hi > lo + 2 * rows).then_some((lo + rows, hi - rows))
        })
        .collect()
}

/// What the regions refining body `name` add to its coarse sites `boxr` (lattice ranges of
/// `lat`, the scene's lattice) less those in `hole`: each coarse site whose centre lies in
/// a region of level ℓ is replaced by the 2^(ℓD) sites of that level that subdivide its cell
/// (`setup::SiteSource`). Returns the sites added (2^(ℓD) − 1 per refined coarse site) and the
/// neighbour-list entries those sites add in units of a coarse particle's: a site of level ℓ
/// with the scene's h lists 2^(ℓD) times a coarse particle's neighbours, one with its level's
/// h as many ([`super::refine::Refine::list_factor`]), but no more than the region's sites of
/// its level; and each coarse site within a support of the region lists its children. The
/// sites are exact for block regions; a sphere or cylinder counts the coarse sites of its
/// bounding box (an upper bound).
fn refined<const D: usize>(
    s: &Scene,
    lat: &Lattice<D>,
    name: &str,
    boxr: &[(u64, u64)],
    hole: Option<&[(u64, u64)]>,
) -> (u64, f64) {
    let within = |a: &[(u64, u64)], r: &[(u64, u64)]| -> u64 {
        (0..D)
            .map(|k| a[k].1.min(r[k].1).saturating_sub(a[k].0.max(r[k].0)))
            .product()
    };
    let (base, support) = (s.discretisation.lattice_neighbours(D), s.discretisation.support());
    let (mut added, mut extra) = (0u64, 0.0f64);
    for r in s.refine.iter().filter(|r| r.applies_to(name)) {
        let rr: Vec<(u64, u64)> = (0..D).map(|a| lat.range(a, r.min[a], r.max[a])).collect();
        let coarse = within(boxr, &rr).saturating_sub(hole.map_or(0, |h| within(h, &rr)));
        let children = coarse << (D as u32 * r.level);
        added += children - coarse;
        // a child lists no more of its kind than the region holds
        let factor = r.list_factor(D).min(1.0 + children as f64 / base);
        extra += children as f64 * (factor - 1.0);
        // the coarse sites within a support of the region list its children: on average
        // the share of a support beyond a plane at a uniform distance below one support,
        // 2/(3π) in 2D and 3/16 in 3D, at 2^(ℓD) times the coarse density
        let wide: Vec<(u64, u64)> = (0..D)
            .map(|a| lat.range(a, r.min[a] - support, r.max[a] + support))
            .collect();
        let shell = (within(boxr, &wide) - within(boxr, &rr))
            .saturating_sub(hole.map_or(0, |h| within(h, &wide) - within(h, &rr)));
        let share = if D == 2 {
            2.0 / (3.0 * std::f64::consts::PI)
        } else {
            3.0 / 16.0
        };
        extra += shell as f64 * share * ((1u64 << (D as u32 * r.level)) - 1) as f64;
    }
    (added, extra)
}

/// The mean neighbour-list length of the scene's particles in units of a coarse particle's
/// (1 without refinement), from the bodies' counts ([`body_sites`]): what the memory
/// estimate multiplies the lattice's neighbours by.
pub fn list_weight(b: &[BodySites]) -> f64 {
    let n: u64 = b.iter().map(|b| b.sites).sum();
    let extra: f64 = b.iter().map(|b| b.list_extra).sum();
    if n == 0 {
        1.0
    } else {
        (1.0 + extra / n as f64).max(1.0)
    }
}

/// Every body builds at least one particle at the scene's dx: one that builds none is an
/// input error naming it and dx, with a spacing that would resolve it.
pub fn check_bodies_build<const D: usize>(s: &Scene) -> Result<()> {
    let dx = s.discretisation.dx;
    let Some(b) = body_sites::<D>(s).into_iter().find(|b| !b.builds) else {
        return Ok(());
    };
    if b.all_open {
        return Err(Error::input(
            format!("{}.open", b.key),
            format!(
                "wall `{}` is a container with every face open, which has no particle at any dx; \
                 close a face (e.g. open = [\"y+\"]) or remove the wall",
                b.name
            ),
        ));
    }
    let smallest = b.smallest;
    Err(Error::input(
        b.key.clone(),
        format!(
            "body `{}` builds no particle at dx = {dx} m: no lattice site (at domain.min + (i + ½)·dx) \
             lies inside it, its smallest extent being {smallest:.4e} m; refine discretisation.dx \
             (e.g. dx = {:.4e}, half that extent) or enlarge the body",
            b.name,
            0.5 * smallest
        ),
    ))
}

/// A body as the lattice builds it: every lattice site whose centre lies in the scene's box
/// `[min, max)` becomes a particle standing for a cell of side dx, so the body as built spans
/// `[origin + lo·dx, origin + hi·dx)` along each axis.
#[derive(Debug, Clone)]
pub struct BuiltBody {
    /// `fluid[i]`, `wall[i]` (a block) or `wall[i] inner` (a container's inner box).
    pub key: String,
    /// The body's name in the scene.
    pub name: String,
    /// Box in the scene (m).
    pub scene: (Vec<f64>, Vec<f64>),
    /// Box as built (m).
    pub built: (Vec<f64>, Vec<f64>),
    /// Sites per axis.
    pub sites: Vec<u64>,
}

/// Largest relative difference between built and scene sizes (per axis, and of the volume).
const EXTENT_TOLERANCE: f64 = 0.01;

impl BuiltBody {
    /// Relative size differences per axis and of the volume, (built − scene) / scene.
    pub fn differences(&self) -> (Vec<f64>, f64) {
        let len = |b: &(Vec<f64>, Vec<f64>), a: usize| b.1[a] - b.0[a];
        let d = self.scene.0.len();
        let per_axis: Vec<f64> = (0..d)
            .map(|a| len(&self.built, a) / len(&self.scene, a) - 1.0)
            .collect();
        let vol = |b: &(Vec<f64>, Vec<f64>)| (0..d).map(|a| len(b, a)).product::<f64>();
        (per_axis, vol(&self.built) / vol(&self.scene) - 1.0)
    }

    /// True if the body as built differs from the scene's by more than 1 % in size or volume.
    pub fn off(&self) -> bool {
        let (axes, vol) = self.differences();
        vol.abs() > EXTENT_TOLERANCE || axes.iter().any(|x| x.abs() > EXTENT_TOLERANCE)
    }
}

/// Every fluid block, wall block and container inner box as built on the scene's lattice.
pub fn built_extents<const D: usize>(s: &Scene) -> Vec<BuiltBody> {
    let lat = Lattice::<D>::new(s);
    let body = |key: String, name: &str, min: &[f64], max: &[f64]| {
        let r: Vec<(u64, u64)> = (0..D).map(|a| lat.range(a, min[a], max[a])).collect();
        let edge = |i: u64, a: usize| lat.origin[a] + i as f64 * lat.dx;
        BuiltBody {
            key,
            name: name.to_string(),
            scene: (min.to_vec(), max.to_vec()),
            built: (
                (0..D).map(|a| edge(r[a].0, a)).collect(),
                (0..D).map(|a| edge(r[a].1, a)).collect(),
            ),
            sites: r.iter().map(|(lo, hi)| hi.saturating_sub(*lo)).collect(),
        }
    };
    let mut out: Vec<BuiltBody> = s
        .fluids
        .iter()
        .enumerate()
        .filter(|(_, f)| f.shape == super::BodyShape::Block)
        .map(|(i, f)| body(format!("fluid[{i}]"), &f.name, &f.min, &f.max))
        .collect();
    for (i, w) in s.walls.iter().enumerate() {
        match (w.shape, w.method.particle_kind()) {
            (WallShape::Block, Some(_)) => out.push(body(format!("wall[{i}]"), &w.name, &w.min, &w.max)),
            (WallShape::Container, Some(_)) => {
                out.push(body(format!("wall[{i}] inner"), &w.name, &w.min, &w.max))
            }
            _ => {}
        }
    }
    out
}

/// The spacing nearest to the scene's dx (within ±30 %) on whose lattice every body is built
/// exactly as written (every extent and offset from the domain's corner a whole number of
/// spacings), if there is one.
pub fn fitting_dx<const D: usize>(s: &Scene) -> Option<f64> {
    let dx = s.discretisation.dx;
    let origin = &s.domain.min;
    let mut lengths = Vec::new();
    for b in built_extents::<D>(s) {
        for (a, o) in origin.iter().enumerate().take(D) {
            lengths.push(b.scene.0[a] - o);
            lengths.push(b.scene.1[a] - o);
        }
    }
    let reference = lengths
        .iter()
        .copied()
        .filter(|l| *l > 0.0)
        .fold(f64::INFINITY, f64::min);
    if !reference.is_finite() {
        return None;
    }
    let whole = |l: f64, h: f64| ((l / h) - (l / h).round()).abs() < 1e-6 * (l / h).abs().max(1.0);
    let n0 = (reference / dx).round().max(1.0) as u64;
    // candidates reference / n near n0, nearest first
    (0..n0.max(8))
        .flat_map(|k| [n0 + k, n0.saturating_sub(k)])
        .filter(|&n| n > 0)
        .map(|n| reference / n as f64)
        .filter(|h| (h / dx - 1.0).abs() <= 0.3)
        .find(|&h| lengths.iter().all(|&l| whole(l, h)))
}

/// Sizes "a × b (× c)" in metres with 4 significant digits.
fn sizes(b: &(Vec<f64>, Vec<f64>)) -> String {
    let v: Vec<String> =
        b.0.iter()
            .zip(&b.1)
            .map(|(lo, hi)| format!("{:.4}", hi - lo))
            .collect();
    v.join(" × ")
}

/// One line per body: its size in the scene and as built, its particles per axis and the
/// volume difference; for a polygon its vertices, box, area and sites.
pub fn extent_lines<const D: usize>(s: &Scene) -> Vec<String> {
    let mut lines: Vec<String> = built_extents::<D>(s)
        .iter()
        .map(|b| {
            let (_, vol) = b.differences();
            let n: Vec<String> = b.sites.iter().map(|k| k.to_string()).collect();
            format!(
                "{} `{}`: scene {} m, built {} m ({} sites), volume {:+.2} %",
                b.key,
                b.name,
                sizes(&b.scene),
                sizes(&b.built),
                n.join(" × "),
                100.0 * vol
            )
        })
        .collect();
    lines.extend(polygon_lines::<D>(s));
    lines.extend(mesh_lines::<D>(s));
    lines.extend(region_mesh_lines::<D>(s));
    lines
}

/// `hsph check`'s line for each mesh refinement region: its file's triangles, format and hash,
/// the placed box, the volume (in 2D the section's area) and the sites of the scene's lattice
/// it holds (the coarse sites it refines, of whichever body), and the memory the mesh and its
/// index take on every rank.
fn region_mesh_lines<const D: usize>(s: &Scene) -> Vec<String> {
    let lat = Lattice::<D>::new(s);
    (s.refine.iter().enumerate())
        .filter_map(|(i, r)| Some((i, r, r.mesh.as_ref()?)))
        .map(|(i, r, m)| {
            let mut n = 0u64;
            lat.for_each_in(&r.min, &r.max, |_, _, x| n += r.contains(x.as_slice()) as u64);
            format!(
                "refine[{i}] (level {}): mesh of {} triangles ({} STL, SHA-256 {}…), box {:?} .. {:?} m, \
                 {} {:.4e} {}, holds {n} sites of the scene's lattice; the mesh takes {:.1} MiB per rank",
                r.level,
                m.triangles(),
                m.format,
                &m.sha256[..12.min(m.sha256.len())],
                r.min,
                r.max,
                if D == 2 { "section area" } else { "volume" },
                m.measure().abs(),
                if D == 2 { "m²" } else { "m³" },
                m.bytes() as f64 / (1u64 << 20) as f64
            )
        })
        .collect()
}

/// `hsph check`'s line for each mesh body: its file's triangles, format and hash, the placed
/// box, the signed volume (positive: normals outward), the sites built with their volume's
/// difference from the mesh's, and the memory the mesh and its index take on every rank.
fn mesh_lines<const D: usize>(s: &Scene) -> Vec<String> {
    let lat = Lattice::<D>::new(s);
    let bodies = (s.fluids.iter().enumerate())
        .map(|(i, f)| (format!("fluid[{i}]"), f))
        .chain((s.solids.iter().enumerate()).map(|(i, f)| (format!("solid[{i}]"), f)));
    bodies
        .filter_map(|(key, f)| Some((key, f, f.mesh.as_ref()?)))
        .map(|(key, f, m)| {
            let vol = m.measure();
            let (measure, unit) = if D == 2 {
                ("section area", "m²")
            } else {
                ("volume", "m³")
            };
            let (mut n, mut tested) = (0u64, 0u64);
            // the fill's own time, one thread (BENCHMARKS.md records it)
            let clock = std::time::Instant::now();
            lat.for_each_in(&f.min, &f.max, |_, _, x| {
                n += f.contains(x.as_slice()) as u64;
                tested += 1;
            });
            let fill = clock.elapsed().as_secs_f64();
            let built = n as f64 * lat.dx.powi(D as i32);
            format!(
                "{key} `{}`: mesh of {} triangles ({} STL, SHA-256 {}…), box {:?} .. {:?} m, {} \
                 {:.4e} {} (normals {}), built {n} sites, {}; {tested} sites tested in \
                 {fill:.2} s; the mesh takes {:.1} MiB per rank",
                f.name,
                m.triangles(),
                m.format,
                &m.sha256[..12.min(m.sha256.len())],
                f.min,
                f.max,
                measure,
                vol.abs(),
                unit,
                if vol > 0.0 { "outward" } else { "inward" },
                match m.shell_depth() {
                    // a shell fills part of the inside: nothing to compare its sites with
                    Some(depth) => format!("a shell {depth:.4e} m deep"),
                    None => format!("{measure} {:+.2} %", 100.0 * (built / vol.abs() - 1.0)),
                },
                m.bytes() as f64 / (1u64 << 20) as f64
            )
        })
        .collect()
}

/// `hsph check`'s line for each polygon body: vertices and their orientation, box, area, and
/// the sites built with their area's difference from the outline's; for a polygon wall the
/// sites of its shell.
fn polygon_lines<const D: usize>(s: &Scene) -> Vec<String> {
    let lat = Lattice::<D>::new(s);
    let walls = (s.walls.iter().enumerate()).filter_map(|(i, w)| {
        let depth = wall_shell(s, w)?.depth();
        let outline = &w.vertices;
        let n = outline_sites(s, w, &lat);
        let shell = match depth.is_finite() {
            true => format!(
                "its shell within {depth:.4e} m of the {}",
                if w.mesh.is_some() { "surface" } else { "outline" }
            ),
            false => "solid".to_string(),
        };
        Some(format!(
            "wall[{i}] `{}`: {}, box {:?} .. {:?} m, built {n} sites ({shell})",
            w.name,
            match &w.mesh {
                Some(m) => format!(
                    "mesh of {} triangles, {} {:.4e} {}",
                    m.triangles(),
                    if D == 2 { "section area" } else { "volume" },
                    m.measure().abs(),
                    if D == 2 { "m²" } else { "m³" }
                ),
                None => format!(
                    "polygon of {} vertices, area {:.4e} m²",
                    outline.len(),
                    super::polygon::signed_area(outline).abs()
                ),
            },
            w.min,
            w.max,
        ))
    });
    let bodies = (s
        .fluids
        .iter()
        .enumerate()
        .map(|(i, f)| (format!("fluid[{i}]"), f)))
    .chain(
        s.solids
            .iter()
            .enumerate()
            .map(|(i, f)| (format!("solid[{i}]"), f)),
    );
    bodies
        .filter(|(_, f)| f.shape == super::BodyShape::Polygon)
        .map(|(key, f)| {
            let area = super::polygon::signed_area(&f.vertices);
            let mut n = 0u64;
            lat.for_each_in(&f.min, &f.max, |_, _, x| n += f.contains(x.as_slice()) as u64);
            let built = n as f64 * lat.dx.powi(D as i32);
            format!(
                "{key} `{}`: polygon of {} vertices ({}), box {:?} .. {:?} m, area {:.4e} m², \
                 built {n} sites, area {:+.2} %",
                f.name,
                f.vertices.len(),
                if area > 0.0 {
                    "counter-clockwise"
                } else {
                    "clockwise"
                },
                f.min,
                f.max,
                area.abs(),
                100.0 * (built / area.abs() - 1.0)
            )
        })
        .chain(walls)
        .collect()
}

/// A fluid body and a solid body whose boxes overlap or come within a kernel support of each
/// other: they would pass through each other, since fluids and solids do not interact yet.
pub fn coupling_warnings(s: &Scene) -> Vec<String> {
    let reach = s.discretisation.support();
    let mut out = Vec::new();
    for (i, f) in s.fluids.iter().enumerate() {
        for (j, b) in s.solids.iter().enumerate() {
            let within =
                |r: f64| (0..s.dimension).all(|a| f.min[a] - r < b.max[a] && b.min[a] - r < f.max[a]);
            if within(reach) {
                let how = if within(0.0) {
                    "overlap".to_string()
                } else {
                    format!(
                        "lie within a kernel support ({} m) of each other",
                        super::checks::num(reach)
                    )
                };
                out.push(format!(
                    "fluid[{i}] `{}` and solid[{j}] `{}` {how}, but fluids and solids do not \
                     interact yet (no coupling): each moves through the other",
                    f.name, b.name
                ));
            }
        }
    }
    out
}

/// A mirror container whose closed face the body force presses the fluid against (a floor):
/// its images carry each particle's own pressure, not the hydrostatic rise across the face, so
/// the wall does not hold the fluid up and the rows next to it sink. The still tank of
/// `hydrostatic_2d.toml` on mirror walls over 0.2 s: speed 0.21 % of √(gH) and pressure error
/// 3.1 % at h/dx = 2 (dummy walls: 0.17 %, 1.0 %), 5.1 % and 3.5 % at h/dx = 4, which refined
/// particles with the scene's h reach at level 1.
pub fn mirror_floor_warnings(s: &Scene) -> Vec<String> {
    let g = &s.physics.body_force;
    let mut out = Vec::new();
    for (i, w) in s.walls.iter().enumerate() {
        if !w.method.makes_images() || w.shape != super::WallShape::Container {
            continue;
        }
        let d = s.dimension;
        // closed faces whose outward normal has the body force's direction
        let floors: Vec<String> = (0..d)
            .flat_map(|a| [(a, false), (a, true)])
            .filter(|&(a, up)| !w.open.iter().any(|o| super::checks::face(o, d) == Some((a, up))))
            .filter(|&(a, up)| if up { g[a] > 0.0 } else { g[a] < 0.0 })
            .map(|(a, up)| format!("{}{}", ["x", "y", "z"][a], if up { "+" } else { "-" }))
            .collect();
        if !floors.is_empty() {
            out.push(format!(
                "wall[{i}] `{}` is a mirror wall under the body force (face {}): mirror images carry \
                 the fluid's own pressure, not the hydrostatic rise across the face, so the rows \
                 beside it are not held up (the still tank: speed 0.2 % of √(gH) and pressure error \
                 3 % at h/dx = 2, 5 % and 3.5 % at h/dx = 4 or with refined particles of the scene's \
                 h); a floor under gravity is better as method = \"dummy\"",
                w.name,
                floors.join(", ")
            ));
        }
    }
    out
}

/// Dynamic walls built in fewer rows than the support of the fluid's first row reaches, under
/// a body force:
/// the fluid beside them lacks part of its support, and the still tank's bottom row sinks half
/// a spacing onto the wall with its pressure far off (docs/methods.md §2).
pub fn thin_dynamic_wall_warnings(s: &Scene) -> Vec<String> {
    if s.physics.body_force.iter().all(|&g| g == 0.0) {
        return Vec::new();
    }
    let (support, dx) = (s.discretisation.support(), s.discretisation.dx);
    // rows within the support of the fluid's first row, dx/2 off the face: k dx < κh
    let reach = (((support / dx) * (1.0 - 1e-12)).ceil() as usize)
        .saturating_sub(1)
        .max(1);
    let mut out = Vec::new();
    for (i, w) in s.walls.iter().enumerate() {
        let rows = match w.shape {
            super::WallShape::Container => w.built_layers(support, dx),
            super::WallShape::Block | super::WallShape::Polygon | super::WallShape::Mesh => {
                w.shell_rows(support, dx).unwrap_or(0) as usize
            }
        };
        if w.method.integrates_density() && rows < reach {
            out.push(format!(
                "wall[{i}] `{}` is a dynamic wall in {rows} of the {reach} rows within the support of \
                 the fluid's first row: it holds the fluid (DualSPHysics's layout), but the fluid beside it lacks \
                 part of its support and still water does not settle (the still tank, h = 2 dx, in 1 \
                 layer: pressure 34 % low at the bottom row and 9 % low at 0.4 H above it, speed 5 % \
                 of √(gH) at 2 s; in 2 layers the pressure error is 1.7 %, in 3 0.36 %); leave \
                 `layers` out where pressures or a still free surface matter",
                w.name
            ));
        }
    }
    out
}

/// Wall blocks thinner than the support between fluid on both sides: across a plate of
/// thickness t along an axis, the first fluid rows on either side lie t + dx apart, and below
/// κh each side's fluid sums the other's through the plate (a one-row plate between 0.5 m and
/// 0.3 m of water read a net force 16–21 % low; two rows, within 2 %).
pub fn thin_plate_warnings(s: &Scene) -> Vec<String> {
    let (support, dx, d) = (s.discretisation.support(), s.discretisation.dx, s.dimension);
    let mut out = Vec::new();
    for (i, w) in s.walls.iter().enumerate() {
        if w.shape != super::WallShape::Block || w.method.particle_kind().is_none() {
            continue;
        }
        for a in 0..d {
            let t = w.max[a] - w.min[a];
            if t + dx >= support {
                continue;
            }
            // a fluid body's box beside the face on `up`'s side, overlapping the plate across
            let beside = |up: bool| {
                s.fluids.iter().any(|f| {
                    let across = (0..d)
                        .filter(|&b| b != a)
                        .all(|b| f.min[b] < w.max[b] && w.min[b] < f.max[b]);
                    let near = if up {
                        f.min[a] >= w.max[a] - 1e-9 && f.min[a] < w.max[a] + support
                    } else {
                        f.max[a] <= w.min[a] + 1e-9 && f.max[a] > w.min[a] - support
                    };
                    across && near
                })
            };
            if beside(false) && beside(true) {
                out.push(format!(
                    "wall[{i}] `{}` is {:.3} m thick along {} with fluid on both sides: the fluid \
                     on each side reaches the other's through it (its first rows lie {:.3} m apart, \
                     within the support {:.3} m), so forces on it and pressures beside it are off (a \
                     one-row plate between 0.5 m and 0.3 m of water read 16–21 % low); make it at \
                     least {:.3} m thick",
                    w.name,
                    t,
                    ["x", "y", "z"][a],
                    t + dx,
                    support,
                    support - dx
                ));
            }
        }
    }
    out
}

/// A scene's set-up warnings: settings outside their tested range (shifting below h/dx 1.8, a
/// CFL number above 1), fluids and solids that touch without coupling, and bodies built more
/// than 1 % off their scene size or volume (a body fills whole lattice cells of dx counted
/// from `domain.min`), with the spacing that would build them all as written, if one lies
/// within ±30 % of dx.
pub fn scene_warnings<const D: usize>(s: &Scene) -> Vec<String> {
    let mut out = sphere_warnings::<D>(s);
    out.extend(coupling_warnings(s));
    out.extend(mirror_floor_warnings(s));
    out.extend(thin_dynamic_wall_warnings(s));
    out.extend(thin_plate_warnings(s));
    if s.time.cfl > 1.0 && s.time.dt == 0.0 {
        out.push(format!(
            "time.cfl = {} is above 1: dt = CFL·h/(c0 + |v|max) then exceeds the time sound takes \
             to cross h; in the 2D dam break every method held to 0.75, plain WCSPH and Molteni's \
             δ-SPH to 1.25, and all failed at 1.5 (docs/validation.md §5c); 0.2 is typical",
            s.time.cfl
        ));
    }
    if let Some(w) = undamped_warning(s) {
        out.push(w);
    }
    let frames = s.output.frames.as_deref().unwrap_or_default();
    if let Some(j) = frames.iter().position(|&t| t > s.time.t_end) {
        let later = match frames.len() - j - 1 {
            0 => String::new(),
            n => format!(" (nor at the {n} later times)"),
        };
        out.push(format!(
            "output.frames[{j}] = {} s lies past time.t_end = {} s: the run writes no frame there{later}",
            frames[j], s.time.t_end,
        ));
    }
    if s.physics.shifting == super::ShiftingKind::DeltaPlus && s.discretisation.h_over_dx < 1.8 {
        out.push(format!(
            "physics.shifting = \"delta_plus\" with discretisation.h_over_dx = {}: shifting is made \
             for h/dx = 2 (Sun et al. 2017); at 1.3 it raised the 40 × 40 cavity's error from 3.2 % \
             to 17.6 % (docs/validation.md §3d); use h_over_dx = 2.0",
            s.discretisation.h_over_dx
        ));
    }
    let off: Vec<BuiltBody> = built_extents::<D>(s).into_iter().filter(|b| b.off()).collect();
    if off.is_empty() {
        return out;
    }
    let fit = match fitting_dx::<D>(s) {
        Some(h) => format!("discretisation.dx = {h:.6e} m would build every body as written"),
        None => "no spacing within ±30 % of dx builds every body as written; align the bodies with \
                 domain.min + k·dx"
            .to_string(),
    };
    out.extend(off.iter().map(|b| {
        let (axes, vol) = b.differences();
        let a: Vec<String> = axes.iter().map(|x| format!("{:+.1} %", 100.0 * x)).collect();
        format!(
            "{} `{}` is built {} m where the scene says {} m ({}; volume {:+.1} %): bodies fill \
                 whole cells of dx = {} m counted from domain.min; {fit}",
            b.key,
            b.name,
            sizes(&b.built),
            sizes(&b.scene),
            a.join(", "),
            100.0 * vol,
            s.discretisation.dx
        )
    }));
    out
}

/// A fluid without density diffusion and with artificial viscosity below 0.02 and no laminar
/// viscosity: plain weakly compressible SPH, whose pressure noise grows until the run blows
/// up in a violent flow (the stability map, docs/validation.md §5 (a): the dam break gains
/// energy at 0.12 s with α = 0 and at 0.28 s with α = 0.005; α = 0.02 or any δ-SPH term holds).
fn undamped_warning(s: &Scene) -> Option<String> {
    let p = &s.physics;
    let undamped = !s.fluids.is_empty()
        && !p.density_diffusion.diffuses()
        && p.artificial_viscosity < 0.02
        && p.laminar_viscosity == 0.0;
    undamped.then(|| {
        format!(
            "the fluid has no density diffusion (physics.density_diffusion = \"none\"), \
             physics.artificial_viscosity = {} and no laminar viscosity: plain weakly compressible \
             SPH, whose pressure noise grows in a violent flow (the 2D dam break gained energy at \
             0.12 s with α = 0 and at 0.28 s with α = 0.005, docs/validation.md §5); set \
             physics.density_diffusion = \"antuono\" (delta = 0.1) or \"fourtakas\", or \
             physics.artificial_viscosity = 0.02",
            p.artificial_viscosity
        )
    })
}

/// Spheres (discs in 2D), cylinders and polygons whose lattice volume (sites × dx^D) differs
/// from the true volume by more than 1 %: a sphere is resolved by its diameter in spacings, a
/// polygon by its narrowest part.
fn sphere_warnings<const D: usize>(s: &Scene) -> Vec<String> {
    let lat = Lattice::<D>::new(s);
    let dx = s.discretisation.dx;
    let mut out = Vec::new();
    for (i, f) in s.fluids.iter().enumerate() {
        let shell = f.mesh.as_ref().is_some_and(|m| m.shell_depth().is_some());
        if f.shape == super::BodyShape::Block || shell {
            continue;
        }
        let mut n = 0u64;
        lat.for_each_in(&f.min, &f.max, |_, _, x| n += f.contains(x.as_slice()) as u64);
        let pi = std::f64::consts::PI;
        let exact = match (f.shape, D) {
            (super::BodyShape::Polygon, _) => super::polygon::signed_area(&f.vertices).abs(),
            (super::BodyShape::Mesh, _) => f.mesh.as_ref().map_or(0.0, |m| m.measure().abs()),
            (super::BodyShape::Cylinder, _) => pi * f.radius.powi(2) * f.length,
            (_, 2) => pi * f.radius.powi(2),
            _ => 4.0 / 3.0 * pi * f.radius.powi(3),
        };
        let rel = n as f64 * dx.powi(D as i32) / exact - 1.0;
        if rel.abs() > 0.01 {
            let what = match f.shape {
                super::BodyShape::Polygon => format!("a polygon of area {exact:.4e} m²"),
                super::BodyShape::Mesh if D == 2 => format!("a mesh section of area {exact:.4e} m²"),
                super::BodyShape::Mesh => format!("a mesh of volume {exact:.4e} m³"),
                shape => format!(
                    "a {} of radius {} m, {:.1} spacings across",
                    shape.name(),
                    f.radius,
                    2.0 * f.radius / dx
                ),
            };
            out.push(format!(
                "fluid[{i}] `{}` ({what}) is built with {} {:+.1} % off the true one; a finer dx \
                 resolves it better",
                f.name,
                if D == 2 { "an area" } else { "a volume" },
                100.0 * rel
            ));
        }
    }
    out
}

/// The outer box of a container wall: its inner box grown by its built layers
/// ([`super::WallBody::built_layers`]) on every closed face (open faces stay at the inner box).
pub(crate) fn container_outer(s: &Scene, w: &super::WallBody) -> (Vec<f64>, Vec<f64>) {
    let (d, dx) = (s.dimension, s.discretisation.dx);
    let layers = w.built_layers(s.discretisation.support(), dx);
    let mut lo = w.min.clone();
    let mut hi = w.max.clone();
    for a in 0..d {
        let open = |up| w.open.iter().any(|o| super::face_of(o, d) == Some((a, up)));
        if !open(false) {
            lo[a] -= layers as f64 * dx;
        }
        if !open(true) {
            hi[a] += layers as f64 * dx;
        }
    }
    (lo, hi)
}

#[cfg(test)]
mod tests {
    use super::Lattice;
    use crate::Vector;

    /// Every site of `[min, max)` with its index, id and centre, in visiting order.
    type Visits = Vec<(Vec<u64>, u64, Vec<f64>)>;

    fn visits<const D: usize>(
        lat: &Lattice<D>,
        min: &[f64],
        max: &[f64],
        hole: Option<&[(u64, u64)]>,
    ) -> Visits {
        let mut v = Vec::new();
        lat.for_each_in_except(min, max, hole, |idx, id, x| {
            v.push((idx.to_vec(), id, x.as_slice().to_vec()))
        });
        v
    }

    /// The hole jumped over equals the full visit filtered by the hole, site for site and in
    /// the same order, for holes inside, across and beyond the visited box (2D and 3D).
    fn check<const D: usize>(n: u64) {
        let lat = Lattice::<D> {
            origin: Vector::<D>::from_fn(|a, _| -0.3 * a as f64),
            dx: 0.1,
            n: [n; D],
            offset: 7,
        };
        let (min, max) = (vec![-1.0; D], vec![10.0; D]);
        let all = visits(&lat, &min, &max, None);
        assert_eq!(all.len() as u64, n.pow(D as u32));
        for (i, id) in all.iter().map(|v| v.1).enumerate() {
            assert_eq!(id, 7 + i as u64, "ids follow the index, last axis fastest");
        }
        let holes: [Vec<(u64, u64)>; 4] = [
            vec![(2, 5); D],
            (0..D).map(|a| (a as u64, n - 1)).collect(),
            vec![(0, n); D],
            (0..D).map(|a| (n - 2, n + 3 + a as u64)).collect(),
        ];
        for hole in &holes {
            let inside = |idx: &[u64]| idx.iter().zip(hole).all(|(i, (l, h))| i >= l && i < h);
            let want: Visits = all.iter().filter(|v| !inside(&v.0)).cloned().collect();
            assert_eq!(visits(&lat, &min, &max, Some(hole)), want, "hole {hole:?}");
            // a sub-box cut by the hole
            let (lo, hi) = (vec![0.15; D], vec![0.55; D]);
            let sub: Visits = visits(&lat, &lo, &hi, None)
                .into_iter()
                .filter(|v| !inside(&v.0))
                .collect();
            assert_eq!(
                visits(&lat, &lo, &hi, Some(hole)),
                sub,
                "hole {hole:?} in a sub-box"
            );
        }
    }

    #[test]
    fn a_hole_is_jumped_over_in_the_visiting_order() {
        check::<2>(9);
        check::<3>(7);
    }

    /// A fluid and a solid are warned about when they overlap or lie within a kernel support
    /// (here 2h = 0.08 m) of each other, each said as it is, and not when farther apart.
    #[test]
    fn fluids_and_solids_are_warned_about_within_a_support_only() {
        let text = include_str!("../../inputs/hydrostatic_2d.toml").to_string()
            + "[[material]]\nname = \"al\"\nmodel = \"solid\"\nlibrary = \"al6061-t6\"\n\
               [[solid]]\nname = \"brick\"\nmaterial = \"al\"\nmin = [0.4, Y0]\nmax = [0.6, 0.7]\n";
        let warned = |y0: &str| {
            let t = text.replace("Y0", y0);
            let (s, _) = crate::scene::load_scene_str(&t, std::path::Path::new("t.toml"), "t", &[]).unwrap();
            super::coupling_warnings(&s)
        };
        assert!(warned("0.6").is_empty(), "0.1 m apart: {:?}", warned("0.6"));
        let near = warned("0.55");
        assert!(
            near.len() == 1 && near[0].contains("within a kernel support (0.08 m)"),
            "{near:?}"
        );
        let over = warned("0.45");
        assert!(over.len() == 1 && over[0].contains("overlap,"), "{over:?}");
    }

    /// A mirror floor under gravity is warned about (the face named), mirror side walls and a
    /// dummy floor are not.
    #[test]
    fn a_mirror_floor_under_gravity_is_warned_about() {
        let text = include_str!("../../inputs/hydrostatic_2d.toml");
        let warned = |sets: &[&str]| {
            let sets: Vec<String> = sets.iter().map(|x| x.to_string()).collect();
            let (s, _) =
                crate::scene::load_scene_str(text, std::path::Path::new("t.toml"), "t", &sets).unwrap();
            super::mirror_floor_warnings(&s)
        };
        let floor = warned(&["wall.0.method=\"mirror\""]);
        assert!(floor.len() == 1 && floor[0].contains("(face y-)"), "{floor:?}");
        assert!(warned(&[]).is_empty(), "dummy walls");
        let sideways = warned(&["wall.0.method=\"mirror\"", "wall.0.open=[\"y+\", \"y-\"]"]);
        assert!(sideways.is_empty(), "{sideways:?}");
    }

    /// A dynamic wall in fewer rows than the support reaches is warned about under gravity;
    /// in the rows it reaches, or without a body force, it is not.
    #[test]
    fn a_thin_dynamic_wall_is_warned_about() {
        let text = include_str!("../../inputs/hydrostatic_2d.toml");
        let warned = |sets: &[&str]| {
            let sets: Vec<String> = sets.iter().map(|x| x.to_string()).collect();
            let (s, _) =
                crate::scene::load_scene_str(text, std::path::Path::new("t.toml"), "t", &sets).unwrap();
            super::thin_dynamic_wall_warnings(&s)
        };
        let thin = warned(&["wall.0.method=\"dynamic\"", "wall.0.layers=1"]);
        assert!(
            thin.len() == 1 && thin[0].contains("in 1 of the 3 rows"),
            "{thin:?}"
        );
        assert!(
            warned(&["wall.0.method=\"dynamic\""]).is_empty(),
            "the rows in reach"
        );
        assert!(warned(&["wall.0.layers=1"]).is_empty(), "dummy walls");
        let weightless = warned(&[
            "wall.0.method=\"dynamic\"",
            "wall.0.layers=1",
            "physics.body_force=[0.0, 0.0]",
        ]);
        assert!(weightless.is_empty(), "{weightless:?}");
    }

    /// A one-row wall block between two waters is warned about; two rows at h = 1.5 dx
    /// (support 3 dx), or water on one side only, are not.
    #[test]
    fn a_thin_plate_between_two_waters_is_warned_about() {
        let text = include_str!("../../inputs/hydrostatic_2d.toml").replace(
            "[[fluid]]\nname = \"water\"\nmaterial = \"water\"\nmin = [0.0, 0.0]\nmax = [1.0, 0.5]",
            "[[fluid]]\nname = \"left\"\nmaterial = \"water\"\nmin = [0.0, 0.0]\nmax = [0.5, 0.5]\n\
             hydrostatic = true\n[[fluid]]\nname = \"right\"\nmaterial = \"water\"\nmin = [PLATE, 0.0]\nmax = [1.0, 0.3]",
        );
        let warned = |plate: f64, sets: &[&str]| {
            let text = text.replace("PLATE", &format!("{plate:?}"))
                + &format!("\n[[wall]]\nname = \"plate\"\nshape = \"block\"\nmin = [0.5, 0.0]\nmax = [{plate:?}, 0.6]\n");
            let mut sets: Vec<String> = sets.iter().map(|x| x.to_string()).collect();
            sets.push("discretisation.h_over_dx=1.5".into());
            let (s, _) =
                crate::scene::load_scene_str(&text, std::path::Path::new("t.toml"), "t", &sets).unwrap();
            super::thin_plate_warnings(&s)
        };
        let one = warned(0.52, &[]);
        assert!(
            one.len() == 1 && one[0].contains("wall[1] `plate` is 0.020 m thick along x"),
            "{one:?}"
        );
        assert!(warned(0.54, &[]).is_empty(), "two rows");
        assert!(
            warned(0.52, &["fluid.1.min=[0.6, 0.0]"]).is_empty(),
            "water on one side only"
        );
    }
}

//! The value checks every part of scene validation shares: one wording for a missing,
//! non-positive or out-of-range number, naming the key, the value, the range and an example.

use super::Domain;
use crate::error::{Error, Result};
use crate::limits::MAX_SPEED;

/// An input error at `key`.
pub(super) fn err<T>(key: impl Into<String>, msg: impl Into<String>) -> Result<T> {
    Err(Error::input(key, msg))
}

/// `x` must be a finite number > 0.
pub(super) fn positive(x: f64, key: &str, example: &str) -> Result<()> {
    if !(x > 0.0 && x.is_finite()) {
        return err(
            key,
            format!("must be a positive number (got {x}); e.g. {example}"),
        );
    }
    Ok(())
}

/// `x` must be a finite number ≥ 0.
pub(super) fn non_negative(x: f64, key: &str) -> Result<()> {
    if !(x >= 0.0 && x.is_finite()) {
        return err(key, format!("must be a finite number ≥ 0 (got {x})"));
    }
    Ok(())
}

/// `x` as a scene would write it, short at any magnitude: `0.3`, `2000`, `1e5`, `1e-300`.
pub(crate) fn num(x: f64) -> String {
    if x == 0.0 || !x.is_finite() || (1e-3..1e5).contains(&x.abs()) {
        format!("{x}")
    } else {
        format!("{x:e}")
    }
}

/// `x` (in `unit`) must lie in `[lo, hi]`, the physical range `name` of `src/limits.rs`;
/// NaN and infinities never do. The message names the value, the range and `example`.
pub(super) fn in_range(
    x: f64,
    key: &str,
    (lo, hi): (f64, f64),
    unit: &str,
    name: &str,
    example: &str,
) -> Result<()> {
    if x >= lo && x <= hi {
        return Ok(());
    }
    // no unit: dimensionless
    let u = if unit.is_empty() {
        String::new()
    } else {
        format!(" {unit}")
    };
    err(
        key,
        format!(
            "{}{u} lies outside [{}, {}]{u}, the range hsph accepts ({name}); e.g. {example}",
            num(x),
            num(lo),
            num(hi)
        ),
    )
}

pub(super) fn check_vec(v: &mut Vec<f64>, d: usize, key: &str, empty_is_zero: bool) -> Result<()> {
    if v.is_empty() && empty_is_zero {
        *v = vec![0.0; d];
    }
    if v.len() != d {
        return err(
            key,
            format!("needs {d} components (dimension = {d}), got {}", v.len()),
        );
    }
    if let Some(x) = v.iter().find(|x| !x.is_finite()) {
        return err(key, format!("components must be finite numbers, got {x}"));
    }
    Ok(())
}

pub(super) fn check_box(min: &[f64], max: &[f64], key: &str) -> Result<()> {
    for a in 0..min.len() {
        if max[a] <= min[a] {
            return err(
                format!("{key}.max"),
                format!(
                    "max must exceed min on every axis; axis {a}: min {} ≥ max {}",
                    min[a], max[a]
                ),
            );
        }
    }
    Ok(())
}

/// A vector `v` (in `unit`) whose length, computed without overflow, is at most `max`.
pub(super) fn length_at_most(
    v: &[f64],
    key: &str,
    max: f64,
    unit: &str,
    name: &str,
    example: &str,
) -> Result<()> {
    let len = norm(v);
    if len <= max {
        return Ok(());
    }
    err(
        key,
        format!(
            "[{}] has length {} {unit}, above the limit of {} {unit} ({name}); e.g. {example}",
            v.iter().map(|x| num(*x)).collect::<Vec<_>>().join(", "),
            num(len),
            num(max)
        ),
    )
}

/// A velocity (m/s) no faster than [`MAX_SPEED`].
pub(super) fn speed_at_most(v: &[f64], key: &str) -> Result<()> {
    length_at_most(v, key, MAX_SPEED, "m/s", "MAX_SPEED", "velocity = [1.0, 0.0]")
}

/// Euclidean length: √(Σ x²) (the bits every earlier version computed), or, where the squares
/// overflow, the same length without intermediate overflow (`hypot`); NaN stays NaN.
pub(super) fn norm(v: &[f64]) -> f64 {
    let n = v.iter().map(|x| x * x).sum::<f64>().sqrt();
    if n.is_finite() {
        n
    } else {
        v.iter().fold(0.0, |n: f64, x| n.hypot(*x))
    }
}

/// The face names of a container's `open` list.
pub fn face(name: &str, dim: usize) -> Option<(usize, bool)> {
    let axes = ["x", "y", "z"];
    // strip_suffix, not split_at: a name ending in a multi-byte character must not panic
    let (ax, up) = match (name.strip_suffix('-'), name.strip_suffix('+')) {
        (Some(ax), _) => (ax, false),
        (_, Some(ax)) => (ax, true),
        _ => return None,
    };
    let a = axes.iter().position(|&n| n == ax)?;
    (a < dim).then_some((a, up))
}

/// Names in file order, with a set to look them up in O(1) (a scene may hold thousands).
pub(super) struct Names {
    pub(super) list: Vec<String>,
    pub(super) set: std::collections::HashSet<String>,
}

impl Names {
    pub(super) fn new<'a>(names: impl Iterator<Item = &'a str>) -> Self {
        let list: Vec<String> = names.map(String::from).collect();
        let set = list.iter().cloned().collect();
        Names { list, set }
    }

    pub(super) fn contains(&self, name: &str) -> bool {
        self.set.contains(name)
    }

    /// The names for a message: all of them, or the first 20 and how many more.
    pub(super) fn shown(&self) -> String {
        let mut out = self.list.iter().take(20).cloned().collect::<Vec<_>>().join(", ");
        if self.list.len() > 20 {
            out.push_str(&format!(" and {} more", self.list.len() - 20));
        }
        out
    }
}

/// An unknown material name of body key `k` (exit 2 listing the defined ones).
pub(super) fn unknown_material(k: &str, name: &str, mat_names: &Names) -> Result<()> {
    err(
        format!("{k}.material"),
        format!("unknown material `{name}`; defined: {}", mat_names.shown()),
    )
}

/// A body [min, max] must lie in the domain; `body` is its key, the error names its `min` or
/// `max`, whichever is out.
pub(super) fn in_domain(min: &[f64], max: &[f64], body: &str, dom: &Domain) -> Result<()> {
    let tol = 1e-9 * disc_scale(dom);
    for a in 0..min.len() {
        let low = min[a] < dom.min[a] - tol;
        if low || max[a] > dom.max[a] + tol {
            return err(
                format!("{body}.{}", if low { "min" } else { "max" }),
                format!(
                    "the body [{:?}, {:?}] lies outside the domain [{:?}, {:?}] on axis {a}; \
                     enlarge domain.min/domain.max or move the body",
                    min, max, dom.min, dom.max
                ),
            );
        }
    }
    Ok(())
}

/// [`in_domain`] for body `f` of key `k`: a block's box is its `min` and `max`, but a sphere's
/// or cylinder's comes from its `centre`, `radius` and `length`, and a box outside the domain
/// is blamed on the key that set it (`radius`, or a cylinder's `length` along its axis), not
/// on a `min` the scene never wrote.
pub(super) fn body_in_domain(f: super::shape::ShapeKeys, k: &str, dom: &Domain) -> Result<()> {
    use super::BodyShape;
    if f.shape == BodyShape::Block {
        return in_domain(f.min, f.max, k, dom);
    }
    let tol = 1e-9 * disc_scale(dom);
    for a in 0..f.min.len() {
        if f.min[a] < dom.min[a] - tol || f.max[a] > dom.max[a] + tol {
            let placed = match f.shape {
                BodyShape::Polygon => Some(("vertices", "polygon", "move its vertices")),
                BodyShape::Mesh => Some(("translate", "mesh", "place it by translate, rotate and scale")),
                _ => None,
            };
            if let Some((key, shape, how)) = placed {
                return err(
                    format!("{k}.{key}"),
                    format!(
                        "the {shape} reaches [{}, {}] on axis {a}, outside the domain [{}, {}]; {how} \
                         or enlarge domain.min/domain.max",
                        f.min[a], f.max[a], dom.min[a], dom.max[a]
                    ),
                );
            }
            let (key, what) = if f.shape == BodyShape::Cylinder && f.axis == Some(a) {
                ("length", format!("length {}", f.length))
            } else {
                ("radius", format!("radius {}", f.radius))
            };
            let shape = if f.shape == BodyShape::Sphere {
                "sphere"
            } else {
                "cylinder"
            };
            return err(
                format!("{k}.{key}"),
                format!(
                    "the {shape} of centre {:?} and {what} reaches [{}, {}] on axis {a}, outside the \
                     domain [{}, {}]; lower its {key}, move its centre or enlarge domain.min/domain.max",
                    f.centre, f.min[a], f.max[a], dom.min[a], dom.max[a]
                ),
            );
        }
    }
    Ok(())
}

pub(crate) fn disc_scale(dom: &Domain) -> f64 {
    dom.min
        .iter()
        .chain(dom.max.iter())
        .fold(1e-300f64, |m, x| m.max(x.abs()))
}

/// A probe point must lie in the domain: outside it would read nothing and report zeros.
pub(super) fn point_in_domain(p: &[f64], key: &str, dom: &Domain) -> Result<()> {
    let inside = p
        .iter()
        .enumerate()
        .all(|(a, &x)| x >= dom.min[a] && x <= dom.max[a]);
    if inside {
        return Ok(());
    }
    err(
        key,
        format!(
            "{p:?} lies outside the domain {:?} .. {:?}: a probe there would read nothing; move it \
             inside",
            dom.min, dom.max
        ),
    )
}

/// A sphere's or cylinder's box from its centre, radius (and axis and length), a polygon's
/// from its vertices and a mesh's from its file; a resolved scene already holds it, any other
/// box is an error; no such keys on a block.
pub(super) fn sphere_box(f: super::shape::ShapeKeysMut, k: &str, d: usize) -> Result<()> {
    use super::BodyShape;
    foreign_keys(&f, k)?;
    match f.shape {
        BodyShape::Block => return Ok(()),
        BodyShape::Polygon => return polygon_box(f, k, d),
        BodyShape::Mesh => return mesh_box(f, k, d),
        BodyShape::Sphere | BodyShape::Cylinder => {}
    }
    let shape = if f.shape == BodyShape::Sphere {
        "sphere"
    } else {
        "cylinder"
    };
    let example = vec!["0.5"; d].join(", ");
    if f.centre.is_empty() {
        let boxed = if !f.min.is_empty() || !f.max.is_empty() {
            " (min and max are a block's keys, or follow from these)"
        } else {
            ""
        };
        return err(
            format!("{k}.centre"),
            format!("is missing: a {shape} is placed by `centre` and `radius`{boxed}; e.g. centre = [{example}], radius = 0.05"),
        );
    }
    check_vec(f.centre, d, &format!("{k}.centre"), false)?;
    if f.radius == 0.0 {
        return err(
            format!("{k}.radius"),
            format!("is missing: a {shape} needs a radius (m) > 0; e.g. radius = 0.05"),
        );
    }
    if !(f.radius > 0.0 && f.radius.is_finite()) {
        return err(
            format!("{k}.radius"),
            format!(
                "needs a positive radius (m), got {}; e.g. radius = 0.05",
                f.radius
            ),
        );
    }
    let mut half: Vec<f64> = vec![f.radius; d];
    if f.shape == BodyShape::Cylinder {
        if d != 3 {
            return err(
                format!("{k}.shape"),
                "a cylinder needs a 3D scene; in 2D a disc is `shape = \"sphere\"`, a rectangle a block",
            );
        }
        let axis = f.axis.unwrap_or(2);
        if axis >= d {
            return err(
                format!("{k}.axis"),
                format!("must be 0, 1 or 2 (x, y, z), got {axis}"),
            );
        }
        if !(f.length > 0.0 && f.length.is_finite()) {
            return err(
                format!("{k}.length"),
                format!(
                    "a cylinder needs a positive length (m) along its axis, got {}",
                    f.length
                ),
            );
        }
        *f.axis = Some(axis);
        half[axis] = 0.5 * f.length;
    } else if f.axis.is_some() || f.length != 0.0 {
        return err(format!("{k}.axis"), "`axis` and `length` belong to a cylinder");
    }
    let lo: Vec<f64> = (0..d).map(|a| f.centre[a] - half[a]).collect();
    let hi: Vec<f64> = (0..d).map(|a| f.centre[a] + half[a]).collect();
    set_box(
        (lo, hi),
        (f.min, f.max),
        k,
        "of a sphere or cylinder comes from its centre, radius and length",
    )
}

/// The keys of another shape on table `k` (of shape `f.shape`): `vertices` off a polygon,
/// `centre`, `radius`, `axis` or `length` off a sphere or cylinder.
fn foreign_keys(f: &super::shape::ShapeKeysMut, k: &str) -> Result<()> {
    use super::BodyShape;
    let round = !f.centre.is_empty() || f.radius != 0.0 || f.axis.is_some() || f.length != 0.0;
    if f.shape != BodyShape::Polygon && !f.vertices.is_empty() {
        return err(
            format!("{k}.vertices"),
            format!(
                "belongs to `shape = \"polygon\"`; this body is a {}",
                f.shape.name()
            ),
        );
    }
    let takes = match f.shape {
        BodyShape::Block => "min and max",
        BodyShape::Polygon => "vertices",
        BodyShape::Mesh => "file, scale, rotate and translate",
        BodyShape::Sphere | BodyShape::Cylinder => return Ok(()),
    };
    if round {
        return err(
            format!("{k}.shape"),
            format!(
                "`centre`, `radius`, `axis` and `length` belong to `shape = \"sphere\"` or \"cylinder\"; a {} takes {takes}",
                f.shape.name()
            ),
        );
    }
    Ok(())
}

/// Set the box `(min, max)` of table `k` to `(lo, hi)`, the box its shape gives (`from` says
/// how, for the message); a resolved scene already holds that box, any other is an error.
fn set_box(
    (lo, hi): (Vec<f64>, Vec<f64>),
    (min, max): (&mut Vec<f64>, &mut Vec<f64>),
    k: &str,
    from: &str,
) -> Result<()> {
    if (!min.is_empty() && *min != lo) || (!max.is_empty() && *max != hi) {
        return err(
            format!("{k}.min"),
            format!("the box {from}: leave out min and max"),
        );
    }
    (*min, *max) = (lo, hi);
    Ok(())
}

/// A polygon's box from its vertices.
fn polygon_box(f: super::shape::ShapeKeysMut, k: &str, d: usize) -> Result<()> {
    resolve_outline_box(f.vertices, (f.min, f.max), k, d)
}

/// A mesh's box from its placed triangles (a 3D scene only).
fn mesh_box(f: super::shape::ShapeKeysMut, k: &str, d: usize) -> Result<()> {
    resolve_mesh_box(f.mesh, (f.min, f.max), k, d)
}

/// Set `min` and `max` of table `k` to the box of its placed mesh (in 2D, of its section); a
/// resolved scene already holds that box, any other is an error.
pub(super) fn resolve_mesh_box(
    mesh: Option<&super::mesh::Mesh>,
    (min, max): (&mut Vec<f64>, &mut Vec<f64>),
    k: &str,
    d: usize,
) -> Result<()> {
    let Some(m) = mesh else {
        return err(
            format!("{k}.file"),
            "a mesh needs `file = \"…\"`, a binary or ASCII STL file relative to the scene file; e.g. file = \"hull.stl\"",
        );
    };
    let (lo, hi) = m.bounds();
    debug_assert_eq!(lo.len(), d);
    set_box(
        (lo, hi),
        (min, max),
        k,
        "of a mesh comes from its file and placement",
    )
}

/// Set `min` and `max` of table `k` to the box of its outline through `vertices` (checked by
/// [`outline_box`]); a resolved scene already holds that box, any other is an error.
pub(super) fn resolve_outline_box(
    vertices: &[Vec<f64>],
    (min, max): (&mut Vec<f64>, &mut Vec<f64>),
    k: &str,
    d: usize,
) -> Result<()> {
    let bounds = outline_box(vertices, k, d)?;
    set_box(bounds, (min, max), k, "of a polygon comes from its vertices")
}

/// The box of the outline through `vertices` of table `k`, checked: a 2D scene, at least three
/// vertices of two finite coordinates each, at most [`crate::limits::MAX_POLYGON_VERTICES`],
/// an outline that encloses an area and does not cross itself.
fn outline_box(vertices: &[Vec<f64>], k: &str, d: usize) -> Result<(Vec<f64>, Vec<f64>)> {
    use super::polygon;
    let key = format!("{k}.vertices");
    if d != 2 {
        return err(
            format!("{k}.shape"),
            "a polygon needs a 2D scene; in 3D a body is a block, sphere or cylinder",
        );
    }
    let example = "vertices = [[0.0, 0.0], [0.4, 0.0], [0.0, 0.3]]";
    if vertices.len() < 3 {
        return err(
            key,
            format!(
                "a polygon needs at least 3 vertices [x, y] (m), got {}; e.g. {example}",
                vertices.len()
            ),
        );
    }
    if vertices.len() > crate::limits::MAX_POLYGON_VERTICES {
        return err(
            key,
            format!(
                "{} vertices exceed the limit of {} (src/limits.rs)",
                vertices.len(),
                crate::limits::MAX_POLYGON_VERTICES
            ),
        );
    }
    for (i, v) in vertices.iter().enumerate() {
        if v.len() != 2 || !v.iter().all(|c| c.is_finite()) {
            return err(
                format!("{key}[{i}]"),
                format!("must be two finite coordinates [x, y] (m), got {v:?}; e.g. {example}"),
            );
        }
    }
    if polygon::signed_area(vertices) == 0.0 {
        return err(key, "the outline encloses no area: its vertices lie on one line");
    }
    if let Some((i, j)) = polygon::self_crossing(vertices) {
        let n = vertices.len();
        return err(
            key,
            format!(
                "the outline crosses itself: the edge from vertex {i} to {} crosses the edge from \
                 vertex {j} to {}; list the vertices in order round the outline",
                (i + 1) % n,
                (j + 1) % n
            ),
        );
    }
    let lo: Vec<f64> = (0..d)
        .map(|a| vertices.iter().map(|v| v[a]).fold(f64::INFINITY, f64::min))
        .collect();
    let hi: Vec<f64> = (0..d)
        .map(|a| vertices.iter().map(|v| v[a]).fold(f64::NEG_INFINITY, f64::max))
        .collect();
    Ok((lo, hi))
}

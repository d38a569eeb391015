//! Mesh files (`shape = "mesh"` with `file = "…"` on a `[[fluid]]`, `[[solid]]`, `[[wall]]` or
//! `[[refine]]`): read when
//! the scene is loaded, placed, checked for closure, and kept beside the table. The table's
//! `file` becomes the absolute path and `sha256` the file's hash, so a resolved scene (a run
//! directory's, a restart's) finds the same file and refuses it if it has changed.

use super::mesh::{self, Mesh, Placement};
use super::Scene;
use crate::error::{Error, Result};
use crate::limits::file_error;
use std::path::Path;
use std::sync::Arc;

/// A table's mesh keys, borrowed for the loader.
pub struct MeshKeys<'a> {
    /// `shape`: true for a mesh.
    pub is_mesh: bool,
    /// The shape's name, for messages.
    pub shape: &'static str,
    /// `file`, relative to the scene file (absolute once loaded).
    pub file: &'a mut Option<String>,
    /// `scale`.
    pub scale: Option<f64>,
    /// `rotate` (degrees).
    pub rotate: &'a [f64],
    /// `translate` (m).
    pub translate: &'a [f64],
    /// `flip`.
    pub flip: Option<bool>,
    /// `slice` (2D scenes).
    pub slice: Option<mesh::Slice>,
    /// `fill` (bodies).
    pub fill: Option<mesh::Fill>,
    /// `layers` of a shell fill (bodies).
    pub layers: Option<usize>,
    /// `sha256`: set when loaded; given, it must match.
    pub sha256: &'a mut Option<String>,
    /// The mesh, once read.
    pub mesh: &'a mut Option<Arc<Mesh>>,
}

/// Read the mesh of every fluid, solid and wall body and every refinement region of shape
/// `mesh`, the path taken relative to the directory of `scene_file`. Placement keys on another
/// shape are input errors, and so are `fill` and `layers` on a region (a region holds every
/// point inside its surface; it has no shell). A region's box (`min`, `max`) is then set from
/// its mesh's bounds by the region checks, as a body's ([`super::checks::sphere_box`]).
pub(super) fn read_meshes(s: &mut Scene, scene_file: &Path) -> Result<()> {
    let dir = scene_file.parent().unwrap_or(Path::new(""));
    let (d, dx) = (s.dimension, s.discretisation.dx);
    let bodies = (s.fluids.iter_mut().enumerate())
        .map(|(i, f)| (format!("fluid[{i}]"), f.mesh_keys_mut()))
        .chain((s.solids.iter_mut().enumerate()).map(|(i, f)| (format!("solid[{i}]"), f.mesh_keys_mut())));
    for (k, m) in bodies {
        load(&k, m, dir, (d, dx))?;
    }
    for (i, w) in s.walls.iter_mut().enumerate() {
        let shape = match w.shape {
            super::WallShape::Block => "block",
            super::WallShape::Container => "container",
            super::WallShape::Polygon => "polygon",
            super::WallShape::Mesh => "mesh",
        };
        let keys = MeshKeys {
            is_mesh: w.shape == super::WallShape::Mesh,
            shape,
            file: &mut w.file,
            scale: w.scale,
            rotate: &w.rotate,
            translate: &w.translate,
            flip: w.flip,
            slice: w.slice,
            fill: None,
            layers: None,
            sha256: &mut w.sha256,
            mesh: &mut w.mesh,
        };
        load(&format!("wall[{i}]"), keys, dir, (d, dx))?;
    }
    for (i, r) in s.refine.iter_mut().enumerate() {
        let k = format!("refine[{i}]");
        let fill = [("fill", r.fill.is_some()), ("layers", r.layers.is_some())];
        if let Some((key, _)) = fill.iter().find(|(_, given)| *given) {
            return Err(Error::input(
                format!("{k}.{key}"),
                format!(
                    "belongs to a mesh body (a shell of rows inside its surface); a refinement \
                     region refines every point inside it, so remove `{key}`"
                ),
            ));
        }
        load(&k, r.mesh_keys_mut(), dir, (d, dx))?;
    }
    Ok(())
}

/// Read, place and check the mesh of table `k` (cut by its `slice` in a scene of dimension
/// `d` = 2, filled as a shell of `layers` × `dx` if asked), or refuse a mesh's keys on
/// another shape.
fn load(k: &str, m: MeshKeys, dir: &Path, (d, dx): (usize, f64)) -> Result<()> {
    let given = [
        ("scale", m.scale.is_some()),
        ("rotate", !m.rotate.is_empty()),
        ("translate", !m.translate.is_empty()),
        ("flip", m.flip.is_some()),
        ("slice", m.slice.is_some()),
        ("fill", m.fill.is_some()),
        ("layers", m.layers.is_some()),
        ("sha256", m.sha256.is_some()),
    ];
    if !m.is_mesh {
        if let Some((key, _)) = given.iter().find(|(_, g)| *g) {
            return Err(Error::input(
                format!("{k}.{key}"),
                format!("belongs to `shape = \"mesh\"`; this body is a {}", m.shape),
            ));
        }
        return Ok(());
    }
    let place = placement(k, &m)?;
    let cut = section(k, m.slice, d)?;
    let shell = shell_depth(k, m.fill, m.layers, dx)?;
    let key = format!("{k}.file");
    let Some(name) = m.file.clone() else {
        return Err(Error::input(
            key,
            "a mesh needs `file = \"…\"`, a binary or ASCII STL file relative to the scene file; \
             e.g. file = \"hull.stl\"",
        ));
    };
    let path = dir.join(&name);
    let read = mesh::read(&path, &key, &place)?;
    if let Some(h) = m.sha256.as_deref() {
        if h != read.sha256 {
            return Err(file_error(
                &path,
                &format!("{k}.sha256"),
                None,
                format!(
                    "has changed since the scene was resolved (SHA-256 {h}, now {}): a run and its \
                     restarts build from one mesh; restore the file, or start a new run from the \
                     original scene",
                    read.sha256
                ),
            ));
        }
    }
    if let Some(defect) = read.topology() {
        return Err(file_error(&path, &key, None, defect.message()));
    }
    let volume = read.signed_volume();
    if volume < 0.0 {
        let why = if place.flip {
            format!(
                "with `flip = true` its normals point inward (signed volume {volume:.4e} m³): the \
                 file's own normals point outward already; remove `{k}.flip`"
            )
        } else {
            format!(
                "its normals point inward (signed volume {volume:.4e} m³, by the corners' order): \
                 a closed mesh's normals point out of the body; set `flip = true` to turn them, or \
                 re-export with outward normals"
            )
        };
        return Err(file_error(&path, &key, None, why));
    }
    let read = match cut {
        None => read,
        Some(c) => {
            let (lo, hi) = (read.lo[c.axis], read.hi[c.axis]);
            read.sliced(c).ok_or_else(|| {
                Error::input(
                    format!("{k}.slice"),
                    format!(
                        "the plane at {} m along axis {} misses the mesh, which spans [{lo}, {hi}] m \
                         along it; e.g. slice = {{ axis = {}, at = {} }}",
                        c.at,
                        c.axis,
                        c.axis,
                        0.5 * (lo + hi)
                    ),
                )
            })?
        }
    };
    let read = match shell {
        Some(depth) => read.with_shell(depth),
        None => read,
    };
    let abs = std::fs::canonicalize(&path).unwrap_or(path);
    *m.file = Some(abs.to_string_lossy().into_owned());
    *m.sha256 = Some(read.sha256.clone());
    *m.mesh = Some(Arc::new(read));
    Ok(())
}

/// The depth (m) of a `fill = "shell"` body, `layers` (default 1, at most
/// [`MAX_SHELL_LAYERS`]) × `dx`; `None` for an inside fill. `layers` without a shell fill is
/// an error.
fn shell_depth(k: &str, fill: Option<mesh::Fill>, layers: Option<usize>, dx: f64) -> Result<Option<f64>> {
    match (fill, layers) {
        (Some(mesh::Fill::Shell), n) => {
            let n = n.unwrap_or(1);
            if n == 0 || n > MAX_SHELL_LAYERS {
                return Err(Error::input(
                    format!("{k}.layers"),
                    format!("a shell has 1 to {MAX_SHELL_LAYERS} rows, got {n}; e.g. layers = 3"),
                ));
            }
            Ok(Some(n as f64 * dx))
        }
        (_, Some(_)) => Err(Error::input(
            format!("{k}.layers"),
            "counts the rows of a shell; set fill = \"shell\" too, or remove it for a filled body",
        )),
        _ => Ok(None),
    }
}

/// Most rows a shell-filled mesh body may have (deeper is a filled body).
pub const MAX_SHELL_LAYERS: usize = 1000;

/// The plane a 2D scene cuts mesh `k` at: `slice` is needed in 2D and refused in 3D; its
/// axis is 0, 1 or 2 and its place finite.
fn section(k: &str, slice: Option<mesh::Slice>, d: usize) -> Result<Option<mesh::Slice>> {
    match (d, slice) {
        (2, None) => Err(Error::input(
            format!("{k}.slice"),
            "a mesh in a 2D scene is cut by a plane: give `slice = { axis = 1, at = 0.0 }` (the \
             axis across the plane, 0, 1 or 2, and where along it, m; the other two axes keep \
             their order, so a y-section gives 2D (x, z)), or draw the outline as `shape = \
             \"polygon\"`",
        )),
        (2, Some(c)) if c.axis > 2 || !c.at.is_finite() => Err(Error::input(
            format!("{k}.slice"),
            format!(
                "needs an axis of 0, 1 or 2 and a finite place, got axis {} at {}; e.g. slice = \
                 {{ axis = 1, at = 0.0 }}",
                c.axis, c.at
            ),
        )),
        (2, c) => Ok(c),
        (_, Some(_)) => Err(Error::input(
            format!("{k}.slice"),
            "cuts a 2D section of a mesh; this scene is 3D, so remove it",
        )),
        (_, None) => Ok(None),
    }
}

/// The placement keys of mesh `k`, checked: `scale` finite and positive, `rotate` and
/// `translate` three finite numbers each.
fn placement(k: &str, m: &MeshKeys) -> Result<Placement> {
    let scale = m.scale.unwrap_or(1.0);
    if !(scale > 0.0 && scale.is_finite()) {
        return Err(Error::input(
            format!("{k}.scale"),
            format!("must be a positive factor from the file's unit to metres, got {scale}; e.g. scale = 0.001 for a file in mm"),
        ));
    }
    let three = |key: &str, v: &[f64], example: &str| -> Result<[f64; 3]> {
        if v.is_empty() {
            return Ok([0.0; 3]);
        }
        match <[f64; 3]>::try_from(v) {
            Ok(a) if a.iter().all(|x| x.is_finite()) => Ok(a),
            _ => Err(Error::input(
                format!("{k}.{key}"),
                format!("must be three finite numbers, got {v:?}; e.g. {key} = {example}"),
            )),
        }
    };
    Ok(Placement {
        scale,
        rotate: three("rotate", m.rotate, "[0.0, 0.0, 90.0] (degrees about x, y, z)")?,
        translate: three("translate", m.translate, "[0.5, 0.0, 0.1] (m)")?,
        flip: m.flip.unwrap_or(false),
    })
}

/// One mesh a scene builds from, for provenance (`summary.json`'s `inputs.meshes`).
#[derive(Debug, Clone, serde::Serialize)]
pub struct MeshInput {
    /// The table, e.g. `fluid[0]`.
    pub key: String,
    /// The file's absolute path.
    pub file: String,
    /// SHA-256 of the file's bytes, hex.
    pub sha256: String,
    /// Triangles in the file.
    pub triangles: usize,
}

/// Every mesh of the scene's bodies, walls and refinement regions, in table order: (table,
/// file, mesh).
fn meshes(s: &Scene) -> impl Iterator<Item = (String, &Option<String>, &Arc<Mesh>)> {
    let bodies = (s.fluids.iter().enumerate())
        .map(|(i, f)| (format!("fluid[{i}]"), &f.file, &f.mesh))
        .chain((s.solids.iter().enumerate()).map(|(i, f)| (format!("solid[{i}]"), &f.file, &f.mesh)))
        .chain((s.walls.iter().enumerate()).map(|(i, w)| (format!("wall[{i}]"), &w.file, &w.mesh)))
        .chain((s.refine.iter().enumerate()).map(|(i, r)| (format!("refine[{i}]"), &r.file, &r.mesh)));
    bodies.filter_map(|(key, file, mesh)| Some((key, file, mesh.as_ref()?)))
}

/// The meshes of the scene's bodies, walls and refinement regions, in table order.
pub fn mesh_inputs(s: &Scene) -> Vec<MeshInput> {
    meshes(s)
        .map(|(key, file, m)| MeshInput {
            key,
            file: file.clone().unwrap_or_default(),
            sha256: m.sha256.clone(),
            triangles: m.triangles(),
        })
        .collect()
}

/// Bytes the scene's meshes and their indexes take (each counted once: bodies may not share
/// a mesh, but a mesh read twice is held twice).
pub fn mesh_bytes(s: &Scene) -> u64 {
    meshes(s).map(|(_, _, m)| m.bytes()).sum()
}

/// A warning per mesh whose surface crosses itself ([`Mesh::self_crossing`]), naming one pair
/// of triangles: its inside is still judged by ray parity, so sites near the crossing may be
/// claimed or left out.
pub fn mesh_warnings(s: &Scene) -> Vec<String> {
    meshes(s)
        .filter_map(|(key, file, m)| {
            let (a, b) = m.self_crossing()?;
            Some(format!(
                "{key}.file ({}): triangles {a} and {b} cross each other, so the surface \
                 intersects itself; the inside is judged by ray parity and sites near the \
                 crossing may be claimed or left out (repair the mesh, e.g. a boolean union of \
                 its parts in the CAD tool)",
                file.as_deref().unwrap_or("?")
            ))
        })
        .collect()
}

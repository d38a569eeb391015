//! Polygon outlines read from files (`file = "…"` on a `shape = "polygon"` body or region): a
//! two-column text file of x y (m) per line, relative to the scene file. The vertices go into
//! the table's `vertices` and the key is cleared, so a resolved scene (a run directory's, a
//! restart's) carries its outline and needs no file.

use super::Scene;
use crate::error::Result;
use crate::limits::file_error;
use std::path::Path;

/// Read the outline file of every fluid, solid, wall and refinement region that names one, the path
/// taken relative to the directory of `scene_file`.
pub(super) fn read_outlines(s: &mut Scene, scene_file: &Path) -> Result<()> {
    let dir = scene_file.parent().unwrap_or(Path::new(""));
    let tables = (s.fluids.iter_mut().enumerate())
        .map(|(i, f)| (format!("fluid[{i}]"), f.shape, &mut f.file, &mut f.vertices))
        .chain(
            (s.solids.iter_mut().enumerate())
                .map(|(i, f)| (format!("solid[{i}]"), f.shape, &mut f.file, &mut f.vertices)),
        )
        .chain(
            (s.refine.iter_mut().enumerate())
                .map(|(i, r)| (format!("refine[{i}]"), r.shape, &mut r.file, &mut r.vertices)),
        );
    // a wall's shape, as a body's for the check below
    let walls = (s.walls.iter_mut().enumerate()).map(|(i, w)| {
        let shape = match w.shape {
            super::WallShape::Polygon => super::BodyShape::Polygon,
            super::WallShape::Mesh => super::BodyShape::Mesh,
            _ => super::BodyShape::Block,
        };
        (format!("wall[{i}]"), shape, &mut w.file, &mut w.vertices)
    });
    let tables = tables.chain(walls);
    for (k, shape, file, vertices) in tables {
        if shape == super::BodyShape::Mesh {
            continue; // a mesh's file is read by `mesh_file`
        }
        let Some(name) = file.take() else {
            continue;
        };
        let key = format!("{k}.file");
        if shape != super::BodyShape::Polygon {
            return Err(crate::error::Error::input(
                key,
                format!(
                    "an outline file belongs to `shape = \"polygon\"`; this one is a {}",
                    shape.name()
                ),
            ));
        }
        if !vertices.is_empty() {
            return Err(crate::error::Error::input(
                key,
                "an outline is given by `vertices` or by `file`, not both; drop one",
            ));
        }
        *vertices = read_vertices(&dir.join(&name), &key)?;
    }
    Ok(())
}

/// The vertices of a two-column text file: `x y` or `x, y` (m) per line; blank lines and
/// lines starting with `#` are skipped. Only a regular file is opened (a FIFO would block).
pub fn read_vertices(path: &Path, key: &str) -> Result<Vec<Vec<f64>>> {
    let meta = std::fs::metadata(path).map_err(|e| {
        file_error(
            path,
            key,
            None,
            format!("cannot be read: {e}; the path is relative to the scene file"),
        )
    })?;
    if !meta.is_file() {
        return Err(file_error(
            path,
            key,
            None,
            "is not a regular file; name a text file of x y rows".into(),
        ));
    }
    let text = crate::limits::read_text(path, key)?;
    let mut out = Vec::new();
    for (n, line) in text.lines().enumerate() {
        let line = line.trim();
        if line.is_empty() || line.starts_with('#') {
            continue;
        }
        let fields: Vec<&str> = line
            .split(|c: char| c == ',' || c.is_whitespace())
            .filter(|f| !f.is_empty())
            .collect();
        let bad = |why: &str| {
            file_error(
                path,
                key,
                Some(n + 1),
                format!("`{line}`: {why}; each row is `x y` (m), e.g. `0.25 0.1`"),
            )
        };
        if fields.len() != 2 {
            return Err(bad(&format!("{} columns where a vertex has 2", fields.len())));
        }
        let mut v = Vec::with_capacity(2);
        for f in fields {
            let x: f64 = f.parse().map_err(|_| bad(&format!("`{f}` is not a number")))?;
            if !x.is_finite() {
                return Err(bad(&format!("`{f}` is not finite")));
            }
            v.push(x);
        }
        out.push(v);
        if out.len() > crate::limits::MAX_POLYGON_VERTICES {
            return Err(file_error(
                path,
                key,
                Some(n + 1),
                format!(
                    "more than {} vertices (src/limits.rs)",
                    crate::limits::MAX_POLYGON_VERTICES
                ),
            ));
        }
    }
    Ok(out)
}

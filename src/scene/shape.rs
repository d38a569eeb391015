//! The shape keys of a scene table, declared once: `shape`, `min`, `max`, `centre`, `radius`,
//! `axis` and `length`. [`shaped_table!`] puts them into every table that has a shape (fluid
//! and solid bodies, `FluidBody`; refinement regions, `Refine`) and gives the table
//! [`ShapeKeys`] (borrowed, no copy) and [`ShapeKeysMut`] (for the checks that resolve a
//! sphere's box). What a shape contains is answered here, once, for all of them.

use serde::{Deserialize, Serialize};

/// Shape of a body or region.
#[derive(Debug, Clone, Copy, Serialize, Deserialize, PartialEq, Eq, Default)]
#[serde(rename_all = "snake_case")]
pub enum BodyShape {
    /// A block [min, max).
    #[default]
    Block,
    /// A sphere (a disc in 2D): the sites with |x − centre| < radius.
    Sphere,
    /// A cylinder (3D): the sites closer than radius to the axis, within length/2 of centre.
    Cylinder,
    /// A closed polygon (2D): the sites inside the outline through `vertices`
    /// ([`crate::scene::polygon`]).
    Polygon,
    /// A closed triangle mesh (3D) from an STL file: the sites inside its surface
    /// ([`crate::scene::mesh`]).
    Mesh,
}

impl BodyShape {
    /// The shape's name as a scene file writes it.
    pub fn name(self) -> &'static str {
        match self {
            BodyShape::Block => "block",
            BodyShape::Sphere => "sphere",
            BodyShape::Cylinder => "cylinder",
            BodyShape::Polygon => "polygon",
            BodyShape::Mesh => "mesh",
        }
    }
}

/// A table's shape keys, borrowed.
#[derive(Debug, Clone, Copy)]
pub struct ShapeKeys<'a> {
    /// `shape`.
    pub shape: BodyShape,
    /// `min` (m).
    pub min: &'a [f64],
    /// `max` (m).
    pub max: &'a [f64],
    /// `centre` (m).
    pub centre: &'a [f64],
    /// `radius` (m).
    pub radius: f64,
    /// `axis` (0, 1 or 2).
    pub axis: Option<usize>,
    /// `length` (m).
    pub length: f64,
    /// `vertices` (m), each `[x, y]`.
    pub vertices: &'a [Vec<f64>],
    /// The mesh read from `file` (a mesh's, once loaded).
    pub mesh: Option<&'a crate::scene::mesh::Mesh>,
}

/// A table's shape keys, the ones a check may resolve borrowed mutably.
#[derive(Debug)]
pub struct ShapeKeysMut<'a> {
    /// `shape`.
    pub shape: BodyShape,
    /// `min` (m; a sphere's or cylinder's is set from its centre and radius).
    pub min: &'a mut Vec<f64>,
    /// `max` (m; likewise).
    pub max: &'a mut Vec<f64>,
    /// `centre` (m).
    pub centre: &'a mut Vec<f64>,
    /// `radius` (m).
    pub radius: f64,
    /// `axis` (0, 1 or 2; a cylinder's default is 2).
    pub axis: &'a mut Option<usize>,
    /// `length` (m).
    pub length: f64,
    /// `vertices` (m), each `[x, y]`.
    pub vertices: &'a [Vec<f64>],
    /// The mesh read from `file` (a mesh's, once loaded).
    pub mesh: Option<&'a crate::scene::mesh::Mesh>,
}

impl ShapeKeys<'_> {
    /// True if the lattice site at `x` (m; inside [min, max)) lies in the shape.
    #[inline]
    pub fn contains(&self, x: &[f64]) -> bool {
        match self.shape {
            BodyShape::Block => true,
            BodyShape::Sphere => {
                let r2: f64 = x.iter().zip(self.centre).map(|(a, c)| (a - c) * (a - c)).sum();
                r2 < self.radius * self.radius
            }
            BodyShape::Cylinder => {
                let axis = self.axis.unwrap_or(2);
                let r2: f64 = (0..x.len())
                    .filter(|&a| a != axis)
                    .map(|a| (x[a] - self.centre[a]).powi(2))
                    .sum();
                r2 < self.radius * self.radius
            }
            BodyShape::Polygon => crate::scene::polygon::contains(self.vertices, x[0], x[1]),
            BodyShape::Mesh => self.mesh.is_some_and(|m| m.claims(x)),
        }
    }

    /// True if `x` (m) lies in the box [min, max) and in the shape.
    #[inline]
    pub fn contains_point(&self, x: &[f64]) -> bool {
        (0..x.len()).all(|a| x[a] >= self.min[a] && x[a] < self.max[a]) && self.contains(x)
    }
}

/// Declares a scene table whose keys are its own leading keys, then the shape keys, then its
/// own trailing keys (`..shape_keys,` marks the place), with `keys()` and `keys_mut()`. A new
/// shape's keys (a mesh's file, placement and fill) are added here, once, for every table.
macro_rules! shaped_table {
    (
        $(#[$meta:meta])*
        pub struct $name:ident {
            $( $(#[$hm:meta])* pub $hf:ident : $ht:ty, )*
            ..shape_keys,
            $( $(#[$tm:meta])* pub $tf:ident : $tt:ty, )*
        }
    ) => {
        $(#[$meta])*
        pub struct $name {
            $( $(#[$hm])* pub $hf: $ht, )*
            /// Shape: `block` (every site in [min, max); a plate is a thin block), `sphere` (a
            /// disc in 2D: every site closer than `radius` to `centre`), `cylinder` (3D: every
            /// site closer than `radius` to the axis through `centre` along `axis`, within
            /// `length`/2 of `centre`), `polygon` (2D: every site inside the closed outline
            /// through `vertices`) or `mesh` (3D: every site inside the closed STL surface in
            /// `file`, placed by `scale`, `rotate` and `translate`).
            #[serde(default)]
            pub shape: $crate::scene::BodyShape,
            /// Lower corner (m); for a sphere or cylinder, set from centre and radius.
            #[serde(default)]
            pub min: Vec<f64>,
            /// Upper corner (m); for a sphere or cylinder, set from centre and radius.
            #[serde(default)]
            pub max: Vec<f64>,
            /// Centre of a sphere or cylinder (m).
            #[serde(default, skip_serializing_if = "Vec::is_empty")]
            pub centre: Vec<f64>,
            /// Radius of a sphere or cylinder (m).
            #[serde(default, skip_serializing_if = "crate::scene::shape::is_zero")]
            pub radius: f64,
            /// Axis of a cylinder: 0, 1 or 2 (x, y, z; default 2).
            #[serde(default, skip_serializing_if = "Option::is_none")]
            pub axis: Option<usize>,
            /// Length of a cylinder along its axis (m).
            #[serde(default, skip_serializing_if = "crate::scene::shape::is_zero")]
            pub length: f64,
            /// Vertices of a polygon (m), `[[x, y], …]` in order round the outline (either
            /// way); the last joins the first.
            #[serde(default, skip_serializing_if = "Vec::is_empty")]
            pub vertices: Vec<Vec<f64>>,
            /// A polygon's vertices from a text file instead, `x y` (m) per row, relative to
            /// the scene file; read into `vertices` when the scene is loaded. A mesh's STL
            /// file (binary or ASCII), relative to the scene file; a resolved scene holds its
            /// absolute path.
            #[serde(default, skip_serializing_if = "Option::is_none")]
            pub file: Option<String>,
            /// A mesh's scale from the file's unit to metres, applied first (0.001 for a CAD
            /// file in mm); default 1.
            #[serde(default, skip_serializing_if = "Option::is_none")]
            pub scale: Option<f64>,
            /// A mesh's rotations about x, y and z (degrees, right-handed), applied in that
            /// order after the scale; default none.
            #[serde(default, skip_serializing_if = "Vec::is_empty")]
            pub rotate: Vec<f64>,
            /// A mesh's translation (m), applied last; default none.
            #[serde(default, skip_serializing_if = "Vec::is_empty")]
            pub translate: Vec<f64>,
            /// A mesh whose normals point inward: reverse each triangle's corners (default
            /// false; a closed mesh must have outward normals after it).
            #[serde(default, skip_serializing_if = "Option::is_none")]
            pub flip: Option<bool>,
            /// In a 2D scene, the plane `{ axis, at }` that cuts the 3D mesh; the section's
            /// two axes keep their order (a y-section gives 2D (x, z)).
            #[serde(default, skip_serializing_if = "Option::is_none")]
            pub slice: Option<$crate::scene::mesh::Slice>,
            /// A mesh body's fill: `inside` (default, every site inside) or `shell` (the sites
            /// inside within `layers` × dx of the surface).
            #[serde(default, skip_serializing_if = "Option::is_none")]
            pub fill: Option<$crate::scene::mesh::Fill>,
            /// The rows of a `fill = "shell"` mesh body (default 1).
            #[serde(default, skip_serializing_if = "Option::is_none")]
            pub layers: Option<usize>,
            /// SHA-256 of a mesh's file, set when the scene is loaded; a resolved scene's (a
            /// run directory's, a restart's) must match the file, which must not change.
            #[serde(default, skip_serializing_if = "Option::is_none")]
            pub sha256: Option<String>,
            /// The mesh read from `file`, placed (not a key).
            #[serde(skip)]
            pub mesh: Option<std::sync::Arc<$crate::scene::mesh::Mesh>>,
            $( $(#[$tm])* pub $tf: $tt, )*
        }

        impl $name {
            /// The shape keys, borrowed.
            pub fn keys(&self) -> $crate::scene::shape::ShapeKeys<'_> {
                $crate::scene::shape::ShapeKeys {
                    shape: self.shape,
                    min: &self.min,
                    max: &self.max,
                    centre: &self.centre,
                    radius: self.radius,
                    axis: self.axis,
                    length: self.length,
                    vertices: &self.vertices,
                    mesh: self.mesh.as_deref(),
                }
            }

            /// The mesh keys, for the loader that reads the file.
            pub fn mesh_keys_mut(&mut self) -> $crate::scene::mesh_file::MeshKeys<'_> {
                $crate::scene::mesh_file::MeshKeys {
                    is_mesh: self.shape == $crate::scene::BodyShape::Mesh,
                    shape: self.shape.name(),
                    file: &mut self.file,
                    scale: self.scale,
                    rotate: &self.rotate,
                    translate: &self.translate,
                    flip: self.flip,
                    slice: self.slice,
                    fill: self.fill,
                    layers: self.layers,
                    sha256: &mut self.sha256,
                    mesh: &mut self.mesh,
                }
            }

            /// The shape keys, for the checks that resolve them.
            pub fn keys_mut(&mut self) -> $crate::scene::shape::ShapeKeysMut<'_> {
                $crate::scene::shape::ShapeKeysMut {
                    shape: self.shape,
                    min: &mut self.min,
                    max: &mut self.max,
                    centre: &mut self.centre,
                    radius: self.radius,
                    axis: &mut self.axis,
                    length: self.length,
                    vertices: &self.vertices,
                    mesh: self.mesh.as_deref(),
                }
            }
        }
    };
}
pub(crate) use shaped_table;

/// Serde's test for a key left at zero (not written in a resolved scene).
pub(crate) fn is_zero(v: &f64) -> bool {
    *v == 0.0
}

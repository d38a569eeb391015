//! Wall bodies (`[[wall]]`): their shape, boundary method, slip condition and motion law, and
//! the checks of their keys. A wall method's parameters live here; its particles and passes
//! in `crate::boundary` and `crate::physics::passes`.

use super::checks::*;
use super::*;
use crate::error::Result;

/// Shape of a wall body.
#[derive(Debug, Clone, Copy, Serialize, Deserialize, PartialEq, Eq)]
#[serde(rename_all = "snake_case")]
pub enum WallShape {
    /// A solid block: every lattice site in [min, max) is a wall particle.
    Block,
    /// A container around the inner box [min, max): `layers` layers outside each face except
    /// the faces listed in `open`.
    Container,
    /// A solid outline (2D): every lattice site inside the closed polygon through `vertices`
    /// ([`crate::scene::polygon`]); a dummy or dynamic one keeps the sites within its shell
    /// rows of the outline, like a block.
    Polygon,
    /// A solid closed triangle mesh (3D) from an STL `file`: every lattice site inside it
    /// ([`crate::scene::mesh`]); a dummy or dynamic one keeps the sites within its shell rows
    /// of the surface, like a block.
    Mesh,
}

impl WallShape {
    /// True for a wall given by an outline or a mesh rather than a box.
    pub fn outlined(self) -> bool {
        matches!(self, WallShape::Polygon | WallShape::Mesh)
    }
}

/// Boundary method of a wall.
#[derive(Debug, Clone, Copy, Serialize, Deserialize, PartialEq, Eq)]
#[serde(rename_all = "snake_case")]
pub enum WallMethod {
    /// Fixed dummy particles with pressure and velocity extrapolation (Adami et al. 2012).
    Dummy,
    /// Monaghan repulsive particles (Lennard-Jones-like force, Monaghan 1994).
    Repulsive,
    /// Mirror (image) particles across the inner faces of a container; no wall particles.
    Mirror,
    /// Fixed particles whose density follows the continuity equation and pressure the EOS
    /// (Crespo et al. 2007, DualSPHysics's dynamic boundary).
    Dynamic,
    /// Test only (`crate::boundary::toy`): dummy-like particles holding the Shepard mean of
    /// the fluid pressure round them, with no body-force term; proves that a wall method is
    /// its file in `boundary/`, one arm of `boundary::update_walls` and a variant here.
    #[cfg(test)]
    Toy,
}

impl WallMethod {
    /// The particle kind the method fills its body with (`None`: mirror walls have no
    /// particles of their own).
    pub fn particle_kind(self) -> Option<crate::particles::Kind> {
        match self {
            WallMethod::Dummy | WallMethod::Dynamic => Some(crate::particles::Kind::Dummy),
            WallMethod::Repulsive => Some(crate::particles::Kind::Repulsive),
            WallMethod::Mirror => None,
            #[cfg(test)]
            WallMethod::Toy => Some(crate::particles::Kind::Dummy),
        }
    }

    /// True if a `[[refine]]` region refines the wall's particles (the set-up builds them on
    /// the refined lattice, like fluid): dummy and dynamic walls.
    pub fn refinable(self) -> bool {
        match self {
            WallMethod::Dummy | WallMethod::Dynamic => true,
            WallMethod::Repulsive | WallMethod::Mirror => false,
            #[cfg(test)]
            WallMethod::Toy => false,
        }
    }

    /// True if the drift bounces a fluid particle that crosses the wall's surface back
    /// across it (`sim`'s wall faces): dummy and dynamic walls.
    pub fn bounces_fluid(self) -> bool {
        match self {
            WallMethod::Dummy | WallMethod::Dynamic => true,
            WallMethod::Repulsive | WallMethod::Mirror => false,
            #[cfg(test)]
            WallMethod::Toy => false,
        }
    }

    /// True if the wall has no particles and shows the fluid its images across a container's
    /// inner faces (`crate::boundary::mirror`): mirror walls.
    pub fn makes_images(self) -> bool {
        match self {
            WallMethod::Mirror => true,
            WallMethod::Dummy | WallMethod::Dynamic | WallMethod::Repulsive => false,
            #[cfg(test)]
            WallMethod::Toy => false,
        }
    }

    /// True if the wall particles' density follows the continuity equation (dynamic walls):
    /// `hsph check` counts them apart, and in fewer rows than the fluid's support they leave
    /// the fluid beside them short of neighbours.
    pub fn integrates_density(self) -> bool {
        match self {
            WallMethod::Dynamic => true,
            WallMethod::Dummy | WallMethod::Repulsive | WallMethod::Mirror => false,
            #[cfg(test)]
            WallMethod::Toy => false,
        }
    }

    /// True if the wall's rows beyond the fluid's support are not built ([`rows_reaching`]):
    /// its particles list fluid neighbours only, so a deeper row takes part in no sum (dummy
    /// and dynamic walls; a repulsive wall keeps its `layers`).
    pub fn trims_to_support(self) -> bool {
        match self {
            WallMethod::Dummy | WallMethod::Dynamic => true,
            WallMethod::Repulsive | WallMethod::Mirror => false,
            #[cfg(test)]
            WallMethod::Toy => false,
        }
    }

    /// True if a `[[wall]]` of the method may set `no_slip = "morris"`: dummy walls (β from
    /// their particles' depths) and mirror walls (their images carry it).
    pub fn allows_morris_no_slip(self) -> bool {
        match self {
            WallMethod::Dummy | WallMethod::Mirror => true,
            WallMethod::Dynamic | WallMethod::Repulsive => false,
            #[cfg(test)]
            WallMethod::Toy => false,
        }
    }

    /// True if a `[[wall]]` of the method may set `volume = "lattice"`: dummy walls, whose
    /// density the fluid's pressure sets each step.
    pub fn allows_lattice_volume(self) -> bool {
        match self {
            WallMethod::Dummy => true,
            WallMethod::Dynamic | WallMethod::Repulsive | WallMethod::Mirror => false,
            #[cfg(test)]
            WallMethod::Toy => false,
        }
    }

    /// True if `no_slip = "morris"` acts on the wall (`crate::physics::viscous`: β from the
    /// depths either side of its surface): dummy walls.
    pub fn takes_morris_no_slip(self) -> bool {
        match self {
            WallMethod::Dummy => true,
            WallMethod::Dynamic | WallMethod::Repulsive | WallMethod::Mirror => false,
            #[cfg(test)]
            WallMethod::Toy => false,
        }
    }
}

/// Tangential condition of a wall.
#[derive(Debug, Clone, Copy, Serialize, Deserialize, PartialEq, Eq)]
#[serde(rename_all = "snake_case")]
pub enum Slip {
    /// Velocity of the fluid at the wall equals the wall's.
    NoSlip,
    /// Only the normal velocity is constrained.
    FreeSlip,
}

/// How a no-slip dummy wall shows the fluid its velocity in the laminar viscous term.
#[derive(Debug, Clone, Copy, Serialize, Deserialize, PartialEq, Eq, Default)]
#[serde(rename_all = "snake_case")]
pub enum NoSlipMethod {
    /// Adami et al. (2012): every dummy wall particle carries v_w = 2 u_wall − ṽ_w, ṽ_w the
    /// kernel-weighted mean of the fluid velocities round it; on a mirror wall, the image's
    /// reflected velocity v′ = 2 u_wall − v.
    #[default]
    Adami,
    /// Morris et al. (1997): per pair, v_i − v_w = β (v_i − u_wall) with β = 1 + d_w/d_i, the
    /// depths of the wall (or image) particle and the fluid particle on either side of the
    /// wall's surface: exact for a linear profile ([`crate::boundary::geometry`],
    /// [`crate::physics::viscous`]).
    Morris,
}

impl NoSlipMethod {
    /// True for `adami` (left out of a written scene).
    pub fn is_adami(&self) -> bool {
        *self == NoSlipMethod::Adami
    }
}

/// What a dummy wall particle holds fixed while its density follows the extrapolated pressure.
#[derive(Debug, Clone, Copy, Serialize, Deserialize, PartialEq, Eq, Default)]
#[serde(rename_all = "snake_case")]
pub enum WallVolume {
    /// Its mass m = ρ0 V0 (Adami et al. 2012): its volume m/ρ_w shrinks under pressure while
    /// the particle stays on its lattice site.
    #[default]
    Mass,
    /// Its volume V0 = (dx/2^ℓ)^D, the lattice cell it fills: the mass follows the density,
    /// m = ρ_w V0. A fluid of hydrostatic density (mass ρ(y) V0 on the same lattice) then
    /// meets walls of its own volume, so Σ_j V_j ∇W_ij vanishes across the wall's face
    /// (`crate::physics::passes`' `wall_volume` row; docs/refinement.md §2).
    Lattice,
}

impl WallVolume {
    /// True for `mass` (left out of a written scene).
    pub fn is_mass(&self) -> bool {
        *self == WallVolume::Mass
    }
}

/// Prescribed motion law x(t) of a wall (a piston or wave maker).
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields, tag = "law", rename_all = "snake_case")]
pub enum Motion {
    /// x(t) = x0 + A sin(2π t/T + φ).
    Sine {
        /// Amplitude vector A (m).
        amplitude: Vec<f64>,
        /// Period T (s).
        period: f64,
        /// Phase φ (rad).
        #[serde(default)]
        phase: f64,
    },
    /// x(t) = x0 + u t.
    ConstantVelocity {
        /// Velocity u (m/s).
        velocity: Vec<f64>,
    },
    /// A piston wave maker that generates one solitary wave of height `amplitude` on still
    /// water of `depth` (Goring 1978): see [`crate::boundary::motion`].
    Solitary {
        /// Wave height A above still water (m).
        amplitude: f64,
        /// Still-water depth h in front of the paddle (m).
        depth: f64,
        /// Direction the paddle pushes (and the wave travels); default +x.
        #[serde(default)]
        direction: Vec<f64>,
    },
}

/// A wall body.
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct WallBody {
    /// Name, unique among all bodies (fluids, solids, walls).
    pub name: String,
    /// `block`, `container` or `polygon`.
    pub shape: WallShape,
    /// Lower corner (m) of the block, or of the container's inner box; a polygon's box is set
    /// from its vertices.
    #[serde(default)]
    pub min: Vec<f64>,
    /// Upper corner (m).
    #[serde(default)]
    pub max: Vec<f64>,
    /// Vertices of a polygon wall (m), `[[x, y], …]` in order round the outline.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub vertices: Vec<Vec<f64>>,
    /// A polygon wall's vertices from a text file, `x y` (m) per row, relative to the scene
    /// file; read into `vertices` when the scene is loaded. A mesh wall's STL file, relative
    /// to the scene file (absolute in a resolved scene).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub file: Option<String>,
    /// A mesh wall's scale from the file's unit to metres (default 1).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub scale: Option<f64>,
    /// A mesh wall's rotations about x, y and z (degrees), in that order after the scale.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub rotate: Vec<f64>,
    /// A mesh wall's translation (m), applied last.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub translate: Vec<f64>,
    /// A mesh wall whose file's normals point inward: reverse each triangle's corners.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub flip: Option<bool>,
    /// In a 2D scene, the plane `{ axis, at }` that cuts the mesh wall (as for a fluid mesh).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub slice: Option<crate::scene::mesh::Slice>,
    /// SHA-256 of a mesh wall's file, set when the scene is loaded; a resolved scene's must
    /// match the file.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub sha256: Option<String>,
    /// The mesh read from `file`, placed (not a key).
    #[serde(skip)]
    pub mesh: Option<std::sync::Arc<crate::scene::mesh::Mesh>>,
    /// Container wall thickness in particle layers outside each closed face, or rows kept
    /// inside each face of a dummy or dynamic block (default: enough to cover the support; a
    /// dummy or dynamic wall builds at most the rows within the support of fluid at its face,
    /// [`rows_reaching`]; `layers = 1` is DualSPHysics's layout for dynamic walls).
    #[serde(default)]
    pub layers: usize,
    /// Open faces of a container, e.g. `["y+"]` for an open-top tank.
    #[serde(default)]
    pub open: Vec<String>,
    /// `dummy`, `dynamic`, `repulsive` or `mirror`.
    #[serde(default = "default_method")]
    pub method: WallMethod,
    /// `no_slip` or `free_slip`.
    #[serde(default = "default_slip")]
    pub slip: Slip,
    /// How a no-slip dummy wall shows the fluid its velocity in the laminar viscous term:
    /// `adami` (default) or `morris` (Morris et al. 1997's distance ratio).
    #[serde(default, skip_serializing_if = "NoSlipMethod::is_adami")]
    pub no_slip: NoSlipMethod,
    /// What a dummy wall particle holds fixed: `mass` (default, Adami et al. 2012) or
    /// `lattice` (its lattice cell's volume; the mass follows the extrapolated density).
    #[serde(default, skip_serializing_if = "WallVolume::is_mass")]
    pub volume: WallVolume,
    /// Material whose EOS converts the wall's pressure to density and back (default: the first
    /// fluid body's, else the first material).
    #[serde(default)]
    pub material: String,
    /// Surface velocity (m/s) seen by the fluid while the particles stay put (a sliding lid or
    /// a Couette plate); default zero.
    #[serde(default)]
    pub velocity: Vec<f64>,
    /// Prescribed motion of the particles (a piston); exclusive with `velocity`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub motion: Option<Motion>,
}

/// Rows of a dummy wall that reach the fluid: the rows k = 1, 2, … whose centres, (k − ½) dx
/// beyond the wall's face, lie within the support κh (m) of a fluid particle at the face,
/// (k − ½) dx < κh. A fluid particle's first row sits dx/2 inside the face, so this keeps half
/// a spacing of margin; a deeper row is in no fluid particle's support, takes part in no sum
/// (a dummy wall particle lists fluid only) and is not built.
pub fn rows_reaching(support: f64, dx: f64) -> usize {
    (1..).find(|&k| (k as f64 - 0.5) * dx >= support).unwrap_or(1) - 1
}

impl WallBody {
    /// Layers of a container built (`layers`, a dummy wall's at most [`rows_reaching`]).
    pub fn built_layers(&self, support: f64, dx: f64) -> usize {
        if self.method.trims_to_support() {
            self.layers.min(rows_reaching(support, dx).max(1))
        } else {
            self.layers
        }
    }

    /// Rows kept inside each face of a dummy or dynamic block wall: `layers` if set, at most
    /// [`rows_reaching`] (the core beyond is in no fluid particle's support and is not built);
    /// `None` for other walls.
    pub fn shell_rows(&self, support: f64, dx: f64) -> Option<u64> {
        let reach = rows_reaching(support, dx).max(1);
        let rows = if self.layers > 0 {
            self.layers.min(reach)
        } else {
            reach
        };
        let solid = matches!(
            self.shape,
            WallShape::Block | WallShape::Polygon | WallShape::Mesh
        );
        (solid && self.method.trims_to_support()).then_some(rows as u64)
    }
}

fn default_method() -> WallMethod {
    WallMethod::Dummy
}
fn default_slip() -> Slip {
    Slip::NoSlip
}

/// Walls: box, material, open faces, container layers, motion.
pub(super) fn validate_walls(s: &mut Scene, mat_names: &Names, support: f64) -> Result<()> {
    let d = s.dimension;
    let dx = s.discretisation.dx;
    // a wall's EOS is the fluid's beside it: the first fluid body's material, not the first
    // material listed (air or steel listed first gave a water tank's walls their EOS)
    let default_material = s
        .fluids
        .first()
        .map_or_else(|| mat_names.list[0].clone(), |f| f.material.clone());
    for (i, w) in s.walls.iter_mut().enumerate() {
        let k = format!("wall[{i}]");
        outline_keys(w, &k, d)?;
        check_vec(&mut w.min, d, &format!("{k}.min"), false)?;
        check_vec(&mut w.max, d, &format!("{k}.max"), false)?;
        check_box(&w.min, &w.max, &k)?;
        check_vec(&mut w.velocity, d, &format!("{k}.velocity"), true)?;
        speed_at_most(&w.velocity, &format!("{k}.velocity"))?;
        if w.material.is_empty() {
            w.material = default_material.clone();
        } else if !mat_names.contains(&w.material) {
            return unknown_material(&k, &w.material, mat_names);
        }
        for (j, o) in w.open.iter().enumerate() {
            if face(o, d).is_none() {
                let valid: Vec<&str> = ["x-", "x+", "y-", "y+", "z-", "z+"]
                    .into_iter()
                    .take(2 * d)
                    .collect();
                return err(
                    format!("{k}.open[{j}]"),
                    format!("unknown face `{o}`; valid faces: {}", valid.join(", ")),
                );
            }
        }
        match w.shape {
            WallShape::Container => {
                seams_open(w, &k, &s.domain.periodic, d)?;
                if w.layers == 0 {
                    w.layers = if w.method.trims_to_support() {
                        rows_reaching(support, dx).max(1)
                    } else {
                        (support / dx - 1e-9).ceil().max(1.0) as usize
                    };
                }
                // the layers built: a dummy or dynamic wall's beyond the support's reach are not
                let built = w.built_layers(support, dx) as f64;
                let mut lo = w.min.clone();
                let mut hi = w.max.clone();
                for a in 0..d {
                    if !w.open.iter().any(|o| face(o, d) == Some((a, false))) {
                        lo[a] -= built * dx;
                    }
                    if !w.open.iter().any(|o| face(o, d) == Some((a, true))) {
                        hi[a] += built * dx;
                    }
                }
                if !w.method.makes_images() {
                    in_domain(&lo, &hi, &k, &s.domain)?;
                }
            }
            WallShape::Block | WallShape::Polygon | WallShape::Mesh => solid_wall(w, &k, &s.domain)?,
        }
        validate_motion(w, &k, d)?;
        if w.no_slip == crate::scene::NoSlipMethod::Morris
            && (!w.method.allows_morris_no_slip() || w.slip != crate::scene::Slip::NoSlip)
        {
            return err(
                format!("{k}.no_slip"),
                "`morris` sets the velocity a no-slip dummy or mirror wall shows the fluid: it \
                 needs method = \"dummy\" or \"mirror\" and slip = \"no_slip\"; remove it, or use \
                 no_slip = \"adami\"",
            );
        }
        if w.volume == WallVolume::Lattice && !w.method.allows_lattice_volume() {
            return err(
                format!("{k}.volume"),
                "`lattice` fixes the volume of dummy wall particles, whose density the fluid's \
                 pressure sets each step: it needs method = \"dummy\"; remove it, or use \
                 volume = \"mass\"",
            );
        }
    }
    Ok(())
}

/// The checks of a solid wall (a block, polygon or mesh) `w` of key `k`: no mirror images, no
/// Morris distances on an outline or mesh, no open faces, inside the domain.
fn solid_wall(w: &crate::scene::WallBody, k: &str, domain: &Domain) -> Result<()> {
    if w.method.makes_images() {
        return err(
            format!("{k}.method"),
            "mirror walls reflect across the inner faces of a container: use \
                 shape = \"container\", or method = \"dummy\" for a block",
        );
    }
    if w.shape.outlined() && w.no_slip == crate::scene::NoSlipMethod::Morris {
        return err(
            format!("{k}.no_slip"),
            "`morris` needs the distance to a block's or container's faces; a polygon \
                 or mesh wall takes no_slip = \"adami\"",
        );
    }
    if !w.open.is_empty() {
        return err(format!("{k}.open"), "only a container has open faces");
    }
    in_domain(&w.min, &w.max, k, domain)
}

/// A polygon wall's box from its vertices; `vertices` on any other wall is an error.
fn outline_keys(w: &mut crate::scene::WallBody, k: &str, d: usize) -> Result<()> {
    match (w.shape, w.vertices.is_empty()) {
        (WallShape::Polygon, _) => {
            super::checks::resolve_outline_box(&w.vertices, (&mut w.min, &mut w.max), k, d)
        }
        (WallShape::Mesh, true) => {
            super::checks::resolve_mesh_box(w.mesh.as_deref(), (&mut w.min, &mut w.max), k, d)
        }
        (_, true) => Ok(()),
        (_, false) => err(
            format!("{k}.vertices"),
            "belongs to `shape = \"polygon\"`; a block or container takes min and max",
        ),
    }
}

/// A container across a periodic axis must leave both faces on it open: fluid could never
/// cross the seam.
fn seams_open(w: &crate::scene::WallBody, k: &str, periodic: &[bool], d: usize) -> Result<()> {
    for (a, axis) in ["x", "y", "z"].iter().enumerate().take(d) {
        let closed: Vec<String> = [(false, "-"), (true, "+")]
            .iter()
            .filter(|(up, _)| !w.open.iter().any(|o| face(o, d) == Some((a, *up))))
            .map(|(_, sign)| format!("\"{axis}{sign}\""))
            .collect();
        if periodic[a] && !closed.is_empty() {
            return err(
                format!("{k}.open"),
                format!(
                    "the container closes face(s) {} across the periodic axis {axis}: \
                     fluid could never cross the periodic seam; open them (open = [\"{axis}-\", \"{axis}+\"]) \
                     or make axis {axis} non-periodic (domain.periodic)",
                    closed.join(", ")
                ),
            );
        }
    }
    Ok(())
}

/// A wall's motion law: not on a mirror wall, not with a surface velocity, valid constants.
fn validate_motion(w: &mut crate::scene::WallBody, k: &str, d: usize) -> Result<()> {
    if let Some(m) = &mut w.motion {
        if w.method.makes_images() {
            return err(
                format!("{k}.motion"),
                "mirror walls cannot move (their planes are fixed); use method = \"dummy\" for a \
                 moving wall",
            );
        }
        if w.velocity.iter().any(|&v| v != 0.0) {
            return err(
                format!("{k}.motion"),
                "a wall has either a surface `velocity` or a `motion` law, not both",
            );
        }
        match m {
            Motion::Sine {
                amplitude, period, ..
            } => {
                check_vec(amplitude, d, &format!("{k}.motion.amplitude"), false)?;
                positive(*period, &format!("{k}.motion.period"), "period = 1.0")?;
            }
            Motion::ConstantVelocity { velocity } => {
                check_vec(velocity, d, &format!("{k}.motion.velocity"), false)?;
                speed_at_most(velocity, &format!("{k}.motion.velocity"))?;
            }
            Motion::Solitary {
                amplitude,
                depth,
                direction,
            } => {
                positive(*depth, &format!("{k}.motion.depth"), "depth = 0.25")?;
                positive(*amplitude, &format!("{k}.motion.amplitude"), "amplitude = 0.05")?;
                if *amplitude > 0.6 * *depth {
                    return err(
                        format!("{k}.motion.amplitude"),
                        format!(
                            "a solitary wave of A/h = {:.2} exceeds the highest one (A/h ≈ 0.8) \
                             and Goring's first-order law is meant for A/h ≤ 0.6; for example \
                             amplitude = {}",
                            *amplitude / *depth,
                            0.2 * *depth
                        ),
                    );
                }
                if direction.is_empty() {
                    *direction = (0..d).map(|a| if a == 0 { 1.0 } else { 0.0 }).collect();
                }
                check_vec(direction, d, &format!("{k}.motion.direction"), false)?;
                let n = direction.iter().map(|x| x * x).sum::<f64>().sqrt();
                if n == 0.0 {
                    return err(
                        format!("{k}.motion.direction"),
                        "the direction must not be zero; for example direction = [1.0, 0.0]",
                    );
                }
                direction.iter_mut().for_each(|x| *x /= n);
            }
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    /// The still tank with `extra` inserted before its material and `sets` applied.
    fn tank(extra: &str, sets: &[&str]) -> crate::error::Result<crate::scene::Scene> {
        let text = include_str!("../../inputs/hydrostatic_2d.toml")
            .replace("[[material]]", &format!("{extra}[[material]]"));
        let sets: Vec<String> = sets.iter().map(|x| x.to_string()).collect();
        crate::scene::load_scene_str(&text, std::path::Path::new("t.toml"), "t", &sets).map(|s| s.0)
    }

    /// A wall without `material` takes the first fluid body's, not the first material listed
    /// (air listed first gave the water tank's walls air's EOS, and the run blew up).
    #[test]
    fn a_wall_takes_the_fluids_material_by_default() {
        let air = "[[material]]\nname = \"air\"\nrho0 = 1.2\nc0 = 35.0\neos = \"tait\"\ngamma = 7.0\n\n";
        let s = tank(air, &[]).unwrap();
        assert_eq!(s.materials[0].name, "air");
        assert_eq!(s.walls[0].material, "water");
        let s = tank(air, &["wall.0.material=\"air\""]).unwrap();
        assert_eq!(s.walls[0].material, "air", "an explicit material stays");
    }

    /// `layers` beyond the support's reach on a dummy or dynamic container is built as the
    /// rows in reach, and the domain is checked against those (it was refused as outside the
    /// domain, though those rows would never be built); a repulsive wall builds them all.
    #[test]
    fn layers_beyond_the_reach_are_checked_as_built() {
        for method in ["dummy", "dynamic"] {
            let m = format!("wall.0.method=\"{method}\"");
            let s = tank("", &[&m, "wall.0.layers=10"]).unwrap_or_else(|e| panic!("{method}: {e}"));
            let (support, dx) = (s.discretisation.support(), s.discretisation.dx);
            assert_eq!(
                s.walls[0].built_layers(support, dx),
                super::rows_reaching(support, dx)
            );
        }
        let e = tank("", &["wall.0.method=\"repulsive\"", "wall.0.layers=10"]).unwrap_err();
        assert!(e.to_string().contains("outside the domain"), "{e}");
    }
}

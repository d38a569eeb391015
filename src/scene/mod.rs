//! Scene files: the TOML contract between users and hsph (SI units throughout).
//!
//! The structs here are dimension-agnostic (vectors are `Vec<f64>` checked against
//! `dimension` in [`validate`]); `sim` turns them into const-generic state. Every optional key
//! has a default, and `hsph run` writes the resolved scene (defaults filled in) to the run
//! directory. The key reference lives in README.md ("Scene files").

mod checks;
pub mod expr;
pub mod lattice;
mod load;
mod materials;
mod models;
mod validate;

pub(crate) use load::{first_line, key_at, line_of, span_of_key};
pub use load::{load_scene, load_scene_str, SceneSource};
pub use validate::{dt_upper_bound, expected_speed, face as face_of, validate};

use crate::kernel::KernelKind;
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;

/// A whole scene.
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct Scene {
    /// Scene name (defaults to the file stem); names the run directory.
    #[serde(default)]
    pub name: String,
    /// Free text shown by `hsph check`.
    #[serde(default)]
    pub description: String,
    /// 2 or 3.
    pub dimension: usize,
    /// Simulation box and periodic axes.
    pub domain: Domain,
    /// Particle spacing and kernel.
    pub discretisation: Discretisation,
    /// Fluid materials (`[[material]]`).
    #[serde(rename = "material")]
    pub materials: Vec<Material>,
    /// Physics switches; everything off by default.
    #[serde(default)]
    pub physics: Physics,
    /// Fluid blocks filled on the lattice (`[[fluid]]`).
    #[serde(default, rename = "fluid")]
    pub fluids: Vec<FluidBody>,
    /// Elastic–plastic solid bodies filled on the lattice (`[[solid]]`: the keys of a fluid
    /// body, a solid material, and `clamped`).
    #[serde(default, rename = "solid", skip_serializing_if = "Vec::is_empty")]
    pub solids: Vec<FluidBody>,
    /// Walls (`[[wall]]`).
    #[serde(default, rename = "wall")]
    pub walls: Vec<WallBody>,
    /// Time integration.
    pub time: Time,
    /// Output schedule and snapshot fields.
    #[serde(default)]
    pub output: Output,
    /// Probes (`[[probe]]`), each written to `probes/<name>.csv`.
    #[serde(default, rename = "probe")]
    pub probes: Vec<Probe>,
    /// Load balancing across ranks.
    #[serde(default)]
    pub balance: Balance,
    /// Bounds beyond which a run is stopped as blown up.
    #[serde(default)]
    pub limits: Limits,
    /// How the run computes (never what it computes): `[performance]`.
    #[serde(default, skip_serializing_if = "Performance::is_default")]
    pub performance: Performance,
    /// Optional analytic or tabulated reference: errors land in `summary.json`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub reference: Option<Reference>,
    /// Checkpoints for restarts (`[checkpoint]`).
    #[serde(default)]
    pub checkpoint: CheckpointSpec,
    /// Named constants for initial-field expressions (`[constants]`, e.g. `U = 1.0`); a name may
    /// not be a coordinate or a built-in name of expressions in any letter case
    /// ([`expr::constant_name`]).
    #[serde(default, skip_serializing_if = "BTreeMap::is_empty")]
    pub constants: BTreeMap<String, f64>,
}

/// When checkpoints are written (`[checkpoint]`), under `<run>/checkpoints/step-<N>/`. A run
/// stopped by a signal always writes one; with `every_steps` or `every` set, so does a run that
/// reaches its end, so that it can be continued with a later `time.t_end`.
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct CheckpointSpec {
    /// Steps between checkpoints (0 = none on a step count).
    #[serde(default)]
    pub every_steps: u64,
    /// Simulated time between checkpoints (s; 0 = none on a time interval).
    #[serde(default)]
    pub every: f64,
    /// Checkpoints kept; older ones are deleted once a newer one is complete.
    #[serde(default = "default_keep")]
    pub keep: usize,
}

fn default_keep() -> usize {
    2
}

impl Default for CheckpointSpec {
    fn default() -> Self {
        CheckpointSpec {
            every_steps: 0,
            every: 0.0,
            keep: default_keep(),
        }
    }
}

impl CheckpointSpec {
    /// True when checkpoints are written on a schedule.
    pub fn scheduled(&self) -> bool {
        self.every_steps > 0 || self.every > 0.0
    }
}

/// Bounds on the state of integrated particles (`[limits]`): a particle outside them stops
/// the run (exit 1, naming step, particle and position) before it blows up further.
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct Limits {
    /// Allowed density ρ/ρ0 of a fluid particle's material, `[low, high]`; a weakly
    /// compressible fluid stays within a few per cent of 1. (Solids are checked for finite
    /// state and positive density only.)
    #[serde(default = "default_density_ratio")]
    pub density_ratio: Vec<f64>,
    /// Largest speed of a fluid particle as a multiple of the material's c0 (c0 is at least
    /// 10 × the expected speed, so 1 means 10 × what the scene expects).
    #[serde(default = "default_speed_over_c0")]
    pub speed_over_c0: f64,
}

fn default_density_ratio() -> Vec<f64> {
    vec![0.5, 2.0]
}
fn default_speed_over_c0() -> f64 {
    1.0
}

impl Default for Limits {
    fn default() -> Self {
        Limits {
            density_ratio: default_density_ratio(),
            speed_over_c0: default_speed_over_c0(),
        }
    }
}

/// How the run computes, not what: `[performance]` (issue 16).
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq, Default)]
#[serde(deny_unknown_fields)]
pub struct Performance {
    /// How the fluid pair loops visit pairs: `gather` (default) or `pairs`
    /// ([`Interactions`]).
    #[serde(default)]
    pub interactions: Interactions,
    /// How passes find neighbours: `lists` (default) or `cells` ([`NeighbourMode`]).
    #[serde(default)]
    pub neighbours: NeighbourMode,
}

/// How passes find neighbours.
#[derive(Debug, Clone, Copy, Serialize, Deserialize, PartialEq, Eq, Default, clap::ValueEnum)]
#[serde(rename_all = "snake_case")]
pub enum NeighbourMode {
    /// Lists built once per step and read by every pass (4 B per pair: fastest).
    #[default]
    Lists,
    /// No stored lists: every pass scans the stencil cells again, in the same order, so the
    /// bits are those of `lists` (the lean-memory mode).
    Cells,
}

impl NeighbourMode {
    /// Scene-file name.
    pub fn name(self) -> &'static str {
        match self {
            NeighbourMode::Lists => "lists",
            NeighbourMode::Cells => "cells",
        }
    }
}

impl Performance {
    /// True for the defaults (left out of a written scene).
    pub fn is_default(&self) -> bool {
        *self == Performance::default()
    }
}

/// How the fluid pair loops visit pairs.
#[derive(Debug, Clone, Copy, Serialize, Deserialize, PartialEq, Eq, Default, clap::ValueEnum)]
#[serde(rename_all = "snake_case")]
pub enum Interactions {
    /// Each particle sums over all its neighbours, in an order fixed by global ids: the same
    /// bits on any number of ranks and threads. Every pair is evaluated twice.
    #[default]
    Gather,
    /// Each pair is evaluated once (half lists) and its equal and opposite contributions go
    /// to both, in an order fixed by the global cell grid and the ids: the same bits on any
    /// number of ranks and threads (not gather's bits), equal to `gather` to round-off.
    Pairs,
}

impl Interactions {
    /// Scene-file name.
    pub fn name(self) -> &'static str {
        match self {
            Interactions::Gather => "gather",
            Interactions::Pairs => "pairs",
        }
    }
}

/// Load balancing of the domain decomposition (issue 3).
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct Balance {
    /// Steps between load-balance checks (0 = never rebalance).
    #[serde(default = "default_check_every")]
    pub check_every: u64,
    /// Rebalance when max/mean load exceeds this (≥ 1).
    #[serde(default = "default_threshold")]
    pub threshold: f64,
    /// What a particle weighs: `particles` (1 each) or `pairs` (1 + its neighbour count,
    /// from the last neighbour search; the initial split uses particle counts).
    #[serde(default)]
    pub load: LoadKind,
    /// Relative speed of each rank (empty: all equal); target loads are proportional.
    #[serde(default)]
    pub weights: Vec<f64>,
}

/// Load measure of the domain decomposition.
#[derive(Debug, Clone, Copy, Serialize, Deserialize, PartialEq, Eq, Default)]
#[serde(rename_all = "snake_case")]
pub enum LoadKind {
    /// Every particle weighs 1.
    #[default]
    Particles,
    /// A particle weighs 1 + its neighbour count (the cost of its force loop).
    Pairs,
}

fn default_check_every() -> u64 {
    20
}
fn default_threshold() -> f64 {
    1.1
}

impl Default for Balance {
    fn default() -> Self {
        Balance {
            check_every: default_check_every(),
            threshold: default_threshold(),
            load: LoadKind::Particles,
            weights: Vec::new(),
        }
    }
}

/// Axis-aligned simulation box (m). Particles leaving it (on a non-periodic axis) stop the run.
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct Domain {
    /// Lower corner (m), `dimension` values.
    pub min: Vec<f64>,
    /// Upper corner (m).
    pub max: Vec<f64>,
    /// Periodic flag per axis (default: none periodic).
    #[serde(default)]
    pub periodic: Vec<bool>,
    /// What a fluid particle that leaves the domain (or whose density leaves
    /// `limits.density_ratio`) does: `remove` (counted and logged) or `stop` the run.
    #[serde(default)]
    pub outflow: Outflow,
    /// Fraction of the particles that may be removed before the run stops (exit 1).
    #[serde(default = "default_max_removed_fraction")]
    pub max_removed_fraction: f64,
}

/// The outflow rule of a scene (`[domain] outflow`).
#[derive(Debug, Clone, Copy, Serialize, Deserialize, PartialEq, Eq, Default)]
#[serde(rename_all = "snake_case")]
pub enum Outflow {
    /// Remove the particle: counted, logged in `removed.csv`, reported in `summary.json`.
    #[default]
    Remove,
    /// Stop the run (exit 1) naming the particle.
    Stop,
}

fn default_max_removed_fraction() -> f64 {
    0.01
}

/// Particle spacing and kernel choice.
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct Discretisation {
    /// Lattice spacing dx (m); every particle sits on the global lattice of this spacing.
    pub dx: f64,
    /// Smoothing length over spacing, h/dx.
    #[serde(default = "default_h_over_dx")]
    pub h_over_dx: f64,
    /// `wendland_c2`, `cubic_spline` or `quintic_spline`.
    #[serde(default = "default_kernel")]
    pub kernel: KernelKind,
}

fn default_h_over_dx() -> f64 {
    1.3
}
fn default_kernel() -> KernelKind {
    KernelKind::WendlandC2
}

pub use crate::material::EosKind;

/// What a material is: a weakly compressible fluid or an elastic–plastic solid.
#[derive(Debug, Clone, Copy, Serialize, Deserialize, PartialEq, Eq, Default)]
#[serde(rename_all = "snake_case")]
pub enum MaterialKind {
    /// Weakly compressible fluid (Tait or linear EOS).
    #[default]
    Fluid,
    /// Elastic–plastic solid: Mie–Grüneisen EOS, shear modulus, optional Johnson–Cook
    /// strength and failure (docs/solids.md).
    Solid,
}

/// Strength model of a solid.
#[derive(Debug, Clone, Copy, Serialize, Deserialize, PartialEq, Eq)]
#[serde(rename_all = "snake_case")]
pub enum StrengthKind {
    /// Elastic: no yield.
    Elastic,
    /// Johnson–Cook flow stress with radial return.
    JohnsonCook,
}

/// A material (`[[material]]`). Fluids give `rho0`, `c0`, `eos`, `gamma`; solids
/// (`model = "solid"`) give their constants, or `library = "al6061-t6"` and only what they
/// change (the validator fills the rest from the library, so the resolved scene is explicit).
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct Material {
    /// Name referred to by bodies.
    pub name: String,
    /// `fluid` (default) or `solid`.
    #[serde(default, skip_serializing_if = "is_fluid_kind")]
    pub model: MaterialKind,
    /// A solid from the material library (`hsph check` lists them): fills every solid constant
    /// not given.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub library: Option<String>,
    /// Reference density ρ0 (kg/m³).
    #[serde(default)]
    pub rho0: f64,
    /// Fluids: numerical sound speed c0 (m/s), ≥ 10 × the expected speed. Solids: the bulk
    /// sound speed, the intercept of the Hugoniot Us = c0 + s·up (m/s).
    #[serde(default)]
    pub c0: f64,
    /// `tait` or `linear`.
    #[serde(default = "default_eos")]
    pub eos: EosKind,
    /// Tait exponent γ (ignored by `linear`).
    #[serde(default = "default_gamma")]
    pub gamma: f64,
    /// Solid: slope s of the Hugoniot Us = c0 + s·up (–).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub hugoniot_slope: Option<f64>,
    /// Solid: Grüneisen coefficient Γ0 (–).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub gruneisen: Option<f64>,
    /// Solid: shear modulus G (Pa).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub shear_modulus: Option<f64>,
    /// Solid: `elastic` or `johnson_cook` (default with a library material).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub strength: Option<StrengthKind>,
    /// Johnson–Cook yield stress A (Pa).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub jc_a: Option<f64>,
    /// Johnson–Cook hardening modulus B (Pa).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub jc_b: Option<f64>,
    /// Johnson–Cook hardening exponent n (–).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub jc_n: Option<f64>,
    /// Johnson–Cook strain-rate coefficient C (–), ε̇0 = 1/s.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub jc_c: Option<f64>,
    /// Johnson–Cook thermal-softening exponent m (–).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub jc_m: Option<f64>,
    /// Room temperature (K).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub t_room: Option<f64>,
    /// Melt temperature (K).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub t_melt: Option<f64>,
    /// Specific heat c_v (J/(kg K)).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub specific_heat: Option<f64>,
    /// Failure: equivalent plastic strain at which a particle fails (–); none by default.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub failure_strain: Option<f64>,
    /// Failure: spall strength, the tension at which a particle fails (Pa); none by default.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub spall_pressure: Option<f64>,
}

fn is_fluid_kind(k: &MaterialKind) -> bool {
    *k == MaterialKind::Fluid
}

impl Material {
    /// A fluid material with a Tait (γ = 7) or linear EOS.
    pub fn fluid(name: &str, rho0: f64, c0: f64, eos: EosKind) -> Self {
        Material {
            name: name.into(),
            model: MaterialKind::Fluid,
            library: None,
            rho0,
            c0,
            eos,
            gamma: default_gamma(),
            hugoniot_slope: None,
            gruneisen: None,
            shear_modulus: None,
            strength: None,
            jc_a: None,
            jc_b: None,
            jc_n: None,
            jc_c: None,
            jc_m: None,
            t_room: None,
            t_melt: None,
            specific_heat: None,
            failure_strain: None,
            spall_pressure: None,
        }
    }

    /// True for a solid material.
    pub fn is_solid(&self) -> bool {
        self.model == MaterialKind::Solid
    }
}

fn default_eos() -> EosKind {
    EosKind::Tait
}
fn default_gamma() -> f64 {
    7.0
}

/// Density diffusion (δ-SPH) variants.
#[derive(Debug, Clone, Copy, Serialize, Deserialize, PartialEq, Eq, Default)]
#[serde(rename_all = "snake_case")]
pub enum DensityDiffusion {
    /// Plain weakly compressible SPH.
    #[default]
    None,
    /// Molteni & Colagrossi (2009): ψ_ij = 2 (ρ_j − ρ_i) x_ji/|x_ij|².
    Molteni,
    /// Antuono et al. (2010): Molteni's term minus the renormalised gradients.
    Antuono,
}

/// Physics switches: a scene switches on only what it needs.
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct Physics {
    /// `none`, `molteni` or `antuono`.
    #[serde(default)]
    pub density_diffusion: DensityDiffusion,
    /// δ coefficient of the density diffusion (dimensionless).
    #[serde(default = "default_delta")]
    pub delta: f64,
    /// Monaghan artificial viscosity α (dimensionless; 0 = off).
    #[serde(default)]
    pub artificial_viscosity: f64,
    /// Laminar kinematic viscosity ν (m²/s; 0 = off), Morris et al. (1997).
    #[serde(default)]
    pub laminar_viscosity: f64,
    /// Body force per unit mass (m/s²), e.g. gravity `[0, -9.81]`; default zero.
    #[serde(default)]
    pub body_force: Vec<f64>,
    /// Solids: the quadratic artificial-viscosity coefficient β (Monaghan & Gingold 1983;
    /// α is `artificial_viscosity`); 0 = off.
    #[serde(default, skip_serializing_if = "is_zero")]
    pub artificial_viscosity_beta: f64,
    /// Solids: the artificial-stress coefficient ε against the tensile instability (Gray,
    /// Monaghan & Swift 2001; 0.3 is theirs), exponent n = 4; 0 = off.
    #[serde(default, skip_serializing_if = "is_zero")]
    pub artificial_stress: f64,
    /// Particle shifting of fluid particles after each step: `none` (default) or
    /// `delta_plus` (Sun et al. 2017, [`crate::physics::shifting`]).
    #[serde(default, skip_serializing_if = "ShiftingKind::is_none")]
    pub shifting: ShiftingKind,
    /// The discrete laminar viscous operator: `morris` (default, Morris et al. 1997) or
    /// `renormalised` (the same, divided by the pair's mean lattice moment, so that it is
    /// exact for quadratic fields on any regular lattice: [`crate::physics::viscous`]).
    #[serde(default, skip_serializing_if = "ViscousOperator::is_morris")]
    pub viscous_operator: ViscousOperator,
}

/// The discrete laminar viscous operator.
#[derive(Debug, Clone, Copy, Serialize, Deserialize, PartialEq, Eq, Default)]
#[serde(rename_all = "snake_case")]
pub enum ViscousOperator {
    /// Morris, Fox & Zhu (1997), eq. (8).
    #[default]
    Morris,
    /// Morris's operator times 2/(L_i + L_j), L the lattice moment −(1/D) Σ_j V_j r_ij W′_ij.
    Renormalised,
}

impl ViscousOperator {
    /// True for `morris` (left out of a written scene).
    pub fn is_morris(&self) -> bool {
        *self == ViscousOperator::Morris
    }
}

/// Particle shifting variants.
#[derive(Debug, Clone, Copy, Serialize, Deserialize, PartialEq, Eq, Default)]
#[serde(rename_all = "snake_case")]
pub enum ShiftingKind {
    /// Particles move with the flow only.
    #[default]
    None,
    /// δ⁺-SPH shifting with its free-surface treatment and Taylor-corrected fields.
    DeltaPlus,
}

impl ShiftingKind {
    /// True for `none` (left out of a written scene).
    pub fn is_none(&self) -> bool {
        *self == ShiftingKind::None
    }
}

fn default_delta() -> f64 {
    0.1
}

impl Default for Physics {
    fn default() -> Self {
        Physics {
            density_diffusion: DensityDiffusion::None,
            delta: default_delta(),
            artificial_viscosity: 0.0,
            laminar_viscosity: 0.0,
            body_force: Vec::new(),
            artificial_viscosity_beta: 0.0,
            artificial_stress: 0.0,
            shifting: ShiftingKind::None,
            viscous_operator: ViscousOperator::Morris,
        }
    }
}

/// A block of fluid filled on the lattice: every lattice site with its centre in [min, max).
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct FluidBody {
    /// Name (used in `final.csv` as the body index order), unique among all bodies (fluids,
    /// solids, walls).
    pub name: String,
    /// Material name.
    pub material: String,
    /// Shape: `block` (every site in [min, max); a plate is a thin block), `sphere` (a disc in
    /// 2D: every site closer than `radius` to `centre`) or `cylinder` (3D: every site closer than
    /// `radius` to the axis through `centre` along `axis`, within `length`/2 of `centre`).
    #[serde(default)]
    pub shape: BodyShape,
    /// Lower corner (m); for a sphere, set from centre and radius.
    #[serde(default)]
    pub min: Vec<f64>,
    /// Upper corner (m); for a sphere, set from centre and radius.
    #[serde(default)]
    pub max: Vec<f64>,
    /// Centre of a sphere (m).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub centre: Vec<f64>,
    /// Radius of a sphere or cylinder (m).
    #[serde(default, skip_serializing_if = "is_zero")]
    pub radius: f64,
    /// Axis of a cylinder: 0, 1 or 2 (x, y, z).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub axis: Option<usize>,
    /// Length of a cylinder along its axis (m).
    #[serde(default, skip_serializing_if = "is_zero")]
    pub length: f64,
    /// Initial velocity (m/s); default zero.
    #[serde(default)]
    pub velocity: Vec<f64>,
    /// Start from the hydrostatic density profile under the body force (free surface at the
    /// top of the block along the body force), instead of ρ0 everywhere.
    #[serde(default)]
    pub hydrostatic: bool,
    /// Initial velocity as one expression per axis of `x`, `y`[, `z`] (m) and the scene's
    /// `[constants]` (m/s), instead of `velocity`; see [`expr`].
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub velocity_field: Option<Vec<String>>,
    /// Initial pressure as an expression of the same names (Pa); the density follows from the
    /// material's EOS. Instead of `hydrostatic`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub pressure_field: Option<String>,
    /// Solids only: the body is held in place (a clamp); its stress still evolves.
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub clamped: bool,
}

/// Shape of a fluid body.
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
}

impl FluidBody {
    /// True if the lattice site at `x` (inside [min, max)) belongs to the body.
    #[inline]
    pub fn contains(&self, x: &[f64]) -> bool {
        match self.shape {
            BodyShape::Block => true,
            BodyShape::Sphere => {
                let r2: f64 = x.iter().zip(&self.centre).map(|(a, c)| (a - c) * (a - c)).sum();
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
        }
    }
}

fn is_zero(v: &f64) -> bool {
    *v == 0.0
}

/// Shape of a wall body.
#[derive(Debug, Clone, Copy, Serialize, Deserialize, PartialEq, Eq)]
#[serde(rename_all = "snake_case")]
pub enum WallShape {
    /// A solid block: every lattice site in [min, max) is a wall particle.
    Block,
    /// A container around the inner box [min, max): `layers` layers outside each face except
    /// the faces listed in `open`.
    Container,
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
}

impl WallMethod {
    /// The particle kind the method fills its body with (`None`: mirror walls have no
    /// particles of their own).
    pub fn particle_kind(self) -> Option<crate::particles::Kind> {
        match self {
            WallMethod::Dummy => Some(crate::particles::Kind::Dummy),
            WallMethod::Repulsive => Some(crate::particles::Kind::Repulsive),
            WallMethod::Mirror => None,
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
    /// `block` or `container`.
    pub shape: WallShape,
    /// Lower corner (m) of the block, or of the container's inner box.
    pub min: Vec<f64>,
    /// Upper corner (m).
    pub max: Vec<f64>,
    /// Container wall thickness in particle layers (default: enough to cover the support).
    #[serde(default)]
    pub layers: usize,
    /// Open faces of a container, e.g. `["y+"]` for an open-top tank.
    #[serde(default)]
    pub open: Vec<String>,
    /// `dummy`, `repulsive` or `mirror`.
    #[serde(default = "default_method")]
    pub method: WallMethod,
    /// `no_slip` or `free_slip`.
    #[serde(default = "default_slip")]
    pub slip: Slip,
    /// How a no-slip dummy wall shows the fluid its velocity in the laminar viscous term:
    /// `adami` (default) or `morris` (Morris et al. 1997's distance ratio).
    #[serde(default, skip_serializing_if = "NoSlipMethod::is_adami")]
    pub no_slip: NoSlipMethod,
    /// Material whose EOS converts extrapolated pressure to density (default: the first).
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

fn default_method() -> WallMethod {
    WallMethod::Dummy
}
fn default_slip() -> Slip {
    Slip::NoSlip
}

/// Time integration settings.
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct Time {
    /// End time (s), at most [`crate::limits::MAX_T_END`]. With `max_steps` unset, t_end over
    /// the first step's bound of dt ([`dt_upper_bound`]) must stay within the step budget
    /// [`crate::limits::MAX_STEPS`].
    pub t_end: f64,
    /// Courant number for dt = CFL · h/(c0 + |v|max) (and the force limit); in (0, 3], with a
    /// warning above 1 (`MAX_CFL` in `scene/validate.rs`).
    #[serde(default = "default_cfl")]
    pub cfl: f64,
    /// Fixed time step (s), overriding the adaptive one (0 = adaptive).
    #[serde(default)]
    pub dt: f64,
    /// Stop after this many steps (0 = no limit). Setting it lifts the step budget: the run
    /// is then bounded by it.
    #[serde(default)]
    pub max_steps: u64,
}

fn default_cfl() -> f64 {
    0.2
}

/// Snapshot formats.
#[derive(Debug, Clone, Copy, Serialize, Deserialize, PartialEq, Eq)]
#[serde(rename_all = "snake_case")]
pub enum SnapshotFormat {
    /// VTK XML unstructured grid (`.vtu` + `.pvd`), ParaView opens it.
    Vtk,
    /// netCDF-3 with 64-bit offsets, one file per snapshot and rank with a manifest, CF point
    /// layout (`src/output/netcdf.rs`), and the series mirrored into `timeseries.nc` and
    /// `probes/*.nc`. Pure Rust: every build writes it.
    Netcdf,
    /// netCDF-4 (HDF5, deflate level 4 with shuffle), otherwise laid out as `netcdf`; needs
    /// the `netcdf` cargo feature (system libnetcdf).
    Netcdf4,
    /// No snapshots.
    None,
}

/// Output schedule.
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct Output {
    /// Simulated time between output steps (s); 0 = 50 outputs over the run.
    #[serde(default)]
    pub interval: f64,
    /// Snapshot format.
    #[serde(default = "default_format")]
    pub format: SnapshotFormat,
    /// Fields written to snapshots (any of `velocity`, `density`, `pressure`, `mass`, `kind`:
    /// the particle table's snapshot names).
    #[serde(default = "default_fields")]
    pub fields: Vec<String>,
    /// Largest particle count for which `final.csv` is gathered on rank 0; above it every rank
    /// writes its own `final/rank_000r.csv`. Snapshots are always written per rank.
    #[serde(default = "default_gather_limit")]
    pub gather_limit: usize,
}

fn default_gather_limit() -> usize {
    2_000_000
}

fn default_format() -> SnapshotFormat {
    SnapshotFormat::Vtk
}
fn default_fields() -> Vec<String> {
    ["velocity", "density", "pressure", "kind"]
        .iter()
        .map(|s| s.to_string())
        .collect()
}

impl Default for Output {
    fn default() -> Self {
        Output {
            interval: 0.0,
            format: default_format(),
            fields: default_fields(),
            gather_limit: default_gather_limit(),
        }
    }
}

/// A probe (`[[probe]]`), written to `probes/<name>.csv` on its own clock: every `interval`
/// seconds of simulated time (default: at the output steps; 0 = every step), buffered and
/// flushed at output steps. Sensors are documented in `src/probes/sensors.rs`.
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields, tag = "kind", rename_all = "snake_case")]
pub enum Probe {
    /// Pressure transducer at a point, usually on a wall face: the kernel-weighted (Shepard)
    /// average of the fluid pressure around it (walls excluded), averaged over a sensing face
    /// of `diameter` across `normal` and over the last `window` seconds: column `p` (Pa).
    Pressure {
        /// Probe name (file `probes/<name>.csv`).
        name: String,
        /// Centre of the sensing face (m).
        point: Vec<f64>,
        /// Diameter of the sensing face (m; 0 = a point).
        #[serde(default)]
        diameter: f64,
        /// Normal of the sensing face (needed when `diameter` > 0; any length).
        #[serde(default, skip_serializing_if = "Option::is_none")]
        normal: Option<Vec<f64>>,
        /// Averaging window (s; 0 = instantaneous). A windowed sensor samples every step.
        #[serde(default)]
        window: f64,
        /// Seconds between rows (default: the output interval; 0 = every step).
        #[serde(default, skip_serializing_if = "Option::is_none")]
        interval: Option<f64>,
    },
    /// Kernel-interpolated velocity at `points` points from `from` to `to`.
    VelocityLine {
        /// Probe name.
        name: String,
        /// Start (m).
        from: Vec<f64>,
        /// End (m).
        to: Vec<f64>,
        /// Number of sample points (≥ 2).
        points: usize,
        /// Seconds between rows (default: the output interval; 0 = every step).
        #[serde(default, skip_serializing_if = "Option::is_none")]
        interval: Option<f64>,
    },
    /// Wave gauge at a station: the elevation (along the last axis) where the continuous water
    /// column on the bed under `point` ends (interpolated matter fraction ½; spray above it is
    /// ignored), 0 when dry: column `eta`.
    Gauge {
        /// Probe name.
        name: String,
        /// A point on the vertical line (m); its last coordinate is ignored.
        point: Vec<f64>,
        /// Seconds between rows (default: the output interval; 0 = every step).
        #[serde(default, skip_serializing_if = "Option::is_none")]
        interval: Option<f64>,
    },
    /// Front of the main body of fluid along `axis` in `direction`: the extreme coordinate of
    /// the largest connected group of fluid particles (two particles connect when closer than
    /// `link`·dx), so that detached drops and spray do not count: column `front` (m).
    Front {
        /// Probe name.
        name: String,
        /// Axis index (0 = x).
        #[serde(default)]
        axis: usize,
        /// `"+"` (largest coordinate, the default) or `"-"` (smallest).
        #[serde(default)]
        direction: Direction,
        /// Connection distance in units of dx (default 1.5).
        #[serde(default = "default_link")]
        link: f64,
        /// Seconds between rows (default: the output interval; 0 = every step).
        #[serde(default, skip_serializing_if = "Option::is_none")]
        interval: Option<f64>,
    },
    /// Force and moment the fluid exerts on the wall `body` (N and N·m; per metre of depth in
    /// 2D), the same pair forces the walls exert on the fluid, reversed; the moment is about
    /// `about`: columns `fx, fy[, fz]` then `mz` (2D) or `mx, my, mz` (3D).
    Force {
        /// Probe name.
        name: String,
        /// Name of a `[[wall]]` with dummy or repulsive particles.
        body: String,
        /// Point the moment is taken about (m; default the origin).
        #[serde(default, skip_serializing_if = "Option::is_none")]
        about: Option<Vec<f64>>,
        /// Averaging window (s; 0 = instantaneous). A windowed sensor samples every step.
        #[serde(default)]
        window: f64,
        /// Seconds between rows (default: the output interval; 0 = every step).
        #[serde(default, skip_serializing_if = "Option::is_none")]
        interval: Option<f64>,
    },
    /// The hole a projectile punches through a plate and the debris cloud behind it
    /// (`probes::hole` states the method): columns `perforated`, `major`, `minor` (m), `angle`
    /// (degrees), `area` (m²), `centre_u`, `centre_v` (m), `debris` (particles),
    /// `debris_length`, `debris_width` (m). `summary.json` reports the axes once settled.
    Hole {
        /// Probe name.
        name: String,
        /// The `[[solid]]` plate.
        plate: String,
        /// The `[[solid]]` projectile (its initial velocity is the impact direction).
        projectile: String,
        /// Seconds between rows (default: the output interval; 0 = every step).
        #[serde(default, skip_serializing_if = "Option::is_none")]
        interval: Option<f64>,
    },
}

/// Which way a front probe looks along its axis.
#[derive(Debug, Clone, Copy, Default, Serialize, Deserialize, PartialEq, Eq)]
pub enum Direction {
    /// Towards larger coordinates.
    #[default]
    #[serde(rename = "+")]
    Plus,
    /// Towards smaller coordinates.
    #[serde(rename = "-")]
    Minus,
}

fn default_link() -> f64 {
    1.5
}

impl Probe {
    /// The probe's name.
    pub fn name(&self) -> &str {
        match self {
            Probe::Pressure { name, .. }
            | Probe::VelocityLine { name, .. }
            | Probe::Gauge { name, .. }
            | Probe::Front { name, .. }
            | Probe::Force { name, .. }
            | Probe::Hole { name, .. } => name,
        }
    }

    /// Seconds between rows, if set (`None`: at the output steps).
    pub fn interval(&self) -> Option<f64> {
        match self {
            Probe::Pressure { interval, .. }
            | Probe::VelocityLine { interval, .. }
            | Probe::Gauge { interval, .. }
            | Probe::Front { interval, .. }
            | Probe::Force { interval, .. }
            | Probe::Hole { interval, .. } => *interval,
        }
    }

    /// Averaging window (s; 0 = none).
    pub fn window(&self) -> f64 {
        match self {
            Probe::Pressure { window, .. } | Probe::Force { window, .. } => *window,
            _ => 0.0,
        }
    }
}

/// An analytic or tabulated reference the run is checked against; the named relative errors
/// (fractions) land in `summary.json` under `errors`.
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields, tag = "kind", rename_all = "snake_case")]
pub enum Reference {
    /// Morris et al. (1997) body-force-driven start-up between plates at y = 0 and y = gap.
    Poiseuille {
        /// Plate gap L (m).
        gap: f64,
        /// Times (s) at which the error is measured (the first step at or after each).
        times: Vec<f64>,
    },
    /// Impulsively started Couette flow; the upper plate's speed is the reference `v0`.
    Couette {
        /// Plate gap L (m).
        gap: f64,
        /// Upper plate speed v0 (m/s).
        v0: f64,
        /// Times (s).
        times: Vec<f64>,
    },
    /// Still water: p = ρ0 g (H − y) with the free surface at `surface`.
    Hydrostatic {
        /// Free-surface height (m) along the last axis.
        surface: f64,
        /// Bottom height (m) of the fluid.
        bottom: f64,
    },
    /// A measured hole (an impact experiment): the hole probe's settled axes are compared
    /// with `major` and `minor` (m) in `summary.json`.
    Hole {
        /// Major axis of the experiment's hole (m).
        major: f64,
        /// Minor axis (m).
        minor: f64,
        /// Where the figures come from.
        #[serde(default)]
        source: String,
    },
    /// Lid-driven square cavity (2D) against Ghia, Ghia & Shin (1982): u on the vertical and
    /// v on the horizontal centreline at their interior tabulated points, in lid-speed units.
    Cavity {
        /// Reynolds number U L/ν of the reference: 100, 400 or 1000 (Ghia's tables) or 1 (a
        /// finite-difference Stokes solution, [`crate::stokes_cavity`]).
        re: u32,
        /// Lid speed U (m/s), along +x.
        lid_speed: f64,
        /// Side L (m).
        size: f64,
        /// Lower-left corner of the cavity (m).
        #[serde(default = "zero2")]
        origin: Vec<f64>,
    },
    /// A solitary wave made by the scene's `solitary` wave maker: the crest at one gauge
    /// against the wave height A, the crest's arrival at another against the celerity
    /// √(g (h + A)), and the maximum run-up at a wall gauge against Su & Mirie (1980),
    /// R/h = 2α + α²/2 + 3α³/4 with α = A/h ([`crate::reference::su_mirie_runup`]).
    SolitaryWave {
        /// Gauge probe whose crest is compared with A (seed 002: 2 m from the paddle).
        crest_gauge: String,
        /// Gauge probe whose crest time is compared with the celerity's (seed 002: 8 m).
        arrival_gauge: String,
        /// Gauge probe at the wall the wave runs up.
        runup_gauge: String,
    },
    /// The decaying Taylor–Green vortex in a periodic square of side L (analytic.md §2):
    /// u = −U e^{bt} cos(2πx/L) sin(2πy/L), v = U e^{bt} sin(2πx/L) cos(2πy/L),
    /// b = −8π²ν/L², with the domain's lower corner at the origin of x and y.
    TaylorGreen {
        /// U (m/s).
        speed: f64,
        /// L (m).
        length: f64,
        /// Times (s) at which the error and the particle disorder are measured.
        times: Vec<f64>,
    },
    /// Koshizuka & Oka (1996) surge front Z = z/L vs T = t·sqrt(2g/L), experiment.
    DamBreakFront {
        /// Column width L (m).
        column_width: f64,
        /// Left wall position (m) from which the front is measured.
        origin: f64,
    },
}

/// Default corner of a cavity reference.
fn zero2() -> Vec<f64> {
    vec![0.0, 0.0]
}

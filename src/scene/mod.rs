//! Scene files: the TOML contract between users and hsph (SI units throughout).
//!
//! The structs here are dimension-agnostic (vectors are `Vec<f64>` checked against
//! `dimension` in [`validate`]); `sim` turns them into const-generic state. Every optional key
//! has a default, and `hsph run` writes the resolved scene (defaults filled in) to the run
//! directory. The key reference lives in README.md ("Scene files").

mod checks;
pub(crate) use checks::{disc_scale, num};
pub mod expr;
pub mod lattice;
mod load;
mod materials;
pub mod mesh;
pub mod mesh_file;
mod models;
mod outline_file;
pub mod polygon;
mod probes;
mod reference;
pub mod refine;
pub mod shape;
mod validate;
mod walls;

pub use checks::face as face_of;
pub(crate) use load::{first_line, key_at, line_of, span_of_key};
pub use load::{load_scene, load_scene_str, SceneFlags, SceneSource};
pub use materials::{Material, MaterialKind, StrengthKind};
#[cfg(test)]
pub(crate) use probes::one_of_each;
pub use probes::{Direction, Probe, DEFAULT_LOAD_FILTER_S, HOLE_COLUMNS};
pub use reference::{ExperimentProtocol, ExperimentSensor, PressureExperiment, Reference};
pub use shape::BodyShape;
pub use validate::{check_rank_weights, dt_upper_bound, expected_speed, validate};
pub use walls::{rows_reaching, Motion, NoSlipMethod, Slip, WallBody, WallMethod, WallShape, WallVolume};

use crate::kernel::KernelKind;
use serde::{Deserialize, Serialize};
use shape::is_zero;
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
    /// Refinement regions (`[[refine]]`): bodies built at dx / 2^level inside them.
    #[serde(default, rename = "refine", skip_serializing_if = "Vec::is_empty")]
    pub refine: Vec<refine::Refine>,
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

impl Scene {
    /// The finest refinement level of the scene's `[[refine]]` regions (0 without regions):
    /// its smallest spacing is dx / 2^level.
    pub fn finest_level(&self) -> u32 {
        self.refine.iter().map(|r| r.level).max().unwrap_or(0)
    }
}

/// Every set-up warning of a scene: the lattice's (settings outside their tested range,
/// uncoupled bodies that touch, bodies built off their scene size) and the refinement
/// regions' (particles that list thousands of neighbours, fine particles under a level-h
/// pressure jump, walls of a smaller h than the fluid beside them, regions that refine nothing) and step counts that local time stepping
/// cannot honour (an odd `checkpoint.every_steps` or `time.max_steps`) and pressure sensors
/// that read the discretisation (a face narrower than dx, a corner within one support) and
/// meshes whose surface crosses itself.
pub fn warnings<const D: usize>(s: &Scene) -> Vec<String> {
    let mut out = lattice::scene_warnings::<D>(s);
    out.extend(refine::list_warnings(s));
    out.extend(refine::level_h_warnings(s));
    out.extend(refine::wall_h_warnings(s));
    out.extend(refine::region_warnings::<D>(s));
    out.extend(validate::stepping_warnings(s));
    out.extend(probes::sensor_warnings(s));
    out.extend(mesh_file::mesh_warnings(s));
    out
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

/// How the run computes, not what: `[performance]` (README, "Scene files").
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct Performance {
    /// How the fluid pair loops visit pairs: `gather` (default) or `pairs`
    /// ([`Interactions`]).
    #[serde(default)]
    pub interactions: Interactions,
    /// How passes find neighbours: `lists` (default), `cells` or `verlet` ([`NeighbourMode`]).
    #[serde(default)]
    pub neighbours: NeighbourMode,
    /// Whether a halo refresh overlaps the interior's compute: `off` (default) or `on`
    /// ([`Overlap`]). The same bits either way.
    #[serde(default)]
    pub overlap: Overlap,
    /// Verlet skin of the ghost set, as a fraction of the kernel support (dimensionless,
    /// 0 ≤ skin ≤ 1; default [`DEFAULT_SKIN`] = 0.1): ghosts are sent to every rank within
    /// support·(1 + skin) and kept, their fields refreshed, until some particle has moved more
    /// than half the skin since they were built (or one wrapped, left, or the planes moved);
    /// migration waits for that rebuild too. 0 rebuilds every step. The same bits either way:
    /// a neighbour is listed only within the support, in global cell and key order. One rank
    /// without periodic axes or mirror planes has no ghost and keeps no skin.
    #[serde(default = "default_skin")]
    pub skin: f64,
}

/// The default Verlet skin of the ghost set (fraction of the kernel support), see
/// docs/benchmark-log.md, "Ghosts kept between builds with a Verlet skin".
pub const DEFAULT_SKIN: f64 = 0.1;

fn default_skin() -> f64 {
    DEFAULT_SKIN
}

impl Default for Performance {
    fn default() -> Self {
        Performance {
            interactions: Interactions::default(),
            neighbours: NeighbourMode::default(),
            overlap: Overlap::default(),
            skin: DEFAULT_SKIN,
        }
    }
}

/// Whether a pass computes the interior while its ghost fields are in flight.
#[derive(Debug, Clone, Copy, Serialize, Deserialize, PartialEq, Eq, Default, clap::ValueEnum)]
#[serde(rename_all = "snake_case")]
pub enum Overlap {
    /// A pass that reads refreshed ghost fields sends them, computes the owned particles no
    /// ghost is a neighbour of, then receives the ghosts and computes the rest: each
    /// particle's sum is its own, in the same order, so the bits are those of `off`.
    On,
    /// Refresh first, then compute every particle: the default, because on this project's
    /// 2-core machine, with a rank per core, overlap made the step 2 % (local ranks) to 7 %
    /// (MPI) slower (docs/benchmark-log.md, "Refreshes overlapped with the interior"); it is for
    /// nodes where the exchange, not the compute, waits.
    #[default]
    Off,
}

impl Overlap {
    /// Scene-file name.
    pub fn name(self) -> &'static str {
        match self {
            Overlap::On => "on",
            Overlap::Off => "off",
        }
    }
}

/// How passes find neighbours.
#[derive(Debug, Clone, Copy, Serialize, Deserialize, PartialEq, Eq, Default, clap::ValueEnum)]
#[serde(rename_all = "snake_case")]
pub enum NeighbourMode {
    /// Lists built once per step and read by every pass (4 B per pair; pair mode's half lists
    /// about 1.1 B). Faster than `cells`; `verlet` builds far fewer lists on the DualSPHysics
    /// scenes, which ship it.
    #[default]
    Lists,
    /// No stored lists: every pass scans the stencil cells again, in the same order, so the
    /// bits are those of `lists` (the lean-memory mode).
    Cells,
    /// Verlet lists: built with the ghosts, to the support·(1 + `skin`), and kept until the
    /// ghosts are built again (some particle moved half the skin, wrapped or left, or the
    /// planes moved); each pass takes a listed pair only within the support of the current
    /// positions. Fewer builds, about (1 + skin)^D times the stored pairs. The same bits on
    /// any number of ranks and threads (builds are decided on all-reduced displacements), not
    /// `lists`' bits (another order of the sums, set by the positions at the build).
    Verlet,
}

impl NeighbourMode {
    /// Scene-file name.
    pub fn name(self) -> &'static str {
        match self {
            NeighbourMode::Lists => "lists",
            NeighbourMode::Cells => "cells",
            NeighbourMode::Verlet => "verlet",
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

/// Load balancing of the domain decomposition (`[balance]`, docs/methods.md §4).
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
    /// from the last neighbour search; the initial split, before any search, weighs each site
    /// by its expected neighbour count from its spacing, h and kind).
    #[serde(default)]
    pub load: LoadKind,
    /// Relative speed of each rank (empty: all equal); target loads are proportional.
    #[serde(default)]
    pub weights: Vec<f64>,
    /// With `load = "pairs"`: the most particles a rank may own over the mean (weighted) count,
    /// ≥ 1 — a memory bound, since a block of cheap particles (dummy walls) would otherwise
    /// own several times the mean (decomp::balance docs: count cap). 1 splits by counts.
    #[serde(default = "default_max_count")]
    pub max_count: f64,
}

impl Balance {
    /// The count cap of the decomposition: `max_count` when the loads are pairs, none when
    /// they are counts (the cap would be redundant).
    pub fn count_cap(&self) -> Option<f64> {
        (self.load == LoadKind::Pairs).then_some(self.max_count)
    }
}

/// Load measure of the domain decomposition.
#[derive(Debug, Clone, Copy, Serialize, Deserialize, PartialEq, Eq, Default)]
#[serde(rename_all = "snake_case")]
pub enum LoadKind {
    /// Every particle weighs 1.
    Particles,
    /// A particle weighs 1 + its neighbour count (the cost of its force loop): the default,
    /// since a wall particle costs a fraction of a fluid one (2 local ranks on the 3D bench:
    /// 0.9 × the step time of `particles`, docs/benchmark-log.md, "Pair loads by default").
    #[default]
    Pairs,
}

fn default_check_every() -> u64 {
    20
}
fn default_threshold() -> f64 {
    1.1
}
fn default_max_count() -> f64 {
    1.5
}

impl Default for Balance {
    fn default() -> Self {
        Balance {
            check_every: default_check_every(),
            threshold: default_threshold(),
            load: LoadKind::Pairs,
            weights: Vec::new(),
            max_count: default_max_count(),
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
    /// Fraction of the moving (fluid and solid) mass that may be removed before the run stops
    /// (exit 1).
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
    /// Iterations of the set-up relaxation (0, the default: none): before t = 0 the fluid
    /// particles move, at rest and walls fixed, until Σ_j V_j ∇W_ij vanishes, except those
    /// whose support the free surface cuts, which are held
    /// ([`crate::physics::shifting::Shifting::relaxation`]); for the interfaces of refinement
    /// regions, where the lattices of two sizes leave it non-zero.
    #[serde(default)]
    pub relax: u32,
    /// The smoothing length of a pair of particles of two sizes (`[[refine]]` regions with
    /// their level's h): `mean` (the default, (h_i + h_j)/2) or `max` (the larger, which keeps
    /// a coarse particle's support whole beside finer ones: walls finer than the fluid then
    /// hold it back as at one size, docs/pressure.md §2e). Read only where h varies.
    #[serde(default, skip_serializing_if = "crate::kernel::sizes::PairH::is_mean")]
    pub pair_h: crate::kernel::sizes::PairH,
}

impl Discretisation {
    /// The kernel support κh of the scene's spacing (m).
    pub fn support(&self) -> f64 {
        self.kernel.support_factor() * self.h_over_dx * self.dx
    }

    /// Neighbours of a particle in the bulk of a `d`-dimensional lattice of spacing dx: the
    /// sites in a disc (sphere) of the support radius, π r² (4/3 π r³) with r = support/dx
    /// (≈ 21 in 2D and 74 in 3D for Wendland C2 with h = 1.3 dx).
    pub fn lattice_neighbours(&self, d: usize) -> f64 {
        let r = self.h_over_dx * self.kernel.support_factor();
        if d == 2 {
            std::f64::consts::PI * r * r
        } else {
            4.0 / 3.0 * std::f64::consts::PI * r * r * r
        }
    }
}

fn default_h_over_dx() -> f64 {
    1.3
}
fn default_kernel() -> KernelKind {
    KernelKind::WendlandC2
}

pub use crate::material::EosKind;

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
    /// Fourtakas et al. (2019): Molteni's term on the density difference less its hydrostatic
    /// part, Δρ_ji − ρ̄ g·x_ji / c²(ρ̄) (no gradient pass; what DualSPHysics calls DDT2).
    Fourtakas,
    /// The density dissipation of the linearised Riemann solver's interface velocity (Zhang,
    /// Hu & Adams 2017, JCP 335:605): (1/(ρ0 c0)) Σ_j V_j (p_i − p_j) ∂W/∂r, here with the
    /// pressure difference less its hydrostatic part as in `fourtakas`. It is Fourtakas's term
    /// with δ replaced by r/(2h) in each pair, so δ is not read.
    Riemann,
    /// Test only (`crate::physics::fluid`): Molteni's pair term under a name of its own. It
    /// proves the density-term recipe of ARCHITECTURE.md: a term is this file and
    /// `physics/fluid.rs`.
    #[cfg(test)]
    Toy,
}

impl DensityDiffusion {
    /// True if the continuity equation carries a δ-SPH term (every variant but `none`).
    pub fn diffuses(self) -> bool {
        match self {
            DensityDiffusion::None => false,
            DensityDiffusion::Molteni
            | DensityDiffusion::Antuono
            | DensityDiffusion::Fourtakas
            | DensityDiffusion::Riemann => true,
            #[cfg(test)]
            DensityDiffusion::Toy => true,
        }
    }

    /// The factor of the pair term ψ_ij·∇_i W_ij V_j in dρ_i/dt (m²/s for the δ-SPH terms,
    /// δ h c0; m/s for `riemann`, c0/2, whose ψ carries the pair's distance), for the pair's
    /// smoothing length `h` (m) and i's sound speed `c0` (m/s).
    pub fn coefficient(self, delta: f64, h: f64, c0: f64) -> f64 {
        match self {
            DensityDiffusion::Riemann => 0.5 * c0,
            DensityDiffusion::None
            | DensityDiffusion::Molteni
            | DensityDiffusion::Antuono
            | DensityDiffusion::Fourtakas => delta * h * c0,
            #[cfg(test)]
            DensityDiffusion::Toy => delta * h * c0,
        }
    }

    /// True if the term reads the renormalised density gradient ⟨∇ρ⟩^L (Antuono's): its pass
    /// runs, particles carry the field, and `physics.density_gradient` may time it.
    pub fn needs_gradient(self) -> bool {
        match self {
            DensityDiffusion::Antuono => true,
            DensityDiffusion::None
            | DensityDiffusion::Molteni
            | DensityDiffusion::Fourtakas
            | DensityDiffusion::Riemann => false,
            #[cfg(test)]
            DensityDiffusion::Toy => false,
        }
    }
}

/// Physics switches: a scene switches on only what it needs.
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct Physics {
    /// `none`, `molteni`, `antuono` or `fourtakas`.
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
    /// Which state Antuono's renormalised density gradient is taken of: `step` (default, its
    /// own pass before continuity) or `lagged` (the previous step's momentum pass, computed
    /// in the same visit of each pair: [`DensityGradient`]).
    #[serde(default, skip_serializing_if = "DensityGradient::is_step")]
    pub density_gradient: DensityGradient,
    /// The fluid pressure term where a particle's support holds several smoothing lengths:
    /// `symmetric` (default, conservative) or `difference` (the renormalised difference form,
    /// exact for a linear pressure: [`PressureGradient`]).
    #[serde(default, skip_serializing_if = "PressureGradient::is_symmetric")]
    pub pressure_gradient: PressureGradient,
}

/// The fluid pressure term of a particle whose support holds particles of several smoothing
/// lengths (`physics.pressure_gradient`; docs/refinement.md §1). Elsewhere the term is always
/// the symmetric one.
#[derive(Debug, Clone, Copy, Serialize, Deserialize, PartialEq, Eq, Default)]
#[serde(rename_all = "snake_case")]
pub enum PressureGradient {
    /// −Σ_j m_j (p_i/ρ_i² + p_j/ρ_j²) ∇_i W_ij: antisymmetric in each pair, so linear momentum
    /// is conserved to round-off; its residual for a pressure p is −2 (p_i/ρ_i) Σ_j V_j ∇_i W_ij,
    /// which the mean-h kernel leaves non-zero where h varies.
    #[default]
    Symmetric,
    /// −(1/ρ_i) L_i Σ_j V_j (p_j − p_i) ∇_i W_ij with L_i the inverse of the first moment, for
    /// particles whose support holds several h, is full and holds no dummy wall particle
    /// (Bonet & Lok 1999; Oger et al. 2007): exact for a linear pressure, not conservative
    /// across those pairs; gather mode only.
    Difference,
    /// The symmetric form with the dissipative part of the linearised Riemann solver's
    /// interface pressure, P* = (p_i + p_j)/2 + ½ ρ̄ β ΔU, ΔU = −v_ij·x_ij/r the pair's
    /// approach speed (m/s), and the low-dissipation limiter β = min(3 max(ΔU, 0), c̄)
    /// (Zhang, Hu & Adams 2017, JCP 335:605): −Σ_j m_j ρ̄ β ΔU/(ρ_i ρ_j) ∇_i W_ij is added,
    /// antisymmetric in each pair, so momentum stays conserved to round-off. It acts on
    /// approaching pairs only, quadratically in ΔU up to c̄/3, as an acoustic impedance ρ̄ c̄ ΔU
    /// beyond.
    Riemann,
}

impl PressureGradient {
    /// True for `symmetric` (left out of a written scene).
    pub fn is_symmetric(&self) -> bool {
        match self {
            PressureGradient::Symmetric => true,
            PressureGradient::Difference | PressureGradient::Riemann => false,
        }
    }

    /// True for the renormalised difference form, which needs a particle's whole support at
    /// once (gather mode) and applies only where h varies.
    pub fn is_difference(&self) -> bool {
        match self {
            PressureGradient::Difference => true,
            PressureGradient::Symmetric | PressureGradient::Riemann => false,
        }
    }

    /// True if the pair's approach is damped by the Riemann solver's dissipative pressure.
    pub fn riemann_dissipation(&self) -> bool {
        match self {
            PressureGradient::Riemann => true,
            PressureGradient::Symmetric | PressureGradient::Difference => false,
        }
    }
}

/// When Antuono's renormalised density gradient ⟨∇ρ⟩^L is computed
/// (`physics.density_gradient`).
#[derive(Debug, Clone, Copy, Serialize, Deserialize, PartialEq, Eq, Default)]
#[serde(rename_all = "snake_case")]
pub enum DensityGradient {
    /// In its own pass at the start of each step's passes, of the drifted positions x^{n+1}
    /// and the densities ρ^n that continuity reads.
    #[default]
    Step,
    /// With the momentum pass, of x^n and ρ^n, and read by the next step's continuity: the
    /// same densities, positions one drift older (|Δx| = dt |v|, a fraction CFL·Ma of h). In
    /// pair mode one visit of each pair serves both, which saves a pass over the lists; the
    /// gradient is then part of the state (checkpoints carry it).
    Lagged,
}

impl DensityGradient {
    /// True for `step` (left out of a written scene).
    pub fn is_step(&self) -> bool {
        *self == DensityGradient::Step
    }
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
            density_gradient: DensityGradient::Step,
            pressure_gradient: PressureGradient::Symmetric,
        }
    }
}

shape::shaped_table! {
/// A block of fluid filled on the lattice: every lattice site with its centre in [min, max).
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct FluidBody {
    /// Name (used in `final.csv` as the body index order), unique among all bodies (fluids,
    /// solids, walls).
    pub name: String,
    /// Material name.
    pub material: String,
    ..shape_keys,
    /// Initial velocity (m/s); default zero.
    #[serde(default)]
    pub velocity: Vec<f64>,
    /// Start from the hydrostatic density profile under the body force (free surface at the
    /// top of the block along the body force, under the weight of any fluid body that rests on
    /// it there, directly or through others), instead of ρ0 everywhere.
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
}

impl FluidBody {
    /// The stretch `(s0, s1)`, 0 ≤ s0 < s1 (m), of the ray x + s·u (s ≥ 0, u a unit vector)
    /// that lies inside the body (its box and its shape), if any: the column of this body
    /// above a site along u = −ĝ (the overburden of a hydrostatic body below it).
    pub fn chord(&self, x: &[f64], u: &[f64]) -> Option<(f64, f64)> {
        let (mut s0, mut s1) = (0.0f64, f64::INFINITY);
        for a in 0..x.len() {
            if u[a] == 0.0 {
                if x[a] < self.min[a] || x[a] >= self.max[a] {
                    return None;
                }
            } else {
                let (t0, t1) = ((self.min[a] - x[a]) / u[a], (self.max[a] - x[a]) / u[a]);
                s0 = s0.max(t0.min(t1));
                s1 = s1.min(t0.max(t1));
            }
        }
        // the shape: where |d + s u_⊥|² < r², d the offset from the centre (across the
        // cylinder's axis only)
        let across = |a: usize| match self.shape {
            BodyShape::Cylinder => a != self.axis.unwrap_or(2),
            _ => true,
        };
        let outlined = match (self.shape, &self.mesh) {
            (BodyShape::Polygon, _) => Some(polygon::chord(&self.vertices, x, u)),
            (BodyShape::Mesh, Some(m)) => Some(m.chord(x, u)),
            _ => None,
        };
        if let Some(c) = outlined {
            return c
                .map(|(p0, p1)| (p0.max(s0), p1.min(s1)))
                .filter(|(p0, p1)| p1 > p0);
        }
        if self.shape != BodyShape::Block {
            let (mut qa, mut qb, mut qc) = (0.0, 0.0, -self.radius * self.radius);
            for a in (0..x.len()).filter(|&a| across(a)) {
                let d = x[a] - self.centre[a];
                qa += u[a] * u[a];
                qb += 2.0 * d * u[a];
                qc += d * d;
            }
            if qa == 0.0 {
                if qc >= 0.0 {
                    return None;
                }
            } else {
                let disc = qb * qb - 4.0 * qa * qc;
                if disc <= 0.0 {
                    return None;
                }
                let r = disc.sqrt();
                s0 = s0.max((-qb - r) / (2.0 * qa));
                s1 = s1.min((-qb + r) / (2.0 * qa));
            }
        }
        (s1 > s0).then_some((s0, s1))
    }

    /// True if the lattice site at `x` (inside [min, max)) belongs to the body.
    #[inline]
    pub fn contains(&self, x: &[f64]) -> bool {
        self.keys().contains(x)
    }
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
    /// Settling before t = 0 (s of simulated time; 0, the default, settles nothing): the scene
    /// runs this long with every velocity damped each step by exp(−dt/τ), τ = settle/8, then
    /// the velocities are zeroed and the clock starts at t = 0 from the settled positions and
    /// densities ([`crate::sim::Simulation`]'s set-up). Still water then starts in the
    /// equilibrium of its own discretisation, without the acoustic transient of a lattice
    /// set-up (docs/refinement.md §2). For scenes at rest: refused with initial velocities,
    /// wall velocities or wall motion.
    #[serde(default)]
    pub settle: f64,
    /// `global` (the default): every particle takes the step of the smallest. `local`: where
    /// particles of several smoothing lengths meet (`[[refine]] smoothing_length = "level"`),
    /// the fluid particles of the scene's h take one step of 2δ while the smaller ones take two
    /// of δ ([`crate::sim::multirate`], docs/splitting.md §8).
    #[serde(default, skip_serializing_if = "Stepping::is_global")]
    pub stepping: Stepping,
}

impl Time {
    /// True once a run at `step` steps and time `t` (s) has reached the end: `t_end` (to a
    /// relative 1e-12) or `max_steps` (when set).
    pub fn ended(&self, step: u64, t: f64) -> bool {
        t >= self.t_end * (1.0 - 1e-12) || (self.max_steps > 0 && step >= self.max_steps)
    }
}

/// How the particles of a scene share the time step (`time.stepping`).
#[derive(Debug, Clone, Copy, Serialize, Deserialize, PartialEq, Eq, Default)]
#[serde(rename_all = "snake_case")]
pub enum Stepping {
    /// Every particle takes the step of the smallest.
    #[default]
    Global,
    /// Fluid particles of the scene's h take twice the step of the smaller ones when their own
    /// CFL bound allows it.
    Local,
}

impl Stepping {
    /// True for [`Stepping::Global`].
    pub fn is_global(&self) -> bool {
        *self == Stepping::Global
    }
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
    /// Times (s) at which the run writes the whole state as a flow frame
    /// (`frames/frame_NN.csv`, as `final.csv`; `hsph report` draws each coloured by pressure):
    /// the first step at or past each. Left out: ¼, ½ and ¾ of `time.t_end` for a scene with
    /// fluid, none otherwise; `[]` writes none.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub frames: Option<Vec<f64>>,
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
            frames: None,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::FluidBody;

    fn body(text: &str) -> FluidBody {
        toml::from_str(&format!("name = \"b\"\nmaterial = \"m\"\n{text}")).unwrap()
    }

    /// The column of a body above a point: a block's slab, a disc's chord, a cylinder's
    /// across its axis and along it, nothing beside a body or below the ray's start.
    #[test]
    fn a_body_s_column_above_a_point_is_its_chord() {
        let close = |a: Option<(f64, f64)>, b: (f64, f64)| {
            let a = a.expect("a chord");
            assert!(
                (a.0 - b.0).abs() < 1e-12 && (a.1 - b.1).abs() < 1e-12,
                "{a:?} against {b:?}"
            );
        };
        let up2 = [0.0, 1.0];
        let block = body("min = [0.0, 1.0]\nmax = [2.0, 3.0]");
        close(block.chord(&[0.5, 0.0], &up2), (1.0, 3.0));
        close(block.chord(&[0.5, 2.0], &up2), (0.0, 1.0));
        assert_eq!(block.chord(&[2.5, 0.0], &up2), None);
        assert_eq!(block.chord(&[0.5, 3.5], &up2), None);
        // a slanted ray: x + s (0.6, 0.8) enters at y = 1 (s = 1.25), leaves at x = 2 (s = 10/3)
        close(block.chord(&[0.0, 0.0], &[0.6, 0.8]), (1.25, 2.0 / 0.6));
        let disc = body(
            "shape = \"sphere\"\ncentre = [0.0, 2.0]\nradius = 1.0\nmin = [-1.0, 1.0]\nmax = [1.0, 3.0]",
        );
        close(disc.chord(&[0.0, 0.0], &up2), (1.0, 3.0));
        let h = (1.0f64 - 0.36).sqrt();
        close(disc.chord(&[0.6, 0.0], &up2), (2.0 - h, 2.0 + h));
        assert_eq!(disc.chord(&[1.2, 0.0], &up2), None);
        let cyl = body(
            "shape = \"cylinder\"\ncentre = [0.0, 0.0, 2.0]\nradius = 1.0\naxis = 0\nlength = 4.0\nmin = [-2.0, -1.0, 1.0]\nmax = [2.0, 1.0, 3.0]",
        );
        let up3 = [0.0, 0.0, 1.0];
        close(cyl.chord(&[1.5, 0.6, 0.0], &up3), (2.0 - 0.8, 2.0 + 0.8));
        assert_eq!(cyl.chord(&[2.5, 0.0, 0.0], &up3), None);
    }
}

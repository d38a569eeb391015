//! Particle storage: one structure of arrays, owned particles first, then ghosts, generated
//! from the field table below.
//!
//! Indices `[0, n_owned)` are the particles this rank integrates; `[n_owned, len)` are ghosts:
//! copies of owned particles under an image operation (periodic shift or mirror reflection)
//! and copies from other ranks. A ghost is identified by its source id and image code
//! (`key`), never by its local index, so sums in a fixed key order reproduce across layouts.
//!
//! **Adding a field** is one entry in the table: its type (any [`FieldValue`]: `u64`, `u16`,
//! [`Kind`], `f64`, [`crate::Vector`]), its rule under image operations, its `final.csv`
//! column stem and snapshot name (or `None`), its unit and long name. Storage, push, permute,
//! the wire record of halos and migration, refresh flags, byte counts and output follow.
//! Owned-only fields (rates) are listed under `owned` and never travel.

mod table;
pub mod value;
pub mod wire;

use crate::error::Result;
use table::particle_table;
pub use value::{Column, FieldValue, ImageRule, Imager, Sym};
use wire::{Count, Reader, Sink};

use crate::Vector;

/// What a particle is: its role in the step (see the `is_*` queries, which the step loop and
/// the passes ask instead of comparing kinds).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[repr(u8)]
pub enum Kind {
    /// Weakly compressible fluid.
    Fluid = 0,
    /// Fixed dummy wall particle with extrapolated pressure and velocity (Adami et al. 2012).
    Dummy = 1,
    /// Monaghan repulsive wall particle.
    Repulsive = 2,
    /// Elastic–plastic solid (stress tensor, internal energy, plastic strain).
    Solid = 3,
    /// A solid particle held in place (a clamp): its stress evolves with its neighbours'
    /// motion, but it is not moved.
    Clamped = 4,
}

/// A set of particle classes — fluid, and every other kind — that a pass writes and a ghost
/// refresh can be limited to (a refresh of the fields only fluid particles changed need not
/// travel for walls).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Kinds(u8);

impl Kinds {
    /// No particle.
    pub const NONE: Kinds = Kinds(0);
    /// Fluid particles.
    pub const FLUID: Kinds = Kinds(1);
    /// Every other kind: walls and solids.
    pub const OTHER: Kinds = Kinds(2);
    /// Every particle.
    pub const ALL: Kinds = Kinds(3);
    /// The two classes, each on its own.
    pub const CLASSES: [Kinds; 2] = [Kinds::FLUID, Kinds::OTHER];

    /// True if the set holds particles of `kind`.
    #[inline]
    pub fn has(self, kind: Kind) -> bool {
        self.0 & kind.class().0 != 0
    }

    /// True if the set holds every particle of class `c`.
    #[inline]
    pub fn covers(self, c: Kinds) -> bool {
        self.0 & c.0 == c.0
    }

    /// The union.
    #[inline]
    pub fn or(self, o: Kinds) -> Kinds {
        Kinds(self.0 | o.0)
    }
}

impl Kind {
    /// Integer code written to output files.
    pub fn code(self) -> u8 {
        self as u8
    }

    /// The kind with code `c`.
    pub fn from_code(c: u8) -> Option<Kind> {
        match c {
            0 => Some(Kind::Fluid),
            1 => Some(Kind::Dummy),
            2 => Some(Kind::Repulsive),
            3 => Some(Kind::Solid),
            4 => Some(Kind::Clamped),
            _ => None,
        }
    }

    /// Integrated by the equations of motion (kick, drift, continuity); walls are not.
    #[inline]
    pub fn is_integrated(self) -> bool {
        matches!(self, Kind::Fluid | Kind::Solid)
    }

    /// A fluid particle.
    #[inline]
    pub fn is_fluid(self) -> bool {
        self == Kind::Fluid
    }

    /// Its class for ghost refreshes: [`Kinds::FLUID`] or [`Kinds::OTHER`].
    #[inline]
    pub fn class(self) -> Kinds {
        if self.is_fluid() {
            Kinds::FLUID
        } else {
            Kinds::OTHER
        }
    }

    /// A wall particle of a fluid (moved only by its wall's motion law).
    #[inline]
    pub fn is_wall(self) -> bool {
        matches!(self, Kind::Dummy | Kind::Repulsive)
    }

    /// A solid particle (free or clamped): carries a stress and runs the solid passes.
    #[inline]
    pub fn is_solid(self) -> bool {
        matches!(self, Kind::Solid | Kind::Clamped)
    }

    /// Enters the SPH sums of its neighbours (kernel-weighted); repulsive particles exert a
    /// pair force only and need no neighbour list of their own.
    #[inline]
    pub fn is_smoothed(self) -> bool {
        self != Kind::Repulsive
    }

    /// Name used in reports.
    pub fn name(self) -> &'static str {
        match self {
            Kind::Fluid => "fluid",
            Kind::Dummy => "dummy wall",
            Kind::Repulsive => "repulsive wall",
            Kind::Solid => "solid",
            Kind::Clamped => "clamped solid",
        }
    }
}

/// Bits of the image code in a particle's sort key (`id << IMAGE_BITS | image`).
pub const IMAGE_BITS: u32 = 10;

/// A set of shared particle fields (a bit set): what a pass reads from ghosts, what a refresh
/// sends. The flags are generated from the field table (`Fields::RHO`, `Fields::P`, ...).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct Fields(u64);

impl Fields {
    /// The empty set.
    pub const NONE: Fields = Fields(0);

    /// Every field (of any table: the flags no field has are ignored).
    pub const ALL: Fields = Fields(u64::MAX);

    /// Union of two sets.
    pub const fn or(self, o: Fields) -> Fields {
        Fields(self.0 | o.0)
    }

    /// Intersection of two sets.
    pub const fn and(self, o: Fields) -> Fields {
        Fields(self.0 & o.0)
    }

    /// This set without the fields of `o`.
    pub const fn without(self, o: Fields) -> Fields {
        Fields(self.0 & !o.0)
    }

    /// True if the two sets share a field.
    pub const fn has(self, o: Fields) -> bool {
        self.0 & o.0 != 0
    }

    /// True if the set is empty.
    pub const fn is_empty(self) -> bool {
        self.0 == 0
    }

    /// Table names of the fields in the set, in table order.
    pub fn names<const D: usize>(self) -> Vec<&'static str> {
        Particles::<D>::field_table()
            .into_iter()
            .filter(|m| self.has(m.flag))
            .map(|m| m.name)
            .collect()
    }
}

/// What the table says of one shared field.
#[derive(Debug, Clone, Copy)]
pub struct FieldMeta {
    /// Name in the table (and of the store's member).
    pub name: &'static str,
    /// Its flag.
    pub flag: Fields,
    /// Column stem in `final.csv` (vectors add the axis name), if written there.
    pub csv: Option<&'static str>,
    /// Name in snapshots (`output.fields`), if it can be written there.
    pub snapshot: Option<&'static str>,
    /// SI unit (UDUNITS spelling).
    pub unit: &'static str,
    /// Long name (CF `long_name`).
    pub long_name: &'static str,
}

particle_table! {
    shared {
        /// Global lattice id (unique, fixed for the run).
        id / ID: u64 {
            image: Same, csv: Some("id"), snapshot: None, unit: "1", long_name: "particle id",
        }
        /// Sort key: `id << IMAGE_BITS | image code` (the image code is 0 for an owned
        /// particle).
        key / KEY: u64 {
            image: Key, csv: None, snapshot: None, unit: "1", long_name: "ghost sort key",
        }
        /// Particle kind.
        kind / KIND: Kind {
            image: Same, csv: Some("kind"), snapshot: Some("kind"), unit: "1",
            long_name: "particle kind (0 fluid, 1 dummy wall, 2 repulsive wall, 3 solid, 4 clamped solid)",
        }
        /// Body index: into the scene's fluids for fluid particles, walls for wall particles.
        body / BODY: u16 {
            image: Same, csv: Some("body"), snapshot: Some("body"), unit: "1", long_name: "body index",
        }
        /// Material index into the scene's materials.
        mat / MAT: u16 {
            image: Same, csv: None, snapshot: None, unit: "1", long_name: "material index",
        }
        /// Refinement level ℓ (`[[refine]]`): spacing dx / 2^ℓ, smoothing length
        /// (h/dx)·dx / 2^ℓ, mass ρ (dx / 2^ℓ)^D at set-up; held only by refined scenes (every
        /// particle of another scene is of level 0).
        level / LEVEL: u16 {
            image: Same, csv: Some("level"), snapshot: Some("level"), unit: "1",
            long_name: "refinement level (spacing dx/2^level)",
        }
        /// Position x (m).
        x / X: Vector<D> {
            image: Position, csv: Some(""), snapshot: None, unit: "m", long_name: "position",
        }
        /// Velocity v (m/s). For wall particles: the wall's prescribed velocity.
        v / V: Vector<D> {
            image: Velocity, csv: Some("v"), snapshot: Some("velocity"), unit: "m s-1",
            long_name: "velocity",
        }
        /// Mass m (kg; kg/m in 2D).
        mass / MASS: f64 {
            image: Same, csv: Some("mass"), snapshot: Some("mass"), unit: "kg", long_name: "mass",
        }
        /// Smoothing length h_i (m) of a refined scene's particle (`[[refine]]`): its level's
        /// in the core of a region, rising to the scene's over the region's transition band;
        /// held only by refined scenes (elsewhere every particle has the scene's h).
        h / H: f64 {
            image: Same, csv: Some("h"), snapshot: Some("smoothing_length"), unit: "m",
            long_name: "smoothing length",
        }
        /// Density ρ (kg/m³). For dummy walls: from the extrapolated pressure.
        rho / RHO: f64 {
            image: Same, csv: Some("rho"), snapshot: Some("density"), unit: "kg m-3",
            long_name: "density",
        }
        /// Pressure p (Pa). For dummy walls: extrapolated (Adami et al. 2012, eq. 27).
        p / P: f64 {
            image: Same, csv: Some("p"), snapshot: Some("pressure"), unit: "Pa",
            long_name: "pressure",
        }
        /// Velocity a dummy wall shows the fluid in viscous terms (m/s); unused for fluid.
        vw / VW: Vector<D> {
            image: Velocity, csv: None, snapshot: None, unit: "m s-1",
            long_name: "extrapolated wall velocity",
        }
        /// Renormalised density gradient ⟨∇ρ⟩^L (kg/m⁴); filled only with Antuono's δ-SPH.
        grad_rho / GRAD_RHO: Vector<D> {
            image: Vector, csv: None, snapshot: None, unit: "kg m-4",
            long_name: "renormalised density gradient",
        }
        /// Lattice moment L_i = −(1/D) Σ_j V_j r_ij W′(r_ij) of fluid particles (–; 1 for a full
        /// continuous support), which the renormalised viscous operator divides by; held only
        /// with `physics.viscous_operator = "renormalised"`.
        lap / LAP: f64 {
            image: Same, csv: None, snapshot: None, unit: "1",
            long_name: "lattice moment of the viscous operator",
        }
        /// Deviatoric stress S (Pa) of solid particles (symmetric; in 2D the in-plane block of
        /// a plane-strain deviator, S_zz = −S_xx − S_yy).
        stress / STRESS: Sym<D> {
            image: Tensor, csv: Some("s"), snapshot: Some("stress"), unit: "Pa",
            long_name: "deviatoric stress",
        }
        /// Kernel-gradient correction B = M⁻¹ of solid particles, M = −(1/ρ) Σ_j m_j x_ij ⊗
        /// ∇W_ij (symmetric; I in the bulk of a lattice), so corrected gradients are exact for
        /// linear fields up to free surfaces (–).
        correction / CORRECTION: Sym<D> {
            image: Tensor, csv: None, snapshot: None, unit: "1",
            long_name: "kernel gradient correction",
        }
        /// Specific internal energy e of solid particles (J/kg), from the state at rest.
        energy / ENERGY: f64 {
            image: Same, csv: Some("e"), snapshot: Some("energy"), unit: "J kg-1",
            long_name: "specific internal energy",
        }
        /// Equivalent plastic strain ε_p of solid particles (–).
        plastic / PLASTIC: f64 {
            image: Same, csv: Some("eps_p"), snapshot: Some("plastic_strain"), unit: "1",
            long_name: "equivalent plastic strain",
        }
        /// 1 once a solid particle has failed (no tension, no shear from then on), else 0.
        failed / FAILED: u16 {
            image: Same, csv: Some("failed"), snapshot: Some("failed"), unit: "1",
            long_name: "failed (1) or intact (0)",
        }
        /// A field that exists only in unit tests: proves that one table entry is enough for a
        /// field to travel through halos and migration and reach `final.csv` and snapshots.
        [cfg(test)]
        tag / TAG: f64 {
            image: Same, csv: Some("tag"), snapshot: Some("tag"), unit: "1", long_name: "test tag",
        }
    }
    owned {
        /// dρ/dt of owned particles (kg/m³/s).
        drho: f64;
        /// dv/dt of owned particles (m/s²).
        acc: Vector<D>;
    }
}

impl Fields {
    /// The fields only solid particles use: a run without solids drops them (no storage, no
    /// traffic).
    pub const SOLID: Fields = Fields::STRESS
        .or(Fields::CORRECTION)
        .or(Fields::ENERGY)
        .or(Fields::PLASTIC)
        .or(Fields::FAILED);

    /// What a ghost is and where, which code outside the passes reads (the cell list, the
    /// neighbour lists, image operations, the pair kernel of particles of several sizes): id,
    /// sort key, kind, body, material, level, position, mass and h. Every ghost build sends
    /// these.
    pub const IDENTITY: Fields = Fields::ID
        .or(Fields::KEY)
        .or(Fields::KIND)
        .or(Fields::BODY)
        .or(Fields::MAT)
        .or(Fields::LEVEL)
        .or(Fields::X)
        .or(Fields::MASS)
        .or(Fields::H);

    /// The part of [`Fields::IDENTITY`] no step changes (all but the position): a ghost kept
    /// between builds keeps these and is refreshed with the rest of what a build sends.
    pub const CONSTANT: Fields = Fields::IDENTITY.without(Fields::X);
}

impl<const D: usize> Particles<D> {
    /// An empty store that holds every shared field except `dropped`.
    pub fn without(dropped: Fields) -> Self {
        Particles {
            dropped,
            ..Particles::default()
        }
    }

    /// An empty store for a gathered view (output, probes) that holds every shared field
    /// except `dropped` and no rates: a view is read, never stepped.
    pub fn for_view(dropped: Fields) -> Self {
        Particles {
            dropped,
            view_only: true,
            ..Particles::default()
        }
    }

    /// The same owned particles in a store that drops `dropped` (no ghosts may exist): a
    /// checkpoint's store holds every field; a fluid-only run keeps none of the solid ones.
    pub fn dropping(self, dropped: Fields) -> Self {
        if self.dropped == dropped {
            return self;
        }
        let mut q = Particles::without(dropped);
        for i in 0..self.n_owned {
            q.push_owned(self.record(i));
        }
        q
    }

    /// Total number of particles, owned and ghost.
    pub fn len(&self) -> usize {
        self.id.len()
    }

    /// True if there are no particles.
    pub fn is_empty(&self) -> bool {
        self.id.is_empty()
    }

    /// Append an owned particle (before any ghost exists); its key is set from its id and its
    /// rates start at zero (a view's store holds none).
    pub fn push_owned(&mut self, mut r: Record<D>) {
        debug_assert_eq!(self.n_owned, self.len(), "owned particles go before ghosts");
        r.key = r.id << IMAGE_BITS;
        self.push_shared(&r);
        self.push_rates();
        self.n_owned += 1;
    }

    /// Append a ghost (another rank's particle or an image), every shared field given.
    pub fn push_ghost(&mut self, r: &Record<D>) {
        self.push_shared(r);
    }

    /// Snapshot field names this build can write (`output.fields`).
    pub fn snapshot_names() -> Vec<&'static str> {
        Self::field_table().iter().filter_map(|m| m.snapshot).collect()
    }
}

impl<const D: usize> Record<D> {
    /// A new particle at rest in the lattice: id, kind, body, material, position, velocity,
    /// mass and density; the wall velocity starts at `v`, everything else at zero.
    #[allow(clippy::too_many_arguments)]
    pub fn new(
        id: u64,
        kind: Kind,
        body: u16,
        mat: u16,
        x: Vector<D>,
        v: Vector<D>,
        mass: f64,
        rho: f64,
    ) -> Self {
        Record {
            id,
            key: id << IMAGE_BITS,
            kind,
            body,
            mat,
            x,
            v,
            mass,
            rho,
            vw: v,
            ..Record::default()
        }
    }
}

#[cfg(test)]
mod tests;

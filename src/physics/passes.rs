//! The passes of one step as data: what each reads from ghosts and what it writes, and the
//! order a scene runs them in. The step loop (`sim`) refreshes before each pass exactly the
//! ghost fields the pass reads that an earlier pass has written since the last exchange, and
//! `hsph plan` walks the same schedule to count the step's exchanges, so the two cannot drift
//! apart.

use super::Model;
use crate::particles::Fields;
use crate::scene::DensityDiffusion;

/// One pass of the step after the ghosts and neighbour lists are built.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Pass {
    /// ⟨∇ρ⟩^L of fluid particles (Antuono's δ-SPH): [`super::delta::renormalised_gradient`].
    DensityGradient,
    /// dρ/dt of fluid particles: [`super::fluid::continuity`].
    Continuity,
    /// Lattice moment L of fluid particles for the renormalised viscous operator:
    /// [`super::viscous::lattice_moment`].
    ViscousMoment,
    /// ρ += dt dρ/dt, then p = EOS(ρ, e) (no neighbours).
    DensityUpdate,
    /// p, ρ and v_w of dummy wall particles: [`crate::boundary::dummy::extrapolate`].
    WallExtrapolation,
    /// dv/dt of fluid particles: [`super::fluid::momentum`].
    Momentum,
    /// Kernel-gradient correction B of solid particles: [`super::solid::dynamics::correction`].
    SolidCorrection,
    /// dρ/dt, dS/dt, de/dt of solid particles: [`super::solid::dynamics::rates`].
    SolidRates,
    /// ρ, e, S (with radial return), p and failure of solid particles (no neighbours):
    /// [`super::solid::dynamics::update`].
    SolidUpdate,
    /// dv/dt of solid particles: [`super::solid::dynamics::momentum`].
    SolidMomentum,
    /// The closing half kick v += ½dt a of integrated particles (no neighbours).
    Kick,
    /// Particle shifting of fluid particles with their fields: [`super::shifting`].
    Shift,
}

impl Pass {
    /// Shared fields of neighbours (ghosts included) the pass reads.
    pub fn reads(self) -> Fields {
        let geometry = Fields::X.or(Fields::KIND).or(Fields::MASS);
        match self {
            Pass::DensityGradient => geometry.or(Fields::RHO),
            Pass::Continuity => geometry
                .or(Fields::V)
                .or(Fields::RHO)
                .or(Fields::GRAD_RHO)
                .or(Fields::MAT),
            Pass::ViscousMoment => geometry.or(Fields::RHO),
            Pass::DensityUpdate => Fields::NONE,
            Pass::WallExtrapolation => geometry.or(Fields::V).or(Fields::RHO).or(Fields::P),
            Pass::Momentum => geometry
                .or(Fields::V)
                .or(Fields::RHO)
                .or(Fields::P)
                .or(Fields::VW)
                .or(Fields::LAP)
                .or(Fields::MAT),
            Pass::SolidCorrection => geometry.or(Fields::RHO),
            // the sound speed of the viscosity comes from (ρ, e)
            // σ of neighbours for the artificial stress's work
            Pass::SolidRates => geometry
                .or(Fields::V)
                .or(Fields::RHO)
                .or(Fields::P)
                .or(Fields::STRESS)
                .or(Fields::ENERGY)
                .or(Fields::MAT),
            Pass::SolidUpdate => Fields::NONE,
            Pass::SolidMomentum => geometry
                .or(Fields::V)
                .or(Fields::RHO)
                .or(Fields::P)
                .or(Fields::STRESS)
                .or(Fields::CORRECTION)
                .or(Fields::ENERGY)
                .or(Fields::MAT),
            Pass::Kick => Fields::NONE,
            Pass::Shift => geometry.or(Fields::V).or(Fields::RHO),
        }
    }

    /// Shared fields the pass writes on owned particles (stale on ghosts afterwards).
    pub fn writes(self) -> Fields {
        match self {
            Pass::DensityGradient => Fields::GRAD_RHO,
            Pass::ViscousMoment => Fields::LAP,
            Pass::Continuity | Pass::Momentum | Pass::SolidRates | Pass::SolidMomentum => Fields::NONE,
            Pass::SolidCorrection => Fields::CORRECTION,
            Pass::SolidUpdate => Fields::RHO
                .or(Fields::P)
                .or(Fields::STRESS)
                .or(Fields::ENERGY)
                .or(Fields::PLASTIC)
                .or(Fields::FAILED),
            Pass::DensityUpdate => Fields::RHO.or(Fields::P),
            Pass::WallExtrapolation => Fields::P.or(Fields::RHO).or(Fields::VW),
            Pass::Kick => Fields::V,
            Pass::Shift => Fields::X.or(Fields::V).or(Fields::RHO).or(Fields::P),
        }
    }

    /// True if the pass walks the neighbour lists (counted as pair interactions).
    pub fn pairs(self) -> bool {
        !matches!(self, Pass::DensityUpdate | Pass::SolidUpdate | Pass::Kick)
    }

    /// Name in logs and in `hsph plan`'s exchange list.
    pub fn name(self) -> &'static str {
        match self {
            Pass::DensityGradient => "density_gradient",
            Pass::Continuity => "continuity",
            Pass::ViscousMoment => "viscous_moment",
            Pass::DensityUpdate => "density_update",
            Pass::WallExtrapolation => "wall_extrapolation",
            Pass::Momentum => "momentum",
            Pass::SolidCorrection => "solid_correction",
            Pass::SolidRates => "solid_rates",
            Pass::SolidUpdate => "solid_update",
            Pass::SolidMomentum => "solid_momentum",
            Pass::Kick => "kick",
            Pass::Shift => "shift",
        }
    }
}

/// The passes a model runs, in order (Störmer–Verlet with (x, ρ) as coordinates: continuity
/// and the density update come before the forces; see `Simulation::advance`).
/// A scene without fluid runs no fluid pass, one without solids no solid pass.
pub fn schedule<const D: usize>(model: &Model<D>) -> Vec<Pass> {
    let mut s = Vec::with_capacity(12);
    let (fluid, solid) = (model.has_fluid, model.has_solid);
    if fluid && model.diffusion == DensityDiffusion::Antuono {
        s.push(Pass::DensityGradient);
    }
    if fluid {
        s.push(Pass::Continuity);
    }
    if fluid && model.nu > 0.0 && model.viscous.renormalised {
        // reads what continuity read: no exchange of its own
        s.push(Pass::ViscousMoment);
    }
    if solid {
        s.push(Pass::SolidCorrection);
        s.push(Pass::SolidRates);
    }
    if fluid {
        s.push(Pass::DensityUpdate);
    }
    if solid {
        s.push(Pass::SolidUpdate);
    }
    if fluid && model.has_dummy {
        s.push(Pass::WallExtrapolation);
    }
    if fluid {
        s.push(Pass::Momentum);
    }
    if solid {
        s.push(Pass::SolidMomentum);
    }
    s.push(Pass::Kick);
    if fluid && model.shifting.is_some() {
        s.push(Pass::Shift);
    }
    s
}

/// Which ghost fields are out of date: every field is fresh after a ghost build; a pass makes
/// what it writes stale; a refresh makes fresh what it sends.
#[derive(Debug, Clone, Copy, Default)]
pub struct Freshness {
    stale: Fields,
}

impl Freshness {
    /// Every ghost field was just sent whole.
    pub fn built(&mut self) {
        self.stale = Fields::NONE;
    }

    /// The fields `pass` needs refreshed before it runs (possibly none); they count as fresh
    /// from now on.
    pub fn before(&mut self, pass: Pass) -> Fields {
        let need = pass.reads().and(self.stale);
        self.stale = self.stale.without(need);
        need
    }

    /// `pass` ran: what it wrote is stale on ghosts.
    pub fn after(&mut self, pass: Pass) {
        self.stale = self.stale.or(pass.writes());
    }
}

/// The ghost exchanges of one step: the whole-record build, then one refresh per pass that
/// needs one, with the fields each sends (`hsph plan` counts these).
pub fn exchanges(schedule: &[Pass]) -> Vec<(&'static str, Option<Fields>)> {
    let mut out = vec![("build", None)];
    let mut f = Freshness::default();
    f.built();
    for &pass in schedule {
        let need = f.before(pass);
        if !need.is_empty() {
            out.push((pass.name(), Some(need)));
        }
        f.after(pass);
    }
    out
}

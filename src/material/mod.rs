//! Material models as typed configurations: what a particle's material answers to the step —
//! its pressure from density and specific internal energy, its sound speed, its reference
//! density — with each model's constants in its own file. The step asks the model, never the
//! scene; the scene builds a model from its keys (`scene::Material::model`).
//!
//! - [`fluid`]: weakly compressible fluids, Tait or linear EOS (`docs/methods.md` §2).
//! - [`solid`]: elastic–plastic solids: [`mie_gruneisen`] EOS, shear modulus, [`strength`]
//!   (Johnson–Cook, radial return, failure).
//! - [`library`]: the material constants hsph ships, each with its source.
//!
//! Adding an equation of state: its constants and p(ρ, e) in a file here, a variant of
//! [`MaterialModel`] (or of [`fluid::EosKind`]) answering through the same methods, and the
//! scene keys that build it in `scene/models.rs`.

pub mod fluid;
pub mod library;
pub mod mie_gruneisen;
pub mod solid;
pub mod strength;

pub use fluid::{Eos, EosKind};
pub use solid::SolidModel;

/// The model of one material of the scene.
#[derive(Debug, Clone, Copy)]
pub enum MaterialModel {
    /// A weakly compressible fluid with a barotropic EOS.
    Fluid(Eos),
    /// An elastic–plastic solid (Mie–Grüneisen, shear modulus, Johnson–Cook, failure).
    Solid(SolidModel),
}

impl MaterialModel {
    /// The solid model, if this is a solid.
    #[inline]
    pub fn solid(&self) -> Option<&SolidModel> {
        match self {
            MaterialModel::Solid(s) => Some(s),
            MaterialModel::Fluid(_) => None,
        }
    }

    /// Pressure p(ρ, e) (Pa) from density ρ (kg/m³) and specific internal energy e (J/kg);
    /// a barotropic fluid ignores e.
    #[inline]
    pub fn pressure(&self, rho: f64, e: f64) -> f64 {
        match self {
            MaterialModel::Fluid(eos) => eos.pressure(rho),
            MaterialModel::Solid(s) => s.eos.pressure(rho, e),
        }
    }

    /// Density at pressure p (Pa) on the material's reference isentrope (kg/m³): the inverse
    /// of [`MaterialModel::pressure`] at e = 0, used to give extrapolated wall particles and
    /// hydrostatic initial states their density.
    #[inline]
    pub fn density(&self, p: f64) -> f64 {
        match self {
            MaterialModel::Fluid(eos) => eos.density(p),
            // the linear (acoustic) branch: exact in tension, first order in compression
            MaterialModel::Solid(s) => s.eos.rho0 * (1.0 + p / (s.eos.rho0 * s.eos.c0 * s.eos.c0)),
        }
    }

    /// Reference density ρ0 (kg/m³).
    #[inline]
    pub fn rho0(&self) -> f64 {
        match self {
            MaterialModel::Fluid(eos) => eos.rho0,
            MaterialModel::Solid(s) => s.eos.rho0,
        }
    }

    /// Specific internal (compression) energy e(ρ) = ∫ from ρ0 to ρ of p(ρ')/ρ'² dρ' (J/kg) of a
    /// barotropic fluid, with r = ρ/ρ0: Tait (B/ρ0)[(r^(γ−1) − 1)/(γ−1) + 1/r − 1], linear
    /// c0²[ln r + 1/r − 1]; both ≈ c0²(r − 1)²/2 near ρ0. The work the pressure stores. A
    /// solid carries its specific internal energy as a field: 0 here.
    pub fn internal_energy(&self, rho: f64) -> f64 {
        match self {
            MaterialModel::Fluid(eos) => eos.internal_energy(rho),
            MaterialModel::Solid(_) => 0.0,
        }
    }

    /// Squared sound speed dp/dρ at density ρ (m²/s²) on the reference isentrope (a solid's
    /// acoustic c0²).
    #[inline]
    pub fn sound_speed2(&self, rho: f64) -> f64 {
        match self {
            MaterialModel::Fluid(eos) => eos.sound_speed2(rho),
            MaterialModel::Solid(s) => s.eos.c0 * s.eos.c0,
        }
    }

    /// ρ/c²(ρ) (kg s² m⁻⁵), with one division for water's Tait EOS
    /// ([`fluid::Eos::density_over_sound_speed2`]).
    #[inline]
    pub fn density_over_sound_speed2(&self, rho: f64) -> f64 {
        match self {
            MaterialModel::Fluid(eos) => eos.density_over_sound_speed2(rho),
            MaterialModel::Solid(_) => rho / self.sound_speed2(rho),
        }
    }

    /// Sound speed used by the time-step limit and the numerical diffusion terms (m/s): the
    /// numerical c0 of a weakly compressible fluid.
    #[inline]
    pub fn c0(&self) -> f64 {
        match self {
            MaterialModel::Fluid(eos) => eos.c0,
            MaterialModel::Solid(s) => s.eos.c0,
        }
    }
}

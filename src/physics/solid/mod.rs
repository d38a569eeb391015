//! Elastic–plastic solids for hypervelocity impact (solids issue 12): the constitutive pieces
//! as pure functions of a particle's state, tested against hand-computed values. The passes
//! that use them (velocity gradient, Jaumann update with radial return, stress divergence with
//! artificial viscosity and artificial stress, energy equation) and the scene keys come next;
//! a fluid scene pays nothing for any of it.
//!
//! - [`eos`]: Mie–Grüneisen on a linear Us–up Hugoniot, ρΓ = ρ0Γ0.
//! - [`strength`]: Johnson–Cook flow stress, Jaumann rate, radial return, temperature,
//!   failure, the longitudinal wave speed of the time step.
//! - [`library`]: the material constants hsph ships, each with its source.

pub mod dynamics;
pub mod eos;
pub mod library;
pub mod model;
pub mod strength;

pub use model::SolidModel;

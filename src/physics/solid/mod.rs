//! Elastic–plastic solids for hypervelocity impact (docs/solids.md): the constitutive pieces
//! as pure functions of a particle's state, tested against hand-computed values. The passes
//! that use them (velocity gradient, Jaumann update with radial return, stress divergence with
//! artificial viscosity and artificial stress, energy equation) and the scene keys come next;
//! a fluid scene pays nothing for any of it.
//!
//! - [`dynamics`]: the solid passes; [`pairs`]: the same in pair mode. The constitutive pieces (Mie–Grüneisen, Johnson–Cook,
//!   radial return, failure) and the material library are in `crate::material`.

pub mod dynamics;
pub mod pairs;

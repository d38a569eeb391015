//! One solid material as the passes see it: EOS, shear modulus, strength, heat capacity and
//! failure, built from a resolved scene material (`scene::Material::model`; the validator has
//! filled every constant).

use super::mie_gruneisen::MieGruneisen;
use super::strength::{Failure, JohnsonCook};

/// An elastic–plastic solid material.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SolidModel {
    /// Mie–Grüneisen EOS on a linear Hugoniot.
    pub eos: MieGruneisen,
    /// Shear modulus G (Pa).
    pub shear: f64,
    /// Johnson–Cook flow stress, or `None` for an elastic solid.
    pub strength: Option<JohnsonCook>,
    /// Specific heat c_v (J/(kg K)); with the room temperature, the temperature T = T_room +
    /// e/c_v.
    pub specific_heat: f64,
    /// Room temperature (K).
    pub t_room: f64,
    /// Failure criteria, or `None` (a particle never fails).
    pub failure: Option<Failure>,
}

impl SolidModel {
    /// Signal speed of a particle of this material at density ρ (kg/m³) and specific internal
    /// energy e (J/kg) for the time step (m/s): the longitudinal wave speed √((K + 4G/3)/ρ),
    /// K = ρc² from the EOS, with no shear once the particle has failed.
    #[inline]
    pub fn signal_speed(&self, rho: f64, e: f64, failed: bool) -> f64 {
        let g = if failed { 0.0 } else { self.shear };
        super::strength::longitudinal_speed(self.eos.bulk_modulus(rho, e), g, rho)
    }

    /// Largest signal speed of the material at rest, the longitudinal wave speed
    /// √((ρ0c0² + 4G/3)/ρ0) (m/s).
    pub fn c_long0(&self) -> f64 {
        let e = &self.eos;
        ((e.rho0 * e.c0 * e.c0 + 4.0 * self.shear / 3.0) / e.rho0).sqrt()
    }
}

//! One solid material as the passes see it: EOS, shear modulus, strength, heat capacity and
//! failure, built from a resolved scene material (the validator has filled every constant).

use super::eos::MieGruneisen;
use super::strength::{Failure, JohnsonCook};
use crate::scene::{Material, StrengthKind};

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
    /// The model of a resolved solid material (missing constants read as the elastic,
    /// failure-free defaults the validator would have rejected).
    pub fn new(m: &Material) -> Self {
        let get = |v: Option<f64>| v.unwrap_or(0.0);
        let t_room = m.t_room.unwrap_or(293.15);
        let strength = (m.strength == Some(StrengthKind::JohnsonCook)).then(|| JohnsonCook {
            a: get(m.jc_a),
            b: get(m.jc_b),
            n: get(m.jc_n),
            c: get(m.jc_c),
            m: m.jc_m.unwrap_or(1.0),
            eps_dot0: 1.0,
            t_room,
            t_melt: m.t_melt.unwrap_or(f64::INFINITY),
        });
        let failure = (m.failure_strain.is_some() || m.spall_pressure.is_some()).then(|| Failure {
            max_plastic_strain: m.failure_strain.unwrap_or(f64::INFINITY),
            spall_pressure: m.spall_pressure.unwrap_or(f64::INFINITY),
        });
        SolidModel {
            eos: MieGruneisen {
                rho0: m.rho0,
                c0: m.c0,
                s: get(m.hugoniot_slope),
                gamma0: get(m.gruneisen),
            },
            shear: get(m.shear_modulus),
            strength,
            specific_heat: m.specific_heat.unwrap_or(f64::INFINITY),
            t_room,
            failure,
        }
    }

    /// Largest signal speed of the material at rest, the longitudinal wave speed
    /// √((ρ0c0² + 4G/3)/ρ0) (m/s).
    pub fn c_long0(&self) -> f64 {
        let e = &self.eos;
        ((e.rho0 * e.c0 * e.c0 + 4.0 * self.shear / 3.0) / e.rho0).sqrt()
    }
}

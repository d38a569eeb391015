//! A scene material as a typed model (`crate::material`): the keys the validator resolved,
//! turned into the constants the step reads.

use super::{Material, StrengthKind};
use crate::material::{Eos, MaterialModel, SolidModel};

impl Material {
    /// The model of this (validated) material.
    pub fn model(&self) -> MaterialModel {
        if self.is_solid() {
            MaterialModel::Solid(self.solid_model())
        } else {
            MaterialModel::Fluid(Eos::new(self.eos, self.rho0, self.c0, self.gamma))
        }
    }

    /// The elastic–plastic model of a resolved solid material (missing constants read as the
    /// elastic, failure-free defaults the validator would have rejected).
    fn solid_model(&self) -> SolidModel {
        let m = self;
        let get = |v: Option<f64>| v.unwrap_or(0.0);
        let t_room = m.t_room.unwrap_or(293.15);
        let strength =
            (m.strength == Some(StrengthKind::JohnsonCook)).then(|| crate::material::strength::JohnsonCook {
                a: get(m.jc_a),
                b: get(m.jc_b),
                n: get(m.jc_n),
                c: get(m.jc_c),
                m: m.jc_m.unwrap_or(1.0),
                eps_dot0: 1.0,
                t_room,
                t_melt: m.t_melt.unwrap_or(f64::INFINITY),
            });
        let failure = (m.failure_strain.is_some() || m.spall_pressure.is_some()).then(|| {
            crate::material::strength::Failure {
                max_plastic_strain: m.failure_strain.unwrap_or(f64::INFINITY),
                spall_pressure: m.spall_pressure.unwrap_or(f64::INFINITY),
            }
        });
        crate::material::SolidModel {
            eos: crate::material::mie_gruneisen::MieGruneisen {
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
}

//! ρ += dt dρ/dt for fluid particles (skipped at dt = 0, the set-up), then p from the EOS.
//! No neighbours.

use super::{Ctx, Row};
use crate::cells::Neighbours;
use crate::material::MaterialModel;
use crate::particles::{Fields, Kinds, Particles};
use crate::physics::Model;
use rayon::prelude::*;

/// The density update.
pub struct DensityUpdate;

impl Row for DensityUpdate {
    const NAME: &'static str = "density_update";
    const NEIGHBOURS: bool = false;

    fn reads() -> Fields {
        Fields::NONE
    }

    fn writes() -> Fields {
        Fields::RHO.or(Fields::P)
    }

    /// ρ and p of fluid particles only.
    fn writes_kinds() -> Kinds {
        Kinds::FLUID
    }

    fn runs<const D: usize>(m: &Model<D>) -> bool {
        m.has_fluid
    }

    /// The particles `nb` visits (every one, or a class of a local time step's cycle).
    fn gather<const D: usize, N: Neighbours>(c: &mut Ctx<'_, D>, nb: &N) {
        let (p, dt) = (&mut *c.p, c.dt);
        if dt > 0.0 {
            let n = p.n_owned;
            let (kind, drho) = (&p.kind, &p.drho);
            p.rho[..n].par_iter_mut().enumerate().for_each(|(i, rho)| {
                if kind[i].is_fluid() && nb.visits(i) {
                    *rho += drho[i] * dt;
                }
            });
        }
        pressure_of(p, &c.model.materials, |i| nb.visits(i));
    }
}

/// p = p(ρ) (Pa) of the particle's material for owned fluid particles (solids: the solid
/// update).
pub fn update_pressure<const D: usize>(p: &mut Particles<D>, materials: &[MaterialModel]) {
    pressure_of(p, materials, |_| true);
}

/// [`update_pressure`] for the owned fluid particles `of` selects.
fn pressure_of<const D: usize>(
    p: &mut Particles<D>,
    materials: &[MaterialModel],
    of: impl Fn(usize) -> bool + Sync,
) {
    let n = p.n_owned;
    let (kind, mat, rho) = (&p.kind, &p.mat, &p.rho);
    p.p[..n].par_iter_mut().enumerate().for_each(|(i, pi)| {
        if kind[i].is_fluid() && of(i) {
            *pi = materials[mat[i] as usize].pressure(rho[i], 0.0);
        }
    });
}

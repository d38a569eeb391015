//! dv/dt of solid particles (m/s²): stress divergence with artificial viscosity and stress
//! (`docs/solids.md`, `crate::physics::solid::dynamics::momentum`).

use super::{geometry, Ctx, Row};
use crate::cells::{HalfView, Neighbours};
use crate::particles::Fields;
use crate::physics::solid::{dynamics, pairs};
use crate::physics::Model;

/// The solid momentum equation.
pub struct SolidMomentum;

impl Row for SolidMomentum {
    const NAME: &'static str = "solid_momentum";
    const NEIGHBOURS: bool = true;
    const PAIR: bool = true;

    fn reads() -> Fields {
        geometry()
            .or(Fields::V)
            .or(Fields::RHO)
            .or(Fields::P)
            .or(Fields::STRESS)
            .or(Fields::CORRECTION)
            .or(Fields::ENERGY)
            .or(Fields::MAT)
    }

    fn writes() -> Fields {
        Fields::NONE
    }

    fn runs<const D: usize>(m: &Model<D>) -> bool {
        m.has_solid
    }

    fn gather<const D: usize, N: Neighbours>(c: &mut Ctx<'_, D>, nb: &N) {
        dynamics::momentum(c.p, nb, c.model, c.solid);
    }

    fn pair<const D: usize>(c: &mut Ctx<'_, D>, h: &HalfView<'_, D>) {
        pairs::momentum(c.p, h, c.model, c.solid, c.pair);
    }
}

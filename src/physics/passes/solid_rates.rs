//! dρ/dt, dS/dt and de/dt of solid particles (`docs/solids.md`,
//! `crate::physics::solid::dynamics::rates`).

use super::{geometry, Ctx, Row};
use crate::cells::{HalfView, Neighbours};
use crate::particles::Fields;
use crate::physics::solid::{dynamics, pairs};
use crate::physics::Model;

/// The solid's rates.
pub struct SolidRates;

impl Row for SolidRates {
    const NAME: &'static str = "solid_rates";
    const NEIGHBOURS: bool = true;
    const PAIR: bool = true;

    /// The sound speed of the viscosity comes from (ρ, e); σ of neighbours for the artificial
    /// stress's work.
    fn reads() -> Fields {
        geometry()
            .or(Fields::V)
            .or(Fields::RHO)
            .or(Fields::P)
            .or(Fields::STRESS)
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
        dynamics::rates(c.p, nb, c.model, c.dt, c.solid);
    }

    fn pair<const D: usize>(c: &mut Ctx<'_, D>, h: &HalfView<'_, D>) {
        pairs::rates(c.p, h, c.model, c.dt, c.solid, c.pair);
    }
}

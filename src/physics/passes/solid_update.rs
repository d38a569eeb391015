//! ρ, e, S (with radial return), p and failure of solid particles (`docs/solids.md`,
//! `crate::physics::solid::dynamics::update`). No neighbours.

use super::{Ctx, Row};
use crate::cells::Neighbours;
use crate::particles::Fields;
use crate::physics::solid::dynamics;
use crate::physics::Model;

/// The solid update.
pub struct SolidUpdate;

impl Row for SolidUpdate {
    const NAME: &'static str = "solid_update";
    const NEIGHBOURS: bool = false;

    fn reads() -> Fields {
        Fields::NONE
    }

    fn writes() -> Fields {
        Fields::RHO
            .or(Fields::P)
            .or(Fields::STRESS)
            .or(Fields::ENERGY)
            .or(Fields::PLASTIC)
            .or(Fields::FAILED)
    }

    fn runs<const D: usize>(m: &Model<D>) -> bool {
        m.has_solid
    }

    fn gather<const D: usize, N: Neighbours>(c: &mut Ctx<'_, D>, _nb: &N) {
        dynamics::update(c.p, c.model, c.dt, c.solid);
    }
}

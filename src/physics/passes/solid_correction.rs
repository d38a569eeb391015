//! The kernel-gradient correction B of solid particles (`docs/solids.md`,
//! `crate::physics::solid::dynamics::correction`).

use super::{geometry, Ctx, Row};
use crate::cells::{HalfView, Neighbours};
use crate::particles::Fields;
use crate::physics::solid::{dynamics, pairs};
use crate::physics::Model;

/// The solid's gradient correction.
pub struct SolidCorrection;

impl Row for SolidCorrection {
    const NAME: &'static str = "solid_correction";
    const NEIGHBOURS: bool = true;
    const PAIR: bool = true;

    fn reads() -> Fields {
        geometry().or(Fields::RHO)
    }

    fn writes() -> Fields {
        Fields::CORRECTION
    }

    fn runs<const D: usize>(m: &Model<D>) -> bool {
        m.has_solid
    }

    fn gather<const D: usize, N: Neighbours>(c: &mut Ctx<'_, D>, nb: &N) {
        dynamics::correction(c.p, nb, c.model);
    }

    fn pair<const D: usize>(c: &mut Ctx<'_, D>, h: &HalfView<'_, D>) {
        pairs::correction(c.p, h, c.model, c.pair);
    }
}

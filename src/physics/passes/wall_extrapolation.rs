//! p, ρ and v_w of dummy wall particles, extrapolated from the fluid (Adami et al. 2012;
//! `crate::boundary::dummy`).

use super::{geometry, Ctx, Row};
use crate::boundary::dummy;
use crate::cells::Neighbours;
use crate::particles::Fields;
use crate::physics::Model;

/// Dummy walls' extrapolation.
pub struct WallExtrapolation;

impl Row for WallExtrapolation {
    const NAME: &'static str = "wall_extrapolation";
    const NEIGHBOURS: bool = true;
    /// Wall particles gather over their own lists of fluid neighbours, which pair mode
    /// builds too.
    const IN_PAIR_MODE: bool = true;

    fn reads() -> Fields {
        geometry().or(Fields::V).or(Fields::RHO).or(Fields::P)
    }

    fn writes() -> Fields {
        Fields::P.or(Fields::RHO).or(Fields::VW)
    }

    fn runs<const D: usize>(m: &Model<D>) -> bool {
        m.has_fluid && m.has_dummy
    }

    fn gather<const D: usize, N: Neighbours>(c: &mut Ctx<'_, D>, nb: &N) {
        dummy::extrapolate(c.p, nb, &c.model.dummy_walls());
    }
}

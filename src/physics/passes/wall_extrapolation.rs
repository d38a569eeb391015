//! p, ρ and v_w of wall particles, from the fluid by their wall's method (dummy walls
//! extrapolate: Adami et al. 2012, `crate::boundary::dummy`; dynamic walls integrate their
//! density: `crate::boundary::dynamic`; `crate::boundary::update_walls`).

use super::{geometry, Ctx, Row};
use crate::boundary::update_walls;
use crate::cells::Neighbours;
use crate::particles::{Fields, Kinds};
use crate::physics::Model;

/// Wall particles' extrapolation.
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

    /// Wall particles only ([`crate::boundary::update_walls`]).
    fn writes_kinds() -> Kinds {
        Kinds::OTHER
    }

    fn runs<const D: usize>(m: &Model<D>) -> bool {
        m.has_fluid && m.updates_walls
    }

    /// It reads p and ρ of fluid particles and writes those of wall particles: never a field
    /// of a particle it writes, so it splits although the field sets meet.
    fn splits() -> bool {
        true
    }

    fn gather<const D: usize, N: Neighbours>(c: &mut Ctx<'_, D>, nb: &N) {
        update_walls(c.p, nb, &c.model.wall_context(c.dt));
    }
}

//! The lattice moment L of fluid particles for the renormalised laminar viscous operator
//! (`crate::physics::viscous`). Reads what continuity read: no exchange of its own.

use super::{geometry, Ctx, Row};
use crate::cells::{HalfView, Neighbours};
use crate::particles::Fields;
use crate::physics::{pairs, viscous, Model};

/// The viscous operator's lattice moment.
pub struct ViscousMoment;

impl Row for ViscousMoment {
    const NAME: &'static str = "viscous_moment";
    const NEIGHBOURS: bool = true;
    const PAIR: bool = true;

    fn reads() -> Fields {
        geometry().or(Fields::RHO)
    }

    fn writes() -> Fields {
        Fields::LAP
    }

    fn runs<const D: usize>(m: &Model<D>) -> bool {
        m.has_fluid && m.nu > 0.0 && m.viscous.renormalised
    }

    fn gather<const D: usize, N: Neighbours>(c: &mut Ctx<'_, D>, nb: &N) {
        viscous::lattice_moment(c.p, nb, c.model, c.pair.buffer());
    }

    fn pair<const D: usize>(c: &mut Ctx<'_, D>, h: &HalfView<'_, D>) {
        pairs::lattice_moment(c.p, h, c.model, c.pair);
    }
}

//! dρ/dt of fluid particles (kg/(m³·s)): the continuity equation with δ-SPH diffusion, at the
//! half-step positions (`docs/methods.md` §1–2, `crate::physics::fluid::continuity`).

use super::{geometry, Ctx, Row};
use crate::cells::{HalfView, Neighbours};
use crate::particles::Fields;
use crate::physics::{fluid, pairs, Model};

/// The continuity equation.
pub struct Continuity;

impl Row for Continuity {
    const NAME: &'static str = "continuity";
    const NEIGHBOURS: bool = true;
    const PAIR: bool = true;

    fn reads() -> Fields {
        geometry()
            .or(Fields::V)
            .or(Fields::RHO)
            .or(Fields::GRAD_RHO)
            .or(Fields::MAT)
    }

    fn writes() -> Fields {
        Fields::NONE
    }

    fn runs<const D: usize>(m: &Model<D>) -> bool {
        m.has_fluid
    }

    fn gather<const D: usize, N: Neighbours>(c: &mut Ctx<'_, D>, nb: &N) {
        fluid::continuity(c.p, nb, c.model, c.dt, c.pair.buffer());
    }

    fn pair<const D: usize>(c: &mut Ctx<'_, D>, h: &HalfView<'_, D>) {
        pairs::continuity(c.p, h, c.model, c.dt, c.pair);
    }
}

//! dv/dt of fluid particles (m/s²): pressure, artificial and laminar viscosity, wall forces and
//! the body force (`docs/methods.md` §1, `crate::physics::fluid::momentum`).

use super::{geometry, Ctx, Row};
use crate::cells::{HalfView, Neighbours};
use crate::particles::Fields;
use crate::physics::{fluid, pairs, Model};

/// The fluid momentum equation.
pub struct Momentum;

impl Row for Momentum {
    const NAME: &'static str = "momentum";
    const NEIGHBOURS: bool = true;
    const PAIR: bool = true;

    fn reads() -> Fields {
        geometry()
            .or(Fields::V)
            .or(Fields::RHO)
            .or(Fields::P)
            .or(Fields::VW)
            .or(Fields::LAP)
            .or(Fields::MAT)
    }

    fn writes() -> Fields {
        Fields::NONE
    }

    /// Fluid scenes, unless the momentum pass also computes the lagged density gradient
    /// ([`super::momentum_gradient`]).
    fn runs<const D: usize>(m: &Model<D>) -> bool {
        m.has_fluid && !m.lagged_gradient
    }

    fn gather<const D: usize, N: Neighbours>(c: &mut Ctx<'_, D>, nb: &N) {
        fluid::momentum(c.p, nb, c.model, c.pair.buffer());
    }

    fn pair<const D: usize>(c: &mut Ctx<'_, D>, h: &HalfView<'_, D>) {
        pairs::momentum(c.p, h, c.model, c.pair);
    }
}

//! The momentum pass with the lagged density gradient (`physics.density_gradient =
//! "lagged"`): dv/dt of fluid particles as [`super::momentum`], and Antuono's ⟨∇ρ⟩^L of the
//! same state (x^n, ρ^n), which the next step's continuity reads (`docs/equations.md` §3).
//! Pair mode computes both in one visit of each pair ([`pairs::momentum_with_gradient`]);
//! gather mode runs the two gather kernels one after the other (the same equations).

use super::{momentum::Momentum, Ctx, Row};
use crate::cells::{HalfView, Neighbours};
use crate::particles::{Fields, Kinds};
use crate::physics::{delta, fluid, pairs, Model};

/// The fluid momentum equation and the next step's renormalised density gradient.
pub struct MomentumGradient;

impl Row for MomentumGradient {
    const NAME: &'static str = "momentum_gradient";
    const NEIGHBOURS: bool = true;
    const PAIR: bool = true;

    /// The momentum pass's reads (the gradient reads a subset of them: x, kind, mass, ρ).
    fn reads() -> Fields {
        Momentum::reads()
    }

    fn writes() -> Fields {
        Fields::GRAD_RHO
    }

    /// Fluid particles' gradients; every other particle's stays zero.
    fn writes_kinds() -> Kinds {
        Kinds::FLUID
    }

    fn runs<const D: usize>(m: &Model<D>) -> bool {
        m.has_fluid && m.lagged_gradient
    }

    fn gather<const D: usize, N: Neighbours>(c: &mut Ctx<'_, D>, nb: &N) {
        fluid::momentum(c.p, nb, c.model, c.pair.buffer());
        delta::renormalised_gradient(c.p, nb, c.model, c.pair.buffer());
    }

    fn pair<const D: usize>(c: &mut Ctx<'_, D>, h: &HalfView<'_, D>) {
        pairs::momentum_with_gradient(c.p, h, c.model, c.pair);
    }
}

//! ⟨∇ρ⟩^L of fluid particles for Antuono's δ-SPH density diffusion (`docs/methods.md` §2),
//! with the renormalisation matrix L of each particle (kg/m⁴). With
//! `physics.density_gradient = "lagged"` the momentum pass computes it instead
//! ([`super::momentum_gradient`]).

use super::{geometry, Ctx, Row};
use crate::cells::{HalfView, Neighbours};
use crate::particles::{Fields, Kinds};
use crate::physics::{delta, pairs, Model};

/// The renormalised density gradient.
pub struct DensityGradient;

impl Row for DensityGradient {
    const NAME: &'static str = "density_gradient";
    const NEIGHBOURS: bool = true;
    const PAIR: bool = true;

    fn reads() -> Fields {
        geometry().or(Fields::RHO)
    }

    fn writes() -> Fields {
        Fields::GRAD_RHO
    }

    /// Fluid particles' gradients; every other particle's stays zero.
    fn writes_kinds() -> Kinds {
        Kinds::FLUID
    }

    fn runs<const D: usize>(m: &Model<D>) -> bool {
        m.has_fluid && m.diffusion.needs_gradient() && !m.lagged_gradient
    }

    fn gather<const D: usize, N: Neighbours>(c: &mut Ctx<'_, D>, nb: &N) {
        delta::renormalised_gradient(c.p, nb, c.model, c.pair.buffer());
    }

    fn pair<const D: usize>(c: &mut Ctx<'_, D>, h: &HalfView<'_, D>) {
        pairs::renormalised_gradient(c.p, h, c.model, c.pair);
    }
}

//! Mass of dummy wall particles that keep their lattice cell's volume (`[[wall]] volume =
//! "lattice"`): m_w = ρ_w V0 with V0 = (dx/2^ℓ)^D (m^D), after the extrapolation has set ρ_w.
//! The pair sums weigh a neighbour by V_j = m_j/ρ_j, so such a wall particle counts for the
//! cell it fills whatever its pressure, as a fluid particle of hydrostatic mass does on the same
//! lattice (docs/refinement.md §2). No neighbours.

use super::{Ctx, Row};
use crate::cells::Neighbours;
use crate::particles::{Fields, Kinds};
use crate::physics::Model;
use rayon::prelude::*;

/// The wall particles' masses from their densities.
pub struct WallVolume;

impl Row for WallVolume {
    const NAME: &'static str = "wall_volume";
    const NEIGHBOURS: bool = false;

    fn reads() -> Fields {
        Fields::NONE
    }

    fn writes() -> Fields {
        Fields::MASS
    }

    /// Wall particles only.
    fn writes_kinds() -> Kinds {
        Kinds::OTHER
    }

    fn runs<const D: usize>(m: &Model<D>) -> bool {
        m.has_fluid && m.updates_walls && m.wall_lattice_volume.iter().any(|&l| l)
    }

    fn gather<const D: usize, N: Neighbours>(c: &mut Ctx<'_, D>, nb: &N) {
        let model = c.model;
        let p = &mut *c.p;
        let n = p.n_owned;
        let levels = model.sizes.is_some();
        let (kind, body, rho, level) = (&p.kind, &p.body, &p.rho, &p.level);
        p.mass[..n].par_iter_mut().enumerate().for_each(|(i, m)| {
            if kind[i].is_wall() && model.wall_lattice_volume[body[i] as usize] && nb.visits(i) {
                let l = if levels { level[i] } else { 0 };
                *m = rho[i] * lattice_volume::<D>(model.dx, l);
            }
        });
    }
}

/// The volume (m^D) of a lattice cell of level `level` of the scene's spacing `dx` (m).
#[inline]
fn lattice_volume<const D: usize>(dx: f64, level: u16) -> f64 {
    (dx / f64::from(1u32 << level)).powi(D as i32)
}

//! Particle shifting of owned fluid particles (Sun et al. 2017, `crate::physics::shifting`):
//! positions moved (wrapped, kept on the fluid side of mirror planes), ρ and v
//! Taylor-corrected, p from the EOS. Skipped at dt = 0 (the set-up).

use super::density_update::update_pressure;
use super::{geometry, Ctx, Row};
use crate::cells::Neighbours;
use crate::particles::{Fields, Kinds};
use crate::physics::shifting;
use crate::physics::Model;
use rayon::prelude::*;

/// δ⁺-SPH particle shifting.
pub struct Shift;

impl Row for Shift {
    const NAME: &'static str = "shift";
    const NEIGHBOURS: bool = true;

    fn reads() -> Fields {
        geometry().or(Fields::V).or(Fields::RHO)
    }

    fn writes() -> Fields {
        Fields::X.or(Fields::V).or(Fields::RHO).or(Fields::P)
    }

    /// Fluid particles only.
    fn writes_kinds() -> Kinds {
        Kinds::FLUID
    }

    fn runs<const D: usize>(m: &Model<D>) -> bool {
        m.has_fluid && m.shifting.is_some()
    }

    fn gather<const D: usize, N: Neighbours>(c: &mut Ctx<'_, D>, nb: &N) {
        let Some(s) = c.model.shifting else { return };
        if c.dt <= 0.0 {
            return;
        }
        let n = c.p.n_owned;
        let (vol, out) = c.pair.shift_buffers();
        shifting::shifts(c.p, nb, c.model, &s, (&mut *vol, &mut *out));
        let out = &out[..];
        let space = c.space;
        let planes = &space.planes;
        let p = &mut *c.p;
        let kind = &p.kind;
        p.x[..n]
            .par_iter_mut()
            .zip(p.rho[..n].par_iter_mut())
            .zip(p.v[..n].par_iter_mut())
            .enumerate()
            .for_each(|(i, ((x, rho), v))| {
                if kind[i].is_fluid() {
                    let o = &out[i];
                    let old = *x;
                    *x += o.dr;
                    // a shift is not a motion: only the position is reflected at a mirror
                    let mut ghost_v = *v;
                    crate::boundary::mirror::bounce_all(planes, &old, x, &mut ghost_v);
                    space.wrap(x);
                    *rho += o.drho;
                    *v += o.dv;
                }
            });
        update_pressure(p, &c.model.materials);
    }
}

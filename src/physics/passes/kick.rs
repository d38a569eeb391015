//! The closing half kick v += ½dt a of integrated particles (Störmer–Verlet, `sim/step.rs`).
//! No neighbours; nothing to kick at the set-up (dt = 0), and skipping keeps −0.0 velocities'
//! bits.

use super::{Ctx, Row};
use crate::cells::Neighbours;
use crate::particles::{Fields, Particles};
use crate::physics::Model;
use rayon::prelude::*;

/// The closing half kick.
pub struct Kick;

impl Row for Kick {
    const NAME: &'static str = "kick";
    const NEIGHBOURS: bool = false;

    fn reads() -> Fields {
        Fields::NONE
    }

    fn writes() -> Fields {
        Fields::V
    }

    fn runs<const D: usize>(_m: &Model<D>) -> bool {
        true
    }

    /// The particles `nb` visits (every one, or a class of a local time step's cycle).
    fn gather<const D: usize, N: Neighbours>(c: &mut Ctx<'_, D>, nb: &N) {
        if c.dt > 0.0 {
            kick_of(c.p, c.dt, |i| nb.visits(i));
        }
    }
}

/// v += ½dt a (m/s) for owned integrated particles.
pub fn half_kick<const D: usize>(p: &mut Particles<D>, dt: f64) {
    kick_of(p, dt, |_| true);
}

/// [`half_kick`] of the owned particles `of` selects.
fn kick_of<const D: usize>(p: &mut Particles<D>, dt: f64, of: impl Fn(usize) -> bool + Sync) {
    let n = p.n_owned;
    let h = 0.5 * dt;
    let (kind, acc) = (&p.kind, &p.acc);
    p.v[..n].par_iter_mut().enumerate().for_each(|(i, v)| {
        if kind[i].is_integrated() && of(i) {
            *v += acc[i] * h;
        }
    });
}

//! Local time stepping (`time.stepping = "local"`; docs/splitting.md §8): where
//! particles of several smoothing lengths meet, the fluid and wall particles of the scene's h
//! (coarse, C) take one step of Δ = 2δ while the others (fine, F: smaller h, solids) take two
//! of δ.
//!
//! **Classes.** C if a fluid or wall particle's h is at least the scene's h, else F: a function
//! of the particle alone, the same on every layout. h changes only when a particle splits or
//! merges, which a cycle does at its ends only (splits before its first kick, merges after its
//! last pass), so a particle keeps its class through a cycle. A coarse wall is extrapolated at
//! the cycle's end only, as a coarse fluid particle is computed then.
//!
//! **The cycle**, Störmer–Verlet per class (`sim/step.rs`), from a state at t_n where every
//! particle has its v, ρ and a:
//! 1. *Mid substep*: C kick ½Δ a_n, F kick ½δ a_n; every particle drifts δ; ghosts and lists;
//!    the passes run over F homes only (`cells::Subset`) at dt = δ: F's ρ advances by δ dρ/dt
//!    and F closes its step with ½δ a. C keeps its ρ_n (and p_n) through the middle: the F
//!    particles beside it read its state at t_n there, and C's own update stays the plain
//!    Verlet one (no rate has to survive a migration or a checkpoint).
//! 2. *End substep*: F kicks ½δ a; every particle drifts δ (a C particle twice by δ with its
//!    half-kicked v: x_n + δv + δv, not x_n + 2δv to the bit, the rule fixed); ghosts and lists;
//!    every pass runs over F homes at dt = δ, then over C homes at dt = Δ (each home's sum is
//!    its own, so the two parts give what one run would: `Pass::splits`). The continuity
//!    equation's half-step positions x − ½dt v are then each particle's own: a C home's
//!    partners sit at t_n + δ, which is where an F partner was before its last drift.
//!    A pass that reads what it writes (shifting, [`once_a_cycle`]) runs only here, once,
//!    over every particle: δ⁺ shifting then moves each particle once a cycle, as a global
//!    step of Δ would.
//!
//! The pair (F, C) breaks Newton's third law at the middle (only F accumulates); masses are
//! untouched, so Σm stays exact. Balance checks, migrations and ghost builds may fall on either
//! substep: what carries over from one substep to the next (x, v, ρ, p, a coarse wall's
//! extrapolated fields) is in every particle's record, which migrations move whole; no rate
//! does.
//! Outputs, probes and checkpoints see whole cycles (the driver's step boundary), so a restart
//! begins a cycle: whether the next `advance` is a cycle is recomputed from the restored state.
//! `step` counts substeps.

use super::Simulation;
use crate::comm::Comm;
use crate::error::{Error, Result};
use crate::physics::passes::Pass;
use crate::physics::Model;
use crate::scene::{Scene, Stepping};
use rayon::prelude::*;

/// Which part of a step the passes are in.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Substep {
    /// A whole step: every particle at the step's dt.
    #[default]
    Whole,
    /// A cycle's first substep: F particles only.
    Mid,
    /// A cycle's second substep: F at δ, then C at Δ = 2δ.
    End,
}

/// The smallest ratio of the coarse particles' CFL bound to the fine ones' at which a cycle
/// pays: below it every particle takes one step of the smaller bound.
pub const CYCLE_RATIO: f64 = 1.5;

/// Input check of `time.stepping = "local"`: it needs particles of several smoothing lengths,
/// the CFL step, the gather kernels and no solid; otherwise an input error naming what to
/// change.
pub fn check<const D: usize>(scene: &Scene, model: &Model<D>) -> Result<()> {
    if scene.time.stepping == Stepping::Global {
        return Ok(());
    }
    let key = "time.stepping";
    let refuse = |why: &str| Err(Error::input(key, format!("\"local\" {why}")));
    if model.varying().is_none() {
        return refuse(
            "gives the particles of the scene's h twice the step of smaller ones, and every \
             particle of this scene has the scene's h; add a [[refine]] region with \
             smoothing_length = \"level\", or use stepping = \"global\"",
        );
    }
    if scene.time.dt > 0.0 {
        return refuse(
            "takes each class's CFL step, and time.dt fixes one step for all; remove time.dt, \
             or use stepping = \"global\"",
        );
    }
    if model.has_solid {
        return refuse("is built for fluids; this scene has solid bodies: use stepping = \"global\"");
    }
    if scene.performance.interactions == crate::scene::Interactions::Pairs {
        return refuse(
            "runs the passes over each class in turn, which the pair kernels cannot (each pair \
             once for both sides); use performance.interactions = \"gather\", or stepping = \
             \"global\"",
        );
    }
    Ok(())
}

/// True if `pass` runs once a cycle, over every particle at the cycle's end (at dt = Δ), and
/// not in its middle: a pass that walks neighbours and reads what it writes (shifting moves
/// the positions it reads), so that it cannot run over the fine particles and then the coarse
/// ones with the bits of one run (`Pass::splits`).
#[inline]
pub(super) fn once_a_cycle(pass: Pass) -> bool {
    pass.walks_neighbours() && !pass.splits()
}

/// True if particle `i` (of kind `kind`, smoothing lengths `h`) is coarse: a fluid or wall
/// particle with at least the scene's h `h0`; none is without local stepping (`h0` = `None`).
#[inline]
pub(super) fn is_coarse(kind: crate::particles::Kind, h: &[f64], h0: Option<f64>, i: usize) -> bool {
    h0.is_some_and(|h0| (kind.is_fluid() || kind.is_wall()) && h[i] >= h0)
}

impl<const D: usize> Simulation<D> {
    /// The scene's h (m), the coarse class's, with local stepping; `None` without it.
    pub(super) fn coarse_h(&self) -> Option<f64> {
        self.model.varying().filter(|_| self.local).map(|z| z.h[0])
    }

    /// `self.active`: per owned particle, true unless it is coarse, for the passes of a
    /// cycle's substeps (after the particles' order is final for the substep).
    pub(super) fn mark_classes(&mut self) {
        let n = self.p.n_owned;
        let h0 = self.coarse_h();
        let (kind, h) = (&self.p.kind, &self.p.h);
        self.active.clear();
        self.active.extend((0..n).map(|i| !is_coarse(kind[i], h, h0, i)));
    }

    /// The opening half kicks of a substep (see the module docs): v += ½dt a for a whole step,
    /// per class at a cycle's substeps (`dt` = δ).
    pub(super) fn opening_kick(&mut self, dt: f64) {
        let (fine, coarse) = match self.substep {
            Substep::Whole => return self.half_kick(dt),
            Substep::Mid => (0.5 * dt, dt),
            Substep::End => (0.5 * dt, 0.0),
        };
        let n = self.p.n_owned;
        let h0 = self.coarse_h();
        let (kind, acc, h) = (&self.p.kind, &self.p.acc, &self.p.h);
        self.p.v[..n].par_iter_mut().enumerate().for_each(|(i, v)| {
            let f = if is_coarse(kind[i], h, h0, i) {
                coarse
            } else {
                fine
            };
            if kind[i].is_integrated() && f > 0.0 {
                *v += acc[i] * f;
            }
        });
    }

    /// The length (s) of the next step: `dt`, or half of it when the next `advance` is a
    /// cycle (its substeps; `step` counts them).
    pub fn step_length(&self) -> f64 {
        if self.cycle {
            0.5 * self.dt
        } else {
            self.dt
        }
    }

    /// One cycle of two substeps of δ = `self.dt`/2 (see the module docs).
    pub(super) fn advance_cycle(&mut self, comm: &dyn Comm) -> Result<()> {
        let delta = 0.5 * self.dt;
        if self.adapts() {
            self.split_entering(comm)?;
        }
        for part in [Substep::Mid, Substep::End] {
            self.substep = part;
            let r = self.substep_of(delta, comm);
            if r.is_err() {
                self.substep = Substep::Whole;
                return r;
            }
        }
        self.substep = Substep::Whole;
        self.cycles += 1;
        if self.adapts() {
            self.merge_leaving(comm)?;
            self.follow_ramps();
        }
        self.close_step(comm)
    }

    /// One substep of a cycle: kicks and drift, ghosts and lists, the classes' passes.
    fn substep_of(&mut self, delta: f64, comm: &dyn Comm) -> Result<()> {
        self.kick_drift(delta)?;
        self.prepare_neighbours(comm)?;
        self.mark_classes();
        self.run_passes(delta, comm, None)
    }

    /// The next `advance`'s span (s) and whether it is a cycle: with local stepping, and
    /// coarse particles whose CFL bound Δ_C is at least [`CYCLE_RATIO`] times the fine ones'
    /// δ_F, a cycle of min(2δ_F, Δ_C); else one step of the smaller bound (the global step,
    /// with the bits of [`Simulation::next_dt`] when there is no class). Never past t_end.
    pub(super) fn plan(&self, comm: &dyn Comm) -> Result<(f64, bool)> {
        let Some(z) = self.model.varying().filter(|_| self.local) else {
            return Ok((self.next_dt(comm)?, false));
        };
        let n = self.p.n_owned;
        let (kind, v, a, h) = (&self.p.kind, &self.p.v, &self.p.acc, &self.p.h);
        type Max5 = [f64; 5];
        let max5 = |x: Max5, y: Max5| std::array::from_fn(|k| x[k].max(y[k]));
        // per class the largest |v|² and |a|², and 1 if the class has a fluid particle
        let m: Max5 = (0..n)
            .into_par_iter()
            .with_min_len(1024)
            .fold(
                || [0.0; 5],
                |m, i| {
                    if !kind[i].is_integrated() {
                        return m;
                    }
                    let (v2, a2) = (v[i].norm_squared(), a[i].norm_squared());
                    if is_coarse(kind[i], h, Some(z.h[0]), i) {
                        // integrated: fluid
                        max5(m, [0.0, 0.0, v2, a2, 1.0])
                    } else {
                        max5(m, [v2, a2, 0.0, 0.0, 0.0])
                    }
                },
            )
            .reduce(|| [0.0; 5], max5);
        let mut m = m;
        comm.all_reduce_max_f64(&mut m)?;
        let c = self.model.c_max;
        let bound = |h: f64, v2: f64, a2: f64| self.cfl_bound(h, c + v2.sqrt(), a2.sqrt());
        let fine = bound(self.model.h_min(), m[0], m[1]);
        let (span, cycle) = if m[4] == 0.0 {
            (fine, false)
        } else {
            let coarse = bound(z.h[0], m[2], m[3]);
            if coarse >= CYCLE_RATIO * fine {
                ((2.0 * fine).min(coarse), true)
            } else {
                (fine.min(coarse), false)
            }
        };
        Ok((self.up_to_end(span), cycle))
    }
}

//! The step: Störmer–Verlet with (x, ρ) as coordinates and v as momentum,
//!   v_{n+½} = v_n + ½dt a_n;  x_{n+1} = x_n + dt v_{n+½};
//!   ρ_{n+1} = ρ_n + dt (dρ/dt)(x_{n+½}, v_{n+½}, ρ_n);  v_{n+1} = v_{n+½} + ½dt a_{n+1},
//!   x_{n+½} = x_{n+1} − ½dt v_{n+½} in the kinematic term (`fluid::continuity`).
//! Evaluating dρ/dt and dv/dt from one state instead (one fused pass) makes the acoustic
//! (ρ, v) coupling grow by 1 + (ω dt)²/4 per step, which is why continuity and momentum are
//! separate passes. Between the drift and the passes: every `check_every` steps a balance
//! check; then, when the ghosts' skin has expired ([`super::skin`]), migration and the ghost
//! build, else a refresh of the kept ghosts; then the neighbour lists. Before each pass the
//! ghosts get exactly the fields it reads that are stale ([`crate::physics::passes`]).

use super::multirate::{once_a_cycle, Substep};
use super::timers::Timer;
use super::Simulation;
use crate::boundary::geometry::WallMove;
use crate::boundary::motion;
use crate::cells::{HalfView, Neighbours, Subset, Wants};
use crate::comm::Comm;
use crate::error::{Error, Result};
use crate::particles::{Fields, Kinds};
use crate::physics::passes::{self, Ctx, Pass};
use crate::Vector;
use rayon::prelude::*;
use std::time::Instant;

/// Run `pass` over `nb`, or over the part `part.1` of the mask `part.0` (a split pass, whose
/// kernels are gather kernels).
fn run_over<const D: usize, N: Neighbours>(
    pass: Pass,
    c: &mut Ctx<'_, D>,
    nb: &N,
    part: Option<(&[bool], bool)>,
    half: Option<&HalfView<'_, D>>,
) {
    match part {
        None => pass.run(c, nb, half),
        Some((mask, part)) => pass.run(c, &Subset { all: nb, mask, part }, None),
    }
}

/// Steps between reorderings of the owned particles into cell order.
const REORDER_EVERY: u64 = 16;

/// The settling's span over its damping time τ (`time.settle`, [`Simulation::settle`]).
pub const SETTLE_DECAYS: f64 = 8.0;

impl<const D: usize> Simulation<D> {
    /// Advance one step (see the module docs): balance check and migration, ghosts and
    /// neighbours, the passes, the closing half kick and the next dt.
    /// With local time stepping a cycle of two substeps instead ([`super::multirate`]).
    pub fn advance(&mut self, comm: &dyn Comm) -> Result<()> {
        if self.cycle {
            return self.advance_cycle(comm);
        }
        let dt = self.dt;
        self.kick_drift(dt)?;
        if self.adapts() {
            self.split_entering(comm)?;
        }
        self.prepare_neighbours(comm)?;
        self.run_passes(dt, comm, None)?;
        if self.adapts() {
            self.merge_leaving(comm)?;
            self.follow_ramps();
        }
        self.close_step(comm)
    }

    /// After the drift: the balance check, then migration and the ghost build when the skin
    /// has expired (or the planes moved), else a refresh of the kept ghosts; the lists.
    pub(super) fn prepare_neighbours(&mut self, comm: &dyn Comm) -> Result<()> {
        let build = if self.nl.is_verlet() {
            let build = self.ghosts_expired(false, comm)?;
            self.check_balance_at_build(build, comm)?;
            build
        } else {
            let planes_moved = self.check_balance(comm)?;
            self.ghosts_expired(planes_moved, comm)?
        };
        if build {
            self.migrate(comm)?;
            self.rebuild_neighbours(comm)
        } else {
            self.refresh_kept_ghosts(comm)
        }
    }

    /// The end of a step or cycle: the outflow rule, the finiteness check, the next span.
    pub(super) fn close_step(&mut self, comm: &dyn Comm) -> Result<()> {
        let t0 = Instant::now();
        self.apply_outflow(true);
        self.check_finite()?;
        self.timers.add(Timer::Integrate, t0);
        (self.dt, self.cycle) = self.plan(comm)?;
        Ok(())
    }

    /// Free the step's neighbour lists, cell list and pair accumulators, which the next step
    /// builds again from scratch: the driver calls it before it gathers a view (probes,
    /// reference, output), so that the view does not sit on top of them at the run's peak of
    /// memory (docs/benchmark-log.md, "The step's lists freed before a view"). The lists are kept
    /// when the next step's balance check reads them, and Verlet lists (with their cell list) until
    /// their next build; the pair accumulators and scratch, which every pass sizes again, go in
    /// either case. Changes no bit.
    pub fn release_step_buffers(&mut self) {
        self.parts_high = self.memory_parts();
        if !self.next_check_reads_lists() && !self.nl.is_verlet() {
            self.free_step_buffers();
        } else {
            self.pair_scratch = Default::default();
        }
    }

    /// Free the neighbour lists, cell list and pair accumulators (see
    /// [`Simulation::release_step_buffers`]).
    pub(super) fn free_step_buffers(&mut self) {
        self.parts_high = self.memory_parts();
        self.nl.release();
        self.cells.release();
        self.pair_scratch = Default::default();
    }

    /// The set-up relaxation (`discretisation.relax` iterations, none by default): the shifting
    /// row with the relaxation's step, each iteration after a migration and a ghost build, the
    /// fluid's density carried to the new positions by the row's Taylor correction (its
    /// velocity is zero). Positions are checked after each iteration.
    pub(super) fn relax(&mut self, comm: &dyn Comm) -> Result<()> {
        let Some((step, iterations)) = self.model.relaxation else {
            return Ok(());
        };
        let kept = self.model.shifting.replace(step);
        let builds = self.skin.builds;
        for k in 0..iterations {
            self.migrate(comm)?;
            self.rebuild_neighbours(comm)?;
            // a positive dt: the row skips the set-up's dt = 0
            self.run_pass(Pass::Shift, 1.0, comm)?;
            self.check_state()?;
            stop_in_setup(comm, || format!("relaxation iteration {} of {iterations}", k + 1))?;
        }
        self.model.shifting = kept;
        // the run's ghost builds (`summary.json`) are the set-up step's and the steps': the
        // relaxation's precede them
        self.skin.builds = builds;
        self.migrate(comm)
    }

    /// The set-up's settling (`time.settle` seconds of simulated time, none by default): the
    /// scene's own steps before t = 0, each followed by v ← v·exp(−dt/τ) for every integrated
    /// particle, τ = settle/[`SETTLE_DECAYS`] (s), so that an oscillation's velocity decays by
    /// e^−8 over the span (its amplitude by about e^−4 when it is slower than the damping);
    /// then v = 0, t = 0, step 0, and the set-up's passes at dt = 0 again. The positions and
    /// densities keep what the discretisation holds at rest, so still water starts without the
    /// acoustic transient of its lattice (docs/refinement.md §2). The scene's walls are still and
    /// its bodies at rest (checked in `scene/validate.rs`). Every rank takes the same steps: the
    /// same bits on any layout. The timers, pair count, ghost-build and cycle counts are the run's
    /// alone afterwards; balance, migration and split/merge counts include the settling.
    pub(super) fn settle(&mut self, comm: &dyn Comm) -> Result<()> {
        let span = self.scene.time.settle;
        if span <= 0.0 {
            return Ok(());
        }
        let tau = span / SETTLE_DECAYS;
        let kept = (
            self.timers.clone(),
            self.pair_count,
            self.skin.builds,
            self.cycles,
        );
        self.dt = self.next_dt(comm)?;
        // time.max_steps bounds the settling's steps too (and the step budget always does)
        let max = self.scene.time.max_steps;
        let budget = if max > 0 {
            max
        } else {
            crate::limits::MAX_STEPS as u64
        };
        while self.t < span {
            if self.step >= budget {
                if comm.rank() == 0 {
                    eprintln!(
                        "hsph: warning: time.settle = {span} s cut short after {} steps at t = {:.4e} s \
                         ({}): the set-up continues from there",
                        self.step,
                        self.t,
                        if max > 0 {
                            "time.max_steps bounds the settling too"
                        } else {
                            "the step budget"
                        }
                    );
                }
                break;
            }
            let dt = self.dt;
            self.advance(comm)?;
            let keep = (-dt / tau).exp();
            self.damp(keep);
            let (step, t) = (self.step, self.t);
            stop_in_setup(comm, || {
                format!("settling step {step}, t = {t:.4e} s of {span} s")
            })?;
        }
        self.damp(0.0);
        (self.timers, self.pair_count, self.skin.builds, self.cycles) = kept;
        self.t = 0.0;
        self.step = 0;
        self.reordered_at = None;
        self.migrate(comm)?;
        self.rebuild_neighbours(comm)?;
        self.run_passes(0.0, comm, None)
    }

    /// v ← keep·v for every owned integrated particle.
    fn damp(&mut self, keep: f64) {
        let n = self.p.n_owned;
        let kind = &self.p.kind;
        self.p.v[..n]
            .par_iter_mut()
            .zip(kind[..n].par_iter())
            .for_each(|(v, k)| {
                if k.is_integrated() {
                    *v *= keep;
                }
            });
    }

    /// v += ½dt a, x += dt v (wrapped), walls moved, t and step advanced, positions checked.
    pub(super) fn kick_drift(&mut self, dt: f64) -> Result<()> {
        let t0 = Instant::now();
        self.opening_kick(dt);
        self.wall_moves(dt);
        {
            let n = self.p.n_owned;
            let space = &self.space;
            let p = &mut self.p;
            let kind = &p.kind;
            let planes = &space.planes;
            let (faces, moves) = (&self.faces, &self.moves);
            p.x[..n]
                .par_iter_mut()
                .zip(p.v[..n].par_iter_mut())
                .enumerate()
                .for_each(|(i, (x, v))| {
                    if kind[i].is_integrated() {
                        let old = *x;
                        *x += *v * dt;
                        if kind[i].is_fluid() {
                            crate::boundary::mirror::bounce_all(planes, &old, x, v);
                            for ((_, face), m) in faces.iter().zip(moves) {
                                face.bounce(&old, x, v, m);
                            }
                        }
                        space.wrap(x);
                    }
                });
        }
        let t_new = self.t + dt;
        self.apply_wall_motion(self.t, t_new);
        self.t = t_new;
        self.step += 1;
        self.apply_outflow(false);
        self.check_state()?;
        self.timers.add(Timer::Integrate, t0);
        Ok(())
    }

    /// Run the model's passes in order (up to and including `until`, if given), refreshing
    /// before each the ghost fields it reads that are stale.
    pub(super) fn run_passes(&mut self, dt: f64, comm: &dyn Comm, until: Option<Pass>) -> Result<()> {
        for k in 0..self.schedule.len() {
            let pass = self.schedule[k];
            self.run_pass(pass, dt, comm)?;
            if Some(pass) == until {
                break;
            }
        }
        Ok(())
    }

    /// One pass: refresh what it needs, run its row, mark what it wrote. With overlap
    /// ([`Simulation::overlaps`]) the refresh is sent, the interior computed while it travels,
    /// then received and the rest computed: the bits of one run (`Pass::splits`).
    fn run_pass(&mut self, pass: Pass, dt: f64, comm: &dyn Comm) -> Result<()> {
        if self.substep == Substep::Mid && once_a_cycle(pass) {
            return Ok(());
        }
        let need = self.fresh.before(pass);
        if !need.0.is_empty() && self.overlaps(pass) {
            let t0 = Instant::now();
            let pending = self.halo.start_refresh(&self.p, &self.space, need, comm)?;
            self.timers.add(Timer::Halo, t0);
            self.compute(pass, dt, Some(true));
            let t0 = Instant::now();
            self.halo.finish_refresh(&mut self.p, need, pending, comm)?;
            self.timers.add(Timer::Halo, t0);
            self.compute(pass, dt, Some(false));
        } else {
            if !need.0.is_empty() {
                self.refresh(need, comm)?;
            }
            self.compute(pass, dt, None);
        }
        self.fresh.after(pass);
        Ok(())
    }

    /// True if `pass` computes the interior while its refresh travels: overlap on, ghosts held,
    /// the interior marked at the last neighbour build, and a gather kernel that splits. Pair
    /// mode's pair kernels do not: each accumulates every pair of a home in one fixed order.
    fn overlaps(&self, pass: Pass) -> bool {
        self.overlap
            && self.substep == Substep::Whole
            && !self.halo.is_empty()
            && self.interior.len() == self.p.n_owned
            && pass.splits()
            && !(self.pair_mode && pass.has_pair_kernel())
    }

    /// Run `pass`'s row over every owned particle (`part` = `None`), or over the interior
    /// (`Some(true)`) or the rest (`Some(false)`) of [`Simulation::interior`]; in a cycle's
    /// substeps over the fine particles at `dt` and, at its end, the coarse ones at 2`dt`
    /// ([`super::multirate`]), but for a pass that runs once a cycle ([`once_a_cycle`]): over
    /// every particle at the cycle's end.
    fn compute(&mut self, pass: Pass, dt: f64, part: Option<bool>) {
        match self.substep {
            Substep::Whole => self.compute_over(pass, dt, part.map(|b| (false, b))),
            Substep::Mid => self.compute_over(pass, dt, Some((true, true))),
            Substep::End if once_a_cycle(pass) => self.compute_over(pass, 2.0 * dt, None),
            Substep::End => {
                self.compute_over(pass, dt, Some((true, true)));
                self.compute_over(pass, 2.0 * dt, Some((true, false)));
            }
        }
    }

    /// [`Simulation::compute`] over every owned particle (`part` = `None`) or over the part
    /// `part.1` of a mask: the classes' (`part.0`, [`Simulation::mark_classes`]) or the
    /// interior's.
    fn compute_over(&mut self, pass: Pass, dt: f64, part: Option<(bool, bool)>) {
        let t0 = Instant::now();
        let mut c = Ctx {
            p: &mut self.p,
            model: &self.model,
            space: &self.space,
            dt,
            pair: &mut self.pair_scratch,
            solid: &mut self.solid,
        };
        let classes = part.is_some_and(|(c, _)| c);
        let part = part.map(|(c, b)| (if c { &self.active[..] } else { &self.interior[..] }, b));
        if !pass.walks_neighbours() {
            match part {
                None => pass.run(&mut c, &self.nl, None),
                Some((mask, part)) => pass.run(
                    &mut c,
                    &Subset {
                        all: &self.nl,
                        mask,
                        part,
                    },
                    None,
                ),
            }
            self.timers.add_pass(Timer::Integrate, pass, t0);
            return;
        }
        let half = self.nl.half(&self.window, &self.cells);
        let half = half.as_ref().filter(|_| self.pair_mode);
        if self.nl.is_lean() {
            let nb = self.nl.scan(&self.window, &self.cells);
            run_over(pass, &mut c, &nb, part, half);
        } else if self.nl.is_verlet() {
            let nb = self.nl.kept::<D>(&self.cells);
            run_over(pass, &mut c, &nb, part, half);
        } else {
            run_over(pass, &mut c, &self.nl, part, half);
        }
        // every listed home's entries once: after a whole step's pass or an overlap's second
        // part; in a cycle, after its first substep's (whose lists skip the coarse homes,
        // but for Verlet lists) and after its end's coarse part
        let last = match part {
            None => true,
            Some((_, b)) => !b || (classes && self.substep == Substep::Mid),
        };
        if last {
            self.pair_count += self.nl.entries() as u64;
        }
        self.timers.add_pass(Timer::Forces, pass, t0);
    }

    /// p = p(ρ) of the particle's material for owned fluid particles (solids: the solid
    /// update).
    pub(super) fn update_pressure(&mut self) {
        passes::update_pressure(&mut self.p, &self.model.materials);
    }

    /// True if this step builds the ghosts again (and migrates): see [`super::skin`]; always
    /// after the cut planes moved.
    fn ghosts_expired(&mut self, planes_moved: bool, comm: &dyn Comm) -> Result<bool> {
        let t0 = Instant::now();
        let r = self.skin.expired(&self.p, planes_moved, comm);
        self.timers.add(Timer::Halo, t0);
        r
    }

    /// The ghosts kept since the last build get, of what a build sends (all but
    /// [`Fields::CONSTANT`]), what changed since they last got it (x and v, moved by the drift
    /// and wall motion; a field a pass wrote after its last refresh), from the same owners in
    /// the same order; then cells and lists.
    fn refresh_kept_ghosts(&mut self, comm: &dyn Comm) -> Result<()> {
        let fields = self
            .build_fields
            .without(Fields::CONSTANT)
            .without(self.p.dropped);
        self.fresh.wrote(Fields::X.or(Fields::V));
        self.fresh.kept();
        let need = self.fresh.needs(fields);
        if !need.0.is_empty() {
            self.refresh(need, comm)?;
        }
        let held = self.p.len();
        self.balance.note_held(held, held - self.p.n_owned);
        if self.nl.is_verlet() {
            // the lists of the build hold every pair within the support now: the passes
            // measure the current positions in the build's cell order
            let t0 = Instant::now();
            self.nl.follow(&self.cells, &self.p);
            self.timers.add(Timer::Neighbours, t0);
            return Ok(());
        }
        self.list_neighbours()
    }

    /// Ghosts (positions and every field), binning and neighbour lists at the current state.
    pub(super) fn rebuild_neighbours(&mut self, comm: &dyn Comm) -> Result<()> {
        self.build_neighbours(self.skin.width, comm)
    }

    /// Verlet lists on a restart: the lists of the uninterrupted run, built from its last
    /// build's positions `at` (owned, in storage order). Those positions are swapped in, the
    /// ghosts (reaching support + 2w: a particle owned here lies within w/2 of this box, its
    /// build position within w/2 of it), cells and lists built, and the current positions
    /// swapped back; the next step refreshes the ghosts' positions before any pass.
    pub(super) fn list_as_built(&mut self, mut at: Vec<Vector<D>>, comm: &dyn Comm) -> Result<()> {
        let n = self.p.n_owned;
        self.p.x[..n].swap_with_slice(&mut at);
        // no reorder: `at` is in this storage order
        self.reordered_at = Some(self.step);
        let built = self.build_neighbours(2.0 * self.skin.width, comm);
        self.p.x[..n].swap_with_slice(&mut at);
        self.fresh.wrote(Fields::X);
        built
    }

    /// Collective: the owned positions at the last neighbour build, in storage order, for a
    /// checkpoint of a run with Verlet lists — empty without them, or when some rank's owned
    /// particles changed since the build (the next step builds on every rank then).
    pub fn build_positions(&self, comm: &dyn Comm) -> Result<&[Vector<D>]> {
        if !self.nl.is_verlet() {
            return Ok(&[]);
        }
        let built = self.skin.positions(&self.p);
        let stale = built.len() != self.p.n_owned;
        let mut m = [f64::from(u8::from(stale))];
        let prev = comm.set_phase(crate::comm::Phase::Other);
        let r = comm.all_reduce_max_f64(&mut m);
        comm.set_phase(prev);
        r?;
        Ok(if m[0] > 0.0 { &[] } else { built })
    }

    /// Ghosts within the support + `extra` (m), binning and neighbour lists at the current
    /// state.
    fn build_neighbours(&mut self, extra: f64, comm: &dyn Comm) -> Result<()> {
        let support = self.model.kernel.support;
        self.p.truncate_ghosts();
        if self.reordered_at.is_none_or(|s| self.step >= s + REORDER_EVERY) {
            self.reordered_at = Some(self.step);
            // the last step's lists are stale from here on: freed before the table's columns
            // are copied, so that the copies do not add to them
            self.free_step_buffers();
            // owned particles in cell order (then sub-cell and key order) for memory locality
            let t0 = Instant::now();
            let grid = &self.grid;
            let (x, key) = (&self.p.x, &self.p.key);
            let split = self.cells.sub_cell_split();
            let sub = |x: &crate::Vector<D>| if split > 0 { grid.sub_cell(x, split) } else { 0 };
            // each particle's sort key made once, in parallel, then sorted in parallel: the
            // keys are distinct (ids are), so the order is the same on any number of threads
            // (cell + 1, 0 outside the grid, then sub-cell), key, index: 24 B a particle
            let mut keyed: Vec<(u64, u64, u32)> = (0..self.p.n_owned)
                .into_par_iter()
                .map(|i| {
                    let cell = grid.coords(&x[i]).map_or(0, |c| grid.linear(&c) as u64 + 1);
                    (cell << 8 | u64::from(sub(&x[i])), key[i], i as u32)
                })
                .collect();
            keyed.par_sort_unstable();
            let perm: Vec<usize> = keyed.into_iter().map(|k| k.2 as usize).collect();
            self.p.permute_owned(&perm);
            self.timers.add(Timer::Neighbours, t0);
        }
        let t0 = Instant::now();
        let sent = self.build_fields;
        self.halo.build(
            &mut self.p,
            &self.space,
            &self.map,
            &self.boxes,
            support + extra,
            sent,
            comm,
        )?;
        self.fresh.built(sent);
        self.skin.built(&self.p);
        let held = self.p.len();
        self.balance.note_held(held, held - self.p.n_owned);
        self.timers.add(Timer::Halo, t0);
        self.list_neighbours()
    }

    /// Bin owned particles and ghosts, mark the interior (with overlap) and build the
    /// neighbour lists: within the support, whatever the ghosts' reach (Verlet lists: within
    /// the support + the skin, kept until the next ghost build).
    fn list_neighbours(&mut self) -> Result<()> {
        let mut support = self.model.kernel.support;
        if self.nl.is_verlet() {
            support += self.skin.width;
        }
        let t0 = Instant::now();
        self.bin()?;
        if self.overlap && !self.halo.is_empty() {
            let n = self.p.n_owned;
            self.cells
                .mark_interior(&self.window, n, &mut self.near, &mut self.interior);
        } else {
            self.interior.clear();
        }
        let kind = &self.p.kind;
        // fluid and solid particles: half lists in pair mode (every pass they run has a pair
        // kernel there, `passes::check_pair_mode`)
        let own_lists = if self.pair_mode { Wants::Half } else { Wants::All };
        // a cycle's first substep computes no coarse particle: stored lists skip them (Verlet
        // lists serve later substeps too)
        let skip = self
            .coarse_h()
            .filter(|_| self.substep == Substep::Mid && !self.nl.is_verlet());
        let h = &self.p.h;
        self.nl.build(&self.window, &self.cells, &self.p, support, |i| {
            let k = kind[i];
            if !k.is_smoothed() || super::multirate::is_coarse(k, h, skip, i) {
                Wants::Nothing
            } else if k.is_wall() {
                Wants::Fluid
            } else {
                own_lists
            }
        });
        self.timers.add(Timer::Neighbours, t0);
        Ok(())
    }

    /// Refresh `fields` on the ghosts of the classes `kinds` (a halo exchange), timed as
    /// `halo`.
    pub(super) fn refresh(&mut self, need: (Fields, Kinds), comm: &dyn Comm) -> Result<()> {
        let t0 = Instant::now();
        self.halo.refresh(&mut self.p, &self.space, need, comm)?;
        self.timers.add(Timer::Halo, t0);
        Ok(())
    }

    /// Bin owned particles and ghosts into the cells of the grid's window they occupy.
    fn bin(&mut self) -> Result<()> {
        self.window = self.grid.window(&self.p.x);
        if let Err(i) = self.cells.build(&self.window, &self.p) {
            let what = if i < self.p.n_owned {
                "left the cell grid"
            } else {
                "(a ghost) lies outside the cell grid"
            };
            return Err(self.particle_error(i, what));
        }
        Ok(())
    }

    /// Where each dummy wall is during the drift from t to t + `dt` (`self.moves`): at rest
    /// with its surface velocity, or moved by its motion law.
    fn wall_moves(&mut self, dt: f64) {
        let (t0, t1) = (self.t, self.t + dt);
        self.moves.clear();
        for &(b, _) in &self.faces {
            let m = match self.kinematics.iter().find(|k| k.body == b) {
                Some(k) => {
                    let ((from, _, _), (to, u, _)) = (k.at::<D>(t0), k.at::<D>(t1));
                    WallMove { from, to, u }
                }
                None => WallMove {
                    from: Vector::<D>::zeros(),
                    to: Vector::<D>::zeros(),
                    u: Vector::<D>::from_fn(|a, _| {
                        self.scene.walls[b].velocity.get(a).copied().unwrap_or(0.0)
                    }),
                },
            };
            self.moves.push(m);
        }
    }

    /// `x`, reflected back across the mirror plane or dummy wall face that the segment from
    /// `from` (in the fluid) to it crosses, if any, with the walls where they are now: the
    /// drift's bounce applied to a particle placed rather than moved (a split's child).
    pub(super) fn faces_keep_inside(&self, from: &Vector<D>, mut x: Vector<D>) -> Vector<D> {
        let mut v = Vector::<D>::zeros();
        crate::boundary::mirror::bounce_all(&self.space.planes, from, &mut x, &mut v);
        for (b, face) in &self.faces {
            let at = self
                .model
                .wall_shift
                .get(*b)
                .copied()
                .unwrap_or_else(Vector::<D>::zeros);
            let m = WallMove {
                from: at,
                to: at,
                u: Vector::<D>::zeros(),
            };
            face.bounce(from, &mut x, &mut v, &m);
        }
        x
    }

    /// Move walls with a motion law from time `t0` to `t1`.
    pub(super) fn apply_wall_motion(&mut self, t0: f64, t1: f64) {
        let m = &mut self.model;
        motion::move_walls(
            &self.kinematics,
            &mut self.p,
            t0,
            t1,
            &mut m.wall_acc,
            &mut m.wall_shift,
        );
    }

    /// Half kick of owned integrated particles: v += ½dt a.
    pub(super) fn half_kick(&mut self, dt: f64) {
        passes::half_kick(&mut self.p, dt);
    }

    /// Signal speed of owned solid particle `i` for the time step (m/s): the longitudinal wave
    /// speed √((K + 4G/3)/ρ) at its state (K = ρc², c the EOS sound speed; no shear once
    /// failed) plus its speed; 0 for other particles.
    fn solid_signal_speed(&self, i: usize) -> f64 {
        let p = &self.p;
        if !p.kind[i].is_solid() {
            return 0.0;
        }
        let Some(s) = self.model.materials[p.mat[i] as usize].solid() else {
            return 0.0;
        };
        s.signal_speed(p.rho[i], p.energy[i], p.failed[i] != 0) + p.v[i].norm()
    }

    /// The time step for the next step (s): min of CFL·h/max(c0 + |v|max, solid signal
    /// speeds), 0.25 sqrt(h/|a|max)
    /// and 0.125 h²/ν, or the scene's fixed dt; never past t_end.
    pub fn next_dt(&self, comm: &dyn Comm) -> Result<f64> {
        let n = self.p.n_owned;
        // the smallest particles set the step where there are several sizes
        let h = self.model.h_min();
        let dt = if self.scene.time.dt > 0.0 {
            self.scene.time.dt
        } else {
            let (kind, v, a) = (&self.p.kind, &self.p.v, &self.p.acc);
            let (rho, drho) = (&self.p.rho, &self.p.drho);
            let solids = self.model.has_solid;
            type Max4 = (f64, f64, f64, f64);
            let max4 = |x: Max4, y: Max4| (x.0.max(y.0), x.1.max(y.1), x.2.max(y.2), x.3.max(y.3));
            // squared norms, one square root after the reduction: sqrt is correctly rounded and
            // monotone, so √(max |v|²) is max |v| to the bit, at one root per rank instead of
            // two per particle; a scene without solids skips their signal and strain rate
            let (v2, a2, smax, dmax) = (0..n)
                .into_par_iter()
                .with_min_len(1024)
                .fold(
                    || (0.0f64, 0.0f64, 0.0f64, 0.0f64),
                    |m, i| {
                        if !kind[i].is_integrated() {
                            return m;
                        }
                        let (v2, a2) = (v[i].norm_squared(), a[i].norm_squared());
                        let (s, d) = if solids && kind[i].is_solid() {
                            // a solid's volumetric strain rate |dρ/dt|/ρ = |tr L| (1/s)
                            (self.solid_signal_speed(i), (drho[i] / rho[i]).abs())
                        } else {
                            (0.0, 0.0)
                        };
                        max4(m, (v2, a2, s, d))
                    },
                )
                .reduce(|| (0.0f64, 0.0f64, 0.0f64, 0.0f64), max4);
            let (vmax, amax) = (v2.sqrt(), a2.sqrt());
            // max is exact, so the all-reduce gives the same bits on any number of ranks
            let mut m = [vmax, amax, smax, dmax];
            comm.all_reduce_max_f64(&mut m)?;
            let (vmax, amax, smax, dmax) = (m[0], m[1], m[2], m[3]);
            let fluid_signal = if self.model.has_fluid {
                self.model.c_max + vmax
            } else {
                0.0
            };
            let mut dt = self.cfl_bound(h, fluid_signal.max(smax), amax);
            if dmax > 0.0 {
                // a solid's volume changes by at most 10 % per step (colliding debris)
                dt = dt.min(0.1 / dmax);
            }
            dt
        };
        Ok(self.up_to_end(dt))
    }

    /// The CFL bound (s) of particles of smoothing length `h` (m) whose largest signal speed is
    /// `signal` (m/s) and largest acceleration `amax` (m/s²): the smallest of cfl·h/signal,
    /// 0.25 √(h/amax) and, with a viscosity ν (m²/s), 0.125 h²/ν (Monaghan 1992; Morris, Fox
    /// & Zhu 1997). One arithmetic for the global step and each class of local steps.
    pub(super) fn cfl_bound(&self, h: f64, signal: f64, amax: f64) -> f64 {
        let mut dt = self.scene.time.cfl * h / signal;
        if amax > 0.0 {
            dt = dt.min(0.25 * (h / amax).sqrt());
        }
        if self.model.nu > 0.0 {
            dt = dt.min(0.125 * h * h / self.model.nu);
        }
        dt
    }

    /// `span` (s), or the time left to t_end when that is shorter or within a relative 1e-9
    /// of it (the last step lands on t_end).
    pub(super) fn up_to_end(&self, span: f64) -> f64 {
        let left = self.scene.time.t_end - self.t;
        if left > 0.0 && left < span * (1.0 + 1e-9) {
            left
        } else {
            span
        }
    }
}

/// Collective, in the set-up's iterations (relaxation, settling): if any rank has received a
/// stopping signal, every rank stops here with [`Error::Stopped`] (exit 3). The set-up has
/// nothing to keep yet, so the run directory is left as it was before the run.
fn stop_in_setup(comm: &dyn Comm, at: impl FnOnce() -> String) -> Result<()> {
    match crate::signals::agreed_stop(comm)? {
        Some(sig) => Err(Error::Stopped(format!(
            "{sig} during the set-up ({}), before step 1: nothing to continue, nothing written; run \
             the scene again",
            at()
        ))),
        None => Ok(()),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::comm::serial::SerialComm;

    /// Run `pass` of `sim` on a copy of its particles and solid scratch, over every particle at
    /// once (`None`) or over the parts `parts` of `mask` in turn; their state afterwards,
    /// printed exactly.
    fn after(sim: &Simulation<2>, pass: Pass, mask: Option<(&[bool], &[bool])>) -> String {
        let (p, solid) = on_copy(sim, |c| match mask {
            None => pass.run(c, &sim.nl, None),
            Some((mask, parts)) => {
                for &part in parts {
                    let nb = Subset {
                        all: &sim.nl,
                        mask,
                        part,
                    };
                    pass.run(c, &nb, None);
                }
            }
        });
        format!("{p:?} {solid:?}")
    }

    /// Run `f` on a copy of `sim`'s particles and solid scratch, with fresh pair scratch;
    /// the copies afterwards.
    fn on_copy(
        sim: &Simulation<2>,
        f: impl FnOnce(&mut Ctx<'_, 2>),
    ) -> (
        crate::particles::Particles<2>,
        crate::physics::solid::dynamics::SolidScratch<2>,
    ) {
        let (mut p, mut solid) = (sim.p.clone(), sim.solid.clone());
        let mut pair = crate::physics::pairs::PairScratch::default();
        f(&mut Ctx {
            p: &mut p,
            model: &sim.model,
            space: &sim.space,
            dt: sim.dt,
            pair: &mut pair,
            solid: &mut solid,
        });
        (p, solid)
    }

    /// The momentum pass with the lagged gradient (`physics.density_gradient = "lagged"`) gives
    /// the momentum pass's accelerations and the gradient pass's ⟨∇ρ⟩^L of the same state to the
    /// bit: in pair mode one visit of each pair serves both, with the same operations in the
    /// same order per slot; in gather mode it runs the two gather kernels.
    #[test]
    fn the_momentum_pass_with_the_gradient_gives_both_passes_bits() {
        let comm = SerialComm::new();
        for mode in ["gather", "pairs"] {
            let sets = vec![format!("performance.interactions=\"{mode}\"")];
            let (scene, _) =
                crate::scene::load_scene(std::path::Path::new("inputs/dam_break_2d.toml"), &sets).unwrap();
            let mut sim = Simulation::<2>::new(&scene, &comm).unwrap();
            for _ in 0..40 {
                sim.advance(&comm).unwrap();
            }
            let half = sim.nl.half(&sim.window, &sim.cells);
            let half = half.as_ref().filter(|_| sim.pair_mode);
            assert_eq!(half.is_some(), mode == "pairs");
            let run = |passes: &[Pass]| {
                let (p, _) = on_copy(&sim, |c| {
                    for pass in passes {
                        pass.run(c, &sim.nl, half);
                    }
                });
                let n = p.n_owned;
                (format!("{:?}", &p.acc[..n]), format!("{:?}", &p.grad_rho[..n]))
            };
            let (acc, grad) = run(&[Pass::DensityGradient, Pass::Momentum]);
            let fused = run(&[Pass::MomentumGradient]);
            assert!(fused.0 == acc, "{mode}: accelerations differ");
            assert!(fused.1 == grad, "{mode}: gradients differ");
            let zero = format!("{:?}", vec![Vector::<2>::zeros(); sim.p.n_owned]);
            assert_ne!(grad, zero, "{mode}: no gradient computed");
        }
    }

    /// The wall extrapolation computed in waves of particles, each written back before the
    /// next is computed, gives the bits of one sweep (a wall reads only fluid neighbours), and
    /// it does change the walls' pressure.
    #[test]
    fn walls_updated_in_waves_give_the_bits_of_one_sweep() {
        let comm = SerialComm::new();
        let (scene, _) =
            crate::scene::load_scene(std::path::Path::new("inputs/dam_break_2d.toml"), &[]).unwrap();
        let mut sim = Simulation::<2>::new(&scene, &comm).unwrap();
        for _ in 0..10 {
            sim.advance(&comm).unwrap();
        }
        let n = sim.p.n_owned;
        // the walls' pressure cleared first, so that an extrapolation that wrote nothing shows
        let mut cleared = sim.p.clone();
        for i in 0..n {
            if cleared.kind[i].is_wall() {
                cleared.p[i] = 0.0;
            }
        }
        let show = |p: &crate::particles::Particles<2>| {
            format!("{:?} {:?} {:?}", &p.p[..n], &p.rho[..n], &p.vw[..n])
        };
        let walls = |wave: usize| {
            let mut p = cleared.clone();
            crate::boundary::update_walls_in_waves(&mut p, &sim.nl, &sim.model.wall_context(0.0), wave);
            show(&p)
        };
        let whole = walls(n);
        assert_eq!(whole, walls(7), "waves of 7 particles");
        assert_eq!(whole, walls(n / 3 + 1), "three waves");
        assert_ne!(whole, show(&cleared), "the extrapolation wrote no wall");
    }

    /// Freeing the step's lists, cells and pair accumulators between steps (as the driver does
    /// before it gathers a view) changes no bit: the next step builds them again, in gather and
    /// in pair mode.
    #[test]
    fn freeing_the_step_buffers_changes_no_bit() {
        let comm = SerialComm::new();
        for mode in ["gather", "pairs"] {
            let sets = vec![format!("performance.interactions=\"{mode}\"")];
            let (scene, _) =
                crate::scene::load_scene(std::path::Path::new("inputs/dam_break_2d.toml"), &sets).unwrap();
            let mut kept = Simulation::<2>::new(&scene, &comm).unwrap();
            let mut freed = Simulation::<2>::new(&scene, &comm).unwrap();
            for _ in 0..20 {
                kept.advance(&comm).unwrap();
                freed.advance(&comm).unwrap();
                assert!(freed.nl.entries() > 0);
                freed.release_step_buffers();
                assert_eq!(freed.nl.entries(), 0, "{mode}: lists kept");
                assert!(freed.cells.order.is_empty(), "{mode}: cells kept");
            }
            assert_eq!(format!("{:?}", kept.p), format!("{:?}", freed.p), "{mode}");
            assert_eq!(kept.dt.to_bits(), freed.dt.to_bits(), "{mode}");
        }
    }

    /// A pass that splits (`Pass::splits`) gives the same bits run over a part of the
    /// particles and then the rest as run over all at once — what overlapping the ghost
    /// exchange with the interior needs — on fluid with dummy walls, δ-SPH, shifting and the
    /// renormalised laminar term, and on an elastic plate; and a pass that reads what it
    /// writes (shifting moves the positions it reads) does not split. A part with no particle
    /// leaves the state as it was: the kernels skip what they do not visit.
    #[test]
    fn a_split_pass_gives_the_bits_of_one_run() {
        let comm = SerialComm::new();
        let cases: [(&str, &[&str], u64); 3] = [
            ("inputs/dam_break_2d.toml", &[], 40),
            (
                "inputs/poiseuille_2d.toml",
                &[
                    "physics.viscous_operator=\"renormalised\"",
                    "physics.shifting=\"delta_plus\"",
                ],
                20,
            ),
            ("inputs/oscillating_plate.toml", &[], 20),
        ];
        let mut split = Vec::new();
        for (path, sets, steps) in cases {
            let sets: Vec<String> = sets.iter().map(|s| s.to_string()).collect();
            let (scene, _) = crate::scene::load_scene(std::path::Path::new(path), &sets).unwrap();
            let mut sim = Simulation::<2>::new(&scene, &comm).unwrap();
            for _ in 0..steps {
                sim.advance(&comm).unwrap();
            }
            // a scattered part, as an interior is (every third particle and a run of them)
            let mask: Vec<bool> = (0..sim.p.n_owned)
                .map(|i| i % 3 == 0 || (100..400).contains(&i))
                .collect();
            for &pass in sim.schedule.iter().filter(|p| p.splits()) {
                let whole = after(&sim, pass, None);
                let parts = after(&sim, pass, Some((&mask, &[true, false])));
                assert!(whole == parts, "{path}: pass {} split differs", pass.name());
                let before = format!("{:?} {:?}", sim.p, sim.solid);
                assert_ne!(whole, before, "{}", pass.name());
                let none = vec![false; mask.len()];
                let nothing = after(&sim, pass, Some((&none, &[true])));
                assert!(
                    nothing == before,
                    "{path}: pass {} visited a particle outside its part",
                    pass.name()
                );
                split.push(pass.name());
            }
        }
        for name in [
            "density_gradient",
            "continuity",
            "viscous_moment",
            "wall_extrapolation",
            "momentum",
            "solid_correction",
            "solid_rates",
            "solid_momentum",
        ] {
            assert!(split.contains(&name), "{name} did not split: {split:?}");
        }
        assert!(!Pass::Shift.splits() && !Pass::Kick.splits() && !Pass::DensityUpdate.splits());
    }
}

//! Load balance during the run: every `check_every` steps the loads are all-reduced and, above
//! the threshold, the cut planes move by parallel bisection from where they were (seed 000's
//! incremental rebalance); then particles that left their rank's box migrate.

use super::multirate::Substep;
use super::timers::Timer;
use super::Simulation;
use crate::comm::{Comm, Phase};
use crate::decomp::{imbalance_weighted, rank_imbalance, BalanceParams};
use crate::error::Result;
use crate::halo::migrate;
use crate::scene::LoadKind;
use std::time::Instant;

/// Load-balance settings and what happened (`[balance]` in the scene).
#[derive(Debug, Clone, Default)]
pub struct BalanceStats {
    /// Particles this rank sent away by migration, in total.
    pub migrated: u64,
    /// Load-balance checks made.
    pub checks: u64,
    /// Rebalances done, with the step of each.
    pub rebalance_steps: Vec<u64>,
    /// max/mean load after the last check or rebalance.
    pub imbalance: f64,
    /// Largest cut-plane displacement of any rebalance (m).
    pub max_plane_shift: f64,
    /// max/mean load after the initial decomposition and after each rebalance.
    pub imbalance_history: Vec<f64>,
    /// Most particles this rank has held at once (owned + ghosts, and every particle the
    /// set-up materialised, kept or not), from the set-up on (O(N/P):
    /// docs/performance_model.md, "Memory per rank").
    pub particle_high_water: u64,
    /// Most ghosts this rank has held at once.
    pub ghost_high_water: u64,
    /// A balance check fell due at a step without a ghost build (Verlet lists): it waits for
    /// the next build ([`Simulation::check_balance_at_build`]).
    pub deferred: bool,
}

impl BalanceStats {
    /// Note that this rank holds `held` particles, `ghosts` of them ghosts.
    pub fn note_held(&mut self, held: usize, ghosts: usize) {
        self.particle_high_water = self.particle_high_water.max(held as u64);
        self.ghost_high_water = self.ghost_high_water.max(ghosts as u64);
    }
}

impl<const D: usize> Simulation<D> {
    /// The load imbalance: max/mean over ranks of the load being balanced (`balance.load`:
    /// particles, or their expected pairs), under `balance.weights`.
    pub(super) fn load_imbalance(&self, comm: &dyn Comm) -> Result<f64> {
        let mut loads = vec![0u64; self.ranks];
        loads[self.rank] = self.particle_loads().sum();
        let prev = comm.set_phase(Phase::Balance);
        comm.all_reduce_sum_u64(&mut loads)?;
        comm.set_phase(prev);
        Ok(rank_imbalance(&loads, &self.scene.balance.weights))
    }

    /// Load of each owned particle (`[balance] load`): 1, or 1 + its neighbour count from the
    /// last neighbour search (valid until particles migrate). An iterator: the sum at set-up
    /// needs no vector on top of the first step's buffers (the run's memory peak).
    fn particle_loads(&self) -> impl Iterator<Item = u64> + '_ {
        let n = self.p.n_owned;
        let pairs = self.scene.balance.load == LoadKind::Pairs && self.nl.listed() == n;
        (0..n).map(move |i| match pairs {
            true => 1 + self.nl.load(i, &self.cells) as u64,
            false => 1,
        })
    }

    /// Relative speed of each rank (`[balance] weights`), if given.
    fn rank_weights(&self) -> Option<Vec<f64>> {
        let w = &self.scene.balance.weights;
        (!w.is_empty()).then(|| (0..self.ranks).map(|r| w[r % w.len()]).collect())
    }

    /// True if step `step` checks the load balance (several ranks, every `check_every` steps).
    pub(super) fn balance_checked_at(&self, step: u64) -> bool {
        let every = self.scene.balance.check_every;
        self.ranks > 1 && every > 0 && step.is_multiple_of(every)
    }

    /// True if the balance check of the next step reads this step's neighbour lists
    /// (`balance.load = "pairs"`).
    /// A cycle ([`super::multirate`]) checks at its first substep for both of its steps.
    pub(super) fn next_check_reads_lists(&self) -> bool {
        self.scene.balance.load == LoadKind::Pairs
            && (self.balance_checked_at(self.step + 1)
                || (self.cycle && self.balance_checked_at(self.step + 2)))
    }

    /// Every `check_every` steps, check the load balance and, above the threshold, move the
    /// cut planes (starting from the current ones). True if the planes moved (the particles
    /// must then migrate and the ghosts be built again).
    /// In a cycle ([`super::multirate`]) the first substep checks for both of the cycle's
    /// steps, while the lists of the last whole step or cycle end hold every particle's pairs
    /// (the first substep lists only the fine particles').
    pub(super) fn check_balance(&mut self, comm: &dyn Comm) -> Result<bool> {
        let due = match self.substep {
            Substep::Whole => self.balance_checked_at(self.step),
            Substep::Mid => self.balance_checked_at(self.step) || self.balance_checked_at(self.step + 1),
            Substep::End => false,
        };
        if !due {
            return Ok(false);
        }
        self.balance_check(comm)
    }

    /// With Verlet lists the builds come from the particles' motion alone, so that they fall
    /// on the same steps on any layout (the lists, hence the sums' order, are those of the
    /// last build): a check that falls due between builds waits for the next one (`built`:
    /// this step builds). True if the planes moved.
    pub(super) fn check_balance_at_build(&mut self, built: bool, comm: &dyn Comm) -> Result<bool> {
        self.balance.deferred |= self.balance_checked_at(self.step);
        if !(built && self.balance.deferred) {
            return Ok(false);
        }
        self.balance.deferred = false;
        self.balance_check(comm)
    }

    /// Check the load balance now and, above the threshold, move the cut planes.
    fn balance_check(&mut self, comm: &dyn Comm) -> Result<bool> {
        let b = &self.scene.balance;
        let t0 = Instant::now();
        self.balance.checks += 1;
        // loads are taken before migration, while the neighbour lists match the particles
        let imb = self.load_imbalance(comm)?;
        self.balance.imbalance = imb;
        let moved = imb > b.threshold && self.rebalance(comm)?;
        self.timers.add(Timer::Balance, t0);
        Ok(moved)
    }

    /// Migrate every particle that left this rank's box, once (the ghosts are dropped).
    pub(super) fn migrate(&mut self, comm: &dyn Comm) -> Result<()> {
        let t0 = Instant::now();
        self.p.truncate_ghosts();
        self.balance.migrated += migrate(&mut self.p, &self.map, &self.boxes, comm)? as u64;
        self.balance.note_held(self.p.n_owned, 0);
        self.timers.add(Timer::Migration, t0);
        Ok(())
    }

    /// Move the cut planes by parallel bisection on all-reduced loads, from where they are.
    /// False when they stay (a count cap, `balance.max_count`, can hold them where the loads
    /// are still above the threshold).
    fn rebalance(&mut self, comm: &dyn Comm) -> Result<bool> {
        let loads: Vec<u64> = self.particle_loads().collect();
        let params = BalanceParams {
            weights: self.rank_weights().map(|w| {
                (0..self.ranks)
                    .map(|blk| w[self.map.block_to_rank[blk]])
                    .collect()
            }),
            id_bound: Some(self.ids.next()),
            max_count: self.scene.balance.count_cap(),
            ..BalanceParams::default()
        };
        let prev = comm.set_phase(Phase::Balance);
        let x = &self.p.x[..self.p.n_owned];
        let id = &self.p.id[..self.p.n_owned];
        let mut err = None;
        let (next, report) = self
            .map
            .decomp
            .rebalance(&params, self.scene.discretisation.dx, |stage| {
                let items = x.iter().zip(id).zip(&loads).map(|((x, i), w)| (*x, *i, *w));
                let mut counts = stage.count_local(items);
                if let Err(e) = comm.all_reduce_sum_u64(&mut counts) {
                    err.get_or_insert(e);
                }
                counts
            });
        comm.set_phase(prev);
        if let Some(e) = err {
            return Err(e);
        }
        if next == self.map.decomp {
            return Ok(false);
        }
        self.balance.max_plane_shift = self.balance.max_plane_shift.max(report.max_displacement());
        self.balance.rebalance_steps.push(self.step);
        // the last counting round gives every block's load: no extra message
        self.balance.imbalance = match &params.weights {
            Some(w) => imbalance_weighted(&report.block_loads, w),
            None => report.imbalance(),
        };
        self.balance.imbalance_history.push(self.balance.imbalance);
        self.map.decomp = next;
        self.boxes = self.map.boxes();
        Ok(true)
    }
}

//! One rank's simulation state and the step loop (kick–drift–kick leapfrog).
//!
//! A step, as named phases (timers in `diagnostics.csv`):
//! `kick ½ (v) → drift (x, wall motion) → wrap/check → ghosts → bin → neighbour lists →
//! [δ-SPH gradient → ghost refresh] → continuity → ρ update, EOS → ghost refresh →
//! [dummy-wall extrapolation → ghost refresh] → momentum → kick ½ (v) → dt`
//! (see [`Simulation::advance`] for why continuity and momentum are separate passes).
//! On many ranks, migration (and every `check_every` steps a load-balance check) comes before
//! `ghosts`, and every ghost build or refresh is a halo exchange through [`Comm`] sending only
//! the fields the next pass reads; one rank goes through the same path (self-sends).

use crate::cells::{CellGrid, CellList, NeighbourList};
use crate::comm::Tag;
use crate::comm::{Comm, Phase};
use crate::decomp::{factorise, imbalance, imbalance_weighted, BalanceParams, Decomposition};
use crate::error::{Error, Result};
use crate::exact::ExactSum;
use crate::ghosts::{ImageSpace, MirrorPlane};
use crate::halo::{migrate, pack_owned, unpack_owned, Fields, HaloPlan, Ranks};
use crate::placement::{halo_volumes, place, Placement};
use crate::topology::Topology;

/// Tag of the output gather.
const TAG_GATHER: Tag = 110;
use crate::particles::{Kind, Particles};
use crate::physics::{delta, fluid, walls, Model};
use crate::scene::{DensityDiffusion, LoadKind, Motion, Scene, WallMethod, WallShape};
use crate::setup::build_particles;
use crate::Vector;
use rayon::prelude::*;
use std::time::Instant;

/// Steps between reorderings of the owned particles into cell order.
const REORDER_EVERY: u64 = 16;

/// Names of the timed phases, in the order of `diagnostics.csv`.
pub const PHASES: [&str; 7] = [
    "neighbours",
    "forces",
    "integrate",
    "halo",
    "migration",
    "balance",
    "output",
];

/// Wall-clock seconds spent per phase.
#[derive(Debug, Clone, Default)]
pub struct PhaseTimers {
    /// Seconds per phase, indexed like [`PHASES`].
    pub seconds: [f64; 7],
}

impl PhaseTimers {
    /// Add the time since `t0` to phase `k`.
    pub fn add(&mut self, k: usize, t0: Instant) {
        self.seconds[k] += t0.elapsed().as_secs_f64();
    }
}

/// Physics observables of one output step (one row of `timeseries.csv`).
#[derive(Debug, Clone)]
pub struct Observables<const D: usize> {
    /// Kinetic energy Σ ½ m |v|² of the fluid (J, or J/m in 2D).
    pub kinetic_energy: f64,
    /// Momentum Σ m v of the fluid (kg m/s).
    pub momentum: Vector<D>,
    /// Largest fluid speed (m/s).
    pub max_speed: f64,
}

/// The whole state gathered on rank 0 for output: every owned particle of every rank, sorted by
/// id, no ghosts. Field names follow [`Simulation`] so output code reads either alike.
pub struct View<'a, const D: usize> {
    /// Every particle, sorted by id.
    pub p: Particles<D>,
    /// Simulated time (s).
    pub t: f64,
    /// Steps taken.
    pub step: u64,
    /// Time step for the next step (s).
    pub dt: f64,
    /// The resolved scene.
    pub scene: &'a Scene,
    /// Physics constants.
    pub model: &'a Model<D>,
}

impl<const D: usize> View<'_, D> {
    /// Number of particles (fluid and wall).
    pub fn n_particles(&self) -> usize {
        self.p.n_owned
    }

    /// Indices in id order (the identity: a view is sorted).
    pub fn by_id(&self) -> Vec<usize> {
        (0..self.p.n_owned).collect()
    }
}

/// Prescribed motion of one wall body.
#[derive(Debug, Clone)]
struct WallKinematics<const D: usize> {
    body: usize,
    motion: Motion,
}

impl<const D: usize> WallKinematics<D> {
    /// Displacement, velocity and acceleration at time t.
    fn at(&self, t: f64) -> (Vector<D>, Vector<D>, Vector<D>) {
        match &self.motion {
            Motion::Sine {
                amplitude,
                period,
                phase,
            } => {
                let w = 2.0 * std::f64::consts::PI / period;
                let a = Vector::<D>::from_fn(|k, _| amplitude[k]);
                let arg = w * t + phase;
                (
                    a * (arg.sin() - phase.sin()),
                    a * (w * arg.cos()),
                    a * (-w * w * arg.sin()),
                )
            }
            Motion::ConstantVelocity { velocity } => {
                let u = Vector::<D>::from_fn(|k, _| velocity[k]);
                (u * t, u, Vector::zeros())
            }
        }
    }
}

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
}

/// The state of one rank.
pub struct Simulation<const D: usize> {
    /// The resolved scene.
    pub scene: Scene,
    /// Physics constants.
    pub model: Model<D>,
    /// Particles (owned, then ghosts).
    pub p: Particles<D>,
    /// Periodic box and mirror planes.
    pub space: ImageSpace<D>,
    /// Cell grid.
    pub grid: CellGrid<D>,
    /// Particles binned by cell.
    pub cells: CellList,
    /// Neighbour lists of owned particles.
    pub nl: NeighbourList,
    /// Halo plan (ghosts from this rank's images and from other ranks).
    pub halo: HaloPlan<D>,
    /// Decomposition of the domain into one block per rank and the blocks' ranks.
    pub map: Ranks<D>,
    /// Box of every rank (m), from `map`.
    pub boxes: Vec<(Vector<D>, Vector<D>)>,
    /// This rank.
    pub rank: usize,
    /// Number of ranks.
    pub ranks: usize,
    /// Load balancing and migration counters.
    pub balance: BalanceStats,
    /// Simulated time (s).
    pub t: f64,
    /// Steps taken.
    pub step: u64,
    /// Time step for the next step (s).
    pub dt: f64,
    /// Phase timers.
    pub timers: PhaseTimers,
    /// Pair interactions evaluated so far (directed neighbour-list entries × passes).
    pub pair_count: u64,
    kinematics: Vec<WallKinematics<D>>,
    has_dummy: bool,
}

impl<const D: usize> Simulation<D> {
    /// Build this rank's particles, decompose the domain over `comm.size()` ranks and compute
    /// the initial rates and time step. Every rank builds the whole lattice and balances the
    /// cut planes on it (identical on every rank, no communication), then keeps its block.
    pub fn new(scene: &Scene, comm: &dyn Comm) -> Result<Self> {
        Self::with_layout(scene, comm, &Layout::default())
    }

    /// [`Simulation::new`] with blocks placed on ranks by `layout` (issue 4): the placement
    /// is computed on every rank from the same particles, so all agree without messages.
    pub fn with_layout(scene: &Scene, comm: &dyn Comm, layout: &Layout) -> Result<Self> {
        let all = build_particles::<D>(scene)?;
        let (rank, ranks) = (comm.rank(), comm.size());
        let model = Model::<D>::new(scene);
        let space = image_space::<D>(scene);
        let (min, max) = (space.min, space.max);
        let kinematics = scene
            .walls
            .iter()
            .enumerate()
            .filter_map(|(b, w)| w.motion.clone().map(|m| WallKinematics { body: b, motion: m }))
            .collect();
        let grid = CellGrid::new(&min, &max, model.kernel.support);
        let has_dummy = all.kind.contains(&Kind::Dummy);
        let support = model.kernel.support;
        let (map, p) = decompose(all, &min, &max, ranks, rank, layout, support)?;
        let boxes = map.boxes();
        let mut sim = Simulation {
            scene: scene.clone(),
            model,
            p,
            space,
            grid,
            cells: CellList::default(),
            nl: NeighbourList::default(),
            halo: HaloPlan::default(),
            map,
            boxes,
            rank,
            ranks,
            balance: BalanceStats::default(),
            t: 0.0,
            step: 0,
            dt: 0.0,
            timers: PhaseTimers::default(),
            pair_count: 0,
            kinematics,
            has_dummy,
        };
        sim.apply_wall_motion(0.0, 0.0);
        sim.check_state()?;
        sim.update_pressure();
        // the set-up runs the exchange sequence of a whole step (its dρ/dt is recomputed
        // before use), so its halo traffic is one step's, as `hsph plan` predicts
        sim.rebuild_neighbours(comm)?;
        sim.density_rate(comm)?;
        sim.refresh(Fields::RHO.or(Fields::P), comm)?;
        sim.forces(comm)?;
        sim.balance.imbalance = sim.load_imbalance(comm)?;
        sim.balance.imbalance_history.push(sim.balance.imbalance);
        sim.dt = sim.next_dt(comm)?;
        Ok(sim)
    }

    /// Number of owned particles (fluid and wall).
    pub fn n_particles(&self) -> usize {
        self.p.n_owned
    }

    /// p = EOS(ρ) for owned fluid particles.
    fn update_pressure(&mut self) {
        let n = self.p.n_owned;
        let (kind, mat, rho) = (&self.p.kind, &self.p.mat, &self.p.rho);
        let eos = &self.model.eos;
        self.p.p[..n].par_iter_mut().enumerate().for_each(|(i, pi)| {
            if kind[i] == Kind::Fluid {
                *pi = eos[mat[i] as usize].pressure(rho[i]);
            }
        });
    }

    /// Ghosts (positions and every field), binning and neighbour lists at the current state.
    fn rebuild_neighbours(&mut self, comm: &dyn Comm) -> Result<()> {
        let support = self.model.kernel.support;
        self.p.truncate_ghosts();
        if self.step % REORDER_EVERY == 0 {
            // owned particles in cell order (then key order) for memory locality
            let t0 = Instant::now();
            let grid = &self.grid;
            let (x, key) = (&self.p.x, &self.p.key);
            let mut perm: Vec<usize> = (0..self.p.n_owned).collect();
            perm.sort_unstable_by_key(|&i| (grid.coords(&x[i]).map(|c| grid.linear(&c)), key[i]));
            self.p.permute_owned(&perm);
            self.timers.add(0, t0);
        }
        let t0 = Instant::now();
        self.halo
            .build(&mut self.p, &self.space, &self.map, &self.boxes, support, comm)?;
        self.timers.add(3, t0);
        let t0 = Instant::now();
        self.bin()?;
        let kind = &self.p.kind;
        self.nl.build(&self.grid, &self.cells, &self.p, support, |i| {
            kind[i] != Kind::Repulsive
        });
        self.timers.add(0, t0);
        Ok(())
    }

    /// Refresh `fields` on every ghost (a halo exchange), timed as `halo`.
    fn refresh(&mut self, fields: Fields, comm: &dyn Comm) -> Result<()> {
        let t0 = Instant::now();
        self.halo.refresh(&mut self.p, &self.space, fields, comm)?;
        self.timers.add(3, t0);
        Ok(())
    }

    /// Bin owned particles and ghosts into cells.
    fn bin(&mut self) -> Result<()> {
        if let Err(i) = self.cells.build(&self.grid, &self.p) {
            let n = self.p.n_owned;
            let what = if i < n {
                "left the cell grid"
            } else {
                "(a ghost) lies outside the cell grid"
            };
            return Err(self.particle_error(i, what));
        }
        Ok(())
    }

    /// Density pass: [⟨∇ρ⟩^L → halo] → dρ/dt of fluid particles.
    fn density_rate(&mut self, comm: &dyn Comm) -> Result<()> {
        if self.model.diffusion == DensityDiffusion::Antuono {
            let t0 = Instant::now();
            delta::renormalised_gradient(&mut self.p, &self.nl, &self.model);
            self.pair_count += self.nl.pairs() as u64;
            self.timers.add(1, t0);
            self.refresh(Fields::GRAD_RHO, comm)?;
        }
        let t0 = Instant::now();
        fluid::continuity(&mut self.p, &self.nl, &self.model);
        self.pair_count += self.nl.pairs() as u64;
        self.timers.add(1, t0);
        Ok(())
    }

    /// Force pass: [dummy-wall extrapolation → halo] → dv/dt of fluid particles.
    fn forces(&mut self, comm: &dyn Comm) -> Result<()> {
        if self.has_dummy {
            let t0 = Instant::now();
            walls::extrapolate(&mut self.p, &self.nl, &self.model);
            self.pair_count += self.nl.pairs() as u64;
            self.timers.add(1, t0);
            self.refresh(Fields::P.or(Fields::RHO).or(Fields::VW), comm)?;
        }
        let t0 = Instant::now();
        fluid::momentum(&mut self.p, &self.nl, &self.model);
        self.pair_count += self.nl.pairs() as u64;
        self.timers.add(1, t0);
        Ok(())
    }

    /// dρ/dt of the current state (for tests and diagnostics).
    pub fn compute_density_rate(&mut self, comm: &dyn Comm) -> Result<()> {
        self.rebuild_neighbours(comm)?;
        self.density_rate(comm)
    }

    /// max/mean of the owned-particle counts over ranks.
    fn load_imbalance(&self, comm: &dyn Comm) -> Result<f64> {
        let mut loads = vec![0u64; self.ranks];
        loads[self.rank] = self.particle_loads().iter().sum();
        let prev = comm.set_phase(Phase::Balance);
        comm.all_reduce_sum_u64(&mut loads)?;
        comm.set_phase(prev);
        Ok(match self.rank_weights() {
            Some(w) => imbalance_weighted(&loads, &w),
            None => imbalance(&loads),
        })
    }

    /// Load of each owned particle (`[balance] load`): 1, or 1 + its neighbour count from the
    /// last neighbour search (valid until particles migrate).
    fn particle_loads(&self) -> Vec<u64> {
        let n = self.p.n_owned;
        match self.scene.balance.load {
            LoadKind::Pairs if self.nl.start.len() == n + 1 => (0..n)
                .map(|i| 1 + (self.nl.start[i + 1] - self.nl.start[i]) as u64)
                .collect(),
            _ => vec![1; n],
        }
    }

    /// Relative speed of each rank (`[balance] weights`), if given.
    fn rank_weights(&self) -> Option<Vec<f64>> {
        let w = &self.scene.balance.weights;
        (!w.is_empty()).then(|| (0..self.ranks).map(|r| w[r % w.len()]).collect())
    }

    /// Every `check_every` steps, check the load balance and, above the threshold, move the
    /// cut planes (starting from the current ones); then migrate every particle that left this
    /// rank's box, once.
    fn migrate_and_balance(&mut self, comm: &dyn Comm) -> Result<()> {
        let b = &self.scene.balance;
        if self.ranks > 1 && b.check_every > 0 && self.step % b.check_every == 0 {
            let t0 = Instant::now();
            self.balance.checks += 1;
            // loads are taken before migration, while the neighbour lists match the particles
            let imb = self.load_imbalance(comm)?;
            self.balance.imbalance = imb;
            if imb > b.threshold {
                let loads = self.particle_loads();
                let params = BalanceParams {
                    weights: self.rank_weights().map(|w| {
                        (0..self.ranks)
                            .map(|blk| w[self.map.block_to_rank[blk]])
                            .collect()
                    }),
                    ..BalanceParams::default()
                };
                let prev = comm.set_phase(Phase::Balance);
                let x = &self.p.x[..self.p.n_owned];
                let mut err = None;
                let (next, report) =
                    self.map
                        .decomp
                        .rebalance(&params, self.scene.discretisation.dx, |stage| {
                            let mut counts = stage.count_local(x.iter().zip(&loads).map(|(x, w)| (*x, *w)));
                            if let Err(e) = comm.all_reduce_sum_u64(&mut counts) {
                                err.get_or_insert(e);
                            }
                            counts
                        });
                comm.set_phase(prev);
                if let Some(e) = err {
                    return Err(e);
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
            }
            self.timers.add(5, t0);
        }
        let t0 = Instant::now();
        self.p.truncate_ghosts();
        self.balance.migrated += migrate(&mut self.p, &self.map, &self.boxes, comm)? as u64;
        self.timers.add(4, t0);
        Ok(())
    }

    /// Move walls with a motion law from time `t0` to `t1`.
    fn apply_wall_motion(&mut self, t0: f64, t1: f64) {
        for k in &self.kinematics {
            let (d0, _, _) = k.at(t0);
            let (d1, v1, a1) = k.at(t1);
            let dd = d1 - d0;
            for i in 0..self.p.n_owned {
                if self.p.kind[i] != Kind::Fluid && self.p.body[i] as usize == k.body {
                    self.p.x[i] += dd;
                    self.p.v[i] = v1;
                }
            }
            self.model.wall_acc[k.body] = a1;
        }
    }

    /// Half kick of owned fluid particles: v += ½dt a.
    fn half_kick(&mut self, dt: f64) {
        let n = self.p.n_owned;
        let h = 0.5 * dt;
        let (kind, acc) = (&self.p.kind, &self.p.acc);
        self.p.v[..n].par_iter_mut().enumerate().for_each(|(i, v)| {
            if kind[i] == Kind::Fluid {
                *v += acc[i] * h;
            }
        });
    }

    /// Advance one step of the Störmer–Verlet scheme with (x, ρ) as coordinates and v as
    /// momentum: v_{n+½} = v_n + ½dt a_n; x_{n+1} = x_n + dt v_{n+½};
    /// ρ_{n+1} = ρ_n + dt (dρ/dt)(x_{n+1}, v_{n+½}, ρ_n); v_{n+1} = v_{n+½} + ½dt a_{n+1}.
    /// Evaluating dρ/dt and dv/dt from one state instead (one fused pass) makes the acoustic
    /// (ρ, v) coupling grow by 1 + (ω dt)²/4 per step, which is why the passes are split.
    pub fn advance(&mut self, comm: &dyn Comm) -> Result<()> {
        let dt = self.dt;
        let t0 = Instant::now();
        self.half_kick(dt);
        {
            let n = self.p.n_owned;
            let space = &self.space;
            let (kind, v) = (&self.p.kind, &self.p.v);
            self.p.x[..n].par_iter_mut().enumerate().for_each(|(i, x)| {
                if kind[i] == Kind::Fluid {
                    *x += v[i] * dt;
                    space.wrap(x);
                }
            });
        }
        let t_new = self.t + dt;
        self.apply_wall_motion(self.t, t_new);
        self.t = t_new;
        self.step += 1;
        self.check_state()?;
        self.timers.add(2, t0);
        self.migrate_and_balance(comm)?;
        self.rebuild_neighbours(comm)?;
        self.density_rate(comm)?;
        let t0 = Instant::now();
        {
            let n = self.p.n_owned;
            let (kind, drho) = (&self.p.kind, &self.p.drho);
            self.p.rho[..n].par_iter_mut().enumerate().for_each(|(i, rho)| {
                if kind[i] == Kind::Fluid {
                    *rho += drho[i] * dt;
                }
            });
        }
        self.update_pressure();
        self.timers.add(2, t0);
        self.refresh(Fields::RHO.or(Fields::P), comm)?;
        self.forces(comm)?;
        let t0 = Instant::now();
        self.half_kick(dt);
        self.check_finite()?;
        self.timers.add(2, t0);
        self.dt = self.next_dt(comm)?;
        Ok(())
    }

    /// The time step for the next step (s): min of CFL·h/(c0 + |v|max), 0.25 sqrt(h/|a|max)
    /// and 0.125 h²/ν, or the scene's fixed dt; never past t_end.
    pub fn next_dt(&self, comm: &dyn Comm) -> Result<f64> {
        let n = self.p.n_owned;
        let h = self.model.kernel.h;
        let dt = if self.scene.time.dt > 0.0 {
            self.scene.time.dt
        } else {
            let (kind, v, a) = (&self.p.kind, &self.p.v, &self.p.acc);
            let (vmax, amax) = (0..n)
                .into_par_iter()
                .filter(|&i| kind[i] == Kind::Fluid)
                .map(|i| (v[i].norm(), a[i].norm()))
                .reduce(|| (0.0f64, 0.0f64), |x, y| (x.0.max(y.0), x.1.max(y.1)));
            // max is exact, so the all-reduce gives the same bits on any number of ranks
            let mut m = [vmax, amax];
            comm.all_reduce_max_f64(&mut m)?;
            let (vmax, amax) = (m[0], m[1]);
            let mut dt = self.scene.time.cfl * h / (self.model.c_max + vmax);
            if amax > 0.0 {
                dt = dt.min(0.25 * (h / amax).sqrt());
            }
            if self.model.nu > 0.0 {
                dt = dt.min(0.125 * h * h / self.model.nu);
            }
            dt
        };
        let left = self.scene.time.t_end - self.t;
        Ok(if left > 0.0 && left < dt * (1.0 + 1e-9) {
            left
        } else {
            dt
        })
    }

    /// True once t_end (or max_steps) is reached.
    pub fn done(&self) -> bool {
        self.t >= self.scene.time.t_end * (1.0 - 1e-12)
            || (self.scene.time.max_steps > 0 && self.step >= self.scene.time.max_steps)
    }

    fn particle_error(&self, i: usize, what: &str) -> Error {
        Error::run(format!(
            "rank {}, step {}, t = {:.6e} s: particle id {} {} at position {:?}",
            self.rank,
            self.step,
            self.t,
            self.p.id[i],
            what,
            self.p.x[i].as_slice()
        ))
    }

    /// Every owned particle inside the domain.
    fn check_state(&self) -> Result<()> {
        let n = self.p.n_owned;
        let bad = (0..n).into_par_iter().find_first(|&i| {
            !self.space.contains(&self.p.x[i]) || !self.p.x[i].iter().all(|c| c.is_finite())
        });
        match bad {
            Some(i) if !self.p.x[i].iter().all(|c| c.is_finite()) => {
                Err(self.particle_error(i, "has a non-finite position (the run blew up: try a smaller time.cfl, more artificial viscosity or density diffusion)"))
            }
            Some(i) => Err(self.particle_error(i, "left the domain (enlarge domain.min/domain.max or check the walls)")),
            None => Ok(()),
        }
    }

    fn check_finite(&self) -> Result<()> {
        let n = self.p.n_owned;
        let bad = (0..n).into_par_iter().find_first(|&i| {
            !(self.p.rho[i].is_finite() && self.p.v[i].iter().all(|c| c.is_finite()) && self.p.rho[i] > 0.0)
        });
        match bad {
            Some(i) => Err(self.particle_error(
                i,
                &format!(
                    "has density {} and velocity {:?} (the run blew up)",
                    self.p.rho[i],
                    self.p.v[i].as_slice()
                ),
            )),
            None => Ok(()),
        }
    }

    /// Kinetic energy, momentum and max speed of the fluid over all ranks, summed exactly
    /// (independent of order, threads and ranks: integer limbs all-reduced).
    pub fn observables(&self, comm: &dyn Comm) -> Result<Observables<D>> {
        let n = self.p.n_owned;
        let p = &self.p;
        let mut sums: Vec<ExactSum> = (0..=D).map(|_| ExactSum::new()).collect();
        let mut vmax = 0.0f64;
        for i in 0..n {
            if p.kind[i] != Kind::Fluid {
                continue;
            }
            let v2 = p.v[i].norm_squared();
            sums[D].add(0.5 * p.mass[i] * v2);
            for (a, sum) in sums[..D].iter_mut().enumerate() {
                sum.add(p.mass[i] * p.v[i][a]);
            }
            vmax = vmax.max(v2.sqrt());
        }
        let per = sums[0].limbs().len();
        let mut limbs: Vec<i64> = sums.iter().flat_map(|s| s.limbs()).collect();
        let prev = comm.set_phase(Phase::Output);
        comm.all_reduce_sum_i64(&mut limbs)?;
        let mut m = [vmax];
        comm.all_reduce_max_f64(&mut m)?;
        comm.set_phase(prev);
        let value = |k: usize| ExactSum::from_limbs(&limbs[k * per..(k + 1) * per]).value();
        Ok(Observables {
            kinetic_energy: value(D),
            momentum: Vector::from_fn(|a, _| value(a)),
            max_speed: m[0],
        })
    }

    /// Gather every owned particle of every rank on rank 0, sorted by id (`None` on the other
    /// ranks). Collective: every rank must call it.
    pub fn gather(&self, comm: &dyn Comm) -> Result<Option<View<'_, D>>> {
        let mut all = Particles::<D>::default();
        if self.ranks == 1 {
            for i in 0..self.p.n_owned {
                all.push_owned(
                    self.p.id[i],
                    self.p.kind[i],
                    self.p.body[i],
                    self.p.mat[i],
                    self.p.x[i],
                    self.p.v[i],
                    self.p.mass[i],
                    self.p.rho[i],
                );
                all.p[i] = self.p.p[i];
                all.vw[i] = self.p.vw[i];
                all.grad_rho[i] = self.p.grad_rho[i];
            }
        } else {
            let prev = comm.set_phase(Phase::Output);
            let mine = pack_owned(&self.p);
            if self.rank != 0 {
                comm.send(0, TAG_GATHER, mine)?;
                comm.set_phase(prev);
                return Ok(None);
            }
            unpack_owned(&mine, &mut all)?;
            for r in 1..self.ranks {
                unpack_owned(&comm.recv(r, TAG_GATHER)?, &mut all)?;
            }
            comm.set_phase(prev);
        }
        let mut perm: Vec<usize> = (0..all.n_owned).collect();
        perm.sort_unstable_by_key(|&i| all.id[i]);
        all.permute_owned(&perm);
        Ok(Some(View {
            p: all,
            t: self.t,
            step: self.step,
            dt: self.dt,
            scene: &self.scene,
            model: &self.model,
        }))
    }

    /// Indices of owned particles sorted by id.
    pub fn by_id(&self) -> Vec<usize> {
        let mut idx: Vec<usize> = (0..self.p.n_owned).collect();
        idx.sort_unstable_by_key(|&i| self.p.id[i]);
        idx
    }
}

/// The periodic box and mirror planes of a scene.
pub fn image_space<const D: usize>(scene: &Scene) -> ImageSpace<D> {
    let min = Vector::<D>::from_fn(|a, _| scene.domain.min[a]);
    let max = Vector::<D>::from_fn(|a, _| scene.domain.max[a]);
    let mut periodic = [false; D];
    for (a, per) in periodic.iter_mut().enumerate() {
        *per = scene.domain.periodic[a];
    }
    let mut planes = Vec::new();
    for w in &scene.walls {
        if w.method != WallMethod::Mirror || w.shape != WallShape::Container {
            continue;
        }
        for a in 0..D {
            for up in [false, true] {
                if w.open
                    .iter()
                    .any(|o| crate::scene::face_of(o, D) == Some((a, up)))
                {
                    continue;
                }
                planes.push(MirrorPlane {
                    axis: a,
                    at: if up { w.max[a] } else { w.min[a] },
                    fluid_above: !up,
                    wall_velocity: Vector::from_fn(|k, _| w.velocity[k]),
                    no_slip: w.slip == crate::scene::Slip::NoSlip,
                });
            }
        }
    }
    ImageSpace {
        min,
        max,
        periodic,
        planes,
    }
}

/// How blocks go on ranks and ranks on nodes (issue 4).
#[derive(Debug, Clone)]
pub struct Layout {
    /// Nodes of the run (virtual or discovered); `None`: all ranks on one node.
    pub topology: Option<Topology>,
    /// Placement of blocks on ranks.
    pub placement: Placement,
}

impl Default for Layout {
    fn default() -> Self {
        Layout {
            topology: None,
            placement: Placement::RankOrder,
        }
    }
}

/// Split the whole lattice over `ranks` blocks (factorisation of the particle cloud's extents,
/// eq. 5 of seed 000, then cut planes balanced on particle counts, eq. 6), place the blocks on
/// ranks and keep rank `rank`'s particles. Every rank computes the same result from the same
/// particles.
pub fn decompose<const D: usize>(
    mut all: Particles<D>,
    min: &Vector<D>,
    max: &Vector<D>,
    ranks: usize,
    rank: usize,
    layout: &Layout,
    support: f64,
) -> Result<(Ranks<D>, Particles<D>)> {
    let map = rank_map(&all.x[..all.n_owned], min, max, ranks, layout, support)?;
    if ranks > 1 {
        let keep: Vec<usize> = (0..all.n_owned)
            .filter(|&i| map.owner(&all.x[i]) == rank)
            .collect();
        all.permute_owned(&keep);
    }
    Ok((map, all))
}

/// The decomposition of particles at `x` over `ranks` blocks and the blocks' ranks.
pub fn rank_map<const D: usize>(
    x: &[Vector<D>],
    min: &Vector<D>,
    max: &Vector<D>,
    ranks: usize,
    layout: &Layout,
    support: f64,
) -> Result<Ranks<D>> {
    let decomp = balanced_blocks(x, min, max, ranks);
    let block_to_rank = match (&layout.topology, layout.placement) {
        (_, Placement::RankOrder) | (None, _) => (0..ranks).collect(),
        (Some(t), method) => {
            t.check_ranks(ranks)?;
            let volumes = halo_volumes(x, &decomp, support);
            place(&decomp, t, method, &volumes)
        }
    };
    Ok(Ranks::new(decomp, block_to_rank))
}

/// Blocks of particles at `x`: the factorisation of the cloud's extents (eq. 5 of seed 000)
/// and cut planes balanced on particle counts (eq. 6). Counting is split over rayon tasks
/// and summed as integers, so the result does not depend on the thread count.
pub fn balanced_blocks<const D: usize>(
    x: &[Vector<D>],
    min: &Vector<D>,
    max: &Vector<D>,
    ranks: usize,
) -> Decomposition<D> {
    let n = x.len();
    let mut lo = Vector::<D>::repeat(f64::INFINITY);
    let mut hi = Vector::<D>::repeat(f64::NEG_INFINITY);
    for x in x {
        lo = lo.inf(x);
        hi = hi.sup(x);
    }
    let extents: Vec<f64> = (0..D)
        .map(|a| if n > 0 { hi[a] - lo[a] } else { max[a] - min[a] })
        .collect();
    let f = factorise(ranks, &extents);
    let mut nf = [1usize; D];
    nf.copy_from_slice(&f[..D]);
    let (decomp, _) = Decomposition::balance(*min, *max, nf, &BalanceParams::default(), |stage| {
        let k = stage.candidates().len();
        x.par_chunks(1 << 15)
            .map(|c| stage.count_local(c.iter().map(|x| (*x, 1u64))))
            .reduce(
                || vec![0u64; k],
                |mut a, b| {
                    a.iter_mut().zip(b).for_each(|(p, q)| *p += q);
                    a
                },
            )
    });
    decomp
}

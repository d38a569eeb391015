//! One rank's simulation state and the step loop.
//!
//! A step, as named phases (timers in `diagnostics.csv`, see [`Timer`]):
//! `kick ½ (v) → drift (x, wall motion) → wrap/check → [balance check] → migration → ghosts →
//! bin → neighbour lists → passes (each after refreshing the ghost fields it reads) → kick ½
//! (v) → dt`. The passes and their order are declared in [`crate::physics::passes`]; one rank
//! goes through the same halo path as many (self-sends).
//!
//! Modules: [`step`] (the step and the passes), [`adapt`] and [`merge`] (fluid particles that
//! change size, `[[refine]] adapt`), [`balance`] (load balance and migration),
//! [`decompose`] (initial blocks and placement), [`observe`] (observables and the gather for
//! output), [`timers`].

pub mod adapt;
pub mod balance;
pub mod decompose;
pub mod merge;
pub mod multirate;
pub mod observe;
pub mod outflow;
pub mod scan;
pub mod skin;
pub mod step;
pub mod timers;

pub use balance::BalanceStats;
pub use decompose::{balanced_blocks, decompose_sites, global_halo_volumes, rank_map};
pub use observe::{Observables, View};
pub use timers::{PhaseTimers, Timer, PHASES};

use crate::boundary::motion::WallKinematics;
use crate::boundary::{image_space, ImageSpace};
use crate::cells::{CellGrid, CellList, NeighbourList};
use crate::comm::Comm;
use crate::error::{Error, Result};
use crate::halo::{HaloPlan, Ranks};
use crate::layout::{Backend, LayoutRequest, RunLayout};
use crate::particles::Particles;
use crate::physics::passes::{schedule, Freshness, Pass};
use crate::physics::Model;
use crate::placement::Placement;
use crate::scene::Scene;
use crate::setup::SiteSource;
use crate::Vector;

/// Particles that changed size in a run segment, the same count on every rank.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct Resized {
    /// Particles split into 2^D children.
    pub splits: u64,
    /// Groups of 2^D particles merged into one.
    pub merges: u64,
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
    /// Cell grid over the whole domain (with the ghosts' margins).
    pub grid: CellGrid<D>,
    /// The window of `grid` the particles occupied when they were last binned: the grid
    /// `cells` is built on, and the one every use of `cells` takes.
    pub window: CellGrid<D>,
    /// Particles binned by cell (of `window`).
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
    /// Placement of blocks on ranks that ran.
    pub placement: Placement,
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
    /// The passes of a step, in order.
    pub schedule: Vec<Pass>,
    /// Pair mode (`performance.interactions = "pairs"`): the passes with a pair kernel visit
    /// each pair of owned fluid particles once over half lists instead of gathering over full
    /// ones. A choice of the step, not of the physics.
    pub pair_mode: bool,
    /// `time.stepping = "local"`: the scene's classes of particles may take steps of two
    /// sizes ([`multirate`]).
    pub local: bool,
    /// The next `advance` is a cycle of two substeps ([`multirate`]), with `dt` its span.
    pub cycle: bool,
    /// Cycles of local time stepping since the run began (over every segment).
    pub cycles: u64,
    /// Which part of a step the passes are in.
    substep: multirate::Substep,
    /// Per owned particle in a cycle's substeps: true unless coarse
    /// ([`Simulation::mark_classes`]).
    active: Vec<bool>,
    /// The next id a created particle takes, the same on every rank ([`crate::ids`]).
    pub ids: crate::ids::IdCounter,
    /// Splits and merges of this run segment, counted over every rank
    /// ([`crate::sim::adapt`], [`crate::sim::merge`]; `summary.json`).
    pub resized: Resized,
    /// Particles removed by the outflow rule and not yet reported (the driver drains it).
    pub removed: Vec<outflow::Removal>,
    fresh: Freshness,
    /// The fields a ghost build sends ([`crate::physics::passes::build_fields`]).
    build_fields: crate::particles::Fields,
    /// `performance.overlap = "on"`: a pass that needs a refresh computes the interior while
    /// the ghosts' fields travel (`step.rs`).
    overlap: bool,
    /// Per owned particle: no ghost is in its stencil ([`CellList::mark_interior`]), from the
    /// last neighbour build (empty without overlap or ghosts).
    interior: Vec<bool>,
    /// Scratch of [`CellList::mark_interior`], one flag per cell.
    near: Vec<bool>,
    /// The ghost set's Verlet skin: when the ghosts are built again ([`skin::Skin`]).
    skin: skin::Skin<D>,
    /// Step of the last reordering of the owned particles into cell order.
    reordered_at: Option<u64>,
    /// The largest bytes each part held before the step's buffers were freed
    /// ([`Simulation::memory_parts`]).
    parts_high: [u64; 4],
    /// Scratch of the solid passes (empty without solids).
    solid: crate::physics::solid::dynamics::SolidScratch<D>,
    /// Accumulators of the pair-mode passes (empty in gather mode).
    pair_scratch: crate::physics::pairs::PairScratch<D>,
    kinematics: Vec<WallKinematics>,
    /// The surfaces of the dummy walls, by wall body: a fluid particle that a drift carries
    /// through one bounces back ([`crate::boundary::geometry::WallSurface::bounce`]).
    faces: Vec<(usize, crate::boundary::geometry::WallSurface<D>)>,
    /// Where each of `faces` is during the current drift (scratch, one per face).
    moves: Vec<crate::boundary::geometry::WallMove<D>>,
}

impl<const D: usize> Simulation<D> {
    /// [`Simulation::with_layout`] with every rank on one node, blocks in rank order.
    pub fn new(scene: &Scene, comm: &dyn Comm) -> Result<Self> {
        let layout = RunLayout::resolve(&LayoutRequest::default(), Backend::Local, comm.size(), None)?;
        Self::with_layout(scene, comm, &layout)
    }

    /// Build this rank's particles, decompose the domain over `comm.size()` ranks with blocks
    /// placed by `layout`, and compute the initial rates and time step. The set-up is
    /// distributed ([`decompose_sites`]): each rank streams its share of the lattice to balance
    /// the cut planes on all-reduced counts, then builds only the sites it owns.
    pub fn with_layout(scene: &Scene, comm: &dyn Comm, layout: &RunLayout) -> Result<Self> {
        let src = SiteSource::<D>::new(scene)?;
        let space = image_space::<D>(scene);
        let support = Model::<D>::new(scene).kernel.support;
        let (map, p, placement) = decompose_sites(&src, (&space.min, &space.max), layout, support, comm)?;
        drop(src);
        let mut sim = Self::assemble(scene, comm, layout, (map, p, placement))?;
        let built = sim.p.n_owned;
        sim.balance.note_held(built, 0);
        sim.apply_wall_motion(0.0, 0.0);
        sim.check_state()?;
        sim.update_pressure();
        sim.relax(comm)?;
        // the set-up runs the passes of a whole step at dt = 0 (its dρ/dt is recomputed before
        // use), so its halo traffic is one step's, as `hsph plan` predicts (and a settling's
        // steps more)
        sim.rebuild_neighbours(comm)?;
        sim.run_passes(0.0, comm, None)?;
        sim.settle(comm)?;
        sim.balance.imbalance = sim.load_imbalance(comm)?;
        sim.balance.imbalance_history.push(sim.balance.imbalance);
        (sim.dt, sim.cycle) = sim.plan(comm)?;
        Ok(sim)
    }

    /// Continue from the checkpoint in `dir` (manifest `m`): each rank reads its share of the
    /// parts (a bad part found by one rank is every rank's input error), then [`Self::resume`].
    pub fn from_checkpoint(
        scene: &Scene,
        comm: &dyn Comm,
        layout: &RunLayout,
        dir: &std::path::Path,
        m: &crate::checkpoint::Manifest,
    ) -> Result<Self> {
        let bound = crate::scene::lattice::id_bound::<D>(scene);
        let next_id = crate::checkpoint::next_id(dir, m, bound);
        // every rank checks its share, and an error on one is every rank's
        let read = next_id.and_then(|next| {
            let s = crate::checkpoint::share::<D>(dir, m, comm.rank(), comm.size())?;
            crate::checkpoint::check_ids(dir, m, &s.0.id[..s.0.n_owned], next)?;
            Ok(s)
        });
        let (share, acc, built) = decompose::agree(read, comm)?;
        let clock = crate::checkpoint::Clock {
            step: m.step,
            t: m.t,
            dt: m.dt,
            next_id: crate::checkpoint::next_id(dir, m, bound)?,
        };
        let built = m.build_positions.then_some(&built[..]);
        Self::resume(scene, comm, layout, share, (&acc, built), clock)
    }

    /// Continue from a checkpoint's state: this rank's share of its particles (any subset of
    /// them) with their accelerations `acc` (m/s²) and, from a run with Verlet lists, their
    /// positions at the last neighbour build `built` (m; the same `Some` or `None` on every
    /// rank), at the
    /// checkpoint's `clock` (step, time, next time step, next id). The
    /// domain is decomposed afresh over `comm.size()` ranks; nothing is recomputed, so the next
    /// step is the step the checkpointed run would have taken.
    pub fn resume(
        scene: &Scene,
        comm: &dyn Comm,
        layout: &RunLayout,
        share: Particles<D>,
        (acc, built): (&[Vector<D>], Option<&[Vector<D>]>),
        clock: crate::checkpoint::Clock,
    ) -> Result<Self> {
        // `share`: the particles of the checkpoint parts this rank read (any subset; all of
        // them on one rank). The blocks are balanced on counts summed over ranks, then every
        // particle migrates to its owner with its acceleration: no rank holds the whole
        // checkpoint (README, "Checkpoints and restart").
        let mut p = share.dropping(crate::setup::dropped_fields(scene));
        let loaded = p.n_owned;
        let space = image_space::<D>(scene);
        // ties between equal coordinates are bisected over every id given so far
        let bound = clock.next_id;
        let n = p.n_owned;
        let model = Model::<D>::new(scene);
        // balanced on pairs, each particle weighs as the set-up weighed it
        let load: Option<Vec<u64>> = crate::scene::refine::load_sizes(scene).map(|z| {
            let h = |i: usize| if z.varies_h { p.h[i] } else { z.h[0] };
            let level = |i: usize| p.level.get(i).copied().unwrap_or(0);
            (0..n)
                .map(|i| crate::setup::particle_load::<D>(&z, p.kind[i], level(i), h(i)))
                .collect()
        });
        let cloud = crate::decomp::Points {
            x: &p.x[..n],
            id: &p.id[..n],
            fluid: None,
            load: load.as_deref(),
        };
        let support = model.kernel.support;
        let (map, placement) = rank_map(
            &cloud,
            (&space.min, &space.max),
            (bound, scene.balance.count_cap()),
            layout,
            support,
            comm,
        )?;
        let accs = crate::halo::route_to_owners(&p, acc, &map, comm)?;
        let verlet = scene.performance.neighbours == crate::scene::NeighbourMode::Verlet;
        // the same answer on every rank: the manifest says whether the parts hold them
        let builts = match built.filter(|_| verlet) {
            Some(b) => Some(crate::halo::route_to_owners(&p, b, &map, comm)?),
            None => None,
        };
        crate::halo::migrate(&mut p, &map, &map.boxes(), comm)?;
        let mut perm: Vec<usize> = (0..p.n_owned).collect();
        perm.sort_unstable_by_key(|&i| p.id[i]);
        p.permute_owned(&perm);
        let mut sim = Self::assemble(scene, comm, layout, (map, p, placement))?;
        sim.balance.note_held(loaded.max(sim.p.n_owned), 0);
        for i in 0..sim.p.n_owned {
            let k = accs
                .binary_search_by_key(&sim.p.id[i], |e| e.0)
                .map_err(|_| Error::run("resume: a particle lost its acceleration"))?;
            sim.p.acc[i] = accs[k].1;
        }
        if let Some(b) = builts {
            // the lists of the uninterrupted run: those of its last build's positions
            let by_id = |id: u64| b.binary_search_by_key(&id, |e| e.0).map(|k| b[k].1);
            let at = (0..sim.p.n_owned)
                .map(|i| {
                    by_id(sim.p.id[i]).map_err(|_| Error::run("resume: a particle lost its build position"))
                })
                .collect::<Result<Vec<_>>>()?;
            sim.list_as_built(at, comm)?;
        }
        (sim.step, sim.t, sim.dt) = (clock.step, clock.t, clock.dt);
        // whether the next advance is a cycle, from the restored state as the run decided it
        sim.cycle = sim.plan(comm)?.1;
        sim.ids = crate::ids::IdCounter::starting_at(clock.next_id);
        sim.check_state()?;
        sim.balance.imbalance = sim.load_imbalance(comm)?;
        sim.balance.imbalance_history.push(sim.balance.imbalance);
        Ok(sim)
    }

    /// The state of this rank from its decomposition, particles and placement, before any
    /// physics (t = 0, no neighbours).
    fn assemble(
        scene: &Scene,
        comm: &dyn Comm,
        layout: &RunLayout,
        (map, p, placement): (Ranks<D>, Particles<D>, Placement),
    ) -> Result<Self> {
        let (rank, ranks) = (comm.rank(), comm.size());
        debug_assert_eq!(ranks, layout.ranks, "layout resolved for this communicator");
        let model = Model::<D>::new(scene);
        let pair_mode = scene.performance.interactions == crate::scene::Interactions::Pairs;
        crate::physics::passes::check_pair_mode(&model, pair_mode)?;
        multirate::check(scene, &model)?;
        let space = image_space::<D>(scene);
        let support = model.kernel.support;
        // one rank without periodic axes or mirror planes has no ghost to keep: no skin, and
        // no build positions stored, unless the neighbour lists are kept with one
        let verlet = scene.performance.neighbours == crate::scene::NeighbourMode::Verlet;
        let ghostless = ranks == 1 && !space.periodic.iter().any(|&p| p) && space.planes.is_empty();
        let skin = skin::Skin::new(if ghostless && !verlet {
            0.0
        } else {
            scene.performance.skin * support
        });
        // a kept ghost lies within support + w of a box and moves w/2 before a build; Verlet
        // lists reach support + w, so the stencil's cells are at least that wide
        let edge = if verlet { support + skin.width } else { support };
        let grid = CellGrid::with_reach(&space.min, &space.max, edge, support + 2.0 * skin.width);
        let boxes = map.boxes();
        let nl = match scene.performance.neighbours {
            crate::scene::NeighbourMode::Cells => NeighbourList::lean(),
            crate::scene::NeighbourMode::Verlet => NeighbourList::verlet(support),
            crate::scene::NeighbourMode::Lists => NeighbourList::default(),
        };
        // several smoothing lengths: each pair listed within its own support, the candidates
        // of stored lists through sub-cells about as wide as the smallest pair support; the
        // lean scan keeps the sub-cell order of the cells (not their tables), so that its
        // pairs come in the stored lists' order and give their bits
        let support_per_h = model.kernel.support / model.kernel.h;
        let (nl, cells) = match model.sizes.as_ref().filter(|z| z.varies_h) {
            Some(z) => {
                let reach_per_h = z.pair_h.reach_per_support() * support_per_h;
                (
                    nl.with_sizes(reach_per_h, z.pair_h == crate::kernel::sizes::PairH::Max),
                    CellList::with_sub_cells(&grid, reach_per_h * z.smallest_h()),
                )
            }
            None => (nl, CellList::default()),
        };
        let build_fields = crate::physics::passes::build_fields(&schedule(&model));
        let sim = Simulation {
            scene: scene.clone(),
            schedule: schedule(&model),
            pair_mode,
            local: scene.time.stepping == crate::scene::Stepping::Local,
            cycle: false,
            cycles: 0,
            substep: multirate::Substep::Whole,
            active: Vec::new(),
            ids: crate::ids::IdCounter::starting_at(crate::scene::lattice::id_bound::<D>(scene)),
            resized: Resized::default(),
            model,
            p,
            space,
            window: grid.clone(),
            grid,
            cells,
            nl,
            halo: HaloPlan::default(),
            map,
            boxes,
            rank,
            ranks,
            placement,
            balance: BalanceStats::default(),
            t: 0.0,
            step: 0,
            dt: 0.0,
            timers: PhaseTimers::default(),
            pair_count: 0,
            fresh: Freshness::default(),
            build_fields,
            overlap: scene.performance.overlap == crate::scene::Overlap::On,
            interior: Vec::new(),
            near: Vec::new(),
            skin,
            reordered_at: None,
            parts_high: [0; 4],
            solid: Default::default(),
            pair_scratch: Default::default(),
            removed: Vec::new(),
            kinematics: WallKinematics::of(scene),
            faces: dummy_faces(scene),
            moves: Vec::new(),
        };
        Ok(sim)
    }

    /// Per owned particle: true if no ghost is in its stencil, so a pass computes it while
    /// the ghosts' fields travel (empty without overlap or without ghosts).
    pub fn interior(&self) -> &[bool] {
        &self.interior
    }

    /// Ghost builds so far, set-up included (every step without a skin).
    pub fn ghost_builds(&self) -> u64 {
        self.skin.builds
    }

    /// Number of owned particles (fluid and wall).
    pub fn n_particles(&self) -> usize {
        self.p.n_owned
    }

    /// dρ/dt of the current state (for tests and diagnostics): ghosts, neighbours and the
    /// passes up to continuity.
    pub fn compute_density_rate(&mut self, comm: &dyn Comm) -> Result<()> {
        self.rebuild_neighbours(comm)?;
        self.run_passes(0.0, comm, Some(Pass::Continuity))
    }

    /// dv/dt of the current state (for tests and diagnostics): ghosts, neighbours and the
    /// passes up to the fluid momentum equation at dt = 0, so densities keep their values;
    /// `p.acc` of every owned fluid particle, body force included (m/s²).
    pub fn compute_acceleration(&mut self, comm: &dyn Comm) -> Result<()> {
        self.rebuild_neighbours(comm)?;
        let until = if self.model.lagged_gradient {
            Pass::MomentumGradient
        } else {
            Pass::Momentum
        };
        self.run_passes(0.0, comm, Some(until))
    }

    /// True once t_end (or max_steps) is reached.
    pub fn done(&self) -> bool {
        self.scene.time.ended(self.step, self.t)
    }

    /// Where the run stands (step, t, dt, next id), as a checkpoint records it.
    pub fn clock(&self) -> crate::checkpoint::Clock {
        crate::checkpoint::Clock {
            step: self.step,
            t: self.t,
            dt: self.dt,
            next_id: self.ids.next(),
        }
    }

    /// Indices of owned particles sorted by id.
    pub fn by_id(&self) -> Vec<usize> {
        let mut idx: Vec<usize> = (0..self.p.n_owned).collect();
        idx.sort_unstable_by_key(|&i| self.p.id[i]);
        idx
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
        let (x, space) = (&self.p.x, &self.space);
        let bad = scan::first(n, |i| {
            !space.contains(&x[i]) | !x[i].iter().all(|c| c.is_finite())
        });
        match bad {
            Some(i) if !self.p.x[i].iter().all(|c| c.is_finite()) => {
                Err(self.particle_error(i, "has a non-finite position (the run blew up: try a smaller time.cfl, more artificial viscosity or density diffusion)"))
            }
            Some(i) if self.p.kind[i].is_wall() => Err(self.particle_error(i, "is a wall particle that its motion law carried out of the domain (outflow never removes wall particles): enlarge domain.min/domain.max or shorten the motion")),
            Some(i) => Err(self.particle_error(i, "left the domain (enlarge domain.min/domain.max, check the walls, or let such particles go with domain.outflow = \"remove\")")),
            None => Ok(()),
        }
    }

    /// Every owned integrated particle finite, with a density and a speed inside the scene's
    /// `[limits]`: a run that is blowing up stops here, early, naming the particle.
    fn check_finite(&self) -> Result<()> {
        let n = self.p.n_owned;
        let (lo, hi) = (
            self.scene.limits.density_ratio[0],
            self.scene.limits.density_ratio[1],
        );
        let k = self.scene.limits.speed_over_c0;
        let (p, mats) = (&self.p, &self.model.materials);
        // what is wrong with particle i: nothing, or a failure below; a few comparisons, so
        // that the scan over every particle streams (squared speeds: no root per particle)
        let verdict = |i: usize| {
            let (rho, v) = (p.rho[i], p.v[i]);
            if !(rho.is_finite() & v.iter().all(|c| c.is_finite()) & (rho > 0.0)) {
                return Failure::NotFinite;
            }
            // solids: finiteness and positive density only (their EOS bounds them, fragments
            // expand freely, and they move at the impact's speeds)
            if !p.kind[i].is_integrated() || p.kind[i].is_solid() {
                return Failure::None;
            }
            let m = &mats[p.mat[i] as usize];
            if !(lo..=hi).contains(&(rho / m.rho0())) {
                Failure::Density
            } else if v.norm_squared() > (k * m.c0()).powi(2) {
                Failure::Speed
            } else {
                Failure::None
            }
        };
        let Some(i) = scan::first(n, |i| verdict(i) != Failure::None) else {
            return Ok(());
        };
        let (rho, v) = (p.rho[i], p.v[i]);
        let m = &mats[p.mat[i] as usize];
        let (ratio, speed) = (rho / m.rho0(), v.norm());
        let what = match verdict(i) {
            Failure::NotFinite | Failure::None => format!(
                "has density {rho} and velocity {:?} (the run blew up)",
                v.as_slice()
            ),
            Failure::Density => format!(
                "has density {rho:.6e} kg/m³ = {ratio:.4} ρ0 (speed {speed:.4e} m/s), outside \
                 limits.density_ratio [{lo}, {hi}] (the run is blowing up: try a smaller time.cfl, \
                 artificial viscosity or density diffusion)"
            ),
            Failure::Speed => format!(
                "moves at {speed:.4e} m/s, beyond limits.speed_over_c0 = {k} × c0 = {:.4e} m/s (the run \
                 is blowing up: try a smaller time.cfl, or a larger c0 if the flow is that fast)",
                k * m.c0()
            ),
        };
        Err(self.particle_error(i, &what))
    }
}

/// What [`Simulation::check_finite`] found wrong with a particle.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Failure {
    None,
    NotFinite,
    Density,
    Speed,
}

/// The surface of every dummy wall of `scene`, by wall body, its faces unbounded along the axes
/// it spans ([`crate::boundary::geometry::WallSurface::spanning`]).
fn dummy_faces<const D: usize>(scene: &Scene) -> Vec<(usize, crate::boundary::geometry::WallSurface<D>)> {
    let dom = &scene.domain;
    (scene.walls.iter().enumerate())
        .filter(|(_, w)| w.method.bounces_fluid())
        .map(|(b, w)| {
            (
                b,
                crate::boundary::geometry::WallSurface::new(w).spanning(&dom.min, &dom.max),
            )
        })
        .collect()
}

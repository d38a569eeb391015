//! One rank's simulation state and the step loop (kick–drift–kick leapfrog).
//!
//! A step, as named phases (timers in `diagnostics.csv`):
//! `kick ½ (v) → drift (x, wall motion) → wrap/check → ghosts → bin → neighbour lists →
//! [δ-SPH gradient → ghost refresh] → continuity → ρ update, EOS → ghost refresh →
//! [dummy-wall extrapolation → ghost refresh] → momentum → kick ½ (v) → dt`
//! (see [`Simulation::advance`] for why continuity and momentum are separate passes).
//! The parallel engine (issue 3) inserts migration before `ghosts` and halo exchanges at the
//! ghost refreshes; nothing in the physics changes.

use crate::cells::{CellGrid, CellList, NeighbourList};
use crate::error::{Error, Result};
use crate::exact::ExactSum;
use crate::ghosts::{GhostPlan, ImageSpace, MirrorPlane};
use crate::particles::{Kind, Particles};
use crate::physics::{delta, fluid, walls, Model};
use crate::scene::{DensityDiffusion, Motion, Scene, WallMethod, WallShape};
use crate::setup::build_particles;
use crate::Vector;
use rayon::prelude::*;
use std::time::Instant;

/// Steps between reorderings of the owned particles into cell order.
const REORDER_EVERY: u64 = 16;

/// Names of the timed phases, in the order of `diagnostics.csv`.
pub const PHASES: [&str; 5] = ["neighbours", "forces", "integrate", "ghosts", "output"];

/// Wall-clock seconds spent per phase.
#[derive(Debug, Clone, Default)]
pub struct PhaseTimers {
    /// Seconds per phase, indexed like [`PHASES`].
    pub seconds: [f64; 5],
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
    /// Ghost plan.
    pub ghosts: GhostPlan<D>,
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
    /// Build particles and compute the initial rates and time step.
    pub fn new(scene: &Scene) -> Result<Self> {
        let p = build_particles::<D>(scene)?;
        let model = Model::<D>::new(scene);
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
        let kinematics = scene
            .walls
            .iter()
            .enumerate()
            .filter_map(|(b, w)| w.motion.clone().map(|m| WallKinematics { body: b, motion: m }))
            .collect();
        let grid = CellGrid::new(&min, &max, model.kernel.support);
        let has_dummy = p.kind.contains(&Kind::Dummy);
        let mut sim = Simulation {
            scene: scene.clone(),
            model,
            p,
            space: ImageSpace {
                min,
                max,
                periodic,
                planes,
            },
            grid,
            cells: CellList::default(),
            nl: NeighbourList::default(),
            ghosts: GhostPlan::default(),
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
        sim.rebuild_neighbours()?;
        sim.forces();
        sim.dt = sim.next_dt();
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
    fn rebuild_neighbours(&mut self) -> Result<()> {
        let support = self.model.kernel.support;
        let t0 = Instant::now();
        self.ghosts.build(&mut self.p, &self.space, support);
        self.ghosts.refresh(&mut self.p, &self.space);
        self.timers.add(3, t0);
        let t0 = Instant::now();
        self.bin()?;
        if self.step % REORDER_EVERY == 0 {
            // owned particles in cell order (then key order) for memory locality
            let n = self.p.n_owned;
            let perm: Vec<usize> = self
                .cells
                .order
                .iter()
                .map(|&i| i as usize)
                .filter(|&i| i < n)
                .collect();
            self.p.truncate_ghosts();
            self.p.permute_owned(&perm);
            self.ghosts.build(&mut self.p, &self.space, support);
            self.ghosts.refresh(&mut self.p, &self.space);
            self.bin()?;
        }
        let kind = &self.p.kind;
        self.nl.build(&self.grid, &self.cells, &self.p, support, |i| {
            kind[i] != Kind::Repulsive
        });
        self.timers.add(0, t0);
        Ok(())
    }

    /// Bin owned particles and ghosts into cells.
    fn bin(&mut self) -> Result<()> {
        if let Err(i) = self.cells.build(&self.grid, &self.p) {
            let n = self.p.n_owned;
            let src = if i < n { i } else { self.ghosts.src[i - n] as usize };
            return Err(self.particle_error(src, "left the cell grid"));
        }
        Ok(())
    }

    /// Density pass: [⟨∇ρ⟩^L → ghosts] → dρ/dt of fluid particles.
    fn density_rate(&mut self) {
        let t0 = Instant::now();
        if self.model.diffusion == DensityDiffusion::Antuono {
            delta::renormalised_gradient(&mut self.p, &self.nl, &self.model);
            self.ghosts.refresh(&mut self.p, &self.space);
            self.pair_count += self.nl.pairs() as u64;
        }
        fluid::continuity(&mut self.p, &self.nl, &self.model);
        self.pair_count += self.nl.pairs() as u64;
        self.timers.add(1, t0);
    }

    /// Force pass: [dummy-wall extrapolation → ghosts] → dv/dt of fluid particles.
    fn forces(&mut self) {
        let t0 = Instant::now();
        if self.has_dummy {
            walls::extrapolate(&mut self.p, &self.nl, &self.model);
            self.ghosts.refresh(&mut self.p, &self.space);
            self.pair_count += self.nl.pairs() as u64;
        }
        fluid::momentum(&mut self.p, &self.nl, &self.model);
        self.pair_count += self.nl.pairs() as u64;
        self.timers.add(1, t0);
    }

    /// dρ/dt of the current state (for tests and diagnostics).
    pub fn compute_density_rate(&mut self) -> Result<()> {
        self.rebuild_neighbours()?;
        self.density_rate();
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
    pub fn advance(&mut self) -> Result<()> {
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
        self.rebuild_neighbours()?;
        self.density_rate();
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
        let t0 = Instant::now();
        self.ghosts.refresh(&mut self.p, &self.space);
        self.timers.add(3, t0);
        self.forces();
        let t0 = Instant::now();
        self.half_kick(dt);
        self.check_finite()?;
        self.dt = self.next_dt();
        self.timers.add(2, t0);
        Ok(())
    }

    /// The time step for the next step (s): min of CFL·h/(c0 + |v|max), 0.25 sqrt(h/|a|max)
    /// and 0.125 h²/ν, or the scene's fixed dt; never past t_end.
    pub fn next_dt(&self) -> f64 {
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
        if left > 0.0 && left < dt * (1.0 + 1e-9) {
            left
        } else {
            dt
        }
    }

    /// True once t_end (or max_steps) is reached.
    pub fn done(&self) -> bool {
        self.t >= self.scene.time.t_end * (1.0 - 1e-12)
            || (self.scene.time.max_steps > 0 && self.step >= self.scene.time.max_steps)
    }

    fn particle_error(&self, i: usize, what: &str) -> Error {
        Error::run(format!(
            "rank 0, step {}, t = {:.6e} s: particle id {} {} at position {:?}",
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

    /// Kinetic energy, momentum and max speed of the fluid, summed exactly (independent of
    /// order, threads and ranks).
    pub fn observables(&self) -> Observables<D> {
        let n = self.p.n_owned;
        let p = &self.p;
        let mut ke = ExactSum::new();
        let mut mom: Vec<ExactSum> = (0..D).map(|_| ExactSum::new()).collect();
        let mut vmax = 0.0f64;
        for i in 0..n {
            if p.kind[i] != Kind::Fluid {
                continue;
            }
            let v2 = p.v[i].norm_squared();
            ke.add(0.5 * p.mass[i] * v2);
            for a in 0..D {
                mom[a].add(p.mass[i] * p.v[i][a]);
            }
            vmax = vmax.max(v2.sqrt());
        }
        Observables {
            kinetic_energy: ke.value(),
            momentum: Vector::from_fn(|a, _| mom[a].value()),
            max_speed: vmax,
        }
    }

    /// Indices of owned particles sorted by id.
    pub fn by_id(&self) -> Vec<usize> {
        let mut idx: Vec<usize> = (0..self.p.n_owned).collect();
        idx.sort_unstable_by_key(|&i| self.p.id[i]);
        idx
    }
}

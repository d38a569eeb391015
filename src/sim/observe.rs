//! What leaves a rank for output: global observables summed exactly, and the whole state
//! gathered on rank 0 in id order.

use super::Simulation;
use crate::comm::{Comm, Phase, Tag};
use crate::error::Result;
use crate::exact::ExactSum;
use crate::halo::{pack_owned_where, unpack_owned};
use crate::particles::{Fields, Particles};
use crate::physics::Model;
use crate::scene::Scene;
use crate::Vector;
use std::borrow::Cow;

/// Tag of the output gather.
const TAG_GATHER: Tag = 110;

/// Physics observables of one output step (one row of `timeseries.csv`).
#[derive(Debug, Clone)]
pub struct Observables<const D: usize> {
    /// Kinetic energy Σ ½ m |v|² of the integrated particles (J, or J/m in 2D).
    pub kinetic_energy: f64,
    /// Momentum Σ m v of the integrated particles (kg m/s).
    pub momentum: Vector<D>,
    /// Largest speed of an integrated particle (m/s).
    pub max_speed: f64,
    /// Potential energy −Σ m g·x of the integrated particles (J, or J/m in 2D; zero at the origin).
    pub potential_energy: f64,
    /// Internal (compression) energy Σ m e(ρ) of the integrated particles (J, or J/m in 2D).
    pub internal_energy: f64,
    /// Mass Σ m of the integrated particles (kg, or kg/m in 2D).
    pub mass: f64,
    /// Energy (kinetic + potential + internal) carried out of the run so far by particles the
    /// outflow rule removed (J, or J/m in 2D): `total_energy + removed_energy` is what a
    /// conservative scheme keeps. Filled in by the driver, which counts the removals.
    pub removed_energy: f64,
    /// Mass carried out of the run so far by removed particles (kg, or kg/m in 2D).
    pub removed_mass: f64,
}

impl<const D: usize> Observables<D> {
    /// Kinetic + potential + internal energy (J, or J/m in 2D).
    pub fn total_energy(&self) -> f64 {
        self.kinetic_energy + self.potential_energy + self.internal_energy
    }
}

/// Exact sums kept by [`Simulation::observables`]: kinetic energy, potential energy, internal
/// energy, mass, then the D momentum components.
const SCALARS: usize = 4;

/// The whole state gathered on rank 0 for output: every owned particle of every rank, sorted by
/// id, no ghosts. Field names follow [`Simulation`] so output code reads either alike.
pub struct View<'a, const D: usize> {
    /// Every particle, sorted by id: a copy, or the table of a lone rank that
    /// [`Simulation::settle_for_gather`] put in id order, lent.
    pub p: Cow<'a, Particles<D>>,
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
    /// Figures already computed from these particles (see [`Memo`]).
    pub memo: Memo,
}

/// Figures computed from a [`View`] once and read by several consumers — the front probe and
/// the dam-break reference measure the same front — keyed by the consumer's tag and the
/// figure's parameters (as bits). Each key is computed at most once.
#[derive(Debug, Default)]
pub struct Memo(std::cell::RefCell<Vec<([u64; 4], f64)>>);

impl Memo {
    /// The value under `key`, computed by `f` the first time.
    pub fn get_or(&self, key: [u64; 4], f: impl FnOnce() -> f64) -> f64 {
        if let Some((_, v)) = self.0.borrow().iter().find(|(k, _)| *k == key) {
            return *v;
        }
        let v = f();
        self.0.borrow_mut().push((key, v));
        v
    }
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

impl<const D: usize> Simulation<D> {
    /// Kinetic ½ m |v|², potential −m g·x and internal m e energy of owned particle `i`
    /// (J, or J/m in 2D); e is the solid's specific internal energy or the fluid's
    /// compression energy e(ρ).
    pub(super) fn energies(&self, i: usize) -> [f64; 3] {
        let p = &self.p;
        let m = p.mass[i];
        let e = if p.kind[i].is_solid() {
            p.energy[i]
        } else {
            self.model.materials[p.mat[i] as usize].internal_energy(p.rho[i])
        };
        [
            0.5 * m * p.v[i].norm_squared(),
            -m * self.model.g.dot(&p.x[i]),
            m * e,
        ]
    }

    /// Kinetic energy, momentum and max speed of the integrated particles over all ranks,
    /// summed exactly (independent of order, threads and ranks: integer limbs all-reduced).
    pub fn observables(&self, comm: &dyn Comm) -> Result<Observables<D>> {
        let p = &self.p;
        let mut sums: Vec<ExactSum> = (0..SCALARS + D).map(|_| ExactSum::new()).collect();
        let mut vmax = 0.0f64;
        for i in 0..p.n_owned {
            // clamped solids are not integrated but store elastic energy
            if !(p.kind[i].is_integrated() || p.kind[i].is_solid()) {
                continue;
            }
            let m = p.mass[i];
            let v2 = p.v[i].norm_squared();
            for (sum, e) in sums.iter_mut().zip(self.energies(i)) {
                sum.add(e);
            }
            sums[3].add(m);
            for (a, sum) in sums[SCALARS..].iter_mut().enumerate() {
                sum.add(m * p.v[i][a]);
            }
            vmax = vmax.max(v2.sqrt());
        }
        let per = sums[0].limbs().len();
        let limbs: Vec<i64> = sums.iter().flat_map(|s| s.limbs()).collect();
        // one collective (an output at every step pays one message round): every rank's
        // limbs, summed as integers (wrapping, as the all-reduce did: exact in any order), and its largest speed
        let mut mine: Vec<u8> = limbs.iter().flat_map(|l| l.to_le_bytes()).collect();
        mine.extend_from_slice(&vmax.to_le_bytes());
        let prev = comm.set_phase(Phase::Output);
        let all = comm.all_gather_bytes(mine)?;
        comm.set_phase(prev);
        let word = |b: &[u8], k: usize| -> [u8; 8] { b[8 * k..8 * k + 8].try_into().expect("8 bytes") };
        let limbs: Vec<i64> = (0..limbs.len())
            .map(|k| {
                all.iter()
                    .fold(0i64, |s, b| s.wrapping_add(i64::from_le_bytes(word(b, k))))
            })
            .collect();
        let mx = [all
            .iter()
            .map(|b| f64::from_le_bytes(word(b, limbs.len())))
            .fold(0.0f64, f64::max)];
        let value = |k: usize| ExactSum::from_limbs(&limbs[k * per..(k + 1) * per]).value();
        Ok(Observables {
            kinetic_energy: value(0),
            momentum: Vector::from_fn(|a, _| value(SCALARS + a)),
            max_speed: mx[0],
            potential_energy: value(1),
            internal_energy: value(2),
            mass: value(3),
            removed_energy: 0.0,
            removed_mass: 0.0,
        })
    }

    /// Gather every owned particle of every rank on rank 0, sorted by id (`None` on the other
    /// ranks). Collective: every rank must call it.
    pub fn gather(&self, comm: &dyn Comm) -> Result<Option<View<'_, D>>> {
        let p = &self.p;
        if self.ranks == 1 && p.len() == p.n_owned && p.id.is_sorted() {
            // the table is the view: no copy (a whole run's memory peak on one rank)
            return Ok(Some(self.view(Cow::Borrowed(p))));
        }
        self.gather_where(comm, &|_, _| true, Fields::ALL)
    }

    /// The most bytes this rank has held by part, by the capacities of its vectors, now or
    /// before the step's buffers were last freed: the particle table (owned and ghosts), the
    /// neighbour lists (with their cell-order copies and the half lists), the cells (the
    /// per-cell arrays span the whole domain) and the passes' scratch.
    pub fn memory_parts(&self) -> [u64; 4] {
        use crate::cells::held;
        let now = [
            self.p.bytes_held(),
            self.nl.bytes_held(),
            self.cells.bytes_held() + held(&self.interior) + held(&self.near),
            self.solid.bytes_held() + self.pair_scratch.bytes_held(),
        ];
        std::array::from_fn(|k| (now[k] as u64).max(self.parts_high[k]))
    }

    /// At the end of a run: free the step's working memory (ghosts, neighbour lists, cells
    /// and the passes' scratch) before the final state is gathered on rank 0, whose copy of
    /// every particle was a multi-rank run's memory peak (3 local ranks of the 3D DualSPHysics
    /// dam break: 29 MB on top of every rank's lists). On one rank, also put the owned
    /// particles in id order, so that [`Simulation::gather`] lends the table instead of
    /// copying it. No step may follow.
    pub fn settle_for_gather(&mut self) {
        self.p.truncate_ghosts();
        self.free_step_buffers();
        self.solid = Default::default();
        self.interior = Vec::new();
        self.near = Vec::new();
        if self.ranks != 1 {
            return;
        }
        let mut perm: Vec<usize> = (0..self.p.n_owned).collect();
        perm.sort_unstable_by_key(|&i| self.p.id[i]);
        self.p.permute_owned(&perm);
    }

    /// A view of the particles `p` (sorted by id) at this step.
    fn view<'s>(&'s self, p: Cow<'s, Particles<D>>) -> View<'s, D> {
        View {
            p,
            t: self.t,
            step: self.step,
            dt: self.dt,
            scene: &self.scene,
            model: &self.model,
            memo: Memo::default(),
        }
    }

    /// Gather on rank 0, sorted by id, the `fields` (the id always) of the owned particles of
    /// every rank that `keep` selects (`None` on the other ranks): what a probe needs without
    /// the whole state. The view holds no other field and no rates. Collective.
    pub fn gather_where(
        &self,
        comm: &dyn Comm,
        keep: &dyn Fn(&Particles<D>, usize) -> bool,
        fields: Fields,
    ) -> Result<Option<View<'_, D>>> {
        let dropped = self.p.dropped.or(Fields::ALL.without(fields.or(Fields::ID)));
        let mut all = Particles::<D>::for_view(dropped);
        if self.ranks == 1 {
            // pushed in id order: no permutation (and no second copy of a field) after
            let mut kept: Vec<usize> = (0..self.p.n_owned).filter(|&i| keep(&self.p, i)).collect();
            kept.sort_unstable_by_key(|&i| self.p.id[i]);
            all.reserve(kept.len());
            for i in kept {
                all.push_owned(self.p.record(i));
            }
            return Ok(Some(self.view(Cow::Owned(all))));
        } else {
            let prev = comm.set_phase(Phase::Output);
            let mine = pack_owned_where(&self.p, keep, dropped);
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
        Ok(Some(self.view(Cow::Owned(all))))
    }
}

//! Particle storage: one structure of arrays, owned particles first, then ghosts.
//!
//! Indices `[0, n_owned)` are the particles this rank integrates; `[n_owned, len)` are ghosts:
//! copies of owned particles under an image operation (periodic shift or mirror reflection),
//! and later copies from other ranks. A ghost is identified by its source id and image code
//! (`key`), never by its local index, so sums in a fixed key order reproduce across layouts.

use crate::Vector;

/// What a particle is.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[repr(u8)]
pub enum Kind {
    /// Weakly compressible fluid.
    Fluid = 0,
    /// Fixed dummy wall particle with extrapolated pressure and velocity (Adami et al. 2012).
    Dummy = 1,
    /// Monaghan repulsive wall particle.
    Repulsive = 2,
}

impl Kind {
    /// Integer code written to output files.
    pub fn code(self) -> u8 {
        self as u8
    }
}

/// Bits of the image code in a particle's sort key (`id << IMAGE_BITS | image`).
pub const IMAGE_BITS: u32 = 10;

/// Particle fields (structure of arrays). Units: m, m/s, kg, kg/m³, Pa.
#[derive(Debug, Clone, Default)]
pub struct Particles<const D: usize> {
    /// Number of owned particles; the rest are ghosts.
    pub n_owned: usize,
    /// Global lattice id (unique, fixed for the run).
    pub id: Vec<u64>,
    /// Sort key: `id << IMAGE_BITS | image code` (0 for an owned particle).
    pub key: Vec<u64>,
    /// Particle kind.
    pub kind: Vec<Kind>,
    /// Body index: into the scene's fluids for fluid particles, walls for wall particles.
    pub body: Vec<u16>,
    /// Material index (EOS) into the scene's materials.
    pub mat: Vec<u16>,
    /// Position x (m).
    pub x: Vec<Vector<D>>,
    /// Velocity v (m/s). For wall particles: the wall's prescribed velocity.
    pub v: Vec<Vector<D>>,
    /// Mass m (kg).
    pub mass: Vec<f64>,
    /// Density ρ (kg/m³). For dummy walls: from the extrapolated pressure.
    pub rho: Vec<f64>,
    /// Pressure p (Pa). For dummy walls: extrapolated (Adami et al. 2012, eq. 27).
    pub p: Vec<f64>,
    /// Velocity a dummy wall shows the fluid in viscous terms (m/s); unused for fluid.
    pub vw: Vec<Vector<D>>,
    /// Renormalised density gradient ⟨∇ρ⟩^L (kg/m⁴); filled only with Antuono's δ-SPH.
    pub grad_rho: Vec<Vector<D>>,
    /// dρ/dt of owned particles (kg/m³/s).
    pub drho: Vec<f64>,
    /// dv/dt of owned particles (m/s²).
    pub acc: Vec<Vector<D>>,
}

impl<const D: usize> Particles<D> {
    /// Total number of particles, owned and ghost.
    pub fn len(&self) -> usize {
        self.id.len()
    }

    /// True if there are no particles.
    pub fn is_empty(&self) -> bool {
        self.id.is_empty()
    }

    /// Drop every ghost, keeping owned particles.
    pub fn truncate_ghosts(&mut self) {
        let n = self.n_owned;
        self.id.truncate(n);
        self.key.truncate(n);
        self.kind.truncate(n);
        self.body.truncate(n);
        self.mat.truncate(n);
        self.x.truncate(n);
        self.v.truncate(n);
        self.mass.truncate(n);
        self.rho.truncate(n);
        self.p.truncate(n);
        self.vw.truncate(n);
        self.grad_rho.truncate(n);
    }

    /// Reorder (or select) the owned particles (ghosts must have been dropped): new particle
    /// k is old particle `perm[k]`; particles not listed are dropped. Results never depend on
    /// local order (sums follow global keys), so reordering only changes memory locality.
    pub fn permute_owned(&mut self, perm: &[usize]) {
        debug_assert_eq!(self.len(), self.n_owned, "drop ghosts before permuting");
        self.n_owned = perm.len();
        fn gather<T: Copy>(v: &mut Vec<T>, perm: &[usize]) {
            let old = std::mem::take(v);
            v.extend(perm.iter().map(|&i| old[i]));
        }
        gather(&mut self.id, perm);
        gather(&mut self.key, perm);
        gather(&mut self.kind, perm);
        gather(&mut self.body, perm);
        gather(&mut self.mat, perm);
        gather(&mut self.x, perm);
        gather(&mut self.v, perm);
        gather(&mut self.mass, perm);
        gather(&mut self.rho, perm);
        gather(&mut self.p, perm);
        gather(&mut self.vw, perm);
        gather(&mut self.grad_rho, perm);
        gather(&mut self.drho, perm);
        gather(&mut self.acc, perm);
    }

    /// Append a ghost from a whole record (another rank's particle or an image); its pressure,
    /// wall velocity and gradient are set by the caller.
    #[allow(clippy::too_many_arguments)]
    pub fn push_ghost_record(
        &mut self,
        id: u64,
        key: u64,
        kind: Kind,
        body: u16,
        mat: u16,
        x: Vector<D>,
        v: Vector<D>,
        mass: f64,
        rho: f64,
    ) {
        self.id.push(id);
        self.key.push(key);
        self.kind.push(kind);
        self.body.push(body);
        self.mat.push(mat);
        self.x.push(x);
        self.v.push(v);
        self.mass.push(mass);
        self.rho.push(rho);
        self.p.push(0.0);
        self.vw.push(v);
        self.grad_rho.push(Vector::zeros());
    }

    /// Append an owned particle (before any ghost exists).
    #[allow(clippy::too_many_arguments)]
    pub fn push_owned(
        &mut self,
        id: u64,
        kind: Kind,
        body: u16,
        mat: u16,
        x: Vector<D>,
        v: Vector<D>,
        mass: f64,
        rho: f64,
    ) {
        debug_assert_eq!(self.n_owned, self.len(), "owned particles go before ghosts");
        // the fields every particle has, then the rates only owned particles carry
        self.push_ghost_record(id, id << IMAGE_BITS, kind, body, mat, x, v, mass, rho);
        self.drho.push(0.0);
        self.acc.push(Vector::zeros());
        self.n_owned += 1;
    }

    /// Bytes per particle of this store (for memory estimates).
    pub fn bytes_per_particle() -> usize {
        // id, key, kind, body, mat, x, v, mass, rho, p, vw, grad_rho, drho, acc
        8 + 8 + 1 + 2 + 2 + 5 * 8 * D + 4 * 8 + 8 * D
    }
}

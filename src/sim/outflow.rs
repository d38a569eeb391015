//! The outflow rule (`[domain] outflow`): a fluid particle that leaves the domain, or whose
//! density leaves `limits.density_ratio`, is removed from the run — counted, logged with its
//! time, position and reason, and reported — instead of stopping it; `stop` keeps the old
//! behaviour. Whether a particle goes depends on its own state only, so the same particles go
//! on any number of ranks and the results keep their bits. Blow-ups (non-finite values, speeds
//! beyond `limits.speed_over_c0`) still stop the run, as does removing more than
//! `domain.max_removed_fraction` of the fluid.

use super::Simulation;
use crate::scene::Outflow;

/// One removed particle.
#[derive(Debug, Clone, PartialEq)]
pub struct Removal {
    /// Particle id.
    pub id: u64,
    /// Step after which it was removed.
    pub step: u64,
    /// Simulated time (s).
    pub t: f64,
    /// Position (m).
    pub x: Vec<f64>,
    /// Density (kg/m³).
    pub rho: f64,
    /// Why: `left the domain` or `density out of band`.
    pub reason: &'static str,
    /// Mass it took out of the run (kg, or kg/m in 2D).
    pub mass: f64,
    /// Kinetic + potential + internal energy it took out of the run (J, or J/m in 2D), as
    /// [`Simulation::observables`] counts it.
    pub energy: f64,
}

/// Words of one encoded [`Removal`]: id, step, reason, t, ρ, x (3), mass, energy.
const WORDS: usize = 10;

impl Removal {
    /// Fixed-size encoding for the gather on rank 0: id, step, reason, t, ρ, x (3 words),
    /// mass, energy.
    pub fn to_bytes(&self) -> Vec<u8> {
        let mut b = Vec::with_capacity(8 * WORDS);
        b.extend_from_slice(&self.id.to_le_bytes());
        b.extend_from_slice(&self.step.to_le_bytes());
        b.extend_from_slice(&u64::from(self.reason == REASONS[1]).to_le_bytes());
        for v in [self.t, self.rho]
            .into_iter()
            .chain((0..3).map(|a| self.x.get(a).copied().unwrap_or(0.0)))
            .chain([self.mass, self.energy])
        {
            b.extend_from_slice(&v.to_bits().to_le_bytes());
        }
        b
    }

    /// Decode the records of [`Removal::to_bytes`] in `b`, for a `d`-dimensional run.
    pub fn from_bytes(b: &[u8], d: usize) -> Vec<Removal> {
        b.chunks_exact(8 * WORDS)
            .map(|c| {
                let w = |k: usize| u64::from_le_bytes(c[8 * k..8 * k + 8].try_into().expect("8 bytes"));
                Removal {
                    id: w(0),
                    step: w(1),
                    reason: REASONS[(w(2) as usize).min(1)],
                    t: f64::from_bits(w(3)),
                    rho: f64::from_bits(w(4)),
                    x: (0..d).map(|a| f64::from_bits(w(5 + a))).collect(),
                    mass: f64::from_bits(w(8)),
                    energy: f64::from_bits(w(9)),
                }
            })
            .collect()
    }
}

/// The reasons for a removal.
pub const REASONS: [&str; 2] = ["left the domain", "density out of band"];

impl<const D: usize> Simulation<D> {
    /// Under `outflow = "remove"`, take out every owned fluid particle with a finite state that
    /// left the domain (`density = false`) or whose density left the band (`density = true`),
    /// recording each in `self.removed`. Ghosts are dropped first (they are rebuilt every step).
    pub(super) fn apply_outflow(&mut self, density: bool) {
        if self.scene.domain.outflow != Outflow::Remove {
            return;
        }
        let (lo, hi) = (
            self.scene.limits.density_ratio[0],
            self.scene.limits.density_ratio[1],
        );
        let p = &self.p;
        let gone = |i: usize| {
            let finite = p.x[i].iter().all(|c| c.is_finite()) && p.rho[i].is_finite();
            if !p.kind[i].is_integrated() || !finite {
                return false;
            }
            if density {
                // the band is a weakly compressible fluid's; solids are bounded by their EOS
                // and fragments may expand freely
                if p.kind[i].is_solid() {
                    return false;
                }
                let r = p.rho[i] / self.model.materials[p.mat[i] as usize].rho0();
                !(lo..=hi).contains(&r)
            } else {
                !self.space.contains(&p.x[i])
            }
        };
        let leaving = super::scan::all(p.n_owned, gone);
        if leaving.is_empty() {
            return;
        }
        for &i in &leaving {
            let [kinetic, potential, internal] = self.energies(i);
            self.removed.push(Removal {
                id: p.id[i],
                step: self.step,
                t: self.t,
                x: p.x[i].iter().copied().collect(),
                rho: p.rho[i],
                reason: REASONS[usize::from(density)],
                mass: p.mass[i],
                energy: kinetic + potential + internal,
            });
        }
        let mut keep = vec![true; self.p.n_owned];
        leaving.iter().for_each(|&i| keep[i] = false);
        let keep: Vec<usize> = (0..self.p.n_owned).filter(|&i| keep[i]).collect();
        self.p.truncate_ghosts();
        self.p.permute_owned(&keep);
    }
}

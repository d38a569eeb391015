//! Repulsive wall particles (Monaghan 1994, J. Comput. Phys. 110, 399): a wall particle j
//! pushes a fluid particle i closer than r0 with the Lennard-Jones-like acceleration
//!   f_ij = D [(r0/r)¹² − (r0/r)⁴] x_ij / r²   (m/s², x_ij = x_i − x_j, r = |x_ij|),
//! and takes part in no SPH sum. D (m²/s²) is of the order of the squared largest speed:
//! hsph uses D = c0²/40, which is 5gH when c0 = 10√(2gH) as Monaghan suggests, and r0 = dx.

use crate::Vector;

/// Force scale D (m²/s²) and range r0 (m) of the repulsive walls of a run.
#[derive(Debug, Clone, Copy)]
pub struct Repulsion {
    /// D (m²/s²).
    pub d: f64,
    /// r0 (m).
    pub r0: f64,
}

impl Repulsion {
    /// D = c_max²/40 and r0 = dx.
    pub fn new(c_max: f64, dx: f64) -> Self {
        Repulsion {
            d: c_max * c_max / 40.0,
            r0: dx,
        }
    }

    /// The acceleration of a fluid particle at offset `xij` (|xij|² = `r2`, |xij| = `r`) from
    /// a wall particle, or `None` beyond r0.
    #[inline(always)]
    pub fn acceleration<const D: usize>(&self, xij: &Vector<D>, r2: f64, r: f64) -> Option<Vector<D>> {
        if r < self.r0 {
            let q = self.r0 / r;
            let q2 = q * q;
            let q4 = q2 * q2;
            Some(xij * (self.d * (q4 * q4 * q4 - q4) / r2))
        } else {
            None
        }
    }
}

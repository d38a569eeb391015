//! Creeping (Stokes, Re → 0) flow in the lid-driven square cavity by finite differences: the
//! reference of the Re = 1 cavity, where inertia changes the centreline velocities by well under
//! the SPH errors measured (the Re = 1 and Stokes solutions differ by O(Re) ≈ 0.1 % of U; see
//! docs/validation.md).
//!
//! Stream function ψ and vorticity ω on a uniform (n+1) × (n+1) grid over the unit square, u =
//! ∂ψ/∂y, v = −∂ψ/∂x, lid y = 1 moving at u = 1:
//!
//! - ∇²ω = 0, ∇²ψ = −ω in the interior (second-order central differences);
//! - ψ = 0 on every wall; wall vorticity by Thom's formula, ω_w = −2 ψ_1 / h² on a fixed wall
//!   and ω_w = −2 ψ_1 / h² − 2U / h on the lid (ψ_1: the first interior line).
//!
//! Solved by alternating SOR sweeps until the largest change of ψ falls below 1e-13.

/// The Stokes solution on 128 intervals, solved once per process (about 0.5 s).
pub fn shared() -> &'static StokesCavity {
    static S: std::sync::OnceLock<StokesCavity> = std::sync::OnceLock::new();
    S.get_or_init(|| StokesCavity::solve(128))
}

/// The converged grid: ψ at (i, j) = (x index, y index), spacing 1/n.
pub struct StokesCavity {
    n: usize,
    psi: Vec<f64>,
}

impl StokesCavity {
    /// Solve on an (n+1) × (n+1) grid (n even, ≥ 8).
    pub fn solve(n: usize) -> Self {
        let n = n.max(8) & !1;
        let h = 1.0 / n as f64;
        let idx = |i: usize, j: usize| j * (n + 1) + i;
        let mut psi = vec![0.0; (n + 1) * (n + 1)];
        let mut omega = vec![0.0; (n + 1) * (n + 1)];
        let w = 1.7;
        for _ in 0..200_000 {
            // wall vorticity (Thom)
            for k in 0..=n {
                omega[idx(k, 0)] = -2.0 * psi[idx(k, 1)] / (h * h);
                omega[idx(k, n)] = -2.0 * psi[idx(k, n - 1)] / (h * h) - 2.0 / h;
                omega[idx(0, k)] = -2.0 * psi[idx(1, k)] / (h * h);
                omega[idx(n, k)] = -2.0 * psi[idx(n - 1, k)] / (h * h);
            }
            for j in 1..n {
                for i in 1..n {
                    let avg = 0.25
                        * (omega[idx(i + 1, j)]
                            + omega[idx(i - 1, j)]
                            + omega[idx(i, j + 1)]
                            + omega[idx(i, j - 1)]);
                    omega[idx(i, j)] += w * (avg - omega[idx(i, j)]);
                }
            }
            let mut change: f64 = 0.0;
            for j in 1..n {
                for i in 1..n {
                    let target = 0.25
                        * (psi[idx(i + 1, j)]
                            + psi[idx(i - 1, j)]
                            + psi[idx(i, j + 1)]
                            + psi[idx(i, j - 1)]
                            + h * h * omega[idx(i, j)]);
                    let d = w * (target - psi[idx(i, j)]);
                    psi[idx(i, j)] += d;
                    change = change.max(d.abs());
                }
            }
            if change < 1e-13 {
                break;
            }
        }
        StokesCavity { n, psi }
    }

    fn psi_at(&self, i: usize, j: usize) -> f64 {
        self.psi[j * (self.n + 1) + i]
    }

    /// u = ∂ψ/∂y on the vertical centreline x = 1/2 at height y ∈ (0, 1) (units of U):
    /// central differences at the grid lines, linear in between.
    pub fn u_centre(&self, y: f64) -> f64 {
        let (n, h) = (self.n, 1.0 / self.n as f64);
        let ic = n / 2;
        let du = |j: usize| {
            if j == n {
                1.0
            } else if j == 0 {
                0.0
            } else {
                (self.psi_at(ic, j + 1) - self.psi_at(ic, j - 1)) / (2.0 * h)
            }
        };
        let s = (y / h).clamp(0.0, n as f64);
        let j = (s.floor() as usize).min(n - 1);
        let f = s - j as f64;
        du(j) * (1.0 - f) + du(j + 1) * f
    }

    /// v = −∂ψ/∂x on the horizontal centreline y = 1/2 at x ∈ (0, 1) (units of U).
    pub fn v_centre(&self, x: f64) -> f64 {
        let (n, h) = (self.n, 1.0 / self.n as f64);
        let jc = n / 2;
        let dv = |i: usize| {
            if i == 0 || i == n {
                0.0
            } else {
                -(self.psi_at(i + 1, jc) - self.psi_at(i - 1, jc)) / (2.0 * h)
            }
        };
        let s = (x / h).clamp(0.0, n as f64);
        let i = (s.floor() as usize).min(n - 1);
        let f = s - i as f64;
        dv(i) * (1.0 - f) + dv(i + 1) * f
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Grid convergence: the 64- and 128-interval solutions agree to 2e-3 U at Ghia's points,
    /// the flow is symmetric about x = 1/2 as Stokes flow must be (u(x) = u(1 − x), v odd), the
    /// lid drags the top forward and the return flow is backward (u(0.5) < 0).
    #[test]
    fn the_stokes_cavity_converges_and_has_its_symmetries() {
        let (a, b) = (StokesCavity::solve(64), StokesCavity::solve(128));
        for k in 1..20 {
            let c = k as f64 / 20.0;
            assert!((a.u_centre(c) - b.u_centre(c)).abs() < 2e-3, "u at {c}");
            assert!((a.v_centre(c) - b.v_centre(c)).abs() < 2e-3, "v at {c}");
            assert!(
                (b.v_centre(c) + b.v_centre(1.0 - c)).abs() < 1e-9,
                "v antisymmetric at {c}"
            );
        }
        assert!(b.u_centre(0.95) > 0.3 && b.u_centre(0.5) < -0.1);
    }
}

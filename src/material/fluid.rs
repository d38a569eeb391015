//! Weakly compressible fluids: a barotropic EOS, Tait or linear (`docs/methods.md` §2).

use serde::{Deserialize, Serialize};

/// Equation of state of a weakly compressible fluid (`eos = "tait"` or `"linear"`).
#[derive(Debug, Clone, Copy, Serialize, Deserialize, PartialEq, Eq)]
#[serde(rename_all = "snake_case")]
pub enum EosKind {
    /// Tait: p = ρ0 c0²/γ [(ρ/ρ0)^γ − 1].
    Tait,
    /// Linear: p = c0² (ρ − ρ0).
    Linear,
}

/// A barotropic fluid EOS with its constants (Tait: p = B[(ρ/ρ0)^γ − 1], B = ρ0c0²/γ;
/// linear: p = c0²(ρ − ρ0)).
#[derive(Debug, Clone, Copy)]
pub struct Eos {
    /// Tait or linear.
    pub kind: EosKind,
    /// Reference density ρ0 (kg/m³).
    pub rho0: f64,
    /// Sound speed c0 (m/s).
    pub c0: f64,
    /// Tait exponent γ.
    pub gamma: f64,
    /// Tait stiffness B = ρ0 c0²/γ (Pa).
    b: f64,
}

impl Eos {
    /// The EOS of `kind` with reference density ρ0 (kg/m³), sound speed c0 (m/s) and Tait
    /// exponent γ.
    pub fn new(kind: EosKind, rho0: f64, c0: f64, gamma: f64) -> Self {
        Eos {
            kind,
            rho0,
            c0,
            gamma,
            b: rho0 * c0 * c0 / gamma,
        }
    }

    /// Pressure p(ρ) (Pa): Tait p = B[(ρ/ρ0)^γ − 1], linear p = c0²(ρ − ρ0).
    #[inline]
    pub fn pressure(&self, rho: f64) -> f64 {
        match self.kind {
            EosKind::Tait => {
                let r = rho / self.rho0;
                // γ = 7 (the usual water value) without powf
                let rg = if self.gamma == 7.0 {
                    let r2 = r * r;
                    r2 * r2 * r2 * r
                } else {
                    r.powf(self.gamma)
                };
                self.b * (rg - 1.0)
            }
            EosKind::Linear => self.c0 * self.c0 * (rho - self.rho0),
        }
    }

    /// Specific internal energy e(ρ) (J/kg), see [`MaterialModel::internal_energy`].
    pub fn internal_energy(&self, rho: f64) -> f64 {
        let r = rho / self.rho0;
        match self.kind {
            EosKind::Tait => {
                let g = self.gamma;
                self.b / self.rho0 * ((r.powf(g - 1.0) - 1.0) / (g - 1.0) + 1.0 / r - 1.0)
            }
            EosKind::Linear => self.c0 * self.c0 * (r.ln() + 1.0 / r - 1.0),
        }
    }

    /// Density ρ(p) (kg/m³), the inverse of [`Eos::pressure`]; tension is limited so the
    /// density stays positive.
    #[inline]
    pub fn density(&self, p: f64) -> f64 {
        match self.kind {
            EosKind::Tait => self.rho0 * (p / self.b + 1.0).max(1e-3).powf(1.0 / self.gamma),
            EosKind::Linear => (self.rho0 + p / (self.c0 * self.c0)).max(1e-3 * self.rho0),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn pressure_and_density_are_inverse_and_match_hand_values() {
        let m = |eos| Eos::new(eos, 1000.0, 20.0, 7.0);
        let tait = m(EosKind::Tait);
        // B = 1000·400/7; p(1010) = B (1.01^7 − 1)
        let b = 1000.0 * 400.0 / 7.0;
        assert!((tait.pressure(1010.0) - b * (1.01f64.powi(7) - 1.0)).abs() < 1e-9);
        let lin = m(EosKind::Linear);
        assert_eq!(lin.pressure(1001.0), 400.0);
        // e(ρ) is the integral of p/ρ²: compare with a fine midpoint rule, and ≈ c0²ε²/2
        for eos in [tait, lin] {
            let rho = 1012.0;
            let n = 20_000;
            let h = (rho - 1000.0) / n as f64;
            let quad: f64 = (0..n)
                .map(|k| {
                    let s = 1000.0 + (k as f64 + 0.5) * h;
                    eos.pressure(s) / (s * s) * h
                })
                .sum();
            assert!((eos.internal_energy(rho) - quad).abs() < 1e-9 * quad, "{quad}");
            assert_eq!(eos.internal_energy(1000.0), 0.0);
            let eps: f64 = 1e-3;
            assert!(
                (eos.internal_energy(1000.0 * (1.0 + eps)) / (400.0 * eps * eps / 2.0) - 1.0).abs() < 0.01
            );
        }
        for rho in [990.0, 1000.0, 1003.5] {
            assert!((tait.density(tait.pressure(rho)) - rho).abs() < 1e-9);
            assert!((lin.density(lin.pressure(rho)) - rho).abs() < 1e-9);
        }
    }
}

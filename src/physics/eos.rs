//! Equations of state of weakly compressible fluids (methods.md §2).

use crate::scene::{EosKind, Material};

/// A fluid EOS with its constants.
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
    /// The EOS of a scene material.
    pub fn new(m: &Material) -> Self {
        Eos {
            kind: m.eos,
            rho0: m.rho0,
            c0: m.c0,
            gamma: m.gamma,
            b: m.rho0 * m.c0 * m.c0 / m.gamma,
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
        let m = |eos| Material {
            name: "w".into(),
            rho0: 1000.0,
            c0: 20.0,
            eos,
            gamma: 7.0,
        };
        let tait = Eos::new(&m(EosKind::Tait));
        // B = 1000·400/7; p(1010) = B (1.01^7 − 1)
        let b = 1000.0 * 400.0 / 7.0;
        assert!((tait.pressure(1010.0) - b * (1.01f64.powi(7) - 1.0)).abs() < 1e-9);
        let lin = Eos::new(&m(EosKind::Linear));
        assert_eq!(lin.pressure(1001.0), 400.0);
        for rho in [990.0, 1000.0, 1003.5] {
            assert!((tait.density(tait.pressure(rho)) - rho).abs() < 1e-9);
            assert!((lin.density(lin.pressure(rho)) - rho).abs() < 1e-9);
        }
    }
}

//! Material models: what a particle's material answers to the step — its pressure from
//! density and specific internal energy, its sound speed, its reference density. Weakly
//! compressible fluids now (Tait or linear EOS, methods.md §2); elastic–plastic solids
//! (Mie–Grüneisen, Johnson–Cook) join [`MaterialModel`] as a second variant with their own
//! side fields, so the step loop asks the model and never the scene.

use super::solid::SolidModel;
use crate::scene::{EosKind, Material};

/// The model of one material of the scene.
#[derive(Debug, Clone, Copy)]
pub enum MaterialModel {
    /// A weakly compressible fluid with a barotropic EOS.
    Fluid(Eos),
    /// An elastic–plastic solid (Mie–Grüneisen, shear modulus, Johnson–Cook, failure).
    Solid(SolidModel),
}

impl MaterialModel {
    /// The model of a scene material.
    pub fn new(m: &Material) -> Self {
        if m.is_solid() {
            MaterialModel::Solid(SolidModel::new(m))
        } else {
            MaterialModel::Fluid(Eos::new(m))
        }
    }

    /// The solid model, if this is a solid.
    #[inline]
    pub fn solid(&self) -> Option<&SolidModel> {
        match self {
            MaterialModel::Solid(s) => Some(s),
            MaterialModel::Fluid(_) => None,
        }
    }

    /// Pressure p(ρ, e) (Pa) from density ρ (kg/m³) and specific internal energy e (J/kg);
    /// a barotropic fluid ignores e.
    #[inline]
    pub fn pressure(&self, rho: f64, e: f64) -> f64 {
        match self {
            MaterialModel::Fluid(eos) => eos.pressure(rho),
            MaterialModel::Solid(s) => s.eos.pressure(rho, e),
        }
    }

    /// Density at pressure p (Pa) on the material's reference isentrope (kg/m³): the inverse
    /// of [`MaterialModel::pressure`] at e = 0, used to give extrapolated wall particles and
    /// hydrostatic initial states their density.
    #[inline]
    pub fn density(&self, p: f64) -> f64 {
        match self {
            MaterialModel::Fluid(eos) => eos.density(p),
            // the linear (acoustic) branch: exact in tension, first order in compression
            MaterialModel::Solid(s) => s.eos.rho0 * (1.0 + p / (s.eos.rho0 * s.eos.c0 * s.eos.c0)),
        }
    }

    /// Reference density ρ0 (kg/m³).
    #[inline]
    pub fn rho0(&self) -> f64 {
        match self {
            MaterialModel::Fluid(eos) => eos.rho0,
            MaterialModel::Solid(s) => s.eos.rho0,
        }
    }

    /// Specific internal (compression) energy e(ρ) = ∫ from ρ0 to ρ of p(ρ')/ρ'² dρ' (J/kg) of a
    /// barotropic fluid, with r = ρ/ρ0: Tait (B/ρ0)[(r^(γ−1) − 1)/(γ−1) + 1/r − 1], linear
    /// c0²[ln r + 1/r − 1]; both ≈ c0²(r − 1)²/2 near ρ0. The work the pressure stores. A
    /// solid carries its specific internal energy as a field: 0 here.
    pub fn internal_energy(&self, rho: f64) -> f64 {
        match self {
            MaterialModel::Fluid(eos) => eos.internal_energy(rho),
            MaterialModel::Solid(_) => 0.0,
        }
    }

    /// Sound speed used by the time-step limit and the numerical diffusion terms (m/s): the
    /// numerical c0 of a weakly compressible fluid.
    #[inline]
    pub fn c0(&self) -> f64 {
        match self {
            MaterialModel::Fluid(eos) => eos.c0,
            MaterialModel::Solid(s) => s.eos.c0,
        }
    }
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
        let m = |eos| Material::fluid("w", 1000.0, 20.0, eos);
        let tait = Eos::new(&m(EosKind::Tait));
        // B = 1000·400/7; p(1010) = B (1.01^7 − 1)
        let b = 1000.0 * 400.0 / 7.0;
        assert!((tait.pressure(1010.0) - b * (1.01f64.powi(7) - 1.0)).abs() < 1e-9);
        let lin = Eos::new(&m(EosKind::Linear));
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

//! Mie–Grüneisen equation of state on a linear Us–up Hugoniot (solids issue, item 1).
//!
//! With the compression η = 1 − ρ0/ρ (μ = ρ/ρ0 − 1 = η/(1 − η)) and the Hugoniot of a linear
//! shock-velocity law Us = c0 + s·up,
//!
//!   p_H(η) = ρ0 c0² η / (1 − s η)²,   e_H(η) = p_H η / (2 ρ0)                    (1)
//!
//! (Rankine–Hugoniot energy jump from a state at rest, p = 0, e = 0). The Grüneisen form
//! p = p_H + Γ ρ (e − e_H) with **ρΓ = ρ0Γ0** (Γ/V constant, the usual choice for metals and
//! the one of Libersky et al. 1993 and LS-DYNA's `*EOS_GRUNEISEN` without its volume
//! correction) gives
//!
//!   compression (η ≥ 0):  p = p_H(η) (1 − Γ0 η / 2) + Γ0 ρ0 e                        (2)
//!   tension     (η < 0):  p = ρ0 c0² μ + Γ0 ρ0 e                                     (3)
//!
//! (the tension branch is the linear, acoustic one: a Hugoniot does not exist in expansion).
//! Both branches meet at η = 0 with the same value and slope ρ0c0²·dη.
//! The isentropic sound speed follows from c² = ∂p/∂ρ|_e + (p/ρ²) ∂p/∂e|_ρ.
//! Units: ρ kg/m³, e J/kg, p Pa, c m/s.

/// Largest s·η the EOS evaluates (see [`MieGruneisen::eta`]).
pub const ETA_CAP: f64 = 0.8;

/// Mie–Grüneisen constants of a material.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct MieGruneisen {
    /// Reference density ρ0 (kg/m³).
    pub rho0: f64,
    /// Bulk sound speed, the intercept of Us = c0 + s·up (m/s).
    pub c0: f64,
    /// Slope s of Us = c0 + s·up (–).
    pub s: f64,
    /// Grüneisen coefficient Γ0 (–), with ρΓ = ρ0Γ0.
    pub gamma0: f64,
}

impl MieGruneisen {
    /// Compression η = 1 − ρ0/ρ, capped at [`ETA_CAP`]/s: the linear Hugoniot's pressure is
    /// infinite at η = 1/s (ρ = 3.5 ρ0 for aluminium), a compression no shock of interest
    /// reaches (4.47 km/s aluminium on aluminium: η ≈ 0.26) but an isolated pair of debris
    /// particles colliding in one step can; beyond the cap the pressure stays at the cap's.
    #[inline]
    pub fn eta(&self, rho: f64) -> f64 {
        let eta = 1.0 - self.rho0 / rho;
        if self.s > 0.0 {
            eta.min(ETA_CAP / self.s)
        } else {
            eta
        }
    }

    /// Hugoniot pressure p_H(η) (Pa), eq. (1); η ≥ 0.
    #[inline]
    pub fn hugoniot_pressure(&self, eta: f64) -> f64 {
        let d = 1.0 - self.s * eta;
        self.rho0 * self.c0 * self.c0 * eta / (d * d)
    }

    /// Specific internal energy on the Hugoniot e_H(η) (J/kg), eq. (1).
    #[inline]
    pub fn hugoniot_energy(&self, eta: f64) -> f64 {
        self.hugoniot_pressure(eta) * eta / (2.0 * self.rho0)
    }

    /// Pressure p(ρ, e) (Pa), eqs. (2)–(3).
    #[inline]
    pub fn pressure(&self, rho: f64, e: f64) -> f64 {
        let eta = self.eta(rho);
        let thermal = self.gamma0 * self.rho0 * e;
        if eta >= 0.0 {
            self.hugoniot_pressure(eta) * (1.0 - 0.5 * self.gamma0 * eta) + thermal
        } else {
            self.rho0 * self.c0 * self.c0 * (rho / self.rho0 - 1.0) + thermal
        }
    }

    /// ∂p/∂ρ at constant e (Pa m³/kg).
    pub fn dp_drho(&self, rho: f64) -> f64 {
        let eta = self.eta(rho);
        if eta >= 0.0 {
            let k = self.rho0 * self.c0 * self.c0;
            let d = 1.0 - self.s * eta;
            let dph = k * (1.0 + self.s * eta) / (d * d * d);
            let dp_deta =
                dph * (1.0 - 0.5 * self.gamma0 * eta) - 0.5 * self.gamma0 * self.hugoniot_pressure(eta);
            dp_deta * self.rho0 / (rho * rho)
        } else {
            self.c0 * self.c0
        }
    }

    /// Isentropic bulk sound speed c (m/s): c² = ∂p/∂ρ|_e + (p/ρ²) Γ0 ρ0, floored at zero
    /// (a state far in tension with little energy can give c² < 0: no sound then).
    pub fn sound_speed(&self, rho: f64, e: f64) -> f64 {
        let p = self.pressure(rho, e);
        let c2 = self.dp_drho(rho) + p * self.gamma0 * self.rho0 / (rho * rho);
        c2.max(0.0).sqrt()
    }

    /// Bulk modulus K = ρ c² (Pa) at (ρ, e).
    pub fn bulk_modulus(&self, rho: f64, e: f64) -> f64 {
        let c = self.sound_speed(rho, e);
        rho * c * c
    }

    /// Shock state from a particle velocity jump `up` (m/s) into material at rest:
    /// Us = c0 + s·up, ρ = ρ0 Us/(Us − up), p = ρ0 Us up, e = up²/2.
    pub fn shock_state(&self, up: f64) -> (f64, f64, f64, f64) {
        let us = self.c0 + self.s * up;
        (us, self.rho0 * us / (us - up), self.rho0 * us * up, 0.5 * up * up)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Al 6061-T6 (Steinberg 1996 via the refdata table).
    fn al() -> MieGruneisen {
        MieGruneisen {
            rho0: 2703.0,
            c0: 5240.0,
            s: 1.40,
            gamma0: 1.97,
        }
    }

    #[test]
    fn pressure_matches_hand_computed_values() {
        let m = al();
        // at rest: no pressure, sound speed c0
        assert_eq!(m.pressure(2703.0, 0.0), 0.0);
        assert!((m.sound_speed(2703.0, 0.0) - 5240.0).abs() < 1e-9);
        // ρ = 3000 kg/m³: η = 1 − 2703/3000 = 0.099; p_H = 2703·5240²·0.099/(1 − 1.4·0.099)²
        //   = 7.34777e9·0.099/0.745651... by hand: 2703·27457600 = 7.4217893e10;
        //   ·0.099 = 7.3475714e9; (1 − 0.1386)² = 0.8614² = 0.74200996; p_H = 9.9022e9 Pa;
        //   p = p_H (1 − 1.97·0.099/2) = p_H · 0.902485 = 8.9366e9 Pa
        let p = m.pressure(3000.0, 0.0);
        assert!((p - 8.9366e9).abs() < 2e6, "{p}");
        // energy term: + Γ0 ρ0 e = 1.97·2703·1e5 = 5.32491e8 Pa
        let pe = m.pressure(3000.0, 1e5);
        assert!((pe - p - 5.32491e8).abs() < 1.0, "{}", pe - p);
        // tension: ρ = 2600: ρ0c0²(ρ/ρ0 − 1) = 7.4217893e10·(−0.0381058) = −2.82813e9 Pa
        let pt = m.pressure(2600.0, 0.0);
        assert!((pt + 2.82813e9).abs() < 1e5, "{pt}");
    }

    #[test]
    fn the_eos_reproduces_its_hugoniot_and_its_slope() {
        let m = al();
        // a shock of up = 1 km/s: Us = 6640 m/s, ρ = 2703·6640/5640, p = 2703·6640·1000,
        // e = up²/2; eq. (2) at that (ρ, e) must give the same p (the Rankine–Hugoniot energy)
        let (us, rho, p, e) = m.shock_state(1000.0);
        assert_eq!(us, 6640.0);
        let rel = (m.pressure(rho, e) - p).abs() / p;
        assert!(rel < 1e-12, "{rel}");
        // ∂p/∂ρ against a central difference, both branches
        for rho in [2500.0, 2703.0 * 1.05, 3500.0] {
            let h = 1e-3;
            let fd = (m.pressure(rho + h, 0.0) - m.pressure(rho - h, 0.0)) / (2.0 * h);
            assert!((m.dp_drho(rho) - fd).abs() / fd < 1e-6, "{rho}");
        }
    }
}

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
    /// Test-only (proves that an EOS kind is added in this file alone and selected from a
    /// scene): quadratic, p = ρ0c0²/2 [(ρ/ρ0)² − 1].
    #[cfg(test)]
    Toy,
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
    /// ρ0⁶/c0² (kg⁶ m⁻²⁰ s²): ρ/c²(ρ) = this / ρ⁵ for Tait with γ = 7
    /// ([`Eos::density_over_sound_speed2`]).
    rho0_6_over_c02: f64,
}

/// r^e of a density ratio r; the exponents of water's γ = 7 (7 for p, 6 for c²) without powf.
#[inline]
fn ratio_pow(r: f64, e: f64) -> f64 {
    let r2 = r * r;
    if e == 7.0 {
        r2 * r2 * r2 * r
    } else if e == 6.0 {
        r2 * r2 * r2
    } else {
        r.powf(e)
    }
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
            rho0_6_over_c02: rho0.powi(6) / (c0 * c0),
        }
    }

    /// Pressure p(ρ) (Pa): Tait p = B[(ρ/ρ0)^γ − 1], linear p = c0²(ρ − ρ0).
    #[inline]
    pub fn pressure(&self, rho: f64) -> f64 {
        match self.kind {
            EosKind::Tait => self.b * (ratio_pow(rho / self.rho0, self.gamma) - 1.0),
            EosKind::Linear => self.c0 * self.c0 * (rho - self.rho0),
            #[cfg(test)]
            EosKind::Toy => {
                let r = rho / self.rho0;
                0.5 * self.rho0 * self.c0 * self.c0 * (r * r - 1.0)
            }
        }
    }

    /// Squared sound speed c²(ρ) = dp/dρ (m²/s²): Tait c0² (ρ/ρ0)^(γ−1), linear c0².
    #[inline]
    pub fn sound_speed2(&self, rho: f64) -> f64 {
        let c02 = self.c0 * self.c0;
        match self.kind {
            EosKind::Tait => c02 * ratio_pow(rho / self.rho0, self.gamma - 1.0),
            EosKind::Linear => c02,
            #[cfg(test)]
            EosKind::Toy => c02 * rho / self.rho0,
        }
    }

    /// ρ/c²(ρ) (kg s² m⁻⁵), what Fourtakas's hydrostatic density difference ρ g·x/c² needs per
    /// pair: for water's Tait γ = 7, c² = c0² (ρ/ρ0)⁶ gives ρ/c² = (ρ0⁶/c0²)/ρ⁵, one division
    /// per pair where ρ/(c0² (ρ/ρ0)⁶) takes two (the pair pass waits on its divisions); to
    /// round-off the same value.
    #[inline]
    pub fn density_over_sound_speed2(&self, rho: f64) -> f64 {
        if self.kind == EosKind::Tait && self.gamma == 7.0 {
            let r2 = rho * rho;
            self.rho0_6_over_c02 / (r2 * r2 * rho)
        } else {
            rho / self.sound_speed2(rho)
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
            #[cfg(test)]
            EosKind::Toy => 0.5 * self.c0 * self.c0 * (r + 1.0 / r - 2.0),
        }
    }

    /// Density ρ(p) (kg/m³), the inverse of [`Eos::pressure`]; tension is limited so the
    /// density stays positive.
    #[inline]
    pub fn density(&self, p: f64) -> f64 {
        match self.kind {
            EosKind::Tait => self.rho0 * (p / self.b + 1.0).max(1e-3).powf(1.0 / self.gamma),
            EosKind::Linear => (self.rho0 + p / (self.c0 * self.c0)).max(1e-3 * self.rho0),
            #[cfg(test)]
            EosKind::Toy => self.rho0 * (1.0 + 2.0 * p / (self.rho0 * self.c0 * self.c0)).max(1e-6).sqrt(),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn density_over_sound_speed2_is_rho_over_c2_to_round_off() {
        // Tait γ = 7 takes (ρ0⁶/c0²)/ρ⁵; the others ρ/c² itself
        for (kind, gamma) in [(EosKind::Tait, 7.0), (EosKind::Tait, 1.4), (EosKind::Linear, 7.0)] {
            let eos = Eos::new(kind, 1000.0, 35.0, gamma);
            for rho in [950.0, 999.0, 1000.0, 1003.7, 1100.0] {
                let want = rho / eos.sound_speed2(rho);
                let got = eos.density_over_sound_speed2(rho);
                assert!(
                    (got - want).abs() <= 4.0 * f64::EPSILON * want,
                    "{kind:?} γ {gamma} ρ {rho}"
                );
            }
        }
        // c² = c0² at ρ0: ρ0/c0²
        let eos = Eos::new(EosKind::Tait, 1000.0, 35.0, 7.0);
        assert!((eos.density_over_sound_speed2(1000.0) - 1000.0 / 1225.0).abs() < 1e-15);
    }

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

    /// A new EOS kind lives in this file alone: the test-only `toy` kind is selected by a scene
    /// file's `eos = "toy"`, reaches the material model, and the hydrostatic set-up gives the
    /// deepest water the density whose toy pressure is ρ0 g d.
    #[test]
    fn an_eos_kind_added_here_is_selected_by_a_scene_and_reaches_the_set_up() {
        let text = std::fs::read_to_string("inputs/hydrostatic_2d.toml")
            .unwrap()
            .replace("eos = \"tait\"", "eos = \"toy\"");
        let (scene, _) =
            crate::scene::load_scene_str(&text, std::path::Path::new("toy.toml"), "toy", &[]).unwrap();
        let m = scene.materials[0].model();
        let (rho0, c0) = (scene.materials[0].rho0, scene.materials[0].c0);
        let rho = 1.01 * rho0;
        assert!((m.pressure(rho, 0.0) - 0.5 * rho0 * c0 * c0 * (1.01f64 * 1.01 - 1.0)).abs() < 1e-9);
        assert!((m.density(m.pressure(rho, 0.0)) - rho).abs() < 1e-9 * rho);
        let e = Eos::new(EosKind::Toy, rho0, c0, 7.0);
        let n = 20_000;
        let h = (rho - rho0) / n as f64;
        let quad: f64 = (0..n)
            .map(|k| {
                let s = rho0 + (k as f64 + 0.5) * h;
                e.pressure(s) / (s * s) * h
            })
            .sum();
        assert!((e.internal_energy(rho) - quad).abs() < 1e-9 * quad);
        let p = crate::setup::build_particles::<2>(&scene).unwrap();
        let g = scene.physics.body_force[1].abs();
        // the set-up's depth runs from the top of the fluid body
        let deepest = (0..p.n_owned)
            .filter(|&i| p.kind[i].is_fluid())
            .min_by(|&a, &b| p.x[a][1].total_cmp(&p.x[b][1]))
            .unwrap();
        let depth = scene.fluids[0].max[1] - p.x[deepest][1];
        let want = m.density(rho0 * g * depth);
        assert!(p.rho[deepest] > rho0, "the toy EOS compressed the deepest water");
        assert!(
            (p.rho[deepest] - want).abs() < 1e-9 * want,
            "ρ {} against {want} (depth {depth} m)",
            p.rho[deepest]
        );
    }
}

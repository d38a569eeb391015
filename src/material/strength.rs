//! Strength of elastic–plastic solids (solids issue, item 1): the Johnson–Cook flow stress, the
//! Jaumann rate of the deviatoric stress, the radial return to the yield surface, temperature
//! from internal energy and the failure criteria. Units: stresses Pa, strains –, rates 1/s,
//! temperatures K, specific energies J/kg.

pub use crate::Tensor;

/// Johnson–Cook flow stress (Johnson & Cook 1983):
///
///   σ_y = (A + B ε_p^n) (1 + C ln max(ε̇_p/ε̇0, 1)) (1 − T*^m),
///   T* = clamp((T − T_room)/(T_melt − T_room), 0, 1)                              (4)
///
/// so rates below ε̇0 do not soften (the logarithm is never negative), and at T* = 1 (melt) the
/// material has no strength.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct JohnsonCook {
    /// Yield stress A (Pa).
    pub a: f64,
    /// Hardening modulus B (Pa).
    pub b: f64,
    /// Hardening exponent n (–).
    pub n: f64,
    /// Strain-rate coefficient C (–).
    pub c: f64,
    /// Thermal-softening exponent m (–).
    pub m: f64,
    /// Reference plastic strain rate ε̇0 (1/s).
    pub eps_dot0: f64,
    /// Room (reference) temperature (K).
    pub t_room: f64,
    /// Melt temperature (K).
    pub t_melt: f64,
}

impl JohnsonCook {
    /// Homologous temperature T*, clamped to [0, 1].
    #[inline]
    pub fn homologous(&self, t: f64) -> f64 {
        ((t - self.t_room) / (self.t_melt - self.t_room)).clamp(0.0, 1.0)
    }

    /// Flow stress σ_y (Pa) at plastic strain `eps_p`, plastic strain rate `rate` (1/s) and
    /// temperature `t` (K), eq. (4).
    pub fn flow_stress(&self, eps_p: f64, rate: f64, t: f64) -> f64 {
        let hardening = self.a + self.b * eps_p.max(0.0).powf(self.n);
        let rate_term = 1.0 + self.c * (rate / self.eps_dot0).max(1.0).ln();
        let thermal = 1.0 - self.homologous(t).powf(self.m);
        hardening * rate_term * thermal
    }
}

/// Temperature from specific internal energy: T = T_room + e / c_v (K), e measured from the
/// state at rest at T_room. The whole internal energy counts as heat: in compression this
/// overestimates the temperature by the recoverable cold-compression energy, which the
/// material gives back on release; the hole's edge, where softening matters, is released
/// material, so the simple form is kept (stated in docs/solids.md).
#[inline]
pub fn temperature(e: f64, c_v: f64, t_room: f64) -> f64 {
    t_room + e.max(0.0) / c_v
}

/// Strain rate ε̇ = ½(∇v + ∇vᵀ) and spin Ω = ½(∇v − ∇vᵀ) of the velocity gradient
/// `grad_v[(a, b)] = ∂v_a/∂x_b` (1/s).
#[inline]
pub fn rate_and_spin<const D: usize>(grad_v: &Tensor<D>) -> (Tensor<D>, Tensor<D>) {
    let t = grad_v.transpose();
    ((grad_v + t) * 0.5, (grad_v - t) * 0.5)
}

/// Jaumann rate of the deviatoric stress S (Pa/s) for shear modulus `g` (Pa):
///
///   dS/dt = 2G (ε̇ − ⅓ tr(ε̇) I) + Ω S − S Ω                                         (5)
///
/// with ε̇ and Ω from [`rate_and_spin`] (Gray, Monaghan & Swift 2001, eq. 2.8, whose
/// S^{ac}R^{bc} + R^{ac}S^{cb} is S Ωᵀ + Ω S = Ω S − S Ω since Ω is antisymmetric). For a
/// symmetric S, S Ω = −(Ω S)ᵀ, so the rotation term is computed as Ω S + (Ω S)ᵀ: one product
/// instead of two, and the rate is symmetric to the bit (each pair of off-diagonal entries
/// adds the same two numbers), so it is stored as its D(D+1)/2 distinct components. In 2D
/// this is plane strain: tr(ε̇) over the two in-plane axes.
pub fn jaumann_rate<const D: usize>(s: &Tensor<D>, grad_v: &Tensor<D>, g: f64) -> Tensor<D> {
    let (rate, spin) = rate_and_spin(grad_v);
    let dev = rate - Tensor::<D>::identity() * (rate.trace() / 3.0);
    let rot = spin * s;
    dev * (2.0 * g) + (rot + rot.transpose())
}

/// Von Mises equivalent stress √(3 J2), J2 = ½ S:S (Pa). In 2D (plane strain) S holds the
/// in-plane block of a traceless deviator, so S_zz = −tr S counts too.
#[inline]
pub fn von_mises<const D: usize>(s: &Tensor<D>) -> f64 {
    let zz = if D == 2 { s.trace() } else { 0.0 };
    (1.5 * (s.component_mul(s).sum() + zz * zz)).sqrt()
}

/// Radial return (Wilkins 1964): if the trial deviator `s` lies outside the yield surface
/// σ_eq > σ_y, scale it back onto it and return the plastic strain increment
/// Δε_p = (σ_eq − σ_y)/(3G); inside, leave it and return 0.
pub fn radial_return<const D: usize>(s: &mut Tensor<D>, yield_stress: f64, g: f64) -> f64 {
    let eq = von_mises(s);
    if eq <= yield_stress || eq == 0.0 {
        return 0.0;
    }
    let y = yield_stress.max(0.0);
    *s *= y / eq;
    (eq - y) / (3.0 * g)
}

/// When a particle fails: its equivalent plastic strain reaches `max_plastic_strain`, or its
/// pressure falls below −`spall_pressure` (tension). A failed particle carries no tension
/// and no shear from then on.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Failure {
    /// Equivalent plastic strain at failure (–).
    pub max_plastic_strain: f64,
    /// Spall strength: the tension at which the material separates (Pa, positive).
    pub spall_pressure: f64,
}

impl Failure {
    /// True if a particle at plastic strain `eps_p` and pressure `p` (Pa) fails.
    #[inline]
    pub fn fails(&self, eps_p: f64, p: f64) -> bool {
        eps_p >= self.max_plastic_strain || p <= -self.spall_pressure
    }
}

/// Longitudinal elastic wave speed √((K + 4G/3)/ρ) (m/s): the solid time-step limit's signal
/// speed (with the particle speed added by the caller).
#[inline]
pub fn longitudinal_speed(bulk_modulus: f64, g: f64, rho: f64) -> f64 {
    ((bulk_modulus + 4.0 * g / 3.0) / rho).sqrt()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Al 6061-T6 Johnson–Cook set (refdata: Uintah's JC 6061-T6 and Payette), ε̇0 = 1/s,
    /// T_melt = 925 K, T_room = 294 K.
    fn jc() -> JohnsonCook {
        JohnsonCook {
            a: 324e6,
            b: 114e6,
            n: 0.42,
            c: 0.002,
            m: 1.34,
            eps_dot0: 1.0,
            t_room: 294.0,
            t_melt: 925.0,
        }
    }

    #[test]
    fn johnson_cook_matches_hand_computed_values() {
        let j = jc();
        // no strain, slow, cold: A
        assert_eq!(j.flow_stress(0.0, 0.5, 294.0), 324e6);
        // below room temperature and below ε̇0 the terms do not go the wrong way
        assert_eq!(j.flow_stress(0.0, 1e-3, 200.0), 324e6);
        // ε_p = 0.1: 0.1^0.42 = e^(0.42 ln 0.1) = e^(−0.967092) = 0.380189;
        //   A + B·0.380189 = 324e6 + 43.3416e6 = 367.3416e6
        let s = j.flow_stress(0.1, 1.0, 294.0);
        assert!((s - 367.3416e6).abs() < 2e3, "{s}");
        // ε̇ = 1e5/s: 1 + 0.002 ln 1e5 = 1 + 0.002·11.512925 = 1.02302585
        let r = j.flow_stress(0.0, 1e5, 294.0);
        assert!((r - 324e6 * 1.023025851).abs() < 1.0, "{r}");
        // T = 609.5 K: T* = 315.5/631 = 0.5; 0.5^1.34 = e^(−1.34·0.693147) = 0.395021;
        //   324e6 · 0.604979 = 196.0132e6
        let t = j.flow_stress(0.0, 1.0, 609.5);
        assert!((t - 196.0132e6).abs() < 2e3, "{t}");
        // melt and above: no strength
        assert_eq!(j.flow_stress(0.3, 1e6, 925.0), 0.0);
        assert_eq!(j.flow_stress(0.3, 1e6, 2000.0), 0.0);
        assert_eq!(j.homologous(100.0), 0.0);
    }

    #[test]
    fn temperature_and_failure() {
        // e = 896 J/kg·K × 100 K above room: T = 394 K
        assert_eq!(temperature(89_600.0, 896.0, 294.0), 394.0);
        assert_eq!(temperature(-5.0, 896.0, 294.0), 294.0);
        let f = Failure {
            max_plastic_strain: 0.5,
            spall_pressure: 1.0e9,
        };
        assert!(!f.fails(0.49, -0.99e9));
        assert!(f.fails(0.5, 0.0));
        assert!(f.fails(0.0, -1.0e9));
    }

    #[test]
    fn pure_shear_rate_and_rotation() {
        // simple shear v_x = γ̇ y: ε̇_xy = γ̇/2, Ω_xy = γ̇/2; from S = 0 the rate is 2G ε̇_dev
        let g = 27.6e9;
        let gamma = 1e3;
        let mut grad = Tensor::<2>::zeros();
        grad[(0, 1)] = gamma;
        let ds = jaumann_rate(&Tensor::<2>::zeros(), &grad, g);
        assert!((ds[(0, 1)] - g * gamma).abs() < 1e-3);
        assert!((ds[(1, 0)] - g * gamma).abs() < 1e-3);
        assert_eq!(ds[(0, 0)], 0.0);
        // a rigid rotation (spin only) of S = diag(s, −s): dS/dt = ΩS − SΩ, off-diagonal
        // −2sω for Ω = [[0, ω], [−ω, 0]]... with ∂v_x/∂y = ω, ∂v_y/∂x = −ω
        let (s0, w) = (1e8, 10.0);
        let s = Tensor::<2>::new(s0, 0.0, 0.0, -s0);
        let spin = Tensor::<2>::new(0.0, w, -w, 0.0);
        let ds = jaumann_rate(&s, &spin, g);
        // ΩS = [[0, −ωs], [−ωs, 0]], SΩ = [[0, ωs], [ωs, 0]]: ΩS − SΩ = −2ωs off the diagonal
        assert!((ds[(0, 1)] + 2.0 * w * s0).abs() < 1e-6, "{ds}");
        assert!((ds[(1, 0)] + 2.0 * w * s0).abs() < 1e-6);
        assert!(ds[(0, 0)].abs() < 1e-6 && ds[(1, 1)].abs() < 1e-6);
        // the rotation keeps J2 to first order: S:dS/dt = 0
        assert!(s.component_mul(&ds).sum().abs() < 1e-3);
    }

    /// In 3D, for a symmetric S and a general velocity gradient, the rate equals
    /// 2G ε̇_dev + Ω S − S Ω to round-off and is symmetric to the bit (it is stored as its six
    /// distinct components).
    #[test]
    fn the_jaumann_rate_is_symmetric_to_the_bit() {
        let g = 26.0e9;
        let s = Tensor::<3>::new(1.3e8, -2.1e7, 4.4e7, -2.1e7, -0.7e8, 9.1e6, 4.4e7, 9.1e6, -0.6e8);
        let grad = Tensor::<3>::new(310.0, -1270.0, 55.5, 883.0, -41.0, 2.2e3, -977.0, 12.5, 77.0);
        let ds = jaumann_rate(&s, &grad, g);
        let (rate, spin) = rate_and_spin(&grad);
        let want = (rate - Tensor::<3>::identity() * (rate.trace() / 3.0)) * (2.0 * g) + spin * s - s * spin;
        for a in 0..3 {
            for b in 0..3 {
                assert_eq!(ds[(a, b)].to_bits(), ds[(b, a)].to_bits(), "({a}, {b})");
                assert!(
                    (ds[(a, b)] - want[(a, b)]).abs() <= 1e-12 * want.abs().max(),
                    "({a}, {b})"
                );
            }
        }
    }

    #[test]
    fn radial_return_lands_on_the_yield_surface() {
        let g = 27.6e9;
        // uniaxial-like deviator diag(2, −1, −1)·k: σ_eq = √(1.5·6k²) = 3k
        let k = 200e6;
        let mut s = Tensor::<3>::from_diagonal(&nalgebra::Vector3::new(2.0 * k, -k, -k));
        assert!((von_mises(&s) - 3.0 * k).abs() < 1e-3);
        let y = 324e6;
        let de = radial_return(&mut s, y, g);
        assert!((von_mises(&s) - y).abs() < 1e-3);
        assert!((de - (600e6 - y) / (3.0 * g)).abs() < 1e-15);
        // inside: untouched
        let before = s;
        assert_eq!(radial_return(&mut s, 2.0 * y, g), 0.0);
        assert_eq!(s, before);
        // melted (σ_y = 0): no deviator left
        radial_return(&mut s, 0.0, g);
        assert_eq!(von_mises(&s), 0.0);
        // longitudinal speed of Al: K = ρ0c0² = 7.42179e10, G = 27.6e9:
        // √((7.42179e10 + 3.68e10)/2703) = √(4.10721e7) = 6408.7 m/s
        let cl = longitudinal_speed(2703.0 * 5240.0 * 5240.0, g, 2703.0);
        assert!((cl - 6408.76).abs() < 0.5, "{cl}");
    }
}

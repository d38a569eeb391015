//! Material constants shipped with hsph, each with its source (the table
//! `inputs/reference/hvi_aluminium_material_parameters.csv` of the project's reference data
//! gives the repositories and papers). Only sets whose digits two sources agree on, or that a
//! named primary source gives, are here: Al 6061-T6 is the one alloy with a verified
//! Johnson–Cook set; the Al 2024-T3 Johnson–Cook row of that table is marked UNVERIFIED and is
//! left out.

use super::mie_gruneisen::MieGruneisen;
use super::strength::JohnsonCook;

/// An elastic–plastic material: EOS, shear modulus, strength, heat capacity.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SolidConstants {
    /// Library name (`material = "..."` in a scene).
    pub name: &'static str,
    /// Mie–Grüneisen EOS.
    pub eos: MieGruneisen,
    /// Shear modulus G (Pa).
    pub shear_modulus: f64,
    /// Johnson–Cook flow stress.
    pub strength: JohnsonCook,
    /// Specific heat c_v (J/(kg K)); for a solid c_v ≈ c_p.
    pub specific_heat: f64,
    /// Where the numbers come from.
    pub source: &'static str,
}

/// Al 6061-T6. EOS: ρ0 = 2703 kg/m³, c0 = 5240 m/s, s = 1.40, Γ0 = 1.97 (Steinberg 1996,
/// UCRL-MA-106439, as shipped by Uintah; c0, s, Γ0 also in Sandia's Payette). G = 27.6 GPa
/// (Steinberg 1996). Johnson–Cook A = 324 MPa, B = 114 MPa, n = 0.42 (Uintah's 6061-T6 set;
/// B and n also Payette's), C = 0.002, m = 1.34 (Uintah), ε̇0 = 1/s, T_room = 294 K, T_melt =
/// 925 K (Uintah's material constants; Payette's MatWeb solidus is 855 K, pure Al melts at
/// 933 K). c_v = 896 J/(kg K) (Payette / MatWeb, Uintah).
pub const AL_6061_T6: SolidConstants = SolidConstants {
    name: "al6061-t6",
    eos: MieGruneisen {
        rho0: 2703.0,
        c0: 5240.0,
        s: 1.40,
        gamma0: 1.97,
    },
    shear_modulus: 27.6e9,
    strength: JohnsonCook {
        a: 324e6,
        b: 114e6,
        n: 0.42,
        c: 0.002,
        m: 1.34,
        eps_dot0: 1.0,
        t_room: 294.0,
        t_melt: 925.0,
    },
    specific_heat: 896.0,
    source: "Steinberg 1996 (UCRL-MA-106439) EOS and G via Uintah and Payette; Johnson-Cook set of \
             Uintah's JCPlastic6061T6Al with B, n confirmed by Payette; c_v MatWeb via Payette",
};

/// Every material of the library.
pub const LIBRARY: &[SolidConstants] = &[AL_6061_T6];

/// A library material by name (case-insensitive).
pub fn find(name: &str) -> Option<&'static SolidConstants> {
    LIBRARY.iter().find(|m| m.name.eq_ignore_ascii_case(name))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_library_holds_the_verified_set_and_its_wave_speeds() {
        let al = find("AL6061-T6").expect("in the library");
        assert_eq!(al, &AL_6061_T6);
        assert!(
            find("al2024-t3").is_none(),
            "unverified Johnson-Cook set left out"
        );
        // Poisson ratio from K = ρ0c0² and G: ν = (3K − 2G)/(2(3K + G)) ≈ 0.34 for aluminium
        let k = al.eos.rho0 * al.eos.c0 * al.eos.c0;
        let g = al.shear_modulus;
        let nu = (3.0 * k - 2.0 * g) / (2.0 * (3.0 * k + g));
        assert!((nu - 0.3345).abs() < 1e-3, "{nu}");
    }
}

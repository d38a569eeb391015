//! Materials: each kind's keys checked and completed (a solid from the library), and each
//! body's material of the body's kind. The models these keys build are in `crate::material`
//! (`models.rs` turns a validated material into one). Every constant a solid needs is filled
//! (from the library where named) and physically possible.

use super::checks::{err, in_range, num, positive};
use super::*;
use crate::error::Result;
use crate::limits::{DENSITY_RANGE, MAX_EOS_CONSTANT, MAX_MODULUS, SOUND_SPEED_RANGE};
use crate::material::library;
use serde::{Deserialize, Serialize};

/// What a material is: a weakly compressible fluid or an elastic–plastic solid.
#[derive(Debug, Clone, Copy, Serialize, Deserialize, PartialEq, Eq, Default)]
#[serde(rename_all = "snake_case")]
pub enum MaterialKind {
    /// Weakly compressible fluid (Tait or linear EOS).
    #[default]
    Fluid,
    /// Elastic–plastic solid: Mie–Grüneisen EOS, shear modulus, optional Johnson–Cook
    /// strength and failure (docs/solids.md).
    Solid,
}

/// Strength model of a solid.
#[derive(Debug, Clone, Copy, Serialize, Deserialize, PartialEq, Eq)]
#[serde(rename_all = "snake_case")]
pub enum StrengthKind {
    /// Elastic: no yield.
    Elastic,
    /// Johnson–Cook flow stress with radial return.
    JohnsonCook,
}

/// A material (`[[material]]`). Fluids give `rho0`, `c0`, `eos`, `gamma`; solids
/// (`model = "solid"`) give their constants, or `library = "al6061-t6"` and only what they
/// change (the validator fills the rest from the library, so the resolved scene is explicit).
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct Material {
    /// Name referred to by bodies.
    pub name: String,
    /// `fluid` (default) or `solid`.
    #[serde(default, skip_serializing_if = "is_fluid_kind")]
    pub model: MaterialKind,
    /// A solid from the material library (`hsph check` lists them): fills every solid constant
    /// not given.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub library: Option<String>,
    /// Reference density ρ0 (kg/m³).
    #[serde(default)]
    pub rho0: f64,
    /// Fluids: numerical sound speed c0 (m/s), ≥ 10 × the expected speed. Solids: the bulk
    /// sound speed, the intercept of the Hugoniot Us = c0 + s·up (m/s).
    #[serde(default)]
    pub c0: f64,
    /// `tait` or `linear`.
    #[serde(default = "default_eos")]
    pub eos: EosKind,
    /// Tait exponent γ (ignored by `linear`).
    #[serde(default = "default_gamma")]
    pub gamma: f64,
    /// Solid: slope s of the Hugoniot Us = c0 + s·up (–).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub hugoniot_slope: Option<f64>,
    /// Solid: Grüneisen coefficient Γ0 (–).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub gruneisen: Option<f64>,
    /// Solid: shear modulus G (Pa).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub shear_modulus: Option<f64>,
    /// Solid: `elastic` or `johnson_cook` (default with a library material).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub strength: Option<StrengthKind>,
    /// Johnson–Cook yield stress A (Pa).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub jc_a: Option<f64>,
    /// Johnson–Cook hardening modulus B (Pa).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub jc_b: Option<f64>,
    /// Johnson–Cook hardening exponent n (–).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub jc_n: Option<f64>,
    /// Johnson–Cook strain-rate coefficient C (–), ε̇0 = 1/s.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub jc_c: Option<f64>,
    /// Johnson–Cook thermal-softening exponent m (–).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub jc_m: Option<f64>,
    /// Room temperature (K).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub t_room: Option<f64>,
    /// Melt temperature (K).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub t_melt: Option<f64>,
    /// Specific heat c_v (J/(kg K)).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub specific_heat: Option<f64>,
    /// Failure: equivalent plastic strain at which a particle fails (–); none by default.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub failure_strain: Option<f64>,
    /// Failure: spall strength, the tension at which a particle fails (Pa); none by default.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub spall_pressure: Option<f64>,
}

fn is_fluid_kind(k: &MaterialKind) -> bool {
    *k == MaterialKind::Fluid
}

impl Material {
    /// A fluid material with a Tait (γ = 7) or linear EOS.
    pub fn fluid(name: &str, rho0: f64, c0: f64, eos: EosKind) -> Self {
        Material {
            name: name.into(),
            model: MaterialKind::Fluid,
            library: None,
            rho0,
            c0,
            eos,
            gamma: default_gamma(),
            hugoniot_slope: None,
            gruneisen: None,
            shear_modulus: None,
            strength: None,
            jc_a: None,
            jc_b: None,
            jc_n: None,
            jc_c: None,
            jc_m: None,
            t_room: None,
            t_melt: None,
            specific_heat: None,
            failure_strain: None,
            spall_pressure: None,
        }
    }

    /// True for a solid material.
    pub fn is_solid(&self) -> bool {
        self.model == MaterialKind::Solid
    }
}

fn default_eos() -> EosKind {
    EosKind::Tait
}
fn default_gamma() -> f64 {
    7.0
}

/// `value` must be a finite number > 0 (or ≥ 0 with `allow_zero`).
fn check(value: Option<f64>, key: &str, example: &str, allow_zero: bool) -> Result<()> {
    match value {
        None => err(key, format!("is needed for a solid; e.g. {example}")),
        Some(x) if !x.is_finite() || x < 0.0 || (x == 0.0 && !allow_zero) => {
            let bound = if allow_zero { "≥ 0" } else { "> 0" };
            err(key, format!("must be a number {bound} (got {x}); e.g. {example}"))
        }
        Some(_) => Ok(()),
    }
}

/// Fill a solid material's missing constants from its library entry, then check them all.
pub(super) fn solid_material(m: &mut Material, k: &str) -> Result<()> {
    if let Some(name) = &m.library {
        let Some(c) = library::find(name) else {
            let names: Vec<&str> = library::LIBRARY.iter().map(|c| c.name).collect();
            return err(
                format!("{k}.library"),
                format!(
                    "unknown library material `{name}`; the library holds: {}",
                    names.join(", ")
                ),
            );
        };
        let fill = |v: &mut f64, x: f64| {
            if *v == 0.0 {
                *v = x
            }
        };
        fill(&mut m.rho0, c.eos.rho0);
        fill(&mut m.c0, c.eos.c0);
        m.hugoniot_slope.get_or_insert(c.eos.s);
        m.gruneisen.get_or_insert(c.eos.gamma0);
        m.shear_modulus.get_or_insert(c.shear_modulus);
        m.strength.get_or_insert(StrengthKind::JohnsonCook);
        let jc = &c.strength;
        m.jc_a.get_or_insert(jc.a);
        m.jc_b.get_or_insert(jc.b);
        m.jc_n.get_or_insert(jc.n);
        m.jc_c.get_or_insert(jc.c);
        m.jc_m.get_or_insert(jc.m);
        m.t_room.get_or_insert(jc.t_room);
        m.t_melt.get_or_insert(jc.t_melt);
        m.specific_heat.get_or_insert(c.specific_heat);
    }
    check(Some(m.rho0), &format!("{k}.rho0"), "rho0 = 2703.0", false)?;
    check(
        Some(m.c0),
        &format!("{k}.c0"),
        "c0 = 5240.0 (the bulk sound speed)",
        false,
    )?;
    m.hugoniot_slope.get_or_insert(0.0);
    m.gruneisen.get_or_insert(0.0);
    check(
        m.hugoniot_slope,
        &format!("{k}.hugoniot_slope"),
        "hugoniot_slope = 1.4",
        true,
    )?;
    check(m.gruneisen, &format!("{k}.gruneisen"), "gruneisen = 1.97", true)?;
    check(
        m.shear_modulus,
        &format!("{k}.shear_modulus"),
        "shear_modulus = 27.6e9",
        false,
    )?;
    if m.strength.get_or_insert(StrengthKind::Elastic) == &StrengthKind::JohnsonCook {
        check(m.jc_a, &format!("{k}.jc_a"), "jc_a = 324e6", false)?;
        check(m.jc_b, &format!("{k}.jc_b"), "jc_b = 114e6", true)?;
        check(m.jc_n, &format!("{k}.jc_n"), "jc_n = 0.42", false)?;
        check(m.jc_c, &format!("{k}.jc_c"), "jc_c = 0.002", true)?;
        check(m.jc_m, &format!("{k}.jc_m"), "jc_m = 1.34", false)?;
        check(m.t_room, &format!("{k}.t_room"), "t_room = 294.0", false)?;
        check(m.t_melt, &format!("{k}.t_melt"), "t_melt = 925.0", false)?;
        check(
            m.specific_heat,
            &format!("{k}.specific_heat"),
            "specific_heat = 896.0",
            false,
        )?;
        let (room, melt) = (m.t_room.unwrap_or(0.0), m.t_melt.unwrap_or(0.0));
        if melt <= room {
            return err(
                format!("{k}.t_melt"),
                format!("the melt temperature {melt} K is not above the room temperature {room} K"),
            );
        }
    }
    solid_ranges(m, k)?;
    if m.failure_strain.is_some() {
        check(
            m.failure_strain,
            &format!("{k}.failure_strain"),
            "failure_strain = 1.5",
            false,
        )?;
    }
    if m.spall_pressure.is_some() {
        check(
            m.spall_pressure,
            &format!("{k}.spall_pressure"),
            "spall_pressure = 1.2e9",
            false,
        )?;
    }
    Ok(())
}

/// The constants of a solid that enter its wave speed (and so the time step) and its stresses
/// lie in the physical ranges of `src/limits.rs`, and so does the longitudinal wave speed
/// √((ρ0c0² + 4G/3)/ρ0) they give.
fn solid_ranges(m: &Material, k: &str) -> Result<()> {
    density_and_sound_speed(m, k, ("rho0 = 2703.0", "c0 = 5240.0"))?;
    let eos = (0.0, MAX_EOS_CONSTANT);
    for (v, key, example) in [
        (m.hugoniot_slope, "hugoniot_slope", "hugoniot_slope = 1.4"),
        (m.gruneisen, "gruneisen", "gruneisen = 1.97"),
    ] {
        if let Some(x) = v {
            in_range(x, &format!("{k}.{key}"), eos, "", "MAX_EOS_CONSTANT", example)?;
        }
    }
    let moduli = (0.0, MAX_MODULUS);
    for (v, key, example) in [
        (m.shear_modulus, "shear_modulus", "shear_modulus = 27.6e9"),
        (m.jc_a, "jc_a", "jc_a = 324e6"),
        (m.jc_b, "jc_b", "jc_b = 114e6"),
        (m.spall_pressure, "spall_pressure", "spall_pressure = 1.2e9"),
    ] {
        if let Some(x) = v {
            in_range(x, &format!("{k}.{key}"), moduli, "Pa", "MAX_MODULUS", example)?;
        }
    }
    let g = m.shear_modulus.unwrap_or(0.0);
    let c_long = (m.c0 * m.c0 + 4.0 * g / (3.0 * m.rho0)).sqrt();
    if c_long.is_nan() || c_long > SOUND_SPEED_RANGE.1 {
        return err(
            format!("{k}.shear_modulus"),
            format!(
                "the longitudinal wave speed √((ρ0c0² + 4G/3)/ρ0) = {c_long:.4e} m/s of G = {} Pa, \
                 ρ0 = {} kg/m³ and c0 = {} m/s is above the largest wave speed hsph accepts, {:e} m/s \
                 (SOUND_SPEED_RANGE); e.g. shear_modulus = 27.6e9 with rho0 = 2703.0",
                num(g),
                num(m.rho0),
                num(m.c0),
                SOUND_SPEED_RANGE.1
            ),
        );
    }
    Ok(())
}

/// A fluid material: no solid keys (a typo for `model = "solid"`, most likely), and ρ0, c0
/// and γ positive and within their physical ranges.
pub(super) fn fluid_material(m: &Material, k: &str) -> Result<()> {
    let solid_keys = [
        ("library", m.library.is_some()),
        ("hugoniot_slope", m.hugoniot_slope.is_some()),
        ("gruneisen", m.gruneisen.is_some()),
        ("shear_modulus", m.shear_modulus.is_some()),
        ("strength", m.strength.is_some()),
        ("jc_a", m.jc_a.is_some()),
        ("jc_b", m.jc_b.is_some()),
        ("jc_n", m.jc_n.is_some()),
        ("jc_c", m.jc_c.is_some()),
        ("jc_m", m.jc_m.is_some()),
        ("t_room", m.t_room.is_some()),
        ("t_melt", m.t_melt.is_some()),
        ("specific_heat", m.specific_heat.is_some()),
        ("failure_strain", m.failure_strain.is_some()),
        ("spall_pressure", m.spall_pressure.is_some()),
    ];
    if let Some((key, _)) = solid_keys.iter().find(|(_, set)| *set) {
        return err(
            format!("{k}.{key}"),
            format!(
                "`{key}` is a key of solid materials; add model = \"solid\" to this material or remove it"
            ),
        );
    }
    positive(m.rho0, &format!("{k}.rho0"), "rho0 = 1000.0")?;
    positive(m.c0, &format!("{k}.c0"), "c0 = 20.0")?;
    positive(m.gamma, &format!("{k}.gamma"), "gamma = 7.0")?;
    density_and_sound_speed(m, k, ("rho0 = 1000.0", "c0 = 20.0"))?;
    in_range(
        m.gamma,
        &format!("{k}.gamma"),
        (f64::MIN_POSITIVE, MAX_EOS_CONSTANT),
        "",
        "MAX_EOS_CONSTANT",
        "gamma = 7.0",
    )
}

/// ρ0 and c0 of any material within the physical ranges of `src/limits.rs`; `examples` are
/// the values the messages suggest for this kind of material.
fn density_and_sound_speed(m: &Material, k: &str, examples: (&str, &str)) -> Result<()> {
    in_range(
        m.rho0,
        &format!("{k}.rho0"),
        DENSITY_RANGE,
        "kg/m³",
        "DENSITY_RANGE",
        examples.0,
    )?;
    in_range(
        m.c0,
        &format!("{k}.c0"),
        SOUND_SPEED_RANGE,
        "m/s",
        "SOUND_SPEED_RANGE",
        examples.1,
    )
}

/// Each body's material is of the body's kind: `fluid[i]` with a fluid material, `solid[i]`
/// with a solid one; `clamped` and `hydrostatic` where they mean something.
pub(super) fn body_kinds(s: &Scene) -> Result<()> {
    let solids: std::collections::HashSet<&str> = s
        .materials
        .iter()
        .filter(|m| m.is_solid())
        .map(|m| m.name.as_str())
        .collect();
    let solid = |name: &str| solids.contains(name);
    for (i, f) in s.fluids.iter().enumerate() {
        if solid(&f.material) {
            return err(
                format!("fluid[{i}].material"),
                format!(
                    "material `{}` is a solid (model = \"solid\"); put this body under [[solid]] or \
                     give it a fluid material",
                    f.material
                ),
            );
        }
        if f.clamped {
            return err(
                format!("fluid[{i}].clamped"),
                "only a [[solid]] body can be clamped",
            );
        }
    }
    for (i, f) in s.solids.iter().enumerate() {
        if !solid(&f.material) {
            return err(
                format!("solid[{i}].material"),
                format!(
                    "material `{}` is a fluid; a [[solid]] body needs a material with model = \"solid\" \
                     (e.g. library = \"al6061-t6\")",
                    f.material
                ),
            );
        }
        if f.hydrostatic {
            return err(
                format!("solid[{i}].hydrostatic"),
                "a solid starts unstressed: hydrostatic applies to fluid bodies only",
            );
        }
    }
    Ok(())
}

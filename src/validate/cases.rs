//! The validation cases `hsph validate` knows: each a shipped scene, the error it reports
//! (a key of `summary.json`'s `errors` and the norm behind it), the resolutions it runs at and
//! the method variants it sweeps. A configuration becomes `--set` overrides of the scene, so
//! every run is an ordinary `hsph run` whose resolved `scene.toml` can be run again.

use crate::kernel::KernelKind;

/// A method variant: kernel, smoothing length, wall method, density diffusion, interactions.
#[derive(Debug, Clone, PartialEq)]
pub struct Variant {
    /// Kernel.
    pub kernel: KernelKind,
    /// h / dx.
    pub h_over_dx: f64,
    /// Wall method of every wall (`dummy`, `mirror`, `repulsive`).
    pub walls: &'static str,
    /// `physics.density_diffusion` (`none`, `molteni`, `antuono`).
    pub diffusion: &'static str,
    /// `performance.interactions` (`gather`, the bitwise default, or `pairs`).
    pub interactions: &'static str,
    /// `physics.viscous_operator` (`morris` or `renormalised`).
    pub viscous: &'static str,
    /// `wall[].no_slip` of every wall (`adami` or `morris`).
    pub no_slip: &'static str,
    /// `physics.shifting` (`none` or `delta_plus`).
    pub shifting: &'static str,
    /// Refinement (`none`; `scene` or `level`: the case's refined scene, whose region's
    /// particles keep the scene's h or take their level's; `difference`: the level's, with
    /// `physics.pressure_gradient = "difference"`; docs/refinement.md).
    pub refine: &'static str,
}

impl Variant {
    /// Short name used in the CSV and the charts, e.g. `quintic_spline-h1.0-dummy-none`, with
    /// `-renorm` appended for the renormalised viscous operator, `-morriswall` for Morris's
    /// no-slip, `-shift` for δ⁺ shifting, `-pairs` for pair mode and `-refine` (`-refineh`)
    /// for the refined scene with the scene's (the level's) h, `-refinehd` with the level's h
    /// and the difference form of the pressure term.
    pub fn name(&self) -> String {
        let suffix = |on: bool, s: &'static str| if on { s } else { "" };
        format!(
            "{}-h{:.1}-{}-{}{}{}{}{}{}",
            self.kernel.name(),
            self.h_over_dx,
            self.walls,
            self.diffusion,
            suffix(self.viscous == "renormalised", "-renorm"),
            suffix(self.no_slip == "morris", "-morriswall"),
            suffix(self.shifting == "delta_plus", "-shift"),
            suffix(self.interactions == "pairs", "-pairs"),
            match self.refine {
                "scene" => "-refine",
                "level" => "-refineh",
                "difference" => "-refinehd",
                _ => "",
            },
        )
    }

    /// This variant on the case's refined scene, its region's particles with the scene's
    /// (`"scene"`) or their level's (`"level"`) smoothing length.
    fn refined(&self, refine: &'static str) -> Self {
        Variant {
            refine,
            ..self.clone()
        }
    }

    /// This variant with the renormalised viscous operator and Morris's no-slip walls.
    fn corrected(&self) -> Self {
        Variant {
            viscous: "renormalised",
            no_slip: "morris",
            ..self.clone()
        }
    }

    /// This variant in pair mode.
    fn in_pairs(&self) -> Self {
        Variant {
            interactions: "pairs",
            ..self.clone()
        }
    }

    /// Support radius over dx.
    fn support_cells(&self) -> f64 {
        self.kernel.support_factor() * self.h_over_dx
    }
}

/// One validation case.
#[derive(Debug, Clone)]
pub struct Case {
    /// Name on the command line.
    pub name: &'static str,
    /// The shipped scene it starts from (for messages).
    pub file: &'static str,
    /// That scene's text, compiled in so that `hsph validate` runs from any directory.
    pub scene: &'static str,
    /// The scene (file, text) the `mirror` wall variants start from, if the case has them.
    pub mirror: Option<(&'static str, &'static str)>,
    /// The scene (file, text) the refinement variants start from, if the case has them, and
    /// the overrides that make their runs comparable with the uniform ones.
    pub refined: Option<(&'static str, &'static str, &'static [&'static str])>,
    /// Key of `summary.json`'s `errors` that is the case's error.
    pub error_key: &'static str,
    /// What that error measures.
    pub norm: &'static str,
    /// Resolutions (cells across the case's length scale), coarse to fine.
    pub resolutions: &'static [u32],
    /// The variant of the shipped scene.
    pub default: Variant,
    /// The variants of `--sweep` (the default first).
    pub sweep: fn() -> Vec<Variant>,
    /// `--set` overrides that give resolution `n` and variant `v`.
    pub overrides: fn(n: u32, v: &Variant) -> Vec<String>,
    /// Length scale that `n` divides (m): dx = length / n.
    pub length: f64,
}

impl Case {
    /// The scene (file, text) variant `v` starts from.
    pub fn scene_for(&self, v: &Variant) -> (&'static str, &'static str) {
        match (self.mirror, self.refined) {
            (Some(m), _) if v.walls == "mirror" => m,
            (_, Some((file, text, _))) if v.refine != "none" => (file, text),
            _ => (self.file, self.scene),
        }
    }

    /// Every `--set` override of resolution `n` and variant `v`: the case's own, then the
    /// interactions, then shifting where it is on (so that the overrides of a sweep written
    /// before shifting was a variant stay the same, and it resumes).
    pub fn sets(&self, n: u32, v: &Variant) -> Vec<String> {
        let mut o = (self.overrides)(n, v);
        o.push(format!("performance.interactions=\"{}\"", v.interactions));
        if v.shifting != "none" {
            o.push(format!("physics.shifting=\"{}\"", v.shifting));
        }
        if let (Some((_, _, sets)), true) = (self.refined, v.refine != "none") {
            o.extend(sets.iter().map(|s| s.to_string()));
            let h = if v.refine == "scene" { "scene" } else { "level" };
            o.push(format!("refine[0].smoothing_length=\"{h}\""));
            if v.refine == "difference" {
                o.push("physics.pressure_gradient=\"difference\"".to_string());
            }
        }
        o
    }
}

/// Every known case, in the order `hsph validate` runs them.
pub fn all() -> Vec<Case> {
    vec![
        poiseuille(),
        couette(),
        hydrostatic(),
        cavity(),
        lobovsky(),
        lobovsky_impulse(),
    ]
}

/// The case called `name`, or an error listing the known ones.
pub fn find(name: &str) -> std::result::Result<Case, String> {
    let cases = all();
    let names: Vec<&str> = cases.iter().map(|c| c.name).collect();
    cases
        .into_iter()
        .find(|c| c.name == name)
        .ok_or_else(|| format!("unknown case `{name}`; known cases: {}", names.join(", ")))
}

/// The channel of the Poiseuille and Couette start-ups (gap L = 1 mm, periodic along x): at
/// dx = L/n the plates are whole rows thick enough to cover the support, the periodic length
/// is a whole number of rows of at least 0.6 mm and three supports, and rows sit half a
/// spacing from each plate. Dummy plates are the blocks wall[0] and wall[1]; mirror plates
/// the faces of `mirrors` containers with the gap as inner box.
fn channel_overrides(n: u32, v: &Variant, mirrors: usize) -> Vec<String> {
    let gap = 1.0e-3;
    let dx = gap / n as f64;
    let rows = |len: f64| (len / dx - 1e-9).ceil();
    let t = dx * rows(v.support_cells() * dx).max(rows(0.2e-3));
    let x = dx * rows(0.6e-3).max(rows(3.0 * v.support_cells() * dx));
    let mut o = vec![
        format!("discretisation.dx={dx:e}"),
        format!("discretisation.h_over_dx={}", v.h_over_dx),
        format!("discretisation.kernel=\"{}\"", v.kernel.name()),
        format!("physics.density_diffusion=\"{}\"", v.diffusion),
        format!("domain.min=[0.0,{:e}]", -t),
        format!("domain.max=[{x:e},{:e}]", gap + t),
        format!("fluid[0].max=[{x:e},{gap:e}]"),
        format!("physics.viscous_operator=\"{}\"", v.viscous),
    ];
    if v.walls == "mirror" {
        for w in 0..mirrors {
            o.push(format!("wall[{w}].max=[{x:e},{gap:e}]"));
            // set only when not the default, so that earlier mirror sweeps resume
            if v.no_slip != "adami" {
                o.push(format!("wall[{w}].no_slip=\"{}\"", v.no_slip));
            }
        }
        return o;
    }
    if v.refine != "none" {
        // the refined scene's bands span the channel's length at every resolution
        o.push(format!("refine[0].max=[{x:e},0.2e-3]"));
        o.push(format!("refine[1].max=[{x:e},1.08e-3]"));
    }
    o.extend([
        format!("wall[0].min=[0.0,{:e}]", -t),
        format!("wall[0].max=[{x:e},0.0]"),
        format!("wall[1].min=[0.0,{gap:e}]"),
        format!("wall[1].max=[{x:e},{:e}]", gap + t),
    ]);
    for w in 0..2 {
        o.push(format!("wall[{w}].method=\"{}\"", v.walls));
        o.push(format!("wall[{w}].no_slip=\"{}\"", v.no_slip));
    }
    o
}

/// Kernel and h/dx pairs the channel sweeps: each kernel at its usual h/dx and at the ends of
/// the 1.2–2.0 range.
fn channel_sweep() -> Vec<Variant> {
    let plain = with_kernels(
        channel_default(),
        &[
            (KernelKind::QuinticSpline, 1.5),
            (KernelKind::CubicSpline, 1.2),
            (KernelKind::CubicSpline, 2.0),
            (KernelKind::WendlandC2, 1.2),
            (KernelKind::WendlandC2, 2.0),
        ],
    );
    // each again with the renormalised operator and Morris's no-slip (physics::viscous), and
    // between mirror walls with the plain and the renormalised operator, and with both
    let mut out = plain.clone();
    out.extend(plain.iter().map(Variant::corrected));
    for viscous in ["morris", "renormalised"] {
        out.extend(plain.iter().map(|v| Variant {
            walls: "mirror",
            viscous,
            ..v.clone()
        }));
    }
    out.extend(plain.iter().map(|v| Variant {
        walls: "mirror",
        ..v.corrected()
    }));
    out.push(channel_default().in_pairs());
    out
}

/// Poiseuille's sweep: the channel's, and the refined bands (the shipped refined scene: the
/// level's h, renormalised operator; docs/refinement.md §3).
fn poiseuille_sweep() -> Vec<Variant> {
    let mut out = channel_sweep();
    out.push(
        Variant {
            viscous: "renormalised",
            ..channel_default()
        }
        .refined("level"),
    );
    out
}

/// Couette's sweep (no refined scene).
fn couette_sweep() -> Vec<Variant> {
    channel_sweep()
}

/// `base` first, then `base` with each (kernel, h/dx) of `pairs`.
fn with_kernels(base: Variant, pairs: &[(KernelKind, f64)]) -> Vec<Variant> {
    let mut out = vec![base.clone()];
    out.extend(pairs.iter().map(|&(kernel, h_over_dx)| Variant {
        kernel,
        h_over_dx,
        ..base.clone()
    }));
    out
}

fn channel_default() -> Variant {
    Variant {
        kernel: KernelKind::QuinticSpline,
        h_over_dx: 1.0,
        walls: "dummy",
        diffusion: "none",
        interactions: "gather",
        viscous: "morris",
        no_slip: "adami",
        shifting: "none",
        refine: "none",
    }
}

fn poiseuille() -> Case {
    Case {
        name: "poiseuille",
        file: "inputs/poiseuille_2d.toml",
        scene: include_str!("../../inputs/poiseuille_2d.toml"),
        mirror: Some((
            "inputs/poiseuille_2d_mirror.toml",
            include_str!("../../inputs/poiseuille_2d_mirror.toml"),
        )),
        // bands of dx/2 along both plates, the plates refined with them (docs/refinement.md §3)
        refined: Some((
            "inputs/poiseuille_2d_refined.toml",
            include_str!("../../inputs/poiseuille_2d_refined.toml"),
            &[],
        )),
        error_key: "velocity_linf_t*",
        norm: "max over the gap of |u − u_exact| / u_max at the last reference time (t = 2 s; Morris et al. 1997)",
        resolutions: &[10, 20, 25, 40],
        default: channel_default(),
        sweep: poiseuille_sweep,
        overrides: |n, v| channel_overrides(n, v, 1),
        length: 1.0e-3,
    }
}

fn couette() -> Case {
    Case {
        name: "couette",
        file: "inputs/couette_2d.toml",
        scene: include_str!("../../inputs/couette_2d.toml"),
        mirror: Some((
            "inputs/couette_2d_mirror.toml",
            include_str!("../../inputs/couette_2d_mirror.toml"),
        )),
        overrides: |n, v| channel_overrides(n, v, 2),
        refined: None,
        sweep: couette_sweep,
        error_key: "velocity_linf_t*",
        norm: "max over the gap of |u − u_exact| / v0 at t = 2 s (Morris et al. 1997)",
        ..poiseuille()
    }
}

/// The still tank (H = 0.5 m): at dx = H/n the domain keeps a margin of a support round
/// the container.
fn hydrostatic_overrides(n: u32, v: &Variant) -> Vec<String> {
    let dx = 0.5 / n as f64;
    let m = (0.1f64).max(dx * (v.support_cells() + 2.0));
    vec![
        format!("discretisation.dx={dx:e}"),
        format!("discretisation.h_over_dx={}", v.h_over_dx),
        format!("discretisation.kernel=\"{}\"", v.kernel.name()),
        format!("physics.density_diffusion=\"{}\"", v.diffusion),
        format!("domain.min=[{:e},{:e}]", -m, -m),
        format!("domain.max=[{:e},{:e}]", 1.0 + m, 0.8 + m),
        format!("wall[0].method=\"{}\"", v.walls),
    ]
}

fn hydrostatic_default() -> Variant {
    Variant {
        kernel: KernelKind::WendlandC2,
        h_over_dx: 2.0,
        walls: "dummy",
        diffusion: "antuono",
        interactions: "gather",
        viscous: "morris",
        no_slip: "adami",
        shifting: "none",
        refine: "none",
    }
}

fn hydrostatic() -> Case {
    Case {
        name: "hydrostatic",
        file: "inputs/hydrostatic_2d.toml",
        scene: include_str!("../../inputs/hydrostatic_2d.toml"),
        mirror: None,
        // the refined tank runs as long as the uniform one, and with its walls (the variant's
        // diffusion replaces the scene's, as in the uniform runs): the charts then differ by
        // the box alone
        refined: Some((
            "inputs/hydrostatic_2d_refined.toml",
            include_str!("../../inputs/hydrostatic_2d_refined.toml"),
            &["time.t_end=0.5", "wall[0].volume=\"mass\""],
        )),
        error_key: "pressure_linf_below_mid_depth",
        norm: "max below mid-depth of |p − ρ g d| / (ρ g H) at t_end",
        resolutions: &[10, 20, 25, 40],
        default: hydrostatic_default(),
        sweep: || {
            let mut out = with_kernels(
                hydrostatic_default(),
                &[
                    (KernelKind::WendlandC2, 1.3),
                    (KernelKind::WendlandC2, 1.5),
                    (KernelKind::CubicSpline, 1.3),
                    (KernelKind::CubicSpline, 2.0),
                ],
            );
            out.extend(["none", "molteni"].map(|diffusion| Variant {
                diffusion,
                ..hydrostatic_default()
            }));
            // δ⁺ shifting at the shipped h = 2 dx and at h = 1.3 dx, where the unshifted
            // lattice rearranges (§5d of docs/validation.md)
            for h_over_dx in [2.0, 1.3] {
                out.push(Variant {
                    h_over_dx,
                    shifting: "delta_plus",
                    ..hydrostatic_default()
                });
            }
            out.push(hydrostatic_default().in_pairs());
            // a box at dx/2 in the middle (docs/refinement.md §2), both smoothing lengths, the
            // level's with either pressure term
            out.extend(["scene", "level", "difference"].map(|r| hydrostatic_default().refined(r)));
            out
        },
        overrides: hydrostatic_overrides,
        length: 0.5,
    }
}

/// The lid-driven cavity (L = 1 m): at dx = L/n the lid block and the domain margin are whole
/// rows covering the support. `walls`: `dummy` or `repulsive` for every wall, `mixed` for
/// mirror side walls and floor under a dummy lid (seed 002's mixed method).
fn cavity_overrides(n: u32, v: &Variant) -> Vec<String> {
    let dx = 1.0 / n as f64;
    let t = dx * (v.support_cells() - 1e-9).ceil();
    let m = t + dx;
    let (box_method, lid_method) = match v.walls {
        "mixed" => ("mirror", "dummy"),
        w => (w, w),
    };
    vec![
        format!("discretisation.dx={dx:e}"),
        format!("discretisation.h_over_dx={}", v.h_over_dx),
        format!("discretisation.kernel=\"{}\"", v.kernel.name()),
        format!("physics.density_diffusion=\"{}\"", v.diffusion),
        format!("domain.min=[{:e},{:e}]", -m, -m),
        format!("domain.max=[{:e},{:e}]", 1.0 + m, 1.0 + m),
        format!("wall[1].min=[{:e},1.0]", -t),
        format!("wall[1].max=[{:e},{:e}]", 1.0 + t, 1.0 + t),
        format!("wall[0].method=\"{box_method}\""),
        format!("wall[1].method=\"{lid_method}\""),
    ]
}

fn cavity_default() -> Variant {
    Variant {
        kernel: KernelKind::WendlandC2,
        h_over_dx: 1.3,
        walls: "dummy",
        diffusion: "antuono",
        interactions: "gather",
        viscous: "morris",
        no_slip: "adami",
        shifting: "none",
        refine: "none",
    }
}

/// Lobovsky's dam break (H = 0.3 m) at dx = H/n to t√(g/H) = 4.6, the variant's density
/// term with its pressure term (the Riemann solver's pair, else the symmetric form): the
/// wall-pressure reference of the scene gives the errors (docs/pressure.md).
fn lobovsky_overrides(n: u32, v: &Variant) -> Vec<String> {
    let pressure = if v.diffusion == "riemann" {
        "riemann"
    } else {
        "symmetric"
    };
    vec![
        format!("discretisation.dx={:e}", 0.3 / n as f64),
        format!("discretisation.h_over_dx={}", v.h_over_dx),
        format!("discretisation.kernel=\"{}\"", v.kernel.name()),
        format!("physics.density_diffusion=\"{}\"", v.diffusion),
        format!("physics.pressure_gradient=\"{pressure}\""),
        "physics.delta=0.1".to_string(),
        format!("wall[0].method=\"{}\"", v.walls),
        "time.t_end=0.8".to_string(),
    ]
}

fn lobovsky_default() -> Variant {
    Variant {
        kernel: KernelKind::WendlandC2,
        h_over_dx: 1.3,
        walls: "dummy",
        diffusion: "riemann",
        interactions: "gather",
        viscous: "morris",
        no_slip: "adami",
        shifting: "none",
        refine: "none",
    }
}

/// The shipped Riemann terms, then δ-SPH with Antuono's and Fourtakas's terms, then the
/// Riemann terms in pair mode.
fn lobovsky_sweep() -> Vec<Variant> {
    let mut out = ["riemann", "antuono", "fourtakas"]
        .map(|diffusion| Variant {
            diffusion,
            ..lobovsky_default()
        })
        .to_vec();
    out.push(lobovsky_default().in_pairs());
    out
}

/// Lobovsky's S1: its filtered first-impact peak against the experiment's 20 kHz run.
fn lobovsky() -> Case {
    Case {
        name: "lobovsky",
        file: "inputs/dam_break_lobovsky.toml",
        scene: include_str!("../../inputs/dam_break_lobovsky.toml"),
        mirror: None,
        refined: None,
        error_key: "S1_peak",
        norm: "|S1's peak through the 2 ms box / the experiment's − 1| over t√(g/H) ∈ [0, 4.5]",
        // 10 and 5 mm; 2.5 mm (--resolutions 120) is a documented command
        resolutions: &[30, 60],
        default: lobovsky_default(),
        sweep: lobovsky_sweep,
        overrides: lobovsky_overrides,
        length: 0.3,
    }
}

/// Lobovsky's S1: the first impact's impulse over 35 ms against the experiment's.
fn lobovsky_impulse() -> Case {
    Case {
        name: "lobovsky_impulse",
        error_key: "S1_impulse",
        norm: "|S1's first-impact impulse over 35 ms / the experiment's − 1|",
        ..lobovsky()
    }
}

fn cavity() -> Case {
    Case {
        name: "cavity",
        file: "inputs/cavity_re100.toml",
        scene: include_str!("../../inputs/cavity_re100.toml"),
        mirror: None,
        refined: None,
        error_key: "cavity_linf",
        norm: "max over Ghia et al.'s 15 + 15 interior centreline points of |u − u_Ghia| and |v − v_Ghia|, in lid-speed units, at t = 30 L/U (Re = 100)",
        resolutions: &[20, 40, 60],
        default: cavity_default(),
        sweep: || {
            let mut out = vec![cavity_default()];
            for walls in ["repulsive", "mixed"] {
                out.push(Variant {
                    walls,
                    ..cavity_default()
                });
            }
            out.push(Variant {
                kernel: KernelKind::QuinticSpline,
                h_over_dx: 1.0,
                ..cavity_default()
            });
            out.push(Variant {
                diffusion: "none",
                ..cavity_default()
            });
            out.push(cavity_default().in_pairs());
            out
        },
        overrides: cavity_overrides,
        length: 1.0,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn mirror_variants_start_from_the_mirror_scenes_and_set_no_wall_particles() {
        for (name, containers) in [("poiseuille", 1), ("couette", 2)] {
            let case = find(name).unwrap();
            let mirror: Vec<Variant> = (case.sweep)()
                .into_iter()
                .filter(|v| v.walls == "mirror")
                .collect();
            assert_eq!(mirror.len(), 18, "{name}: six kernels x three wall treatments");
            for v in &mirror {
                let (file, text) = case.scene_for(v);
                assert!(file.ends_with("_mirror.toml"), "{file}");
                assert_eq!(text.matches("method = \"mirror\"").count(), containers);
                let sets = case.sets(40, v);
                // the containers' boxes follow the periodic length; no block plates
                assert_eq!(
                    sets.iter().filter(|s| s.contains("].max=[")).count(),
                    1 + containers,
                    "{sets:?}"
                );
                // Morris's no-slip on every plate where it is on, nothing otherwise
                let morris = sets.iter().filter(|s| s.contains("no_slip=\"morris\"")).count();
                let want = if v.no_slip == "morris" { containers } else { 0 };
                assert_eq!(morris, want, "{sets:?}");
                assert_eq!(sets.iter().filter(|s| s.contains("no_slip")).count(), want);
            }
            assert_eq!(case.scene_for(&case.default).0, case.file);
        }
    }

    #[test]
    fn poiseuille_refined_bands_load_at_every_resolution_spanning_the_channel() {
        let case = find("poiseuille").unwrap();
        let refined: Vec<Variant> = (case.sweep)()
            .into_iter()
            .filter(|v| v.refine != "none")
            .collect();
        assert_eq!(refined.len(), 1);
        let v = &refined[0];
        assert_eq!(v.name(), "quintic_spline-h1.0-dummy-none-renorm-refineh");
        let (file, text) = case.scene_for(v);
        assert_eq!(file, "inputs/poiseuille_2d_refined.toml");
        for &n in case.resolutions {
            let sets = case.sets(n, v);
            let s = crate::scene::load_scene_str(text, std::path::Path::new(file), "p", &sets)
                .unwrap_or_else(|e| panic!("n = {n}: {e}"))
                .0;
            assert_eq!(s.refine.len(), 2);
            for r in &s.refine {
                assert_eq!(r.max[0], s.domain.max[0], "n = {n}: a band spans the channel");
                assert_eq!(r.smoothing_length, crate::scene::refine::RegionH::Level);
            }
            assert_eq!(
                s.physics.viscous_operator,
                crate::scene::ViscousOperator::Renormalised
            );
        }
    }

    #[test]
    fn refinement_variants_start_from_the_refined_scene_for_as_long() {
        let case = find("hydrostatic").unwrap();
        let refined: Vec<Variant> = (case.sweep)()
            .into_iter()
            .filter(|v| v.refine != "none")
            .collect();
        assert_eq!(refined.len(), 3);
        for (v, h) in refined.iter().zip(["scene", "level", "level"]) {
            let (file, text) = case.scene_for(v);
            assert_eq!(file, "inputs/hydrostatic_2d_refined.toml");
            assert!(text.contains("[[refine]]"));
            let sets = case.sets(20, v);
            assert!(sets.contains(&"time.t_end=0.5".to_string()), "{sets:?}");
            assert!(sets.contains(&"wall[0].volume=\"mass\"".to_string()), "{sets:?}");
            let h = format!("refine[0].smoothing_length=\"{h}\"");
            assert!(sets.contains(&h), "{sets:?}");
            let difference = "physics.pressure_gradient=\"difference\"".to_string();
            assert_eq!(sets.contains(&difference), v.refine == "difference", "{sets:?}");
            // every override loads
            let scene = crate::scene::load_scene_str(text, std::path::Path::new(file), "t", &sets);
            assert!(scene.is_ok(), "{}: {:?}", v.name(), scene.err());
        }
        assert_eq!(refined[1].name(), format!("{}-refineh", case.default.name()));
        assert_eq!(refined[2].name(), format!("{}-refinehd", case.default.name()));
        // the other variants start from the uniform scene and set no refinement
        let sets = case.sets(20, &case.default);
        assert!(sets.iter().all(|s| !s.contains("refine")), "{sets:?}");
        assert_eq!(case.scene_for(&case.default).0, case.file);
    }

    #[test]
    fn every_case_sweeps_its_method_in_pair_mode_too() {
        for case in all() {
            let sweep = (case.sweep)();
            assert_eq!(sweep[0], case.default, "{}: the default comes first", case.name);
            let pairs: Vec<&Variant> = sweep.iter().filter(|v| v.interactions == "pairs").collect();
            assert_eq!(pairs.len(), 1, "{}", case.name);
            assert_eq!(pairs[0].name(), format!("{}-pairs", case.default.name()));
            let sets = case.sets(case.resolutions[0], pairs[0]);
            assert!(
                sets.contains(&"performance.interactions=\"pairs\"".to_string()),
                "{sets:?}"
            );
            let sets = case.sets(case.resolutions[0], &case.default);
            assert!(
                sets.contains(&"performance.interactions=\"gather\"".to_string()),
                "{sets:?}"
            );
            // names are unique, so a resumed sweep never confuses two variants
            let mut names: Vec<String> = sweep.iter().map(Variant::name).collect();
            names.sort();
            names.dedup();
            assert_eq!(names.len(), sweep.len(), "{}", case.name);
        }
    }
}

//! Semantic checks of a scene, with defaults that depend on other keys filled in.
//!
//! Each error names the dotted key and what would be valid; [`super::SceneSource::locate`]
//! adds the file and line.

use super::checks::*;
use super::probes::validate_probes;
use super::reference::validate_reference;
use super::walls::validate_walls;
use super::*;
use crate::error::{Error, Result};
use crate::limits::{
    MAX_BODY_FORCE, MAX_CELLS, MAX_COEFFICIENT, MAX_EXPR_TOTAL_CHARS, MAX_FRAMES, MAX_PARTICLES, MAX_STEPS,
    MAX_T_END, MAX_VISCOSITY, SOUND_SPEED_RANGE,
};

/// Most iterations of the set-up relaxation (`discretisation.relax`): each is a ghost build and a
/// pass over the particles, and the interface settles within ~50.
pub const MAX_RELAX: u32 = 1000;

/// Check a vector key has `d` components, all finite; fill an empty one with zeros if allowed.
/// The initial-field expressions of fluid body `k` (`velocity_field`, `pressure_field`): one
/// per axis, parsed against the coordinates and `[constants]`, not together with the plain
/// key they replace; finite at the body's corners and centre (every site is checked at set-up).
fn validate_fields(
    f: &crate::scene::FluidBody,
    k: &str,
    d: usize,
    constants: &std::collections::BTreeMap<String, f64>,
) -> Result<()> {
    use crate::scene::expr::FieldExpr;
    let mut exprs = Vec::new();
    if let Some(v) = &f.velocity_field {
        if v.len() != d {
            return err(
                format!("{k}.velocity_field"),
                format!("needs {d} expressions (one per axis), got {}", v.len()),
            );
        }
        if f.velocity.iter().any(|&c| c != 0.0) {
            return err(
                format!("{k}.velocity_field"),
                "give either `velocity` or `velocity_field`, not both",
            );
        }
        for (a, t) in v.iter().enumerate() {
            exprs.push(FieldExpr::parse(
                &format!("{k}.velocity_field[{a}]"),
                t,
                d,
                constants,
            )?);
        }
    }
    if let Some(t) = &f.pressure_field {
        if f.hydrostatic {
            return err(
                format!("{k}.pressure_field"),
                "give either `hydrostatic = true` or `pressure_field`, not both",
            );
        }
        exprs.push(FieldExpr::parse(&format!("{k}.pressure_field"), t, d, constants)?);
    }
    for e in &exprs {
        for x in box_samples(&f.min, &f.max, 2) {
            e.eval(&x)?;
        }
    }
    Ok(())
}

/// `[constants]`: finite values, and names that expressions read as the constant
/// ([`crate::scene::expr::constant_name`]: no coordinate, no built-in name in any case).
fn validate_constants(constants: &std::collections::BTreeMap<String, f64>) -> Result<()> {
    for (name, v) in constants {
        crate::scene::expr::constant_name(name).or_else(|why| err(format!("constants.{name}"), why))?;
        if !v.is_finite() {
            return err(
                format!("constants.{name}"),
                format!("a constant needs a finite value, got {v}; e.g. {name} = 1.0"),
            );
        }
    }
    Ok(())
}

/// `(n + 1)^d` points spread over the box [min, max] (corners included).
fn box_samples(min: &[f64], max: &[f64], n: usize) -> Vec<Vec<f64>> {
    let d = min.len();
    let mut out = vec![Vec::new()];
    for a in 0..d {
        out = out
            .into_iter()
            .flat_map(|p| {
                (0..=n).map(move |k| {
                    let mut q = p.clone();
                    q.push(min[a] + (max[a] - min[a]) * k as f64 / n as f64);
                    q
                })
            })
            .collect();
    }
    out
}

/// Largest speed of a `velocity_field` over a grid of 9 points per axis in the body (m/s; 0
/// without one): the set-up's estimate for the sound-speed check.
fn sampled_speed(
    f: &crate::scene::FluidBody,
    d: usize,
    constants: &std::collections::BTreeMap<String, f64>,
) -> f64 {
    use crate::scene::expr::FieldExpr;
    let Some(v) = &f.velocity_field else { return 0.0 };
    let exprs: Vec<FieldExpr> = v
        .iter()
        .filter_map(|t| FieldExpr::parse("", t, d, constants).ok())
        .collect();
    box_samples(&f.min, &f.max, 8)
        .iter()
        .map(|x| {
            exprs
                .iter()
                .map(|e| e.eval(x).unwrap_or(0.0).powi(2))
                .sum::<f64>()
                .sqrt()
        })
        .fold(0.0, f64::max)
}

/// Validate a scene and fill the defaults that depend on other keys.
pub fn validate(s: &mut Scene) -> Result<()> {
    validate_counts(s)?;
    let support = validate_domain(s)?;
    validate_materials(s)?;
    validate_constants(&s.constants)?;
    check_body_names(s, None)?;
    let mat_names = Names::new(s.materials.iter().map(|m| m.name.as_str()));
    validate_fluids(s, &mat_names)?;
    validate_walls(s, &mat_names, support)?;
    super::refine::validate_refine(s)?;
    validate_pressure_gradient(s)?;
    validate_time_output(s)?;
    check_particle_count(s)?;
    crate::with_dim!(s.dimension, D => super::lattice::check_bodies_build::<D>(s))?;
    if !(s.balance.threshold >= 1.0 && s.balance.threshold.is_finite()) {
        return err(
            "balance.threshold",
            format!(
                "must be a number ≥ 1 (max/mean load), got {}; 1.1 is typical",
                s.balance.threshold
            ),
        );
    }
    if !(s.balance.max_count >= 1.0 && s.balance.max_count.is_finite()) {
        return err(
            "balance.max_count",
            format!(
                "must be a number ≥ 1 (most particles a rank may own over the mean), got {}; \
                 1.5 is the default, 1 splits by counts",
                s.balance.max_count
            ),
        );
    }
    if let Some((k, w)) = s
        .balance
        .weights
        .iter()
        .enumerate()
        .find(|(_, w)| !(**w > 0.0 && w.is_finite()))
    {
        return err(
            format!("balance.weights[{k}]"),
            format!("must be a positive relative speed, got {w}"),
        );
    }
    // their length is checked against the ranks of a run where the ranks are known
    // ([`check_rank_weights`])
    let skin = s.performance.skin;
    if !(0.0..=1.0).contains(&skin) {
        return err(
            "performance.skin",
            format!(
                "must be a fraction of the kernel support from 0 (rebuild the ghosts every step) \
                 to 1, got {}; e.g. skin = {}",
                num(skin),
                DEFAULT_SKIN
            ),
        );
    }
    check_verlet(s)?;
    validate_probes(s)?;
    validate_checkpoint(&s.checkpoint)?;
    validate_reference(s)?;
    check_sound_speed(s)?;
    check_step_budget(s)
}

/// Verlet lists (`performance.neighbours = "verlet"`) need a skin to keep, and one
/// smoothing length per pair support: a region with the level's h lists each pair within its
/// own support, which the skin does not widen.
pub(super) fn check_verlet(s: &Scene) -> Result<()> {
    if s.performance.neighbours != NeighbourMode::Verlet {
        return Ok(());
    }
    if s.performance.skin <= 0.0 {
        return err(
            "performance.skin",
            format!(
                "must be above 0 with neighbours = \"verlet\" (the lists reach the support plus \
                 the skin and are kept while no particle has moved half of it); e.g. skin = {}, \
                 or neighbours = \"lists\" to build them every step",
                DEFAULT_SKIN
            ),
        );
    }
    if let Some(k) = s
        .refine
        .iter()
        .position(|r| r.smoothing_length == refine::RegionH::Level)
    {
        return err(
            "performance.neighbours",
            format!(
                "\"verlet\" lists need one smoothing length, and refine[{k}] gives its particles \
                 the level's h; use neighbours = \"lists\" (or \"cells\"), or \
                 refine[{k}].smoothing_length = \"scene\""
            ),
        );
    }
    Ok(())
}

/// `physics.pressure_gradient = "difference"` changes the pressure term only where a support
/// holds several smoothing lengths, which needs a region with the level's h.
fn validate_pressure_gradient(s: &Scene) -> Result<()> {
    if !s.physics.pressure_gradient.is_difference()
        || s.refine
            .iter()
            .any(|r| r.smoothing_length == refine::RegionH::Level)
    {
        return Ok(());
    }
    err(
        "physics.pressure_gradient",
        "\"difference\" applies where a particle's support holds several smoothing lengths, and no \
         [[refine]] region of this scene gives its particles the level's h: add \
         smoothing_length = \"level\" to a region, or remove pressure_gradient (the symmetric \
         form is the default)",
    )
}

/// Materials and bodies of each kind: at most [`crate::limits::MAX_BODIES`] (a particle stores
/// its body and material as 16-bit indices), checked before anything else looks at them.
fn validate_counts(s: &Scene) -> Result<()> {
    let max = crate::limits::MAX_BODIES;
    for (key, n) in [
        ("material", s.materials.len()),
        ("fluid", s.fluids.len()),
        ("solid", s.solids.len()),
        ("wall", s.walls.len()),
    ] {
        if n > max {
            return err(
                key,
                format!(
                    "the scene has {n} [[{key}]] entries, above the limit of {max} (limits::MAX_BODIES); \
                     merge bodies that share a material and motion into fewer, larger ones"
                ),
            );
        }
    }
    Ok(())
}

/// Body names are unique across `[[fluid]]`, `[[solid]]` and `[[wall]]`: probes and outputs
/// refer to bodies by name. A second use of a name is an error on its `name`, naming the first;
/// "second" in the file when `order` gives each body's position there (its key, `fluid[0]`,
/// to a byte offset), else in the order fluids, solids, walls.
pub(crate) fn check_body_names(
    s: &Scene,
    order: Option<&std::collections::HashMap<String, usize>>,
) -> Result<()> {
    let mut bodies: Vec<(String, &String)> = (s
        .fluids
        .iter()
        .enumerate()
        .map(|(i, b)| (format!("fluid[{i}]"), &b.name)))
    .chain(
        s.solids
            .iter()
            .enumerate()
            .map(|(i, b)| (format!("solid[{i}]"), &b.name)),
    )
    .chain(
        s.walls
            .iter()
            .enumerate()
            .map(|(i, b)| (format!("wall[{i}]"), &b.name)),
    )
    .collect();
    if let Some(at) = order {
        // stable: a body the file does not place keeps its place after those it does
        bodies.sort_by_key(|(k, _)| at.get(k).copied().unwrap_or(usize::MAX));
    }
    let mut seen: std::collections::HashMap<&str, &str> = std::collections::HashMap::new();
    for (k, name) in &bodies {
        if let Some(first) = seen.get(name.as_str()) {
            return err(
                format!("{k}.name"),
                format!(
                    "`{name}` is already the name of {first}: body names are unique across [[fluid]], \
                     [[solid]] and [[wall]], since probes and outputs refer to bodies by name; e.g. \
                     name = \"{name}_2\""
                ),
            );
        }
        seen.insert(name, k);
    }
    Ok(())
}

/// The spacing, h/dx and the set-up relaxation's iterations.
fn validate_discretisation(disc: &super::Discretisation) -> Result<()> {
    positive(disc.dx, "discretisation.dx", "dx = 0.01")?;
    if !(disc.h_over_dx >= 0.5 && disc.h_over_dx <= 4.0) {
        return err(
            "discretisation.h_over_dx",
            format!("must lie in [0.5, 4] (got {}); 1.3 is typical", disc.h_over_dx),
        );
    }
    if disc.relax > MAX_RELAX {
        return err(
            "discretisation.relax",
            format!(
                "at most {MAX_RELAX} iterations of set-up relaxation (got {}); 50 settles a \
                 refinement region's interface",
                disc.relax
            ),
        );
    }
    Ok(())
}

/// Dimension, domain, limits and discretisation; returns the kernel support (m).
fn validate_domain(s: &mut Scene) -> Result<f64> {
    let d = s.dimension;
    if d != 2 && d != 3 {
        return err("dimension", format!("must be 2 or 3, got {d}"));
    }
    check_vec(&mut s.domain.min, d, "domain.min", false)?;
    check_vec(&mut s.domain.max, d, "domain.max", false)?;
    check_box(&s.domain.min, &s.domain.max, "domain")?;
    if s.domain.periodic.is_empty() {
        s.domain.periodic = vec![false; d];
    }
    if s.domain.periodic.len() != d {
        return err(
            "domain.periodic",
            format!("needs {d} booleans, e.g. [true, false]"),
        );
    }
    let f = s.domain.max_removed_fraction;
    if !(0.0..=1.0).contains(&f) {
        return err(
            "domain.max_removed_fraction",
            format!("must lie in [0, 1] (a fraction of the particles), e.g. 0.01; got {f}"),
        );
    }
    let lim = &s.limits;
    if !(lim.density_ratio.len() == 2
        && lim.density_ratio[0] > 0.0
        && lim.density_ratio[0] < 1.0
        && lim.density_ratio[1] > 1.0
        && lim.density_ratio[1].is_finite())
    {
        return err(
            "limits.density_ratio",
            format!(
                "needs [low, high] with 0 < low < 1 < high, e.g. [0.5, 2.0]; got {:?}",
                lim.density_ratio
            ),
        );
    }
    positive(lim.speed_over_c0, "limits.speed_over_c0", "speed_over_c0 = 1.0")?;
    let disc = &s.discretisation;
    validate_discretisation(disc)?;
    let support = disc.kernel.support_factor() * disc.h_over_dx * disc.dx;
    for a in 0..d {
        let len = s.domain.max[a] - s.domain.min[a];
        if len < disc.dx {
            return err(
                "domain.max",
                format!("axis {a} is shorter than one particle spacing"),
            );
        }
        let cells = len / disc.dx;
        if s.domain.periodic[a] && (cells - cells.round()).abs() > 1e-6 * cells.max(1.0) {
            return err(
                "domain.periodic",
                format!(
                    "periodic axis {a} is {len} m long, {cells:.4} spacings: it must hold a \
                     whole number of spacings dx = {} m, or the lattice leaves a gap or an \
                     overlap across the periodic seam",
                    disc.dx
                ),
            );
        }
        if s.domain.periodic[a] && len < 3.0 * support {
            return err(
                "domain.periodic",
                format!(
                    "periodic axis {a} is {len} m long but must span at least 3 kernel supports \
                     ({} m); lengthen the domain or refine dx",
                    3.0 * support
                ),
            );
        }
    }
    // The cell list spans the whole domain (cells of the support size, plus margins) with
    // u32 offsets: refuse a grid that could not be allocated rather than abort or overflow.
    let cells: f64 = (0..d)
        .map(|a| ((s.domain.max[a] - s.domain.min[a]) / support).floor().max(1.0) + 2.0)
        .product();
    if cells.is_nan() || cells > MAX_CELLS as f64 {
        return err(
            "domain.max",
            format!(
                "the domain spans {cells:.3e} cells of the kernel support ({support:.3e} m), \
                 more than the {:.3e} hsph allows; shrink the domain or coarsen dx",
                MAX_CELLS as f64
            ),
        );
    }
    Ok(support)
}

/// Materials (unique names, positive constants) and the physics switches.
fn validate_materials(s: &mut Scene) -> Result<()> {
    let d = s.dimension;
    if s.materials.is_empty() {
        return err("material", "at least one [[material]] is needed");
    }
    let mut seen = std::collections::HashSet::new();
    for (i, m) in s.materials.iter_mut().enumerate() {
        let k = format!("material[{i}]");
        if m.is_solid() {
            super::materials::solid_material(m, &k)?;
        } else {
            super::materials::fluid_material(m, &k)?;
        }
        if !seen.insert(m.name.clone()) {
            return err(
                format!("{k}.name"),
                format!("material `{}` is defined twice", m.name),
            );
        }
    }
    let ph = &mut s.physics;
    for (x, key, example) in [
        (ph.delta, "physics.delta", "delta = 0.1"),
        (
            ph.artificial_viscosity,
            "physics.artificial_viscosity",
            "artificial_viscosity = 0.02",
        ),
        (
            ph.artificial_viscosity_beta,
            "physics.artificial_viscosity_beta",
            "artificial_viscosity_beta = 2.0",
        ),
        (
            ph.artificial_stress,
            "physics.artificial_stress",
            "artificial_stress = 0.3",
        ),
    ] {
        non_negative(x, key)?;
        in_range(x, key, (0.0, MAX_COEFFICIENT), "", "MAX_COEFFICIENT", example)?;
    }
    non_negative(ph.laminar_viscosity, "physics.laminar_viscosity")?;
    in_range(
        ph.laminar_viscosity,
        "physics.laminar_viscosity",
        (0.0, MAX_VISCOSITY),
        "m²/s",
        "MAX_VISCOSITY",
        "laminar_viscosity = 1.0e-6 (water)",
    )?;
    check_vec(&mut ph.body_force, d, "physics.body_force", true)?;
    length_at_most(
        &ph.body_force,
        "physics.body_force",
        MAX_BODY_FORCE,
        "m/s²",
        "MAX_BODY_FORCE",
        "body_force = [0.0, -9.81]",
    )?;
    if ph.viscous_operator != crate::scene::ViscousOperator::Morris && ph.laminar_viscosity == 0.0 {
        return err(
            "physics.viscous_operator",
            "`renormalised` changes the laminar viscous term, and laminar_viscosity is 0: set \
             physics.laminar_viscosity (m²/s), or remove viscous_operator",
        );
    }
    if ph.density_gradient != crate::scene::DensityGradient::Step && !ph.density_diffusion.needs_gradient() {
        return err(
            "physics.density_gradient",
            "`lagged` times the renormalised density gradient of Antuono's δ-SPH term, and this \
             scene's density_diffusion is not `antuono`: set density_diffusion = \"antuono\", or \
             remove density_gradient",
        );
    }

    Ok(())
}

/// Fluid bodies: material, shape and box, velocity and initial-field expressions, in the domain.
fn validate_fluids(s: &mut Scene, mat_names: &Names) -> Result<()> {
    let d = s.dimension;
    if s.fluids.is_empty() && s.solids.is_empty() {
        return err("fluid", "at least one [[fluid]] or [[solid]] body is needed");
    }
    let bodies = (s
        .fluids
        .iter_mut()
        .enumerate()
        .map(|(i, f)| (format!("fluid[{i}]"), f)))
    .chain(
        s.solids
            .iter_mut()
            .enumerate()
            .map(|(i, f)| (format!("solid[{i}]"), f)),
    );
    let mut total = 0;
    for (k, f) in bodies {
        // every expression's length before any is parsed ([`crate::scene::expr`] bounds each)
        let texts = (f.velocity_field.iter().flatten().enumerate())
            .map(|(a, t)| (format!("{k}.velocity_field[{a}]"), t))
            .chain(
                f.pressure_field
                    .iter()
                    .map(|t| (format!("{k}.pressure_field"), t)),
            );
        for (key, t) in texts {
            crate::scene::expr::check_size(&key, t)?;
            total += t.chars().count();
        }
        if total > MAX_EXPR_TOTAL_CHARS {
            let key = if f.pressure_field.is_some() {
                "pressure_field"
            } else {
                "velocity_field"
            };
            return err(
                format!("{k}.{key}"),
                format!(
                    "the initial-field expressions of the bodies up to this one hold {total} characters, \
                     above the limit of {MAX_EXPR_TOTAL_CHARS} for a scene (limits::MAX_EXPR_TOTAL_CHARS); \
                     name common parts in [constants] or share one body's fields"
                ),
            );
        }
        if !mat_names.contains(&f.material) {
            return unknown_material(&k, &f.material, mat_names);
        }
        sphere_box(f.keys_mut(), &k, d)?;
        check_vec(&mut f.min, d, &format!("{k}.min"), false)?;
        check_vec(&mut f.max, d, &format!("{k}.max"), false)?;
        check_box(&f.min, &f.max, &k)?;
        check_vec(&mut f.velocity, d, &format!("{k}.velocity"), true)?;
        speed_at_most(&f.velocity, &format!("{k}.velocity"))?;
        validate_fields(f, &k, d, &s.constants)?;
        body_in_domain(f.keys(), &k, &s.domain)?;
    }
    super::materials::body_kinds(s)
}

/// The largest `time.cfl` a scene may ask for. Above 1 a run gets a warning: the stability
/// map (`hsph validate --map cfl`, docs/validation.md §5c) goes there to find where each
/// method fails.
pub const MAX_CFL: f64 = 3.0;

/// Time stepping, output schedule, format and snapshot fields.
fn validate_time_output(s: &mut Scene) -> Result<()> {
    let t = &s.time;
    positive(t.t_end, "time.t_end", "t_end = 1.0")?;
    in_range(
        t.t_end,
        "time.t_end",
        (0.0, MAX_T_END),
        "s",
        "MAX_T_END",
        "t_end = 1.0",
    )?;
    if !(t.cfl > 0.0 && t.cfl <= MAX_CFL) {
        return err(
            "time.cfl",
            format!(
                "must lie in (0, {MAX_CFL}] (got {}); 0.2 is typical, above 1 only for stability studies",
                t.cfl
            ),
        );
    }
    non_negative(t.dt, "time.dt")?;
    in_range(
        t.dt,
        "time.dt",
        (0.0, MAX_T_END),
        "s",
        "MAX_T_END",
        "dt = 1.0e-4, or 0 for the adaptive step",
    )?;
    check_settle(s)?;
    non_negative(s.output.interval, "output.interval")?;
    if s.output.interval == 0.0 {
        s.output.interval = s.time.t_end / 50.0;
    }
    validate_frames(s)?;
    if s.output.format == SnapshotFormat::Netcdf4 && !cfg!(feature = "netcdf") {
        return Err(Error::missing_feature("output.format", "netcdf"));
    }
    // the particle table names what snapshots can hold (the same in 2D and 3D)
    let valid = crate::particles::Particles::<3>::snapshot_names();
    let solid_only: Vec<&str> = crate::particles::Particles::<3>::field_table()
        .iter()
        .filter(|m| m.flag.has(crate::particles::Fields::SOLID))
        .filter_map(|m| m.snapshot)
        .collect();
    for (j, f) in s.output.fields.iter().enumerate() {
        if !valid.contains(&f.as_str()) {
            return err(
                format!("output.fields[{j}]"),
                format!("unknown field `{f}`; valid: {}", valid.join(", ")),
            );
        }
        if s.solids.is_empty() && solid_only.contains(&f.as_str()) {
            return err(
                format!("output.fields[{j}]"),
                format!(
                    "`{f}` is a field of solids and this scene has no [[solid]] body; fields of \
                     solids: {}",
                    solid_only.join(", ")
                ),
            );
        }
    }
    Ok(())
}

/// `output.frames`: each time finite and positive, at most [`MAX_FRAMES`]; resolved to
/// ascending times without repeats, the default (¼, ½, ¾ of t_end with fluid) written out. A
/// time past t_end is kept (a run shortened with `--set time.t_end` keeps its scene's frames)
/// and warned ([`crate::scene::lattice`]'s warnings).
fn validate_frames(s: &mut Scene) -> Result<()> {
    let t_end = s.time.t_end;
    let Some(frames) = &mut s.output.frames else {
        let auto = match s.fluids.is_empty() {
            true => Vec::new(),
            false => vec![0.25 * t_end, 0.5 * t_end, 0.75 * t_end],
        };
        s.output.frames = Some(auto);
        return Ok(());
    };
    if frames.len() > MAX_FRAMES {
        return err(
            "output.frames".to_string(),
            format!(
                "names {} times, more than the {MAX_FRAMES} frames a run writes (MAX_FRAMES): \
                 each frame is the whole state; use snapshots (output.interval) for a film",
                frames.len()
            ),
        );
    }
    for (j, &t) in frames.iter().enumerate() {
        if !(t.is_finite() && t > 0.0 && t <= MAX_T_END) {
            return err(
                format!("output.frames[{j}]"),
                format!(
                    "must be a time in (0, {MAX_T_END:e}] s (MAX_T_END), got {t}; e.g. frames = \
                     [{:.3}, {:.3}]",
                    0.5 * t_end,
                    t_end
                ),
            );
        }
    }
    frames.sort_by(f64::total_cmp);
    frames.dedup();
    Ok(())
}

/// Upper bound on the lattice sites of a box: ⌈len/dx⌉ + 1 per axis.
fn sites_in(min: &[f64], max: &[f64], dx: f64) -> f64 {
    min.iter()
        .zip(max)
        .map(|(lo, hi)| ((hi - lo) / dx).ceil() + 1.0)
        .product()
}

fn check_particle_count(s: &Scene) -> Result<()> {
    let dx = s.discretisation.dx;
    let mut n = 0.0;
    let mut key = "fluid";
    for f in s.fluids.iter().chain(&s.solids) {
        n += sites_in(&f.min, &f.max, dx);
        // the fine sites of every region refining it (the coarse ones left out stay counted)
        for r in s.refine.iter().filter(|r| r.applies_to(&f.name)) {
            let lo: Vec<f64> = (0..f.min.len()).map(|a| f.min[a].max(r.min[a])).collect();
            let hi: Vec<f64> = (0..f.min.len()).map(|a| f.max[a].min(r.max[a])).collect();
            if (0..lo.len()).all(|a| lo[a] < hi[a]) {
                n += sites_in(&lo, &hi, dx / f64::from(1u32 << r.level));
            }
        }
    }
    for w in &s.walls {
        let grow = if w.shape == WallShape::Container {
            w.layers as f64 * dx
        } else {
            0.0
        };
        let lo: Vec<f64> = w.min.iter().map(|x| x - grow).collect();
        let hi: Vec<f64> = w.max.iter().map(|x| x + grow).collect();
        if !w.method.makes_images() {
            n += sites_in(&lo, &hi, dx);
            key = "wall";
        }
    }
    if n.is_nan() || n > MAX_PARTICLES as f64 {
        return err(
            key,
            format!(
                "the bodies hold up to {n:.3e} particles at dx = {dx}, more than the \
                 {:.3e} hsph allows; shrink the bodies or coarsen dx",
                MAX_PARTICLES as f64
            ),
        );
    }
    Ok(())
}

fn validate_checkpoint(c: &CheckpointSpec) -> Result<()> {
    if !(c.every >= 0.0 && c.every.is_finite()) {
        return err(
            "checkpoint.every",
            format!("must be ≥ 0 s (0 = no time schedule), got {}", c.every),
        );
    }
    if c.keep == 0 {
        return err(
            "checkpoint.keep",
            "must be at least 1 (2 keeps the previous one while a new one is written)",
        );
    }
    Ok(())
}

/// The speed the flow is expected to reach (m/s): the largest of sqrt(2 g H) (g along the
/// non-periodic axes, H the fluid's extent along it), wall surface and motion speeds, initial
/// speeds, and the reference solution's peak speed. Computed without overflow to a false 0: a
/// speed too large for an f64 is +∞ (and a validated scene has none: its c0 covers it).
pub fn expected_speed(s: &Scene) -> f64 {
    let d = s.dimension;
    let g: Vec<f64> = (0..d)
        .map(|a| {
            if s.domain.periodic[a] {
                0.0
            } else {
                s.physics.body_force[a]
            }
        })
        .collect();
    let gmag = norm(&g);
    // of two candidate speeds the larger; NaN (0 × ∞ of absurd inputs) counts as unbounded
    let up = |s: f64, x: f64| if x.is_nan() { f64::INFINITY } else { s.max(x) };
    let mut speed: f64 = 0.0;
    if gmag > 0.0 && gmag.is_finite() && !s.fluids.is_empty() {
        let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
        for f in &s.fluids {
            // extreme corners of the box along ĝ
            let (mut a, mut b) = (0.0, 0.0);
            for (ax, gx) in g.iter().enumerate().take(d) {
                let e = gx / gmag;
                a += (f.min[ax] * e).min(f.max[ax] * e);
                b += (f.min[ax] * e).max(f.max[ax] * e);
            }
            lo = lo.min(a);
            hi = hi.max(b);
        }
        let v = (2.0 * gmag * (hi - lo)).sqrt();
        // where 2gH overflows, √(2g)·√H does not
        speed = up(
            speed,
            if v.is_finite() {
                v
            } else {
                (2.0 * gmag).sqrt() * (hi - lo).sqrt()
            },
        );
    } else if !gmag.is_finite() {
        speed = f64::INFINITY;
    }
    for f in &s.fluids {
        speed = up(up(speed, norm(&f.velocity)), sampled_speed(f, d, &s.constants));
    }
    for w in &s.walls {
        speed = up(speed, norm(&w.velocity));
        match &w.motion {
            Some(Motion::Sine {
                amplitude, period, ..
            }) => speed = up(speed, 2.0 * std::f64::consts::PI * norm(amplitude) / period),
            Some(Motion::ConstantVelocity { velocity }) => speed = up(speed, norm(velocity)),
            // the paddle's top speed c A/(h + A); the run-up at a wall moves about twice as fast
            Some(Motion::Solitary { amplitude, depth, .. }) => {
                let c = (gmag * (depth + amplitude)).sqrt();
                speed = up(speed, 2.0 * c * amplitude / (depth + amplitude));
            }
            None => {}
        }
    }
    match &s.reference {
        Some(Reference::Poiseuille { gap, .. }) if s.physics.laminar_viscosity > 0.0 => {
            let f = norm(&s.physics.body_force);
            if f > 0.0 {
                speed = up(speed, f * gap * gap / (8.0 * s.physics.laminar_viscosity));
            }
        }
        Some(Reference::Couette { v0, .. }) => speed = up(speed, v0.abs()),
        Some(Reference::TaylorGreen { speed: u, .. }) => speed = up(speed, *u),
        _ => {}
    }
    speed
}

fn check_sound_speed(s: &Scene) -> Result<()> {
    let u = expected_speed(s);
    for (i, m) in s.materials.iter().enumerate() {
        if u.is_nan() || 10.0 * u > SOUND_SPEED_RANGE.1 {
            return err(
                format!("material[{i}].c0"),
                format!(
                    "the expected speed {u:.4e} m/s (from gravity × fluid height, wall and initial \
                     speeds) would need c0 ≥ {:.4e} m/s, above the largest sound speed hsph accepts, \
                     {:e} m/s (SOUND_SPEED_RANGE); lower physics.body_force, the velocities or the \
                     wall motions",
                    10.0 * u,
                    SOUND_SPEED_RANGE.1
                ),
            );
        }
        if m.c0 < 10.0 * u {
            return err(
                format!("material[{i}].c0"),
                format!(
                    "c0 = {} m/s is below 10 × the expected speed {u:.4e} m/s (from gravity × \
                     fluid height, wall and initial speeds); weakly compressible SPH needs \
                     c0 ≥ {:.4e}",
                    m.c0,
                    10.0 * u
                ),
            );
        }
    }
    Ok(())
}

/// An upper bound of the time step (s), known before any particle is built, and what sets it:
/// the scene's fixed `time.dt`, or the first step's bound of the adaptive one,
/// min(CFL·h/c, 0.125 h²/ν), where c is the fastest signal at rest: the largest c0 of the
/// materials when there is fluid (the run's c_max), each solid body's longitudinal wave speed
/// √((ρ0c0² + 4G/3)/ρ0) plus its initial speed. The run's steps can only be shorter (the
/// fluid's own speed, the acceleration bound and a solid's strain rate shorten them), so
/// `t_end` over this is a lower bound of the step count, and the CFL part the same bound
/// `sim::Simulation::next_dt` takes.
pub fn dt_upper_bound(s: &Scene) -> (f64, String) {
    let t = &s.time;
    if t.dt > 0.0 {
        return (t.dt, "the fixed time.dt".to_string());
    }
    // the finest particles' h where regions refine the scene
    let h = s.discretisation.h_over_dx * s.discretisation.dx / f64::from(1u32 << super::refine::finest_h(s));
    let mut c: f64 = 0.0;
    if !s.fluids.is_empty() {
        c = s.materials.iter().fold(0.0, |m, x| m.max(x.c0));
    }
    let by_name: std::collections::HashMap<&str, &Material> =
        s.materials.iter().map(|m| (m.name.as_str(), m)).collect();
    for b in &s.solids {
        if let Some(m) = by_name.get(b.material.as_str()) {
            let g = m.shear_modulus.unwrap_or(0.0);
            let c_long = (m.c0 * m.c0 + 4.0 * g / (3.0 * m.rho0)).sqrt();
            c = c.max(c_long + norm(&b.velocity));
        }
    }
    let mut dt = t.cfl * h / c;
    let mut why = format!("CFL·h/c with CFL = {}, h = {h:.4e} m, c = {c:.4e} m/s", t.cfl);
    let nu = s.physics.laminar_viscosity;
    if nu > 0.0 && 0.125 * h * h / nu < dt {
        dt = 0.125 * h * h / nu;
        why = format!("0.125 h²/ν with h = {h:.4e} m, ν = {nu:e} m²/s");
    }
    (dt, why)
}

/// `time.settle`: a span like `t_end`'s, for a scene that starts at rest (the settling damps
/// every velocity away and zeroes it at its end).
fn check_settle(s: &Scene) -> Result<()> {
    let settle = s.time.settle;
    in_range(
        settle,
        "time.settle",
        (0.0, MAX_T_END),
        "s",
        "MAX_T_END",
        "settle = 0.3, or 0 to start from the set-up's lattice",
    )?;
    if settle == 0.0 {
        return Ok(());
    }
    let moving = |v: &[f64]| v.iter().any(|c| *c != 0.0);
    for (kind, bodies) in [("fluid", &s.fluids), ("solid", &s.solids)] {
        if let Some((k, f)) = bodies
            .iter()
            .enumerate()
            .find(|(_, f)| moving(&f.velocity) || f.velocity_field.is_some())
        {
            return err(
                "time.settle",
                format!(
                    "settles a scene at rest, but {kind}[{k}] ('{}') starts with a velocity, which \
                     the settling would damp away; remove time.settle or the initial velocity",
                    f.name
                ),
            );
        }
    }
    if let Some((j, w)) = s
        .walls
        .iter()
        .enumerate()
        .find(|(_, w)| w.motion.is_some() || moving(&w.velocity))
    {
        return err(
            "time.settle",
            format!(
                "settles a scene at rest, but wall[{j}] ('{}') moves; remove time.settle or the \
                 wall's motion and velocity",
                w.name
            ),
        );
    }
    Ok(())
}

/// The step budget: a run that needs more than [`MAX_STEPS`] steps (t_end over
/// [`dt_upper_bound`]) is refused unless `time.max_steps` bounds it; the steps of
/// `time.settle` count in any case.
fn check_step_budget(s: &Scene) -> Result<()> {
    // time.max_steps bounds the run, not the settling's steps before it
    let run = if s.time.max_steps > 0 { 0.0 } else { s.time.t_end };
    if run == 0.0 && s.time.settle == 0.0 {
        return Ok(());
    }
    let (dt, why) = dt_upper_bound(s);
    let steps = (run + s.time.settle) / dt;
    if steps <= MAX_STEPS {
        return Ok(());
    }
    let key = if s.time.dt > 0.0 { "time.dt" } else { "time.t_end" };
    err(
        key,
        format!(
            "time.t_end = {} s (and time.settle = {} s) needs at least {steps:.3e} steps of dt ≤ \
             {dt:.4e} s ({why}), above the step budget of {MAX_STEPS:e} steps; shorten time.t_end, \
             coarsen discretisation.dx, or set time.max_steps to run it anyway",
            num(s.time.t_end),
            num(s.time.settle)
        ),
    )
}

/// `balance.weights` against the `ranks` of a run, plan or job (`flag` names where that count
/// came from: `--ranks 4`): one relative speed per rank, or none for ranks of equal speed. A
/// list of another length is exit 2 naming the key, its length and the ranks: it cannot say
/// each rank's share of the load (the decomposition would repeat or drop entries). One rank
/// balances nothing, so any list passes there.
pub fn check_rank_weights(s: &Scene, ranks: usize, flag: &str) -> Result<()> {
    let n = s.balance.weights.len();
    if n == 0 || n == ranks || ranks <= 1 {
        return Ok(());
    }
    let example = vec!["1.0"; ranks.min(8)].join(", ") + if ranks > 8 { ", …" } else { "" };
    err(
        "balance.weights",
        format!(
            "has {n} entr{} but the run has {ranks} ranks ({flag}): the weights are the ranks' \
             relative speeds, one per rank, and set each rank's share of the load; give {ranks} \
             numbers (weights = [{example}]) or leave the key out for ranks of equal speed",
            if n == 1 { "y" } else { "ies" }
        ),
    )
}

/// Step counts under local time stepping. With `time.stepping = "local"` a cycle takes two
/// steps (`step` counts substeps) and the driver looks at the clock at a cycle's end only:
/// checkpoints, outputs, probes and the step limit all fall there (`sim/multirate.rs`). Every
/// key that counts steps then acts on even steps where cycles run: an odd
/// `checkpoint.every_steps = n` writes only at multiples of 2n, an odd `time.max_steps = n`
/// stops at n + 1. One warning per such key, naming the steps it will act on and an even
/// value that does what was asked. (`balance.check_every` is honoured inside a cycle: a cycle
/// checks at its first substep for both of its steps.)
pub fn stepping_warnings(s: &Scene) -> Vec<String> {
    if s.time.stepping != Stepping::Local {
        return Vec::new();
    }
    let mut out = Vec::new();
    let c = s.checkpoint.every_steps;
    if c % 2 == 1 {
        let lower = if c > 1 {
            format!(" or {}", c - 1)
        } else {
            String::new()
        };
        out.push(format!(
            "checkpoint.every_steps = {c} is odd: under time.stepping = \"local\" a cycle takes 2 steps and \
             checkpoints are written at cycle ends only, so where cycles run they fall every {} steps \
             (steps {}, {}, …), not every {c}; give an even number, e.g. checkpoint.every_steps = {}{lower}",
            2 * c,
            2 * c,
            4 * c,
            c + 1
        ));
    }
    let m = s.time.max_steps;
    if m % 2 == 1 {
        out.push(format!(
            "time.max_steps = {m} is odd: under time.stepping = \"local\" a cycle takes 2 steps and the run \
             stops at a cycle's end, so where cycles run it ends at step {}, not {m}; give an even number, \
             e.g. time.max_steps = {}{}",
            m + 1,
            m + 1,
            if m > 1 {
                format!(" or {}", m - 1)
            } else {
                String::new()
            }
        ));
    }
    out
}

//! `hsph check`: what a scene will be before it runs — particles, dt, steps, memory, output volume, warnings.

use super::*;

/// `hsph check`: counts and the memory estimate first, without building a particle; then, if
/// the scene fits, what a run would do.
pub(super) fn cmd_check(
    scene: &std::path::Path,
    set: &[String],
    ranks: usize,
    max_memory: Option<f64>,
    preview: Option<&std::path::Path>,
) -> Result<i32> {
    let (scene, src) = load_scene(scene, set)?;
    rank_weights(&scene, &src, ranks, &format!("--ranks {ranks}"))?;
    let opts = RunOptions {
        max_memory,
        min_particles_per_rank: 1,
        ..Default::default()
    };
    let est = driver::check_limits(&scene, ranks, ranks, &opts).map_err(|e| locate(&src, e))?;
    say(&estimate_report(&est, ranks, max_memory));
    let report = check_report(&scene).map_err(|e| locate(&src, e))?;
    say(&report);
    if let Some(n) = built_count(&report).filter(|&n| n != est.particles) {
        let memory = if n < est.particles {
            "so the memory above is an upper bound".to_string()
        } else {
            format!(
                "so the memory above is low by about {:.0} %",
                100.0 * (n as f64 / est.particles as f64 - 1.0)
            )
        };
        say(&format!(
            "note        the estimate counts {} sites of the bodies' and refinement regions' boxes, before \
             any is built; {n} are built (spheres, cylinders and refinement regions fill part of their \
             box), {memory}\n",
            est.particles
        ));
    }
    if let Some(dir) = preview {
        let files = crate::report::preview::write(dir, &scene).map_err(|e| locate(&src, e))?;
        let names: Vec<String> = files.iter().map(|f| f.display().to_string()).collect();
        say(&format!("preview     {}\n", names.join(", ")));
    }
    Ok(0)
}

/// The particle count of a [`check_report`]'s `particles` line.
fn built_count(report: &str) -> Option<u64> {
    let line = report.lines().find_map(|l| l.strip_prefix("particles   "))?;
    line.split_whitespace().next()?.parse().ok()
}

/// `balance.weights` of `scene` against `ranks` ranks (`flag` says where they came from),
/// located in the scene file or at the `--set` that gave them.
pub(super) fn rank_weights(scene: &Scene, src: &SceneSource, ranks: usize, flag: &str) -> Result<()> {
    crate::scene::check_rank_weights(scene, ranks, flag).map_err(|e| src.locate(e))
}

/// The limits `hsph run` applies to `ranks` ranks of `scene` (the same function: ranks, particles
/// per rank, probe sizes), for the commands that plan a layout without running it (`plan`,
/// `model`, `jobscript`); the memory of this machine is not the run's, so it is not checked.
pub(super) fn layout_limits(scene: &Scene, src: &SceneSource, ranks: usize) -> Result<()> {
    layout_estimate(scene, src, ranks).map(|_| ())
}

/// [`layout_limits`], giving the memory estimate of one rank per process (as under MPI).
pub(super) fn layout_estimate(
    scene: &Scene,
    src: &SceneSource,
    ranks: usize,
) -> Result<crate::memory::Estimate> {
    let opts = RunOptions {
        max_memory: Some(f64::INFINITY),
        ..Default::default()
    };
    driver::check_limits(scene, ranks, 1, &opts).map_err(|e| locate(src, e))
}

/// The estimate lines of `hsph check`.
pub(super) fn estimate_report(
    est: &crate::memory::Estimate,
    ranks: usize,
    max_memory: Option<f64>,
) -> String {
    use crate::memory::{available, human};
    let limit = max_memory.map(|m| (m, "--max-memory")).or_else(available);
    let avail = limit.map_or("unknown".to_string(), |(b, what)| {
        format!("{} ({what})", human(b))
    });
    let b = &est.parts;
    let per = |x: f64| x / est.rank_owned.max(1.0);
    format!(
        "estimate    {} particles; {ranks} rank(s) in one process need about {} (set-up peak {} per rank, \
         {} per rank running); available {avail}\n\
         {:12}a rank running, in B per owned particle: table {:.0}, ghosts and halo buffers {:.0}, lists {:.0}, \
         cells {:.0}, scratch (pair accumulators, solids' rates) {:.0}; the process itself {}\n",
        est.particles,
        human(est.process),
        human(est.rank_setup),
        human(est.rank_run),
        "",
        per(b.table),
        per(b.ghosts),
        per(b.lists),
        per(b.cells),
        per(b.scratch),
        human(crate::memory::PROCESS_BASE)
    )
}

/// The `hsph check` line on solid bodies: the fastest body's speed against the longitudinal
/// wave speed √((K + 4G/3)/ρ0) of its material (the speeds that set dt), or `None` without
/// solids.
pub(super) fn solid_speeds(scene: &Scene) -> Option<String> {
    let norm = |v: &[f64]| v.iter().map(|x| x * x).sum::<f64>().sqrt();
    let (mut v, mut c) = (0.0f64, 0.0f64);
    for b in &scene.solids {
        v = v.max(norm(&b.velocity));
        let m = scene.materials.iter().find(|m| m.name == b.material)?;
        if let Some(sm) = m.model().solid() {
            c = c.max(sm.c_long0());
        }
    }
    (!scene.solids.is_empty()).then(|| {
        format!(
            "expected    solid speed {v:.4e} m/s; longitudinal wave speed {c:.4e} m/s \
             (dt follows c_L + |v|)"
        )
    })
}

/// The `hsph check` lines on what a run will write: the bytes by kind, a warning when an output
/// or probe interval is below dt₀ (then a row or snapshot every step) and when the total
/// exceeds the free space where runs are written.
pub(super) fn output_volume<const D: usize>(
    scene: &Scene,
    n: usize,
    steps: f64,
    dt: f64,
    dropped: crate::particles::Fields,
) -> String {
    use crate::memory::human;
    use crate::output::volume::{estimate, free_space};
    let t_end = scene.time.t_end;
    let interval = if scene.output.interval > 0.0 {
        scene.output.interval
    } else {
        t_end / 50.0
    };
    let record = crate::particles::Particles::<D>::bytes_per_particle_carried(dropped) as f64;
    let v = estimate(scene, D, n as f64, steps, record, interval);
    let mut s = format!(
        "output      about {} written: snapshots {}, probes {}, series {}, final.csv {}, checkpoints {}\n",
        human(v.total()),
        human(v.snapshots),
        human(v.probes),
        human(v.series),
        human(v.final_csv),
        human(v.checkpoints)
    );
    let mut short = Vec::new();
    if interval < dt {
        short.push(format!("output.interval {interval:e} s"));
    }
    for (k, p) in scene.probes.iter().enumerate() {
        if let Some(iv) = p.interval().filter(|&iv| iv > 0.0 && iv < dt) {
            short.push(format!("probe[{k}].interval {iv:e} s"));
        }
    }
    if !short.is_empty() {
        s += &format!(
            "  warning: {} below dt₀ = {dt:.4e} s: written at every step\n",
            short.join(", ")
        );
    }
    let here = if std::path::Path::new("runs").is_dir() {
        "runs"
    } else {
        "."
    };
    if let Some(free) = free_space(std::path::Path::new(here)) {
        if v.total() > free {
            s += &format!(
                "  warning: about {} to write, more than the {} free where runs go ({here}); \
                 raise output.interval or write elsewhere with --out\n",
                human(v.total()),
                human(free)
            );
        }
    }
    s
}

/// The text `hsph check` prints: counts, physics, dt and memory estimates.
pub fn check_report(scene: &Scene) -> Result<String> {
    crate::with_dim!(scene.dimension, D => check_dim::<D>(scene))
}

/// The `particles` line: the count by kind, dynamic walls (particles of the dummy kind) told
/// apart by their body's method.
fn particles_line<const D: usize>(scene: &Scene, p: &crate::particles::Particles<D>) -> String {
    use crate::particles::Kind;
    let n = p.n_owned;
    let count = |k: Kind| p.kind[..n].iter().filter(|&&x| x == k).count();
    let (fluid, rep) = (count(Kind::Fluid), count(Kind::Repulsive));
    let dynamic = (0..n)
        .filter(|&i| p.kind[i] == Kind::Dummy && scene.walls[p.body[i] as usize].method.integrates_density())
        .count();
    let dummy = count(Kind::Dummy) - dynamic;
    let (solid, clamped) = (count(Kind::Solid), count(Kind::Clamped));
    let solids = if solid + clamped > 0 {
        format!(" + {solid} solid + {clamped} clamped solid")
    } else {
        String::new()
    };
    let dynamic = if dynamic > 0 {
        format!(" + {dynamic} dynamic wall")
    } else {
        String::new()
    };
    format!("particles   {n} = {fluid} fluid + {dummy} dummy wall{dynamic} + {rep} repulsive wall{solids}")
}

/// One line per wall body: method, rows built, slip and the material of its EOS.
fn wall_lines(scene: &Scene) -> Vec<String> {
    let (support, dx) = (scene.discretisation.support(), scene.discretisation.dx);
    (scene.walls.iter().enumerate())
        .map(|(i, w)| {
            let method = serde_json::to_value(w.method)
                .map_or(String::new(), |v| v.as_str().unwrap_or("").to_string());
            let slip = if w.slip == crate::scene::Slip::NoSlip {
                "no-slip"
            } else {
                "free-slip"
            };
            let rows = match (w.shape, w.method.makes_images()) {
                (_, true) => "images, no particles".to_string(),
                (crate::scene::WallShape::Container, false) => {
                    format!("{} layer(s) outside", w.built_layers(support, dx))
                }
                (
                    crate::scene::WallShape::Block
                    | crate::scene::WallShape::Polygon
                    | crate::scene::WallShape::Mesh,
                    false,
                ) => match w.shell_rows(support, dx) {
                    Some(r) => format!("a shell {r} row(s) deep"),
                    None => "solid".to_string(),
                },
            };
            format!(
                "wall[{i}] `{}`: {method}, {rows}, {slip}, material `{}`",
                w.name, w.material
            )
        })
        .collect()
}

pub(super) fn check_dim<const D: usize>(scene: &Scene) -> Result<String> {
    use crate::particles::Particles;
    use std::fmt::Write;
    // the set-up as a run builds it, without the relaxation's iterations and the settling's
    // steps (a run's work, not a check's: the `time` line counts the settling, the physics
    // lines the relaxation)
    let mut unsettled = scene.clone();
    unsettled.time.settle = 0.0;
    unsettled.discretisation.relax = 0;
    let sim = crate::sim::Simulation::<D>::new(&unsettled, &crate::comm::serial::SerialComm::new())?;
    let n = sim.p.n_owned;
    let mut s = String::new();
    let w = &mut s;
    let _ = writeln!(
        w,
        "scene       {} ({}D): {}",
        scene.name,
        D,
        scene.description.trim()
    );
    let _ = writeln!(w, "{}", particles_line(scene, &sim.p));
    let _ = writeln!(
        w,
        "bodies      as built on the lattice (each particle fills a cell of dx)"
    );
    for line in crate::scene::lattice::extent_lines::<D>(scene) {
        let _ = writeln!(w, "  - {line}");
    }
    for warning in crate::scene::warnings::<D>(scene) {
        let _ = writeln!(w, "  warning: {warning}");
    }
    for line in wall_lines(scene) {
        let _ = writeln!(w, "walls       {line}");
    }
    let _ = writeln!(w, "ghosts      {} (periodic and mirror images)", sim.halo.len());
    let per = sim.nl.entries() as f64 / n.max(1) as f64;
    let _ = if sim.pair_mode {
        writeln!(
            w,
            "neighbours  {per:.1} list entries per particle (pair mode: each pair once)"
        )
    } else {
        writeln!(w, "neighbours  {per:.1} per particle on average")
    };
    let _ = writeln!(w, "physics");
    for line in sim.model.describe() {
        let _ = writeln!(w, "  - {line}");
    }
    if !scene.fluids.is_empty() {
        let _ = writeln!(
            w,
            "expected    fluid speed {:.4e} m/s (c0 must be ≥ 10×)",
            crate::scene::expected_speed(scene)
        );
    }
    if let Some(line) = solid_speeds(scene) {
        let _ = writeln!(w, "{line}");
    }
    let (line, dt0, steps) = time_line(scene, &sim);
    let _ = writeln!(w, "{line}");
    let bytes = n * Particles::<D>::bytes_per_particle_carried(sim.p.dropped)
        + sim.halo.len() * Particles::<D>::bytes_per_ghost_carried(sim.p.dropped)
        + sim.nl.entries() * 4
        + sim.cells.order.len() * 8;
    let _ = writeln!(
        w,
        "memory      particle table and neighbour lists about {:.1} MiB ({:.0} B per particle; \
         the whole process: `estimate` above)",
        bytes as f64 / (1024.0 * 1024.0),
        bytes as f64 / n.max(1) as f64
    );
    let _ = writeln!(w, "probes      {}", scene.probes.len());
    let _ = write!(w, "{}", output_volume::<D>(scene, n, steps, dt0, sim.p.dropped));
    if let Some(r) = &scene.reference {
        let _ = writeln!(w, "reference   {r:?}");
    }
    Ok(s)
}

/// `hsph check`'s `time` line for `sim` built from `scene`, with dt₀ (s) and the steps to
/// t_end (a cycle's two substeps counted under `time.stepping = "local"`).
fn time_line<const D: usize>(scene: &Scene, sim: &crate::sim::Simulation<D>) -> (String, f64, f64) {
    let dt0 = sim.step_length();
    let steps = (scene.time.t_end / dt0).ceil();
    let settle = scene.time.settle;
    let settling = if settle > 0.0 {
        format!(
            "; settling {settle} s before t = 0 (about {:.0} steps more)",
            (settle / dt0).ceil()
        )
    } else {
        String::new()
    };
    let line = format!(
        "time        t_end {} s, dt₀ {:.4e} s{}, about {:.0} steps, {} output steps{settling}",
        scene.time.t_end,
        dt0,
        if sim.cycle {
            " (local steps: the coarse particles take 2 dt₀)"
        } else {
            ""
        },
        steps,
        (scene.time.t_end / scene.output.interval).round()
    );
    (line, dt0, steps)
}

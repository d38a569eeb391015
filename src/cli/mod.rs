//! The `hsph` command line (clap derive): the commands and their flags here, with `main`, the
//! dispatch and the small helpers every command uses (`say`, locating errors in a scene,
//! duration and memory parsers); each larger command in its own file: `run.rs` (run, restart),
//! `check.rs` (`hsph check`'s report), `plan.rs` (`hsph plan`, `hsph model`), `jobscript.rs`, `loads.rs`
//! (`hsph loads`).
//!
//! Every user-facing failure becomes an [`Error`] whose exit status is 2 for bad input (scene,
//! flags, a feature the build lacks) and 1 for a run that failed; nothing here panics.

mod check;
mod jobscript;
mod loads;
mod plan;
mod run;

pub use check::check_report;
use check::{cmd_check, layout_estimate, layout_limits, rank_weights};
use jobscript::{cmd_jobscript, JobArgs};
use loads::{cmd_loads, LoadsArgs};
use plan::{cmd_model, cmd_plan, ModelArgs};
use run::cmd_run_args;
pub use run::RunArgs;

use crate::affinity::Bind;
use crate::bench::{self, BenchOptions};
use crate::driver::{self, RunOptions};
use crate::error::{Error, Result};
use crate::layout::{Backend, LayoutRequest, RunLayout};
use crate::placement::Placement;
use crate::report;
use crate::scene::{load_scene, Scene, SceneFlags, SceneSource};
use crate::topology::Topology;
use clap::{Parser, Subcommand, ValueEnum};
use std::path::PathBuf;

const EXAMPLES: &str = "\
Examples:
  hsph run inputs/dam_break_2d.toml                  run the default scene (output in runs/)
  hsph run inputs/poiseuille_2d.toml --out runs/poi --threads 2
  hsph run inputs/dam_break_3d.toml --ranks 4 --threads 1    4 subdomains as threads, no MPI
  mpirun -np 4 hsph run inputs/dam_break_3d.toml             MPI (build with --features mpi)
  hsph run inputs/dam_break_2d.toml --set time.t_end=0.2 --set discretisation.dx=0.005
  hsph check inputs/dam_break_3d.toml                validate, count particles, estimate dt and memory
  hsph bench --threads 1,2                           particle-steps/s of the benchmark scenes";

/// hsph: hybrid MPI + threads smoothed-particle hydrodynamics (weakly compressible δ-SPH).
#[derive(Debug, Parser)]
#[command(name = "hsph", version, about, after_help = EXAMPLES)]
pub struct Cli {
    /// What to do.
    #[command(subcommand)]
    pub command: Command,
}

/// `--placement` of `hsph plan`: one method or every one.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum PlanPlacement {
    /// Every method, side by side.
    All,
    /// Block i on rank i.
    RankOrder,
    /// Fill nodes by the distance between block centres (seed 000).
    CentreDistance,
    /// Compact sub-grids of blocks per node.
    NodeGrid,
    /// The best of the above, refined by swaps weighted by halo volume.
    MinCut,
}

impl PlanPlacement {
    /// The methods to plan.
    pub fn methods(self) -> Vec<Placement> {
        match self {
            PlanPlacement::All => Placement::ALL.to_vec(),
            PlanPlacement::RankOrder => vec![Placement::RankOrder],
            PlanPlacement::CentreDistance => vec![Placement::CentreDistance],
            PlanPlacement::NodeGrid => vec![Placement::NodeGrid],
            PlanPlacement::MinCut => vec![Placement::MinCut],
        }
    }
}

/// Subcommands.
#[derive(Debug, Subcommand)]
pub enum Command {
    /// Run a scene and write a run directory.
    #[command(after_help = "\
The run directory holds scene.toml (resolved), timeseries.csv (deterministic physics),
diagnostics.csv (timers), final.csv (every particle, sorted by id), probes/*.csv,
snapshots/series.pvd (open in ParaView) and, last, summary.json.

Examples:
  hsph run inputs/dam_break_2d.toml
  hsph run inputs/couette_2d.toml --out runs/couette --force --threads 2
  hsph run inputs/dam_break_2d.toml --set physics.artificial_viscosity=0.05 --set fluid[0].max=[0.6,0.6]")]
    Run(RunArgs),
    /// Write a Slurm batch script for a scene: the layout as #SBATCH lines, rayon threads per
    /// rank, the early USR1 forwarded to the run (checkpoint, exit 3) and a requeue that
    /// continues from the checkpoint. Needs an hsph built with `--features mpi`.
    #[command(after_help = "\
Examples:
  hsph jobscript inputs/dam_break_3d.toml --nodes 4 --ranks-per-node 24 --threads-per-rank 2 --time 12:00:00 > db3.sbatch
  hsph jobscript inputs/dam_break_2d.toml --nodes 2 --ranks-per-node 2 --time 00:02:00 --signal-before 60 --launcher mpirun --script job.sh")]
    Jobscript(JobArgs),
    /// Show the machine as hwloc sees it (packages, NUMA nodes, cores, PUs with their cpusets)
    /// and which core each thread gets under `hsph run --bind cores` (cargo feature `hwloc`).
    #[command(after_help = "Example:\n  hsph topology --ranks 2 --threads 4")]
    Topology {
        /// Ranks of the local back end sharing this process's cpuset.
        #[arg(long, default_value_t = 1)]
        ranks: usize,
        /// Rayon threads per rank (default: the usable cores divided among the ranks).
        #[arg(long, default_value_t = 0)]
        threads: usize,
    },
    /// Plan a parallel layout without running physics: decomposition, placement on nodes and
    /// the halo traffic of one step, split into intra- and inter-node bytes.
    #[command(after_help = "\
Examples:
  hsph plan inputs/dam_break_3d.toml --ranks 96 --ranks-per-node 24 --placement all
  hsph plan inputs/dam_break_3d.toml --ranks 96 --topology topology/four_nodes_24.toml --out runs/plan")]
    Plan {
        /// Scene file (TOML).
        scene: PathBuf,
        /// Ranks (subdomains).
        #[arg(long)]
        ranks: usize,
        /// Virtual nodes of K consecutive ranks.
        #[arg(long, value_name = "K", default_value_t = 0, conflicts_with = "topology")]
        ranks_per_node: usize,
        /// Node layout file (wins over --ranks-per-node).
        #[arg(long, value_name = "FILE")]
        topology: Option<PathBuf>,
        /// Placement to plan, or all of them.
        #[arg(long, value_enum, default_value_t = PlanPlacement::All)]
        placement: PlanPlacement,
        /// Write plan.json and plan.csv here.
        #[arg(long)]
        out: Option<PathBuf>,
        /// Override a scene key (repeatable).
        #[arg(long = "set", value_name = "KEY.PATH=VALUE")]
        set: Vec<String>,
    },
    /// Predict the step time and parallel efficiency of a layout from measured runs: a
    /// bulk-synchronous model calibrated on a 1-rank run (cost per particle-step) and a
    /// multi-rank run on this machine (cost per ghost), with the network between nodes
    /// assumed (docs/performance_model.md).
    #[command(after_help = "\
Examples:
  hsph run inputs/dam_break_3d_bench.toml --threads 1 --out r1
  hsph run inputs/dam_break_3d_bench.toml --threads 1 --ranks 2 --out r2
  hsph model inputs/dam_break_3d.toml --one r1 --many r2 --ranks 96 --ranks-per-node 24 \\
      --set discretisation.dx=0.0035
  hsph model --one r1 --many r2 r4 --check r8     measured runs against the model
  hsph run inputs/dam_break_3d_bench.toml --threads 2 --out r1t2
  hsph model inputs/dam_break_3d.toml --one r1 --many r2 --two r1t2 --layouts 24 --nodes 4 \\
      --set discretisation.dx=0.0035                 which ranks × threads of 4 nodes of 24 cores")]
    Model(ModelArgs),
    /// The loads of a pressure series in a CSV file (an experiment's run) by the rules
    /// `summary.json` gives a run's pressure probes: raw maximum, maximum after a centred box
    /// filter, and the first impact's impulse (docs/pressure.md).
    #[command(after_help = "\
Example (Lobovsky et al. 2014, sensor 1, in t·√(g/H) and p/(ρgH) with H = 0.3 m):
  hsph loads inputs/reference/dambreak_lobovsky2014_H300_pressure_run.csv --time tstar \\
      --column p_sensor1_3mm --time-scale 0.174874 --scale 2943 --impulse-span 0.035")]
    Loads(LoadsArgs),
    /// Validate a scene and print what a run would do, without running it.
    #[command(after_help = "\
Examples:
  hsph check inputs/dam_break_3d.toml --set discretisation.dx=0.01
  hsph check inputs/dam_break_2d.toml --preview runs/preview    the built particles, as VTK and pictures")]
    Check {
        /// Scene file (TOML).
        scene: PathBuf,
        /// Ranks of the run to estimate memory for (all in one process, as --ranks does).
        #[arg(long, default_value_t = 1)]
        ranks: usize,
        /// Memory this process may use (as for `run`).
        #[arg(long, value_name = "SIZE", value_parser = parse_memory)]
        max_memory: Option<f64>,
        /// Override a scene key (repeatable).
        #[arg(long = "set", value_name = "KEY.PATH=VALUE")]
        set: Vec<String>,
        /// Write the particles the set-up builds, before any step, into this directory:
        /// `particles.vtu` and `particles.nc` (kind, body, level, mass, density, pressure) and
        /// pictures coloured by body (2D: one; 3D: a section through the domain's middle per
        /// axis).
        #[arg(long, value_name = "DIR")]
        preview: Option<PathBuf>,
    },
    /// Measure particle-steps/s and pair interactions/s (no output files).
    #[command(after_help = "\
Examples:
  hsph bench                                   the two benchmark scenes, 1 and 2 threads
  hsph bench inputs/dam_break_2d.toml --threads 2 --steps 200")]
    Bench {
        /// Scenes (default: inputs/dam_break_2d_dsph.toml and inputs/dam_break_3d_bench.toml).
        scenes: Vec<PathBuf>,
        /// Thread counts to measure, comma separated.
        #[arg(long, value_delimiter = ',', default_values_t = vec![1usize, 2])]
        threads: Vec<usize>,
        /// Timed steps per measurement (after 5 warm-up steps).
        #[arg(long, default_value_t = 100)]
        steps: u64,
        /// Repetitions per measurement; the median is reported.
        #[arg(long, default_value_t = 3)]
        repeat: usize,
        /// Override a scene key (repeatable).
        #[arg(long = "set", value_name = "KEY.PATH=VALUE")]
        set: Vec<String>,
        /// `--interactions`, `--neighbours`, `--overlap` (declared once, in `scene::SceneFlags`).
        #[command(flatten)]
        flags: SceneFlags,
    },
    /// Speed against accuracy: run validation cases at several resolutions and method
    /// variants, each run's error against its reference and its cost in one CSV row, charts
    /// with the Pareto front and the convergence order, and the cheapest configuration that
    /// meets a target error.
    #[command(after_help = "\
Cases: poiseuille, couette (Morris et al. 1997 start-ups; velocity error at t = 2 s in units of
the peak speed; variants include dummy plates with Adami's or Morris's no-slip, mirror plates,
and the renormalised viscous operator), hydrostatic (still tank; pressure error below
mid-depth in units of rho g H; variants include delta-plus shifting),
cavity (lid-driven, Re = 100, against Ghia et al. 1982 at t = 30 L/U; variants include the
wall methods dummy, repulsive and mixed: mirror box under a dummy lid), lobovsky and
lobovsky_impulse (the dam break's wall pressure at S1 against the experiment's 20 kHz run:
the filtered peak, the first impact's impulse; at dx = 10 and 5 mm; variants: the Riemann
solver's terms, delta-SPH Antuono and Fourtakas, the Riemann terms in pair mode).
Writes into --out: sweep.csv (one row per run: error, wall time, particle-steps/s, peak RSS,
status), runs/<case>-n<N>-<variant>/ (each an ordinary run directory), <case>_cost_error and
<case>_convergence (.png, .svg) and validate.md. Running again skips the configurations
already in sweep.csv. Timed runs run one at a time; --jobs N runs N at once and marks their
costs untimed.

Examples:
  hsph validate poiseuille                        the shipped method at n = 10, 20, 25, 40
  hsph validate poiseuille couette --sweep        every kernel and h/dx variant as well
  hsph validate poiseuille --resolutions 10,20 --variants cubic_spline-h1.2-dummy-none \
       --set time.t_end=0.6 --set reference.times=[0.6] --out validate-short
  hsph validate poiseuille --sweep --target 0.005 --write cheapest.toml
  hsph validate lobovsky lobovsky_impulse --sweep  wall pressure: error against wall time
  hsph validate --map --out stability               every stability study (a few minutes)
  hsph validate --map walls,lattice --out stability")]
    Validate {
        /// Cases to run (default: all).
        cases: Vec<String>,
        /// Sweep the method variants (kernels, h/dx, walls, density diffusion, viscous operator,
        /// shifting, pair mode), not only the shipped scene's method.
        #[arg(long)]
        sweep: bool,
        /// Resolutions (cells across the case's length scale), comma separated (default: the
        /// case's own).
        #[arg(long, value_delimiter = ',')]
        resolutions: Vec<u32>,
        /// Variants by name, comma separated (the names are in sweep.csv and the error message
        /// of an unknown one).
        #[arg(long, value_delimiter = ',')]
        variants: Vec<String>,
        /// Output directory.
        #[arg(long, default_value = "validate")]
        out: PathBuf,
        /// Runs at once; above 1 their costs are marked untimed.
        #[arg(long, default_value_t = 1)]
        jobs: usize,
        /// Rayon threads per run.
        #[arg(long, default_value_t = 1)]
        threads: usize,
        /// Override a scene key in every run (repeatable).
        #[arg(long = "set", value_name = "KEY.PATH=VALUE")]
        set: Vec<String>,
        /// Name the cheapest configuration with an error at most this (a fraction: 0.005 is
        /// 0.5 %); exit 1 if none met it.
        #[arg(long)]
        target: Option<f64>,
        /// With --target: write that configuration's resolved scene here.
        #[arg(long, value_name = "SCENE")]
        write: Option<PathBuf>,
        /// Stability map: run these studies (diffusion, cfl, walls, lattice, tensile; none
        /// named: all)
        /// until each run fails or ends, into map.csv, map_<study>.png/.svg and map.md.
        #[arg(long, value_delimiter = ',', num_args = 0.., value_name = "STUDY")]
        map: Option<Vec<String>>,
    },
    /// Charts (PNG, SVG) and a markdown summary of a finished run, or several runs compared.
    #[command(after_help = "\
Writes into RUNDIR/report/ (or --out): traffic_heatmap, traffic_time, ghosts_imbalance and
phase_times as .png and .svg, and report.md. A run with a hole probe (an impact) also gets
impact_top (the plate seen along its normal: particles coloured by --field, the hole's cells and
its fitted ellipse) and impact_side (every solid particle seen across the impact plane: the
debris cloud). With --compare (default --out report-compare): compare.md (a table) and
compare.png/.svg (bars per run).

Examples:
  hsph report runs/dam_break_3d-20250101T120000Z
  hsph report runs/impact_oblique_45-20250101T120000Z --field p
  hsph report --compare runs/rank-order runs/centre-distance --out runs/placements")]
    Report {
        /// Run directory (several with --compare).
        #[arg(required = true, value_name = "RUNDIR")]
        runs: Vec<PathBuf>,
        /// Set several runs side by side (layouts, placements, scaling).
        #[arg(long)]
        compare: bool,
        /// Output directory.
        #[arg(long)]
        out: Option<PathBuf>,
        /// `final.csv` column that colours the impact views (e.g. eps_p, p, rho, e, vx).
        #[arg(long, default_value = "eps_p")]
        field: String,
    },
}

/// Entry point of the binary: parse, dispatch, print any error and return the exit status.
pub fn main() -> i32 {
    crate::signals::catch_file_size_limit();
    let cli = match Cli::try_parse() {
        Ok(c) => c,
        Err(e) => {
            let code = if e.use_stderr() { 2 } else { 0 };
            let _ = e.print();
            return code;
        }
    };
    match dispatch(cli.command) {
        Ok(code) => code,
        Err(e) => {
            eprintln!("hsph: {e}");
            e.exit_code()
        }
    }
}

/// Run a command; the exit status of a success (0, or 3 for a run stopped early by a signal).
fn dispatch(cmd: Command) -> Result<i32> {
    match cmd {
        Command::Run(a) => cmd_run_args(a),
        Command::Jobscript(a) => cmd_jobscript(a),
        Command::Topology { ranks, threads } => {
            crate::limits::ranks("--ranks", ranks)?;
            if threads > 0 {
                crate::limits::threads("--threads", threads, ranks)?;
            }
            say(&crate::affinity::topology_report(ranks, threads)?);
            Ok(0)
        }
        Command::Plan {
            scene,
            ranks,
            ranks_per_node,
            topology,
            placement,
            out,
            set,
        } => {
            if let Some(dir) = &out {
                output_path("--out", dir, Written::Dir)?;
            }
            let topology = topology.map(|f| Topology::load(&f)).transpose()?;
            cmd_plan(
                &scene,
                &set,
                ranks,
                ranks_per_node,
                topology,
                placement,
                out.as_deref(),
            )
        }
        Command::Model(a) => cmd_model(a),
        Command::Loads(a) => cmd_loads(a),
        Command::Validate {
            cases,
            sweep,
            resolutions,
            variants,
            out,
            jobs,
            threads,
            set,
            target,
            write,
            map,
        } => {
            output_path("--out", &out, Written::Dir)?;
            if let Some(w) = &write {
                output_path("--write", w, Written::File)?;
            }
            crate::validate::command(&crate::validate::Options {
                cases,
                sweep,
                resolutions,
                variants,
                out,
                jobs,
                threads,
                set,
                target,
                write,
                map,
            })
        }
        Command::Check {
            scene,
            set,
            ranks,
            max_memory,
            preview,
        } => {
            if let Some(dir) = &preview {
                output_path("--preview", dir, Written::Dir)?;
            }
            cmd_check(&scene, &set, ranks.max(1), max_memory, preview.as_deref())
        }
        Command::Bench {
            scenes,
            threads,
            steps,
            repeat,
            set,
            flags,
        } => cmd_bench(scenes, threads, steps, repeat, set, flags),
        Command::Report {
            runs,
            compare,
            out,
            field,
        } => {
            if let Some(dir) = &out {
                output_path("--out", dir, Written::Dir)?;
            }
            let (_, files) = report::command(&runs, compare, out.as_deref(), &field)?;
            for f in &files {
                say(&format!("{}\n", f.display()));
            }
            Ok(0)
        }
    }
}

/// Give a scene error found after loading (e.g. overlapping bodies, found while filling the
/// lattice) the file and line of its key; flag errors (`--out`, ...) stay as they are.
fn locate(src: &SceneSource, e: Error) -> Error {
    match &e {
        Error::Input { at: None, key, .. } if !key.starts_with("--") => src.locate(e),
        _ => e,
    }
}

/// What an output-path flag names: a directory the command fills, or a file it writes.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Written {
    /// A run directory (`--out` of `run` and `jobscript`).
    RunDir,
    /// A directory (`--out` of `plan`, `validate`, `report`).
    Dir,
    /// A file (`jobscript --script`, `validate --write`).
    File,
}

/// Check the path of an output flag before anything runs, the same way for every command:
/// it exists as what it should be (a directory, or a regular file to replace), or it does
/// not exist and lies under a directory: a file's parent must exist, a directory's missing
/// parents are made with it (as `run` always made `runs/`). `/dev/null`, a path under a
/// regular file or a device, and a file whose parent is missing are exit 2 naming the flag,
/// with a path that would do.
pub(crate) fn output_path(flag: &str, path: &std::path::Path, kind: Written) -> Result<()> {
    use std::io::ErrorKind;
    let (what, example) = match kind {
        Written::RunDir => ("a run directory", "runs/out"),
        Written::Dir => ("a directory", "runs/out"),
        Written::File if flag == "--write" => ("a regular file", "cheap.toml"),
        Written::File => ("a regular file", "job.sh"),
    };
    let bad = |m: String| {
        Error::input(
            flag,
            format!("{}: {m}; give {what} path, e.g. {flag} {example}", path.display()),
        )
    };
    if path.as_os_str().is_empty() {
        return Err(bad("is empty".into()));
    }
    match std::fs::metadata(path) {
        Ok(m) if kind != Written::File && !m.is_dir() => {
            return Err(bad(
                "exists and is not a directory (a file, a device or a FIFO)".into()
            ))
        }
        Ok(m) if kind == Written::File && !m.is_file() => {
            return Err(bad(
                "exists and is not a regular file (a directory, a device or a FIFO), and would be replaced"
                    .into(),
            ))
        }
        Ok(_) => return Ok(()),
        Err(e) if e.kind() == ErrorKind::NotFound || e.kind() == ErrorKind::NotADirectory => {}
        Err(e) => return Err(bad(format!("cannot be reached: {e}"))),
    }
    // it does not exist: its parent must be an existing directory
    let parent = match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p,
        _ => std::path::Path::new("."),
    };
    let mut up = Some(parent);
    while let Some(a) = up {
        match std::fs::metadata(a) {
            Ok(m) if m.is_dir() && (a == parent || kind != Written::File) => return Ok(()),
            Ok(m) if m.is_dir() => {
                return Err(bad(format!(
                    "its parent directory {} does not exist (create it first: mkdir -p {})",
                    parent.display(),
                    parent.display()
                )))
            }
            Ok(_) => {
                return Err(bad(format!(
                    "lies under {}, which is not a directory (a file, a device or a FIFO)",
                    a.display()
                )))
            }
            Err(_) => up = a.parent().filter(|p| !p.as_os_str().is_empty()),
        }
    }
    Err(bad(format!(
        "its parent directory {} does not exist",
        parent.display()
    )))
}

/// Print to standard output; a closed pipe (`hsph check … | head -1`) is not an error.
pub fn say(text: &str) {
    use std::io::Write;
    let _ = std::io::stdout().write_all(text.as_bytes());
}

/// `--time`, `--max-wall`: HH:MM:SS, MM:SS or seconds, as seconds. Fields after the first are
/// below 60; the whole is above zero and at most [`crate::limits::MAX_WALL_SECONDS`].
fn parse_duration(s: &str) -> std::result::Result<f64, String> {
    use crate::limits::MAX_WALL_SECONDS;
    const EXAMPLE: &str = "e.g. 23:50:00, 45:00 or 3600";
    let parts: Vec<&str> = s.split(':').collect();
    let nums: Option<Vec<f64>> = parts.iter().map(|p| p.trim().parse::<f64>().ok()).collect();
    let n = match nums {
        Some(n) if (1..=3).contains(&n.len()) && n.iter().all(|x| *x >= 0.0 && x.is_finite()) => n,
        _ => return Err(format!("`{s}` is not a duration; {EXAMPLE}")),
    };
    if let Some(x) = n[1..].iter().find(|x| **x >= 60.0) {
        return Err(format!(
            "`{s}`: {x} is not below 60; minutes and seconds after the first field are 0 to 59, {EXAMPLE}"
        ));
    }
    let secs = n.iter().fold(0.0, |acc, x| acc * 60.0 + x);
    if secs <= 0.0 {
        Err(format!("`{s}` is zero; {EXAMPLE}"))
    } else if secs > MAX_WALL_SECONDS {
        Err(format!(
            "`{s}` is {secs} s, above the limit of {MAX_WALL_SECONDS} s (366 days); {EXAMPLE}"
        ))
    } else {
        Ok(secs)
    }
}

/// `--max-memory SIZE`.
fn parse_memory(s: &str) -> std::result::Result<f64, String> {
    crate::memory::parse_size(s)
        .ok_or_else(|| format!("`{s}` is not a size; e.g. 64G, 512MiB or 1000000 (bytes)"))
}

/// `hsph bench`: the default scenes unless named, with the `--set` overrides and typed flags.
fn cmd_bench(
    scenes: Vec<PathBuf>,
    threads: Vec<usize>,
    steps: u64,
    repeat: usize,
    set: Vec<String>,
    flags: SceneFlags,
) -> Result<i32> {
    use crate::limits::{count, MAX_BENCH_STEPS, MAX_REPEAT};
    count("--steps", steps, MAX_BENCH_STEPS)?;
    count("--repeat", repeat as u64, MAX_REPEAT as u64)?;
    for &t in &threads {
        crate::limits::threads("--threads", t, 1)?;
    }
    let scenes = if scenes.is_empty() {
        bench::default_scenes()
    } else {
        scenes
    };
    let opts = BenchOptions {
        threads,
        steps,
        repeat,
        overrides: set,
        flags,
    };
    say(&bench::table(&bench::run(&scenes, &opts)?));
    Ok(0)
}

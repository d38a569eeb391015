//! The `hsph` command line (clap derive): `run`, `check`, `bench`.
//!
//! Every user-facing failure becomes an [`Error`] whose exit status is 2 for bad input (scene,
//! flags, a feature the build lacks) and 1 for a run that failed; nothing here panics.

use crate::affinity::Bind;
use crate::bench::{self, BenchOptions};
use crate::driver::{self, RunOptions};
use crate::error::{Error, Result};
use crate::layout::{Backend, LayoutRequest, RunLayout};
use crate::placement::Placement;
use crate::report;
use crate::scene::{load_scene, Scene, SceneSource};
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
  hsph model --one r1 --many r2 r4 --check r8     measured runs against the model")]
    Model {
        /// Scene file (TOML) to predict; optional with --check.
        scene: Option<PathBuf>,
        /// A finished run directory on 1 rank with 1 thread (cost per particle-step).
        #[arg(long, value_name = "DIR")]
        one: PathBuf,
        /// Finished run directories on 2 or more ranks of 1 thread on this machine (contention
        /// and cost per ghost, fitted).
        #[arg(long, value_name = "DIR", num_args = 1.., required = true)]
        many: Vec<PathBuf>,
        /// Ranks to predict.
        #[arg(long, default_value_t = 1)]
        ranks: usize,
        /// Ranks per node of the prediction (0: one node).
        #[arg(long, value_name = "K", default_value_t = 0)]
        ranks_per_node: usize,
        /// Cores the predicted ranks share (0: one per rank); measured runs use this machine's.
        #[arg(long, default_value_t = 0)]
        cores: usize,
        /// Network bandwidth of one node (GB/s).
        #[arg(long, value_name = "GB_PER_S", default_value_t = 12.5)]
        bandwidth: f64,
        /// Network latency of one message (µs).
        #[arg(long, value_name = "MICROSECONDS", default_value_t = 1.5)]
        latency: f64,
        /// Finished run directories to compare with the model's prediction.
        #[arg(long, value_name = "DIR", num_args = 1..)]
        check: Vec<PathBuf>,
        /// Override a scene key of the predicted scene (repeatable).
        #[arg(long = "set", value_name = "KEY.PATH=VALUE")]
        set: Vec<String>,
    },
    /// Validate a scene and print what a run would do, without running it.
    #[command(after_help = "Example:\n  hsph check inputs/dam_break_3d.toml --set discretisation.dx=0.01")]
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
        /// Pair loops: `gather` (each particle sums all its neighbours; the same bits on any
        /// layout) or `pairs` (each pair once); default: the scene's `[performance]`.
        #[arg(long, value_enum)]
        interactions: Option<crate::scene::Interactions>,
        /// Neighbour search: `lists` or `cells` (no stored lists); default: the scene's.
        #[arg(long, value_enum)]
        neighbours: Option<crate::scene::NeighbourMode>,
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
wall methods dummy, repulsive and mixed: mirror box under a dummy lid).
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
        Command::Model {
            scene,
            one,
            many,
            ranks,
            ranks_per_node,
            cores,
            bandwidth,
            latency,
            check,
            set,
        } => cmd_model(
            scene.as_deref(),
            (&one, &many),
            (ranks, ranks_per_node, cores),
            (bandwidth, latency),
            &check,
            &set,
        ),
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
        } => crate::validate::command(&crate::validate::Options {
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
        }),
        Command::Check {
            scene,
            set,
            ranks,
            max_memory,
        } => cmd_check(&scene, &set, ranks.max(1), max_memory),
        Command::Bench {
            scenes,
            threads,
            steps,
            repeat,
            set,
            interactions,
            neighbours,
        } => cmd_bench(scenes, threads, steps, repeat, set, interactions, neighbours),
        Command::Report {
            runs,
            compare,
            out,
            field,
        } => {
            let (_, files) = report::command(&runs, compare, out.as_deref(), &field)?;
            for f in &files {
                say(&format!("{}\n", f.display()));
            }
            Ok(0)
        }
    }
}

/// `hsph bench`: the default scenes unless named, the flags as `--set` overrides.
fn cmd_bench(
    scenes: Vec<PathBuf>,
    threads: Vec<usize>,
    steps: u64,
    repeat: usize,
    mut set: Vec<String>,
    interactions: Option<crate::scene::Interactions>,
    neighbours: Option<crate::scene::NeighbourMode>,
) -> Result<i32> {
    use crate::limits::{count, MAX_BENCH_STEPS, MAX_REPEAT};
    count("--steps", steps, MAX_BENCH_STEPS)?;
    count("--repeat", repeat as u64, MAX_REPEAT as u64)?;
    for &t in &threads {
        crate::limits::threads("--threads", t, 1)?;
    }
    set.extend(interactions_override(interactions));
    set.extend(neighbours.map(|m| format!("performance.neighbours=\"{}\"", m.name())));
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
    };
    say(&bench::table(&bench::run(&scenes, &opts)?));
    Ok(0)
}

/// `hsph run`: load the scene, install the signal handlers, run; 3 if a signal stopped it.
fn cmd_run(scene: &std::path::Path, set: &[String], opts: &RunOptions) -> Result<i32> {
    let (scene, src) = load_scene(scene, set)?;
    crate::signals::install()?;
    let outcome = driver::run_scene(&scene, opts).map_err(|e| locate(&src, e))?;
    Ok(if outcome.stopped_by.is_some() {
        crate::signals::EXIT_STOPPED
    } else {
        0
    })
}

/// `hsph run`'s flags.
#[derive(clap::Args, Debug)]
pub struct RunArgs {
    /// Scene file (TOML); with --restart, the checkpoint's own scene is used.
    #[arg(required_unless_present = "restart")]
    scene: Option<PathBuf>,
    /// Continue a run from a checkpoint: a checkpoint directory, or a run directory (its
    /// newest complete checkpoint). The run continues in its own directory, on any number of
    /// ranks; --set may change only time.t_end, time.max_steps, output and checkpoint keys.
    #[arg(long, value_name = "DIR", conflicts_with_all = ["scene", "out", "force"])]
    restart: Option<PathBuf>,
    /// Wall-clock limit of the run, e.g. 23:50:00 (HH:MM:SS, MM:SS or seconds): before it
    /// the run writes a checkpoint and stops with exit 3, to be continued with --restart.
    #[arg(long, value_name = "HH:MM:SS", value_parser = parse_duration)]
    max_wall: Option<f64>,
    /// Write a checkpoint every M minutes of wall-clock time.
    #[arg(long, value_name = "M")]
    checkpoint_every_minutes: Option<f64>,
    /// Output directory (default runs/<scene>-<UTC timestamp>).
    #[arg(long)]
    out: Option<PathBuf>,
    /// Overwrite a non-empty output directory.
    #[arg(long)]
    force: bool,
    /// Rayon threads per rank (default: one per core).
    #[arg(long, default_value_t = 0)]
    threads: usize,
    /// Override a scene key by its dotted TOML path, e.g. --set time.t_end=0.5 (repeatable).
    #[arg(long = "set", value_name = "KEY.PATH=VALUE")]
    set: Vec<String>,
    /// Pair loops: `gather` (each particle sums all its neighbours in a fixed order: the same
    /// bits on any number of ranks and threads) or `pairs` (each pair of fluid particles once,
    /// fewer kernel evaluations; also the same bits on any number of ranks and threads — its
    /// own, equal to gather's to round-off). Default: the scene's `[performance] interactions`, else gather.
    #[arg(long, value_enum)]
    interactions: Option<crate::scene::Interactions>,
    /// Neighbour search: `lists` (stored once per step, 4 B per pair) or `cells` (no lists,
    /// each pass scans the cells again: the lean-memory mode, same bits). Default: the scene's
    /// `[performance] neighbours`, else lists.
    #[arg(long, value_enum)]
    neighbours: Option<crate::scene::NeighbourMode>,
    /// Communication back end.
    #[arg(long, value_enum, default_value_t = Backend::Auto)]
    backend: Backend,
    /// Ranks (subdomains) of the local back end: threads of this process, no MPI needed.
    #[arg(long, default_value_t = 1)]
    ranks: usize,
    /// Virtual nodes of K consecutive ranks (wins over the nodes MPI discovers).
    #[arg(long, value_name = "K", default_value_t = 0, conflicts_with = "topology")]
    ranks_per_node: usize,
    /// Node layout file (see topology/), e.g. topology/four_nodes_24.toml.
    #[arg(long, value_name = "FILE")]
    topology: Option<PathBuf>,
    /// Placement of subdomains on ranks.
    #[arg(long, value_enum, default_value_t = Placement::RankOrder)]
    placement: Placement,
    /// No progress output.
    #[arg(long, short)]
    quiet: bool,
    /// Pin each rank's rayon threads to cores of the launcher's cpuset (`cores`, cargo
    /// feature `hwloc`; `hsph topology` shows the plan and the policy).
    #[arg(long, value_enum, default_value_t = Bind::None)]
    bind: Bind,
    /// Memory this process may use, e.g. 64G or 512MiB (default: the smallest of the cgroup
    /// limit, the memory available and ulimit -v). A run estimated above it is refused.
    #[arg(long, value_name = "SIZE", value_parser = parse_memory)]
    max_memory: Option<f64>,
    /// Fewest particles per rank: more ranks than particles / N are refused.
    #[arg(long, value_name = "N", default_value_t = driver::MIN_PARTICLES_PER_RANK)]
    min_particles_per_rank: usize,
}

/// The `--set` override of an `--interactions` flag.
fn interactions_override(i: Option<crate::scene::Interactions>) -> Option<String> {
    i.map(|i| format!("performance.interactions=\"{}\"", i.name()))
}

/// `hsph run`: a scene, or `--restart` of a checkpoint.
fn cmd_run_args(a: RunArgs) -> Result<i32> {
    let RunArgs {
        scene,
        restart,
        max_wall,
        checkpoint_every_minutes,
        out,
        force,
        threads,
        mut set,
        interactions,
        neighbours,
        backend,
        ranks,
        ranks_per_node,
        topology,
        placement,
        quiet,
        bind,
        max_memory,
        min_particles_per_rank,
    } = a;
    set.extend(interactions_override(interactions));
    set.extend(neighbours.map(|m| format!("performance.neighbours=\"{}\"", m.name())));
    check_run_flags(backend, bind, ranks, checkpoint_every_minutes)?;
    let opts = RunOptions {
        out,
        force,
        threads,
        quiet,
        ranks,
        backend,
        fault: driver::Fault::from_env(),
        ranks_per_node,
        topology: topology.map(|f| Topology::load(&f)).transpose()?,
        placement,
        bind,
        max_memory,
        min_particles_per_rank,
        restart: None,
        max_wall,
        checkpoint_wall: checkpoint_every_minutes.map(|m| m * 60.0),
    };
    match (scene, restart) {
        (_, Some(from)) => cmd_restart(&from, &set, opts),
        (Some(scene), None) => cmd_run(&scene, &set, &opts),
        (None, None) => Err(Error::input("SCENE", "give a scene file, or --restart DIR")),
    }
}

/// Flags of `hsph run` that need no scene: the back end and binding this build has, a rank
/// count, a positive checkpoint interval.
fn check_run_flags(
    backend: Backend,
    bind: Bind,
    ranks: usize,
    checkpoint_minutes: Option<f64>,
) -> Result<()> {
    crate::limits::ranks("--ranks", ranks.max(1))?;
    if backend == Backend::Mpi && !cfg!(feature = "mpi") {
        return Err(Error::missing_feature("--backend", "mpi"));
    }
    if bind == Bind::Cores && !cfg!(feature = "hwloc") {
        return Err(Error::missing_feature("--bind cores", "hwloc"));
    }
    if ranks == 0 {
        return Err(Error::input("--ranks", "must be at least 1, e.g. --ranks 4"));
    }
    if checkpoint_minutes.is_some_and(|m| !(m > 0.0 && m.is_finite())) {
        return Err(Error::input(
            "--checkpoint-every-minutes",
            "must be a positive number of minutes, e.g. 30",
        ));
    }
    Ok(())
}

/// `hsph jobscript`'s flags. Every value is checked before the script is written
/// ([`crate::jobscript::JobSpec::validate`]): counts and times against [`crate::limits`],
/// Slurm names against their charset, paths for control characters.
#[derive(clap::Args, Debug)]
pub struct JobArgs {
    /// Scene file (TOML); its `name` is the job's name (letters, digits and . _ + -).
    scene: PathBuf,
    /// Nodes (nodes × ranks per node at most 4096).
    #[arg(long)]
    nodes: usize,
    /// Ranks (MPI tasks) per node.
    #[arg(long)]
    ranks_per_node: usize,
    /// Rayon threads per rank (CPUs per task), at most 1024.
    #[arg(long, default_value_t = 1)]
    threads_per_rank: usize,
    /// Time limit, HH:MM:SS (or MM:SS, or seconds), at most 366 days.
    #[arg(long, value_parser = parse_duration)]
    time: f64,
    /// Seconds before the limit at which the run is told to checkpoint and stop, 10 to 65535
    /// and below --time (default: a tenth of the time, 60 s to 15 min).
    #[arg(long, value_name = "SECONDS")]
    signal_before: Option<u64>,
    /// Slurm partition, or a comma-separated list (letters, digits and . _ + -).
    #[arg(long)]
    partition: Option<String>,
    /// Slurm account (letters, digits and . _ + -).
    #[arg(long)]
    account: Option<String>,
    /// Placement of subdomains on ranks.
    #[arg(long, value_enum, default_value_t = Placement::CentreDistance)]
    placement: Placement,
    /// How ranks are started.
    #[arg(long, value_enum, default_value_t = crate::jobscript::Launcher::Srun)]
    launcher: crate::jobscript::Launcher,
    /// Run directory (default runs/<scene name>).
    #[arg(long)]
    out: Option<PathBuf>,
    /// Write the script to this file (default: standard output); an existing path must be a
    /// regular file.
    #[arg(long)]
    script: Option<PathBuf>,
}

/// `hsph jobscript`: the sbatch script for a scene, to a file or standard output.
fn cmd_jobscript(a: JobArgs) -> Result<i32> {
    use crate::jobscript::{path_text, HSPH_ADVICE, OUT_ADVICE, SCENE_ADVICE};
    let JobArgs {
        scene,
        nodes,
        ranks_per_node,
        threads_per_rank,
        time,
        signal_before,
        partition,
        account,
        placement,
        launcher,
        out,
        script,
    } = a;
    if let Some(path) = &script {
        crate::jobscript::script_target(path)?;
    }
    let (sc, src) = load_scene(&scene, &[])?;
    let abs = |p: &std::path::Path| std::path::absolute(p).unwrap_or_else(|_| p.to_path_buf());
    // the default run directory as `run` makes it from the name: one safe path component
    let run = out
        .clone()
        .unwrap_or_else(|| PathBuf::from("runs").join(crate::output::safe_name(&sc.name)));
    let hsph = match std::env::current_exe() {
        Ok(p) => path_text("HSPH", &p, HSPH_ADVICE)?,
        Err(_) => "hsph".into(),
    };
    let time_s = time.round() as u64;
    let spec = crate::jobscript::JobSpec {
        scene: path_text("SCENE", &abs(&scene), SCENE_ADVICE)?,
        run: path_text("--out", &abs(&run), OUT_ADVICE)?,
        hsph,
        name: sc.name.clone(),
        nodes,
        ranks_per_node,
        threads_per_rank,
        time_s,
        signal_s: signal_before.unwrap_or_else(|| crate::jobscript::default_signal(time_s)),
        partition,
        account,
        placement: placement
            .to_possible_value()
            .map_or("rank-order".into(), |v| v.get_name().to_string()),
        launcher,
    };
    spec.validate()?;
    // the limits `run` will apply to this many ranks (after the flags, which name the limit
    // themselves)
    layout_limits(&sc, &src, nodes * ranks_per_node).map_err(|e| match e {
        Error::Input { at, key, message } if key == "--ranks" => Error::Input {
            at,
            key: "--nodes × --ranks-per-node".into(),
            message,
        },
        e => e,
    })?;
    let text = spec.script();
    match script {
        Some(path) => {
            crate::output::write_atomic(&path, |f| std::io::Write::write_all(f, text.as_bytes()))?;
            say(&format!(
                "wrote {}: submit it with `sbatch {}`\n",
                path.display(),
                path.display()
            ));
        }
        None => say(&text),
    }
    Ok(0)
}

/// `hsph run --restart`: the checkpoint's scene with the allowed `--set` changes, continued
/// in the checkpoint's run directory.
fn cmd_restart(from: &std::path::Path, set: &[String], mut opts: RunOptions) -> Result<i32> {
    let ck = crate::checkpoint::locate(from)?;
    let m = crate::checkpoint::manifest(&ck)?;
    let at = ck.join("manifest.json");
    let (original, _) = crate::scene::load_scene_str(&m.scene, &at, "restart", &[])?;
    let (scene, src) = crate::scene::load_scene_str(&m.scene, &at, &original.name, set)?;
    crate::checkpoint::compat::check(&original, &scene)?;
    restart_not_before_start(&scene, &m).map_err(|e| locate(&src, e))?;
    if scene.dimension != m.dimension {
        return Err(Error::input(
            "--restart",
            "the checkpoint's scene and parts disagree on the dimension",
        ));
    }
    opts.out = Some(crate::checkpoint::run_dir_of(&ck));
    opts.restart = Some((ck, m));
    crate::signals::install()?;
    let outcome = driver::run_scene(&scene, &opts).map_err(|e| locate(&src, e))?;
    Ok(if outcome.stopped_by.is_some() {
        crate::signals::EXIT_STOPPED
    } else {
        0
    })
}

/// A restart must end after it starts: `time.t_end` not before the checkpoint's time, and
/// `time.max_steps` not below its step.
fn restart_not_before_start(scene: &Scene, m: &crate::checkpoint::Manifest) -> Result<()> {
    if scene.time.t_end < m.t {
        return Err(Error::input(
            "time.t_end",
            format!(
                "{} s is before the checkpoint's time {} s: a restart continues from there; set \
                 time.t_end above it, e.g. --set time.t_end={}",
                scene.time.t_end,
                m.t,
                m.t * 2.0
            ),
        ));
    }
    let max = scene.time.max_steps;
    if max > 0 && max < m.step {
        return Err(Error::input(
            "time.max_steps",
            format!(
                "{max} is below the checkpoint's step {}: a restart continues from there",
                m.step
            ),
        ));
    }
    Ok(())
}

/// `hsph plan`: the layout resolved as `hsph run` resolves it (nodes declared, never
/// discovered), then every placement asked for.
fn cmd_plan(
    scene: &std::path::Path,
    set: &[String],
    ranks: usize,
    ranks_per_node: usize,
    topology: Option<Topology>,
    placement: PlanPlacement,
    out: Option<&std::path::Path>,
) -> Result<i32> {
    let (scene, src) = load_scene(scene, set)?;
    layout_limits(&scene, &src, ranks)?;
    let req = LayoutRequest {
        backend: Backend::Local,
        ranks,
        ranks_per_node,
        topology,
        ..Default::default()
    };
    let topo = RunLayout::resolve(&req, Backend::Local, ranks, None)?.placement_topology();
    let rows = crate::plan::plan(&scene, ranks, &topo, &placement.methods())?;
    say(&crate::plan::table(&scene, ranks, &topo, &rows));
    if let Some(dir) = out {
        crate::plan::write(dir, &scene, ranks, &topo, &rows)?;
        say(&format!("wrote {}/plan.json and plan.csv\n", dir.display()));
    }
    Ok(0)
}

/// `hsph model`: calibrate on `one` and `many`, compare with the `check` runs, predict `scene`.
fn cmd_model(
    scene: Option<&std::path::Path>,
    (one, many): (&std::path::Path, &[PathBuf]),
    (ranks, ranks_per_node, cores): (usize, usize, usize),
    (bandwidth, latency): (f64, f64),
    check: &[PathBuf],
    set: &[String],
) -> Result<i32> {
    use crate::model::{calibrate, calibration_text, predict, Measured, Network};
    if !(bandwidth.is_finite() && bandwidth > 0.0) {
        return Err(Error::input(
            "--bandwidth",
            "must be a positive number of GB/s, e.g. 12.5",
        ));
    }
    if !(latency.is_finite() && latency >= 0.0) {
        return Err(Error::input("--latency", "must be ≥ 0 µs, e.g. 1.5"));
    }
    if scene.is_none() && check.is_empty() {
        return Err(Error::input(
            "SCENE",
            "give a scene to predict, or --check DIR… to compare runs with the model",
        ));
    }
    let here = std::thread::available_parallelism().map_or(1, |n| n.get());
    let one = Measured::read(one)?;
    let many = many
        .iter()
        .map(|d| Measured::read(d))
        .collect::<Result<Vec<_>>>()?;
    let cal = calibrate(&one, &many, here)?;
    say(&calibration_text(&cal, &one, &many));
    let net = Network {
        bandwidth: bandwidth * 1e9,
        latency: latency * 1e-6,
    };
    if !check.is_empty() {
        say("| run | ranks | particles | measured s/step | predicted s/step | error |\n|---|---:|---:|---:|---:|---:|\n");
        for dir in check {
            let m = Measured::read(dir)?;
            if m.threads != 1 {
                return Err(Error::input(
                    dir.display().to_string(),
                    "the model predicts runs of 1 thread per rank; this run had more",
                ));
            }
            let (row, topo) = m.plan()?;
            let p = predict(&cal, &net, &[row], &topo, here).remove(0);
            // a calibration run is reproduced to round-off: print it as +0.0, not −0.0
            let err = 100.0 * (p.step / m.per_step() - 1.0);
            let err = if err.abs() < 0.05 { 0.0 } else { err };
            say(&format!(
                "| {} | {} | {} | {:.5} | {:.5} | {:+.1} % |\n",
                m.dir,
                m.ranks,
                m.particles,
                m.per_step(),
                p.step,
                err
            ));
        }
    }
    let Some(path) = scene else {
        return Ok(0);
    };
    let (scene, src) = load_scene(path, set)?;
    layout_limits(&scene, &src, ranks)?;
    let per_node = if ranks_per_node == 0 {
        ranks
    } else {
        ranks_per_node
    };
    let topo = Topology::from_ranks_per_node(ranks, per_node)?;
    let rows = crate::plan::plan(&scene, ranks, &topo, &PlanPlacement::All.methods())?;
    let n: u64 = rows[0].owned.iter().sum();
    let cores = if cores == 0 { ranks } else { cores };
    say(&format!(
        "{}: {n} particles on {ranks} ranks ({} node(s) of {per_node}), {cores} cores; network {bandwidth} GB/s, {latency} µs\n\
         one rank: {:.4} s/step\n\
         | placement | imbalance | s/step | compute s | network s | speed-up | efficiency |\n|---|---:|---:|---:|---:|---:|---:|\n",
        scene.name,
        topo.nodes(),
        cal.per_particle * n as f64
    ));
    for p in predict(&cal, &net, &rows, &topo, cores) {
        say(&format!(
            "| {} | {:.4} | {:.5} | {:.5} | {:.5} | {:.1} | {:.3} |\n",
            p.placement.name(),
            p.imbalance,
            p.step,
            p.compute,
            p.network,
            p.speedup,
            p.efficiency
        ));
    }
    Ok(0)
}

/// `hsph check`: counts and the memory estimate first, without building a particle; then, if
/// the scene fits, what a run would do.
fn cmd_check(scene: &std::path::Path, set: &[String], ranks: usize, max_memory: Option<f64>) -> Result<i32> {
    let (scene, src) = load_scene(scene, set)?;
    let opts = RunOptions {
        max_memory,
        min_particles_per_rank: 1,
        ..Default::default()
    };
    let est = driver::check_limits(&scene, ranks, ranks, &opts).map_err(|e| locate(&src, e))?;
    say(&estimate_report(&est, ranks, max_memory));
    say(&check_report(&scene).map_err(|e| locate(&src, e))?);
    Ok(0)
}

/// The limits `hsph run` applies to `ranks` ranks of `scene` (the same function: ranks, particles
/// per rank, probe sizes), for the commands that plan a layout without running it (`plan`,
/// `model`, `jobscript`); the memory of this machine is not the run's, so it is not checked.
fn layout_limits(scene: &Scene, src: &SceneSource, ranks: usize) -> Result<()> {
    let opts = RunOptions {
        max_memory: Some(f64::INFINITY),
        ..Default::default()
    };
    driver::check_limits(scene, ranks, 1, &opts)
        .map(|_| ())
        .map_err(|e| locate(src, e))
}

/// Give a scene error found after loading (e.g. overlapping bodies, found while filling the
/// lattice) the file and line of its key; flag errors (`--out`, ...) stay as they are.
fn locate(src: &SceneSource, e: Error) -> Error {
    match &e {
        Error::Input { at: None, key, .. } if !key.starts_with("--") => src.locate(e),
        _ => e,
    }
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

/// The estimate lines of `hsph check`.
fn estimate_report(est: &crate::memory::Estimate, ranks: usize, max_memory: Option<f64>) -> String {
    use crate::memory::{available, human};
    let limit = max_memory.map(|m| (m, "--max-memory")).or_else(available);
    let avail = limit.map_or("unknown".to_string(), |(b, what)| {
        format!("{} ({what})", human(b))
    });
    format!(
        "estimate    {} particles; {ranks} rank(s) in one process need about {} (set-up peak {} per rank, \
         {} per rank running); available {avail}\n",
        est.particles,
        human(est.process),
        human(est.rank_setup),
        human(est.rank_run)
    )
}

/// The `hsph check` line on solid bodies: the fastest body's speed against the longitudinal
/// wave speed √((K + 4G/3)/ρ0) of its material (the speeds that set dt), or `None` without
/// solids.
fn solid_speeds(scene: &Scene) -> Option<String> {
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
fn output_volume<const D: usize>(
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

fn check_dim<const D: usize>(scene: &Scene) -> Result<String> {
    use crate::particles::{Kind, Particles};
    use std::fmt::Write;
    let sim = crate::sim::Simulation::<D>::new(scene, &crate::comm::serial::SerialComm::new())?;
    let n = sim.p.n_owned;
    let count = |k: Kind| sim.p.kind[..n].iter().filter(|&&x| x == k).count();
    let (fluid, dummy, rep) = (count(Kind::Fluid), count(Kind::Dummy), count(Kind::Repulsive));
    let (solid, clamped) = (count(Kind::Solid), count(Kind::Clamped));
    let mut s = String::new();
    let w = &mut s;
    let _ = writeln!(
        w,
        "scene       {} ({}D): {}",
        scene.name,
        D,
        scene.description.trim()
    );
    let solids = if solid + clamped > 0 {
        format!(" + {solid} solid + {clamped} clamped solid")
    } else {
        String::new()
    };
    let _ = writeln!(
        w,
        "particles   {n} = {fluid} fluid + {dummy} dummy wall + {rep} repulsive wall{solids}"
    );
    let _ = writeln!(
        w,
        "bodies      as built on the lattice (each particle fills a cell of dx)"
    );
    for line in crate::scene::lattice::extent_lines::<D>(scene) {
        let _ = writeln!(w, "  - {line}");
    }
    for warning in crate::scene::lattice::scene_warnings::<D>(scene) {
        let _ = writeln!(w, "  warning: {warning}");
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
    let steps = (scene.time.t_end / sim.dt).ceil();
    let _ = writeln!(
        w,
        "time        t_end {} s, dt₀ {:.4e} s, about {:.0} steps, {} output steps",
        scene.time.t_end,
        sim.dt,
        steps,
        (scene.time.t_end / scene.output.interval).round()
    );
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
    let _ = write!(
        w,
        "{}",
        output_volume::<D>(scene, n, steps, sim.dt, sim.p.dropped)
    );
    if let Some(r) = &scene.reference {
        let _ = writeln!(w, "reference   {r:?}");
    }
    Ok(s)
}

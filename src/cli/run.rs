//! `hsph run`: its flags, a fresh run or a restart from a checkpoint, and the checks of run-only flags.

use super::*;

/// `hsph run`: load the scene, install the signal handlers, run; 3 if a signal stopped it.
pub(super) fn cmd_run(
    scene: &std::path::Path,
    (set, flags): (&[String], SceneFlags),
    opts: &RunOptions,
) -> Result<i32> {
    let (mut scene, mut src) = load_scene(scene, set)?;
    flags.apply(&mut scene, &mut src)?;
    rank_weights(&scene, &src, opts.ranks, &format!("--ranks {}", opts.ranks))?;
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
    /// `--interactions`, `--neighbours`, `--overlap` (declared once, in `scene::SceneFlags`).
    #[command(flatten)]
    flags: SceneFlags,
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

/// `hsph run`: a scene, or `--restart` of a checkpoint.
pub(super) fn cmd_run_args(a: RunArgs) -> Result<i32> {
    let RunArgs {
        scene,
        restart,
        max_wall,
        checkpoint_every_minutes,
        out,
        force,
        threads,
        set,
        flags,
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
    check_run_flags(backend, bind, ranks, checkpoint_every_minutes)?;
    if let Some(dir) = &out {
        output_path("--out", dir, Written::RunDir)?;
    }
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
        (_, Some(from)) => cmd_restart(&from, (&set, flags), opts),
        (Some(scene), None) => cmd_run(&scene, (&set, flags), &opts),
        (None, None) => Err(Error::input("SCENE", "give a scene file, or --restart DIR")),
    }
}

/// Flags of `hsph run` that need no scene: the back end and binding this build has, a rank
/// count, a positive checkpoint interval.
pub(super) fn check_run_flags(
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

/// `hsph run --restart`: the checkpoint's scene with the allowed `--set` changes, continued
/// in the checkpoint's run directory.
pub(super) fn cmd_restart(
    from: &std::path::Path,
    (set, flags): (&[String], SceneFlags),
    mut opts: RunOptions,
) -> Result<i32> {
    let ck = crate::checkpoint::locate(from)?;
    // its run directory, or no restart: nothing is read or locked elsewhere
    let dir = crate::checkpoint::run_dir_of(&ck)?;
    let m = crate::checkpoint::manifest(&ck)?;
    let at = ck.join("manifest.json");
    let (original, _) = crate::scene::load_scene_str(&m.scene, &at, "restart", &[])?;
    let (mut scene, mut src) = crate::scene::load_scene_str(&m.scene, &at, &original.name, set)?;
    flags.apply(&mut scene, &mut src)?;
    rank_weights(&scene, &src, opts.ranks, &format!("--ranks {}", opts.ranks))?;
    crate::checkpoint::compat::check(&original, &scene)?;
    restart_not_before_start(&scene, &m).map_err(|e| locate(&src, e))?;
    if scene.dimension != m.dimension {
        return Err(Error::input(
            "--restart",
            "the checkpoint's scene and parts disagree on the dimension",
        ));
    }
    if let Some(why) = driver::nothing_to_run(&dir, &scene, &m) {
        eprintln!("hsph: {why}");
        return Ok(0);
    }
    opts.out = Some(dir);
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
pub(super) fn restart_not_before_start(scene: &Scene, m: &crate::checkpoint::Manifest) -> Result<()> {
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

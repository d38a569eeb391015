//! `hsph jobscript`: its flags and the batch script they make.

use super::*;

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
    /// Memory per node Slurm's `--mem` asks for, e.g. 64G or 500M (k, M, G, T powers of 1000;
    /// Ki, Mi, Gi, Ti of 1024). Default: each rank's peak as `hsph check` estimates it, with
    /// 25 % headroom and 128 MB for MPI, times the ranks per node.
    #[arg(long, value_parser = parse_mem, value_name = "SIZE")]
    mem: Option<f64>,
    /// Run directory (default runs/<scene name>).
    #[arg(long)]
    out: Option<PathBuf>,
    /// Write the script to this file (default: standard output); an existing path must be a
    /// regular file.
    #[arg(long)]
    script: Option<PathBuf>,
}

/// `hsph jobscript`: the sbatch script for a scene, to a file or standard output.
pub(super) fn cmd_jobscript(a: JobArgs) -> Result<i32> {
    use crate::jobscript::{mib, path_text, HSPH_ADVICE, OUT_ADVICE, SCENE_ADVICE};
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
        mem,
        out,
        script,
    } = a;
    // both paths up front: the script written now, the run directory the job will make
    if let Some(path) = &script {
        output_path("--script", path, Written::File)?;
    }
    if let Some(dir) = &out {
        output_path("--out", dir, Written::RunDir)?;
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
    let ranks = nodes.saturating_mul(ranks_per_node);
    let peak = rank_peak(&sc, &src, ranks)?;
    let need = peak.map(|b| crate::jobscript::mem_per_node_mib(b, ranks_per_node));
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
        mem_mib: mem.map(mib).or(need).unwrap_or(0),
        mem_estimate: if mem.is_some() { None } else { peak },
    };
    spec.validate()?;
    if let (Some(m), Some(need), Some(b)) = (mem, need, peak) {
        if mib(m) < need {
            eprintln!(
                "hsph: warning: --mem {} MiB is below the {need} MiB per node the estimate asks for ({ranks_per_node} \
                 rank(s) at about {} each, `hsph check SCENE --ranks {ranks}`); Slurm may stop the job \
                 when a node runs out",
                mib(m),
                crate::memory::human(b),
            );
        }
    }
    rank_weights(
        &sc,
        &src,
        nodes * ranks_per_node,
        &format!("--nodes {nodes} × --ranks-per-node {ranks_per_node}"),
    )?;
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

/// The limits `run` will apply to `ranks` ranks, and the estimated peak (bytes) of one rank's
/// process: under MPI each rank is a process of its own. `None` when the rank count is beyond
/// its bound, which the job spec's own check then refuses, naming its flags.
fn rank_peak(sc: &Scene, src: &SceneSource, ranks: usize) -> Result<Option<f64>> {
    if crate::limits::ranks("--nodes × --ranks-per-node", ranks).is_err() {
        return Ok(None);
    }
    let est = layout_estimate(sc, src, ranks).map_err(|e| match e {
        Error::Input { at, key, message } if key == "--ranks" => Error::Input {
            at,
            key: "--nodes × --ranks-per-node".into(),
            message,
        },
        e => e,
    })?;
    Ok(Some(est.process))
}

/// `--mem`: a size as [`crate::memory::parse_size`] reads it (bytes).
fn parse_mem(s: &str) -> std::result::Result<f64, String> {
    crate::memory::parse_size(s).ok_or_else(|| format!("`{s}` is not a size; e.g. 64G, 500M or 16GiB"))
}

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

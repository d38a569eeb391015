//! `hsph plan` and `hsph model`: node layouts and the performance model, before allocation hours are spent.

use super::*;

/// `hsph plan`: the layout resolved as `hsph run` resolves it (nodes declared, never
/// discovered), then every placement asked for.
pub(super) fn cmd_plan(
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
    rank_weights(&scene, &src, ranks, &format!("--ranks {ranks}"))?;
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

/// `hsph model`'s flags.
#[derive(clap::Args, Debug)]
pub struct ModelArgs {
    /// Scene file (TOML) to predict; optional with --check.
    scene: Option<PathBuf>,
    /// A finished run directory on 1 rank with 1 thread (cost per particle-step).
    #[arg(long, value_name = "DIR")]
    one: PathBuf,
    /// Finished run directories on 2 or more ranks of 1 thread on this machine (contention
    /// and cost per ghost, fitted).
    #[arg(long, value_name = "DIR", num_args = 1.., required = true)]
    many: Vec<PathBuf>,
    /// A finished run of the --one run's scene on 1 rank with 2 threads (the thread
    /// efficiency e(2); beyond 2 threads assumed, pessimistic and optimistic).
    #[arg(long, value_name = "DIR")]
    two: Option<PathBuf>,
    /// Threads per rank to predict (more than 1 needs --two).
    #[arg(long, default_value_t = 1)]
    threads: usize,
    /// Predict with every exchange overlapped with the interior's compute (a rank pays
    /// only the exchange that exceeds it).
    #[arg(long)]
    overlap: bool,
    /// Rank every layout ranks × threads of nodes of C cores (C×1, C/2×2, …, 1×C) and
    /// name the fastest (needs --two).
    #[arg(long, value_name = "C", requires = "scene")]
    layouts: Option<usize>,
    /// Nodes of the --layouts ranking.
    #[arg(long, default_value_t = 1)]
    nodes: usize,
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
}

/// `hsph model`: calibrate on `one`, `many` and `two`, compare with the `check` runs, then
/// predict `scene`: every layout of a node (`--layouts`) or one layout.
pub(super) fn cmd_model(a: ModelArgs) -> Result<i32> {
    let ModelArgs {
        scene,
        one,
        many,
        two,
        threads,
        overlap,
        layouts,
        nodes,
        ranks,
        ranks_per_node,
        cores,
        bandwidth,
        latency,
        check,
        set,
    } = a;
    let (scene, check, set) = (scene.as_deref(), &check[..], &set[..]);
    use crate::model::{predict, Network};
    // the network and the cores are bounded like every other flag (src/limits.rs)
    use crate::limits::{flag_in_range, BANDWIDTH_RANGE, LATENCY_RANGE, MAX_CORES};
    flag_in_range("--bandwidth", bandwidth, BANDWIDTH_RANGE, "GB/s", "12.5")?;
    flag_in_range("--latency", latency, LATENCY_RANGE, "µs", "1.5")?;
    if cores > 0 {
        crate::limits::count("--cores", cores as u64, MAX_CORES)?;
    }
    if scene.is_none() && check.is_empty() {
        return Err(Error::input(
            "SCENE",
            "give a scene to predict, or --check DIR… to compare runs with the model",
        ));
    }
    let here = std::thread::available_parallelism().map_or(1, |n| n.get());
    let cal = calibration(&one, &many, two.as_deref(), here)?;
    let options = |t: usize| options(&cal, t, overlap);
    let net = Network {
        bandwidth: bandwidth * 1e9,
        latency: latency * 1e-6,
    };
    check_runs(&cal, &net, check, here, &options)?;
    let Some(path) = scene else {
        return Ok(0);
    };
    let (scene, src) = load_scene(path, set)?;
    if let Some(c) = layouts {
        crate::limits::count("--layouts", c as u64, crate::limits::MAX_THREADS as u64)?;
        crate::limits::count("--nodes", nodes as u64, crate::limits::MAX_RANKS as u64)?;
        layout_limits(&scene, &src, nodes.saturating_mul(c))?;
        let rows = crate::model::layouts(&cal, &net, &scene, (nodes, c), &PlanPlacement::All.methods())?;
        say(&format!(
            "{}: {} particles, every layout of {nodes} node(s) of {c} cores under every placement; network {bandwidth} GB/s, {latency} µs\n",
            scene.name,
            rows.first().map_or(0, |r| r.particles)
        ));
        say(&crate::model::layouts_text(&rows, c));
        return Ok(0);
    }
    crate::limits::count("--threads", threads as u64, crate::limits::MAX_THREADS as u64)?;
    layout_limits(&scene, &src, ranks)?;
    rank_weights(&scene, &src, ranks, &format!("--ranks {ranks}"))?;
    let per_node = if ranks_per_node == 0 {
        ranks
    } else {
        ranks_per_node
    };
    let topo = Topology::from_ranks_per_node(ranks, per_node)?;
    let rows = crate::plan::plan(&scene, ranks, &topo, &PlanPlacement::All.methods())?;
    let n: u64 = rows[0].owned.iter().sum();
    let cores = if cores == 0 { ranks * threads } else { cores };
    let opts = options(threads)?;
    say(&format!(
        "{}: {n} particles on {ranks} ranks × {threads} thread(s) ({} node(s) of {per_node} ranks), {cores} cores{}; network {bandwidth} GB/s, {latency} µs\n\
         one rank: {:.4} s/step\n\
         | placement | load imbalance | s/step | compute s | network s | speed-up | efficiency |\n|---|---:|---:|---:|---:|---:|---:|\n",
        scene.name,
        topo.nodes(),
        if overlap { ", exchange overlapped" } else { "" },
        cal.per_particle * n as f64
    ));
    for p in predict(&cal, &net, &rows, &topo, cores, &opts) {
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

/// The model's calibration on the runs `one` (1 × 1), `many` and, if given, `two` (1 × 2),
/// printed.
fn calibration(
    one: &std::path::Path,
    many: &[PathBuf],
    two: Option<&std::path::Path>,
    here: usize,
) -> Result<crate::model::Calibration> {
    use crate::model::{calibrate, calibration_text, Measured};
    let one = Measured::read(one)?;
    let many = many
        .iter()
        .map(|d| Measured::read(d))
        .collect::<Result<Vec<_>>>()?;
    let mut cal = calibrate(&one, &many, here)?;
    say(&calibration_text(&cal, &one, &many));
    if let Some(two) = two {
        let two = Measured::read(two)?;
        let e = crate::model::thread_efficiency(&one, &two)?;
        cal.thread_eff = Some(e);
        say(&format!(
            "thread efficiency e(2) = {e:.3} ({}: 1 rank × 2 threads); beyond 2 threads assumed \
             e(t) = e(2)^log2(t) (pessimistic) or e(2) (optimistic)\n",
            two.dir
        ));
    }
    Ok(cal)
}

/// How `t` threads per rank run under `cal` (more than one needs its thread efficiency).
fn options(cal: &crate::model::Calibration, t: usize, overlap: bool) -> Result<crate::model::Options> {
    use crate::model::{Options, Threads};
    let threads = match (t, cal.thread_eff) {
        (1, _) => Threads::ONE,
        (t, Some(e2)) => Threads {
            t,
            e2,
            pessimistic: true,
        },
        (_, None) => {
            return Err(Error::input(
                "--two",
                "a layout with more than one thread per rank needs the thread efficiency: \
                 give a run on 1 rank with 2 threads, e.g. --two r1t2",
            ))
        }
    };
    Ok(Options { threads, overlap })
}

/// The `check` runs' measured steps against the model's, as a table.
fn check_runs(
    cal: &crate::model::Calibration,
    net: &crate::model::Network,
    check: &[PathBuf],
    here: usize,
    options: &dyn Fn(usize) -> Result<crate::model::Options>,
) -> Result<()> {
    use crate::model::{predict, Measured};
    if !check.is_empty() {
        say("| run | ranks | threads | particles | measured s/step | predicted s/step | error |\n|---|---:|---:|---:|---:|---:|---:|\n");
        for dir in check {
            let m = Measured::read(dir)?;
            let (row, topo) = m.plan()?;
            let p = predict(cal, net, &[row], &topo, here, &options(m.threads)?).remove(0);
            // a calibration run is reproduced to round-off: print it as +0.0, not −0.0
            let err = 100.0 * (p.step / m.per_step() - 1.0);
            let err = if err.abs() < 0.05 { 0.0 } else { err };
            say(&format!(
                "| {} | {} | {} | {} | {:.5} | {:.5} | {:+.1} % |\n",
                m.dir,
                m.ranks,
                m.threads,
                m.particles,
                m.per_step(),
                p.step,
                err
            ));
        }
    }
    Ok(())
}

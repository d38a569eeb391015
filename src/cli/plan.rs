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
pub(super) fn cmd_model(
    scene: Option<&std::path::Path>,
    (one, many, two): (&std::path::Path, &[PathBuf], Option<&std::path::Path>),
    (ranks, ranks_per_node, cores, threads): (usize, usize, usize, usize),
    (bandwidth, latency, overlap): (f64, f64, bool),
    (layouts, nodes): (Option<usize>, usize),
    check: &[PathBuf],
    set: &[String],
) -> Result<i32> {
    use crate::model::{calibrate, calibration_text, predict, Measured, Network, Options, Threads};
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
    let options = |t: usize| -> Result<Options> {
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
    };
    let net = Network {
        bandwidth: bandwidth * 1e9,
        latency: latency * 1e-6,
    };
    if !check.is_empty() {
        say("| run | ranks | threads | particles | measured s/step | predicted s/step | error |\n|---|---:|---:|---:|---:|---:|---:|\n");
        for dir in check {
            let m = Measured::read(dir)?;
            let (row, topo) = m.plan()?;
            let p = predict(&cal, &net, &[row], &topo, here, &options(m.threads)?).remove(0);
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
         | placement | imbalance | s/step | compute s | network s | speed-up | efficiency |\n|---|---:|---:|---:|---:|---:|---:|\n",
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

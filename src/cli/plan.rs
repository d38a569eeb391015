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

//! `hsph report`: charts (PNG and SVG) and a markdown summary of a finished run directory, and
//! `hsph report --compare` for several runs side by side.
//!
//! Inputs are the run directory's files: `summary.json` (required: written last, so its absence
//! means the run did not finish), `diagnostics.csv` (required: phase timers, ghost fraction and
//! imbalance per output step) and `traffic.csv` (optional: runs made before traffic accounting
//! have none; the traffic charts are then left out and `report.md` says so).
//!
//! For a run with fluid it draws the flow itself, each flow frame (`output.frames`) and the
//! final state coloured by pressure ([`flow`], reading the states through [`state`]); for a
//! run with a hole probe the impact's pictures ([`impact`]).
//!
//! Charts are drawn by [`charts`] with plotters' pure-Rust bitmap and SVG back ends and DejaVu
//! Sans compiled into the binary, so no system font library is needed.

pub mod charts;
mod flow;
mod impact;
mod load;
mod pressure;
pub mod preview;
mod state;

pub use load::{Diagnostics, Run, TrafficRow};

use crate::error::{Error, Result};
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

/// Traffic phases in the order of `traffic.csv` and `summary.json`.
pub const TRAFFIC_PHASES: [&str; 5] = ["halo", "migration", "balance", "output", "other"];

/// The chart files (stems) `hsph report RUNDIR` writes, each as `.png` and `.svg`.
pub const RUN_CHARTS: [&str; 4] = [
    "traffic_heatmap",
    "traffic_time",
    "ghosts_imbalance",
    "phase_times",
];

/// Entry point of `hsph report`: one run (`compare == false`) or several side by side. Returns
/// the output directory and the files written, in order (the caller prints them).
pub fn command(
    runs: &[PathBuf],
    compare: bool,
    out: Option<&Path>,
    field: &str,
) -> Result<(PathBuf, Vec<PathBuf>)> {
    let (dir, files) = if compare {
        if runs.len() < 2 {
            return Err(Error::input(
                "--compare",
                "needs at least two run directories, e.g. hsph report --compare runs/a runs/b",
            ));
        }
        let loaded = runs.iter().map(|r| Run::load(r)).collect::<Result<Vec<_>>>()?;
        let dir = out
            .map(Path::to_path_buf)
            .unwrap_or_else(|| PathBuf::from("report-compare"));
        let files = write_compare(&loaded, &dir)?;
        (dir, files)
    } else {
        let [run] = runs else {
            return Err(Error::input(
                "RUNDIR",
                format!(
                    "expected one run directory, got {}; use --compare to set several side by side",
                    runs.len()
                ),
            ));
        };
        let run = Run::load(run)?;
        let dir = out
            .map(Path::to_path_buf)
            .unwrap_or_else(|| run.dir.join("report"));
        let mut files = write_run(&run, &dir)?;
        files.extend(impact::charts(&run.dir, &dir, field)?);
        (dir, files)
    };
    Ok((dir, files))
}

fn create_dir(dir: &Path) -> Result<()> {
    std::fs::create_dir_all(dir).map_err(|e| Error::input("--out", format!("{}: {e}", dir.display())))
}

/// True if ranks exchanged bytes with other ranks (a 1-rank run never does).
fn has_inter_rank_traffic(ranks: usize, traffic: &[TrafficRow]) -> bool {
    ranks > 1 && traffic.iter().any(|r| r.src_rank != r.dst_rank && r.bytes > 0)
}

/// Write the charts and `report.md` of one run into `dir`; returns the files written.
pub fn write_run(run: &Run, dir: &Path) -> Result<Vec<PathBuf>> {
    create_dir(dir)?;
    let mut files = Vec::new();
    let mut charts_done = Vec::new();
    // what an engineer looks at first: the wall pressure against the experiment's
    let traces = pressure::traces(&run.dir, &run.summary, dir)?;
    if !traces.is_empty() {
        files.extend(traces);
        charts_done.push((
            "pressure_traces".into(),
            "Wall pressure at each compared sensor: the run (raw, and through its box filter) over the experiment"
                .into(),
        ));
    }
    // and the flow itself: each frame and the final state coloured by pressure
    for (file, stem, caption) in flow::charts(&run.dir, &run.summary, dir)? {
        if file.extension().is_some_and(|e| e == "png") {
            charts_done.push((stem, format!("The flow, {caption}")));
        }
        files.push(file);
    }
    if let Some(traffic) = &run.traffic {
        let nodes = run.rank_nodes();
        // one rank only sends to itself (its periodic and mirror images): nothing to map
        if has_inter_rank_traffic(run.ranks(), traffic) {
            files.extend(charts::traffic_heatmap(dir, run.ranks(), &nodes, traffic)?);
            charts_done.push((
                "traffic_heatmap".into(),
                "Rank-pair traffic (bytes, all phases; lines: node boundaries)".into(),
            ));
        }
        files.extend(charts::traffic_time(dir, &traffic_by_interval(traffic))?);
        charts_done.push((
            "traffic_time".into(),
            "Intra- and inter-node bytes per output interval".into(),
        ));
    }
    files.extend(charts::ghosts_imbalance(dir, &run.diag)?);
    charts_done.push((
        "ghosts_imbalance".into(),
        "Ghost fraction and load imbalance over time".into(),
    ));
    files.extend(charts::phase_times(dir, &run.diag, &run.phase_totals())?);
    charts_done.push((
        "phase_times".into(),
        "Time per phase: per output interval (mean over ranks) and in total (min–max over ranks)".into(),
    ));
    let md = dir.join("report.md");
    let text = run_markdown(run, &charts_done);
    crate::output::write_file(&md, text.as_bytes())?;
    files.push(md);
    Ok(files)
}

/// Per output interval (ending at `step`): (step, intra-node bytes, inter-node bytes).
pub fn traffic_by_interval(rows: &[TrafficRow]) -> Vec<(u64, u64, u64)> {
    let mut m: std::collections::BTreeMap<u64, (u64, u64)> = Default::default();
    for r in rows {
        let e = m.entry(r.step).or_default();
        // saturating: a damaged file's counts must not wrap (each is at most 2⁶², read)
        if r.src_node == r.dst_node {
            e.0 = e.0.saturating_add(r.bytes);
        } else {
            e.1 = e.1.saturating_add(r.bytes);
        }
    }
    m.into_iter().map(|(s, (a, b))| (s, a, b)).collect()
}

/// A fixed-point number without trailing zeros: `0.040000` → `0.04`.
fn trim(t: String) -> String {
    if t.contains('.') {
        t.trim_end_matches('0').trim_end_matches('.').to_string()
    } else {
        t
    }
}

/// `x` as a percentage with two decimals, e.g. `12.62 %`.
pub fn percent(x: f64) -> String {
    format!("{:.2} %", 100.0 * x)
}

/// A byte count in binary units, e.g. `739.5 KiB`.
pub fn human_bytes(b: f64) -> String {
    const UNITS: [&str; 5] = ["B", "KiB", "MiB", "GiB", "TiB"];
    let mut v = b;
    let mut k = 0;
    while v.abs() >= 1024.0 && k + 1 < UNITS.len() {
        v /= 1024.0;
        k += 1;
    }
    if k == 0 {
        format!("{b:.0} B")
    } else {
        format!("{v:.1} {}", UNITS[k])
    }
}

fn opt(x: Option<f64>, f: impl Fn(f64) -> String) -> String {
    x.map(f).unwrap_or_else(|| "—".to_string())
}

/// Total intra- and inter-node bytes of a run: from `summary.json` `traffic`, else summed over
/// `traffic.csv`.
fn traffic_totals(run: &Run) -> Option<(u64, u64)> {
    let t = run.summary.get("traffic");
    if let Some(t) = t {
        if let (Some(a), Some(b)) = (
            t.get("intra_node_bytes").and_then(|v| v.as_u64()),
            t.get("inter_node_bytes").and_then(|v| v.as_u64()),
        ) {
            return Some((a, b));
        }
    }
    run.traffic.as_ref().map(|rows| {
        traffic_by_interval(rows).iter().fold((0u64, 0u64), |acc, r| {
            (acc.0.saturating_add(r.1), acc.1.saturating_add(r.2))
        })
    })
}

fn layout(run: &Run) -> String {
    let nodes = run.nodes();
    let ranks = run.ranks();
    let threads = run.num("threads").map(|t| t as u64);
    match (nodes, threads) {
        (Some(n), Some(t)) if n > 0.0 => {
            format!(
                "{n} node(s) × {} rank(s) × {t} thread(s)",
                ranks.div_ceil(n as usize)
            )
        }
        (_, Some(t)) => format!("{ranks} rank(s) × {t} thread(s)"),
        _ => format!("{ranks} rank(s)"),
    }
}

/// The markdown summary of one run; `charts` lists (file stem, caption) of the charts drawn.
pub fn run_markdown(run: &Run, charts: &[(String, String)]) -> String {
    let s = &run.summary;
    let mut w = String::new();
    let text = |k: &str| s.get(k).and_then(|v| v.as_str()).unwrap_or("—").to_string();
    let _ = writeln!(w, "# hsph run report: {}\n", text("scene"));
    if s.get("complete") == Some(&serde_json::Value::Bool(false)) {
        let _ = writeln!(
            w,
            "**Partial run**: stopped by {} after step {} (t = {} s of {} s); the figures cover \
             the steps run.\n",
            text("stopped_by"),
            s["steps"],
            s["t"],
            s["t_end"]
        );
    }
    let _ = writeln!(w, "Run directory: `{}`\n", run.dir.display());
    summary_table(&mut w, run);
    traffic_per_phase(&mut w, run);
    time_per_phase(&mut w, run);
    charts_section(&mut w, run, charts);
    w
}

/// The run's figures, one row each: layout, speed, balance, communication, traffic.
fn summary_table(w: &mut String, run: &Run) {
    let s = &run.summary;
    let text = |k: &str| s.get(k).and_then(|v| v.as_str()).unwrap_or("—").to_string();
    let _ = writeln!(w, "| quantity | value |\n|---|---|");
    let mut row = |k: &str, v: String| {
        let _ = writeln!(w, "| {k} | {v} |");
    };
    row("scene", text("scene"));
    row("dimension", opt(run.num("dimension"), |x| format!("{x:.0}D")));
    row("particles", opt(run.num("particles"), |x| format!("{x:.0}")));
    row(
        "steps, simulated time",
        format!(
            "{}, {} s",
            opt(run.num("steps"), |x| format!("{x:.0}")),
            opt(run.num("t"), |x| trim(format!("{x:.6}")))
        ),
    );
    row("ranks", format!("{}", run.ranks()));
    row("nodes", opt(run.nodes(), |x| format!("{x:.0}")));
    row("threads per rank", opt(run.num("threads"), |x| format!("{x:.0}")));
    row("layout", layout(run));
    row("back end", text("backend"));
    if let Some(p) = s.get("placement").and_then(|v| v.as_str()) {
        row("placement", p.to_string());
    }
    if let Some(d) = s.get("decomposition").and_then(|v| v.as_array()) {
        let f: Vec<String> = d.iter().map(|x| x.to_string()).collect();
        row("decomposition", f.join(" × "));
    }
    row("wall time", opt(run.num("wall_s"), |x| format!("{x:.3} s")));
    row(
        "particle-steps/s",
        opt(run.num("particle_steps_per_s"), |x| format!("{x:.3e}")),
    );
    row(
        "ghost fraction (remote ghosts / particles)",
        opt(run.num("ghost_fraction"), percent),
    );
    row(
        "load imbalance (final, max/mean of the balanced load)",
        opt(run.num("imbalance"), |x| format!("{x:.4}")),
    );
    row(
        "count imbalance (final, max/mean of the particles)",
        opt(run.num("count_imbalance"), |x| format!("{x:.4}")),
    );
    row(
        "communication fraction (halo + migration / wall)",
        opt(run.num("communication_fraction"), percent),
    );
    row(
        "balance fraction (balance / wall)",
        opt(run.num("balance_fraction"), percent),
    );
    row("rebalances", opt(run.num("rebalances"), |x| format!("{x:.0}")));
    match traffic_totals(run) {
        Some((intra, inter)) => {
            let total = intra.saturating_add(inter);
            let all = total.max(1) as f64;
            row(
                "traffic, total",
                format!("{total} B ({})", human_bytes(total as f64)),
            );
            row(
                "traffic, intra-node",
                format!(
                    "{intra} B ({}, {})",
                    human_bytes(intra as f64),
                    percent(intra as f64 / all)
                ),
            );
            row(
                "traffic, inter-node",
                format!(
                    "{inter} B ({}, {})",
                    human_bytes(inter as f64),
                    percent(inter as f64 / all)
                ),
            );
            if let Some(c) = s.get("traffic").and_then(|t| t.get("estimated_cost")) {
                let f = |k: &str| c.get(k).and_then(|v| v.as_f64()).unwrap_or(0.0);
                row(
                    "shared memory saved (estimate)",
                    format!(
                        "{} of the traffic cost, with relative costs per byte {} inside and {} across nodes",
                        percent(f("saved_fraction")),
                        f("intra_node_cost_per_byte"),
                        f("inter_node_cost_per_byte")
                    ),
                );
            }
        }
        None => row(
            "traffic",
            "not recorded (no traffic.csv, no `traffic` in summary.json)".into(),
        ),
    }
}

/// Bytes and messages per phase of the step, intra- and inter-node.
fn traffic_per_phase(w: &mut String, run: &Run) {
    let s = &run.summary;
    if let Some(phases) = s
        .get("traffic")
        .and_then(|t| t.get("phases"))
        .and_then(|p| p.as_object())
    {
        let _ = writeln!(w, "\n## Traffic per phase\n");
        let _ = writeln!(
            w,
            "| phase | intra-node bytes | inter-node bytes | messages |\n|---|---:|---:|---:|"
        );
        let mut names: Vec<&String> = phases.keys().collect();
        names.sort_by_key(|n| TRAFFIC_PHASES.iter().position(|p| p == n).unwrap_or(usize::MAX));
        for name in names {
            let p = &phases[name];
            let g = |k: &str| opt(p.get(k).and_then(|v| v.as_f64()), |x| format!("{x:.0}"));
            let _ = writeln!(
                w,
                "| {name} | {} | {} | {} |",
                g("intra_node_bytes"),
                g("inter_node_bytes"),
                g("messages")
            );
        }
    }
}

/// Seconds per phase over ranks.
fn time_per_phase(w: &mut String, run: &Run) {
    let totals = run.phase_totals();
    if !totals.is_empty() {
        let _ = writeln!(w, "\n## Time per phase (over ranks)\n");
        let _ = writeln!(
            w,
            "| phase | min (s) | mean (s) | max (s) |\n|---|---:|---:|---:|"
        );
        for (p, [lo, mean, hi]) in &totals {
            let _ = writeln!(w, "| {p} | {lo:.4} | {mean:.4} | {hi:.4} |");
        }
    }
}

/// The charts, and why a missing one is missing.
fn charts_section(w: &mut String, run: &Run, charts: &[(String, String)]) {
    let _ = writeln!(w, "\n## Charts\n");
    if run.traffic.is_none() {
        let _ = writeln!(
            w,
            "No `traffic.csv` in the run directory (a run from before traffic accounting): the \
             traffic heat map and the intra/inter-node chart are left out.\n"
        );
    } else if !charts.iter().any(|(stem, _)| stem == "traffic_heatmap") {
        let _ = writeln!(
            w,
            "No rank-pair heat map: this run's {} rank(s) exchanged no bytes with another rank (a \
             rank's periodic and mirror images are sent to itself).\n",
            run.ranks()
        );
    }
    for (stem, caption) in charts {
        let _ = writeln!(
            w,
            "### {caption}\n\n![{caption}]({stem}.png)\n\n[{stem}.svg]({stem}.svg)\n"
        );
    }
}

/// One row of the comparison table.
#[derive(Debug, Clone, PartialEq)]
pub struct CompareRow {
    /// The run's label (its directory as given).
    pub label: String,
    /// Scene name.
    pub scene: String,
    /// Layout, e.g. `2 node(s) × 2 rank(s) × 2 thread(s)`.
    pub layout: String,
    /// Placement, when the run recorded one.
    pub placement: String,
    /// Particle-steps per second.
    pub rate: Option<f64>,
    /// Intra- and inter-node bytes.
    pub traffic: Option<(u64, u64)>,
    /// Ghost fraction.
    pub ghost_fraction: Option<f64>,
    /// Final load imbalance.
    pub imbalance: Option<f64>,
    /// Communication fraction.
    pub comm_fraction: Option<f64>,
}

/// The comparison rows of `runs`, in order.
pub fn compare_rows(runs: &[Run]) -> Vec<CompareRow> {
    runs.iter()
        .map(|r| CompareRow {
            label: r.label.clone(),
            scene: r
                .summary
                .get("scene")
                .and_then(|v| v.as_str())
                .unwrap_or("—")
                .to_string(),
            layout: layout(r),
            placement: r
                .summary
                .get("placement")
                .and_then(|v| v.as_str())
                .unwrap_or("—")
                .to_string(),
            rate: r.num("particle_steps_per_s"),
            traffic: traffic_totals(r),
            ghost_fraction: r.num("ghost_fraction"),
            imbalance: r.num("imbalance"),
            comm_fraction: r.num("communication_fraction"),
        })
        .collect()
}

/// The markdown of `hsph report --compare`.
pub fn compare_markdown(rows: &[CompareRow]) -> String {
    let mut w = String::new();
    let _ = writeln!(w, "# hsph run comparison\n");
    let _ = writeln!(
        w,
        "| # | run | scene | layout | placement | particle-steps/s | intra-node bytes | inter-node bytes | inter-node share | ghost fraction | load imbalance | communication fraction |"
    );
    let _ = writeln!(w, "|---:|---|---|---|---|---:|---:|---:|---:|---:|---:|---:|");
    for (i, r) in rows.iter().enumerate() {
        let (intra, inter, share) = match r.traffic {
            Some((a, b)) => (
                a.to_string(),
                b.to_string(),
                percent(b as f64 / a.saturating_add(b).max(1) as f64),
            ),
            None => ("—".into(), "—".into(), "—".into()),
        };
        let _ = writeln!(
            w,
            "| {} | `{}` | {} | {} | {} | {} | {intra} | {inter} | {share} | {} | {} | {} |",
            i + 1,
            r.label,
            r.scene,
            r.layout,
            r.placement,
            opt(r.rate, |x| format!("{x:.3e}")),
            opt(r.ghost_fraction, percent),
            opt(r.imbalance, |x| format!("{x:.4}")),
            opt(r.comm_fraction, percent)
        );
    }
    let _ = writeln!(
        w,
        "\n![particle-steps/s, inter-node bytes, ghost fraction and communication fraction per run](compare.png)\n\n[compare.svg](compare.svg)"
    );
    w
}

/// Write the comparison of `runs` into `dir`: `compare.md` and `compare.{png,svg}`.
pub fn write_compare(runs: &[Run], dir: &Path) -> Result<Vec<PathBuf>> {
    create_dir(dir)?;
    let rows = compare_rows(runs);
    let mut files = charts::compare(dir, &rows)?;
    let md = dir.join("compare.md");
    crate::output::write_file(&md, compare_markdown(&rows).as_bytes())?;
    files.push(md);
    Ok(files)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn report_formats() {
        assert_eq!(percent(0.1262), "12.62 %");
        assert_eq!(human_bytes(512.0), "512 B");
        assert_eq!(human_bytes(757280.0), "739.5 KiB");
        assert_eq!(human_bytes(3.0 * 1024.0 * 1024.0), "3.0 MiB");
    }

    #[test]
    fn report_traffic_by_interval_splits_by_node() {
        let row = |step, src_node, dst_node, bytes| TrafficRow {
            step,
            phase: "halo".into(),
            src_rank: 0,
            dst_rank: 1,
            src_node,
            dst_node,
            bytes,
            messages: 1,
        };
        let rows = [
            row(10, 0, 0, 5),
            row(10, 0, 1, 7),
            row(20, 1, 1, 3),
            row(10, 1, 0, 1),
        ];
        assert_eq!(traffic_by_interval(&rows), vec![(10, 5, 8), (20, 3, 0)]);
    }

    /// 96 ranks on 4 nodes given round-robin (not consecutive): the heat map orders ranks by
    /// node; 1024 ranks are binned. Both render to valid files.
    #[test]
    fn report_heatmap_many_ranks() {
        let dir = std::env::temp_dir().join(format!("hsph-report-heatmap-{}", std::process::id()));
        for (p, per_node) in [(96usize, 24usize), (1024, 256)] {
            let node = |r: usize| if p == 96 { r % 4 } else { r / per_node };
            let mut rows = Vec::new();
            for s in 0..p {
                for d in [s.wrapping_sub(1), s + 1, s + 4] {
                    if d < p {
                        rows.push(TrafficRow {
                            step: 10,
                            phase: "halo".into(),
                            src_rank: s,
                            dst_rank: d,
                            src_node: node(s),
                            dst_node: node(d),
                            bytes: 1000 + 10 * (s as u64 % 7),
                            messages: 1,
                        });
                    }
                }
            }
            let nodes: Vec<usize> = (0..p).map(node).collect();
            let out = dir.join(p.to_string());
            std::fs::create_dir_all(&out).unwrap();
            let files = charts::traffic_heatmap(&out, p, &nodes, &rows).unwrap();
            for f in files {
                let b = std::fs::read(&f).unwrap();
                assert!(b.len() > 1000, "{}", f.display());
            }
        }
        let _ = std::fs::remove_dir_all(&dir);
    }
}

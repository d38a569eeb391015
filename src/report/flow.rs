//! The flow pictures of `hsph report`, for a run whose scene has fluid: each flow frame the
//! run wrote (`output.frames`, [`crate::driver::frames`]) and its final state, particles
//! coloured by pressure on one colour scale for all of them (fluid and solids; walls grey). A
//! 2D run shows every particle; a 3D run the slab one spacing thick about the domain's middle
//! across its second axis (y), in x and z.

use super::charts::{both, register_font, viridis, Res};
use super::preview::{legend, Plane};
use super::state::{read_state, scale, State};
use crate::error::Result;
use crate::scene::{load_scene, Scene};
use plotters::prelude::*;
use std::path::{Path, PathBuf};

/// One state to draw: its picture's stem, what the caption says of its time, and its files.
struct Frame {
    stem: String,
    when: String,
    pieces: Vec<PathBuf>,
}

/// The run's frames in order, then its final state; a frame whose index or pieces are
/// missing or unreadable (a run stopped while writing it) is left out with a warning.
fn frames(run: &Path, summary: &serde_json::Value) -> Vec<Frame> {
    let mut out = Vec::new();
    let dir = run.join("frames");
    let mut index: Vec<PathBuf> = std::fs::read_dir(&dir)
        .map(|d| d.filter_map(|e| e.ok().map(|e| e.path())).collect())
        .unwrap_or_default();
    index.retain(|p| p.extension().is_some_and(|e| e == "json"));
    index.sort();
    for path in index {
        let stem = path.file_stem().unwrap_or_default().to_string_lossy().to_string();
        let entry: Option<serde_json::Value> = crate::limits::read_text(&path, "frames")
            .ok()
            .and_then(|t| serde_json::from_str(&t).ok());
        let fields = entry.as_ref().and_then(|e| {
            Some((
                e["requested_t"].as_f64()?,
                e["t"].as_f64()?,
                e["step"].as_u64()?,
                e["pieces"].as_u64()?,
            ))
        });
        let Some((asked, t, step, pieces)) = fields else {
            eprintln!(
                "hsph: warning: {}: not a frame index; frame left out",
                path.display()
            );
            continue;
        };
        let pieces: Vec<PathBuf> = (0..pieces)
            .map(|r| dir.join(&stem).join(format!("rank_{r:04}.csv")))
            .collect();
        if let Some(lost) = pieces.iter().find(|p| !p.is_file()) {
            eprintln!("hsph: warning: {} is missing; frame left out", lost.display());
            continue;
        }
        out.push(Frame {
            stem: format!("flow_{}", stem.trim_start_matches("frame_")),
            when: format!("t = {t:.4} s (asked {asked} s), step {step}"),
            pieces,
        });
    }
    let gathered = run.join("final.csv");
    let pieces = if gathered.is_file() {
        vec![gathered]
    } else {
        let mut p: Vec<PathBuf> = std::fs::read_dir(run.join("final"))
            .map(|d| d.filter_map(|e| e.ok().map(|e| e.path())).collect())
            .unwrap_or_default();
        p.retain(|f| f.extension().is_some_and(|e| e == "csv"));
        p.sort();
        p
    };
    if !pieces.is_empty() {
        let t = summary["t"].as_f64().unwrap_or(f64::NAN);
        out.push(Frame {
            stem: "flow_final".to_string(),
            when: format!("final state, t = {t:.4} s"),
            pieces,
        });
    }
    out
}

/// The flow pictures (`flow_KK` per frame, `flow_final`) of the run in `run` into `out`, with
/// their captions for `report.md`; none for a run without fluid or without written states.
pub fn charts(run: &Path, summary: &serde_json::Value, out: &Path) -> Result<Vec<(PathBuf, String, String)>> {
    let scene_path = run.join("scene.toml");
    if !scene_path.is_file() {
        return Ok(Vec::new());
    }
    let (scene, _) = load_scene(&scene_path, &[])?;
    if scene.fluids.is_empty() {
        return Ok(Vec::new());
    }
    crate::with_dim!(scene.dimension, D => draw_all::<D>(&scene, &frames(run, summary), out))
}

fn draw_all<const D: usize>(
    scene: &Scene,
    frames: &[Frame],
    out: &Path,
) -> Result<Vec<(PathBuf, String, String)>> {
    let states = frames
        .iter()
        .map(|f| read_state::<D>(&f.pieces, "p"))
        .collect::<Result<Vec<_>>>()?;
    // one scale for every picture: the fluid's and solids' pressures of all of them
    let all: Vec<f64> = states
        .iter()
        .flat_map(|s| {
            (0..s.p.n_owned)
                .filter(|&i| !s.p.kind[i].is_wall())
                .map(|i| s.values[i])
        })
        .collect();
    let range = scale(&all, (0.01, 0.99));
    let mut files = Vec::new();
    for (f, s) in frames.iter().zip(&states) {
        let caption = format!("{}: {}", scene.name, f.when);
        for file in draw(out, scene, &f.stem, &caption, s, range)? {
            files.push((file, f.stem.clone(), caption.clone()));
        }
    }
    Ok(files)
}

/// One picture of `s`, coloured by pressure over `range` (Pa).
fn draw<const D: usize>(
    out: &Path,
    scene: &Scene,
    stem: &str,
    caption: &str,
    s: &State<D>,
    range: (f64, f64),
) -> Result<Vec<PathBuf>> {
    let (lo, hi, dx) = (&scene.domain.min, &scene.domain.max, scene.discretisation.dx);
    // 2D: x, y; 3D: x, z about the middle of y
    let (u, v) = if D == 2 { (0, 1) } else { (0, 2) };
    let mid = 0.5 * (lo[1] + hi[1]);
    let shown: Vec<usize> = (0..s.p.n_owned)
        .filter(|&i| D == 2 || (s.p.x[i][1] - mid).abs() < 0.5 * dx)
        .collect();
    let plane = Plane::of(scene, (u, v));
    let radius = plane.radius;
    let kpa = |p: f64| format!("{:.3} kPa", p * 1e-3);
    let title = match D {
        2 => format!("{caption}; pressure {} to {}", kpa(range.0), kpa(range.1)),
        _ => format!(
            "{caption}; y = {mid:.4} m; pressure {} to {}",
            kpa(range.0),
            kpa(range.1)
        ),
    };
    let colour = |x: f64| viridis(((x - range.0) / (range.1 - range.0)).clamp(0.0, 1.0));
    both!(out, stem, plane.size, |root| {
        let mut ch = plane.chart(root, &title)?;
        let grey = RGBColor(170, 170, 170);
        ch.draw_series(
            shown
                .iter()
                .filter(|&&i| s.p.kind[i].is_wall())
                .map(|&i| Circle::new((s.p.x[i][u], s.p.x[i][v]), radius, grey.filled())),
        )?
        .label("wall")
        .legend(move |(x, y)| Circle::new((x, y), 4, grey.filled()));
        ch.draw_series(shown.iter().filter(|&&i| !s.p.kind[i].is_wall()).map(|&i| {
            let c = match s.values[i].is_finite() {
                true => colour(s.values[i]),
                false => RED,
            };
            Circle::new((s.p.x[i][u], s.p.x[i][v]), radius, c.filled())
        }))?;
        // the scale's ends as legend entries
        for (label, x) in [("low", range.0), ("high", range.1)] {
            let c = colour(x);
            ch.draw_series(std::iter::empty::<Circle<(f64, f64), i32>>())?
                .label(format!("{label}: {}", kpa(x)))
                .legend(move |(x, y)| Circle::new((x, y), 4, c.filled()));
        }
        legend(&mut ch)
    })
}

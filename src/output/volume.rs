//! How many bytes a run will write (`hsph check`), and the free space of the file system it
//! writes to, so that a run that would fill a disk is seen before it starts.
//!
//! The estimate is an order of magnitude, from counts known before the run: the steps (from
//! dt₀), the output and probe clocks, the particles, the fields written and the checkpoints
//! kept. It does not follow the particles (a snapshot of a run that removes particles is
//! smaller than estimated).

use crate::scene::{Probe, Scene, SnapshotFormat};
use std::path::Path;

/// Bytes of text a CSV value takes, on average (shortest round-trip floats and a comma).
const CSV_VALUE: f64 = 22.0;

/// Bytes a run is expected to write, by kind.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct Volume {
    /// Snapshots (every output step).
    pub snapshots: f64,
    /// Probe series.
    pub probes: f64,
    /// `timeseries.csv`, `diagnostics.csv`, `traffic.csv`.
    pub series: f64,
    /// `final.csv`.
    pub final_csv: f64,
    /// Checkpoints kept on disk at once.
    pub checkpoints: f64,
}

impl Volume {
    /// All of it (bytes).
    pub fn total(&self) -> f64 {
        self.snapshots + self.probes + self.series + self.final_csv + self.checkpoints
    }
}

/// Rows a clock of `interval` seconds writes over `steps` steps to `t_end` (s): one per
/// multiple of the interval, at most one per step (`interval` ≤ 0: every step).
pub fn rows(interval: f64, t_end: f64, steps: f64) -> f64 {
    if interval > 0.0 {
        (t_end / interval).min(steps) + 1.0
    } else {
        steps + 1.0
    }
}

/// The columns of a probe's file, `t` included: the fields of its header
/// ([`Probe::header`]), so a kind's count is stated once.
pub fn probe_columns(p: &Probe, dim: usize) -> usize {
    1 + p.columns(dim).len()
}

/// The estimate for `scene` in `D` dimensions with `n` particles, `steps` steps,
/// `record_bytes` per particle in a checkpoint and `output_interval` the resolved output
/// interval (s).
pub fn estimate(
    scene: &Scene,
    dim: usize,
    n: f64,
    steps: f64,
    record_bytes: f64,
    output_interval: f64,
) -> Volume {
    let t_end = scene.time.t_end;
    let outputs = rows(output_interval, t_end, steps);
    let d = dim as f64;
    // vectors have D components, every other field one; binary, base64-encoded in VTK
    let per_particle = 8.0 * (d + 1.0 + scene.output.fields.len() as f64 * d);
    let snapshots = match scene.output.format {
        SnapshotFormat::None => 0.0,
        SnapshotFormat::Vtk => outputs * n * per_particle * 4.0 / 3.0,
        _ => outputs * n * per_particle,
    };
    let probes = scene
        .probes
        .iter()
        .map(|p| {
            let columns = probe_columns(p, dim) as f64;
            let interval = p.interval().unwrap_or(output_interval);
            // a windowed or spaced pressure probe's every-step series (t and p)
            let raw = if p.raw_series() { steps * 2.0 } else { 0.0 };
            (rows(interval, t_end, steps) * columns + raw) * CSV_VALUE
        })
        // from +0 (an empty f64 sum is −0, printed "-0.0 B")
        .fold(0.0, |a, b| a + b);
    let series = outputs * 60.0 * CSV_VALUE;
    let final_csv = n * (4.0 * d + 12.0) * CSV_VALUE;
    let checkpoints = if scene.checkpoint.scheduled() {
        scene.checkpoint.keep.max(1) as f64 * n * record_bytes
    } else {
        n * record_bytes
    };
    Volume {
        snapshots,
        probes,
        series,
        final_csv,
        checkpoints,
    }
}

/// Bytes free to an unprivileged user on the file system holding `dir` (POSIX `df -Pk`), or
/// `None` when it cannot be told.
pub fn free_space(dir: &Path) -> Option<f64> {
    let out = std::process::Command::new("df")
        .arg("-Pk")
        .arg(dir)
        .output()
        .ok()?;
    if !out.status.success() {
        return None;
    }
    let text = String::from_utf8_lossy(&out.stdout);
    let line = text.lines().nth(1)?;
    let kib: f64 = line.split_whitespace().nth(3)?.parse().ok()?;
    Some(kib * 1024.0)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_clock_writes_at_most_one_row_per_step() {
        assert_eq!(rows(0.1, 1.0, 1e6), 11.0);
        assert_eq!(rows(1e-30, 1.0, 1000.0), 1001.0);
        assert_eq!(rows(0.0, 1.0, 50.0), 51.0);
    }

    #[test]
    fn the_free_space_of_the_working_directory_is_known() {
        let free = free_space(Path::new(".")).expect("df -Pk .");
        assert!(free > 0.0 && free.is_finite());
    }

    /// For every probe kind in 2D and 3D, the estimate counts the columns its file's header
    /// names (a pressure probe was once estimated at 1 + 2D columns; it writes `t,p`).
    #[test]
    fn the_estimate_counts_every_probe_kinds_header_columns() {
        for d in [2, 3] {
            for p in &crate::scene::one_of_each(d) {
                let header = p.header(d).split(',').count();
                assert_eq!(probe_columns(p, d), header, "{} in {d}D", p.name());
            }
        }
    }

    /// `output.format = "none"` writes no snapshot, and a scene without probes no probe
    /// file: both are +0 bytes (not the −0 of an empty float sum, printed "-0.0 B").
    #[test]
    fn no_snapshots_and_no_probes_are_nothing_written() {
        let text = include_str!("../../inputs/poiseuille_2d.toml");
        let sets = ["output.format=\"none\"".to_string(), "probe=[]".to_string()];
        let path = Path::new("poiseuille_2d.toml");
        let (s, _) = crate::scene::load_scene_str(text, path, "scene", &sets).unwrap();
        let v = estimate(&s, 2, 1000.0, 100.0, 100.0, 0.01);
        assert_eq!(v.snapshots.to_bits(), 0.0f64.to_bits());
        assert_eq!(v.probes.to_bits(), 0.0f64.to_bits());
        assert!(v.series > 0.0 && v.final_csv > 0.0);
    }
}

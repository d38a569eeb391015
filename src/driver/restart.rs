//! A restart as a transaction (README, "Restart"): everything it will cut or write is checked
//! first — the checkpoint, its run directory, every series to be cut back, every output path —
//! and only then is anything changed. A refused restart changes no byte, and so does a restart
//! with nothing left to run.

use crate::checkpoint::Manifest;
use crate::error::{Error, Result};
use crate::output;
use crate::scene::Scene;
use std::path::{Path, PathBuf};

/// Every series of the checkpoint's run state (`series`: file → length at the checkpoint),
/// checked without changing any: a series path of a run directory, a regular file, at least
/// as long as it was at the checkpoint. Returns each path with the length to cut it back to.
pub fn check_series(dir: &Path, series: &serde_json::Value) -> Result<Vec<(PathBuf, u64)>> {
    let Some(map) = series.as_object() else {
        return Err(Error::input(
            "--restart",
            "the checkpoint's run state lacks the series lengths",
        ));
    };
    let bad = |file: &str, why: &str| {
        Error::input(
            "--restart",
            format!("the checkpoint's run state names the series {file:?}, which {why}"),
        )
    };
    let mut cuts = Vec::with_capacity(map.len());
    for (file, len) in map {
        if !output::is_series_path(file) {
            return Err(bad(file, "is not a series file of a run directory"));
        }
        let path = dir.join(file);
        let meta = std::fs::symlink_metadata(&path).map_err(|e| Error::io(&path, e))?;
        let len = len.as_u64().ok_or_else(|| bad(file, "has no length"))?;
        if !meta.is_file() {
            return Err(bad(file, "is not a regular file"));
        }
        if len > meta.len() {
            return Err(bad(
                file,
                &format!("is {} bytes, shorter than the checkpoint's {len}", meta.len()),
            ));
        }
        cuts.push((path, len));
    }
    Ok(cuts)
}

/// Cut every series file of a restarted run back to its length at the checkpoint (rows
/// written after it, before the run stopped, would otherwise be there twice) — all of them
/// checked before the first is cut.
pub(super) fn truncate_series(dir: &Path, series: &serde_json::Value) -> Result<()> {
    for (path, len) in check_series(dir, series)? {
        let f = std::fs::OpenOptions::new()
            .write(true)
            .open(&path)
            .map_err(|e| Error::io(&path, e))?;
        f.set_len(len).map_err(|e| Error::io(&path, e))?;
    }
    Ok(())
}

/// Everything a restart of `m` into its run directory `dir` with `scene` will cut or write,
/// checked before anything changes: the series to cut back, and every output path of the run
/// (a FIFO named `final.csv`, a directory named `summary.json`: refused now, not after the
/// segment has run).
pub fn check_restart(dir: &Path, scene: &Scene, m: &Manifest) -> Result<()> {
    check_series(dir, &m.run["series"])?;
    let probes: Vec<String> = scene.probes.iter().map(|p| p.name().to_string()).collect();
    output::names::check_targets(dir, &probes)
}

/// `Some(why)` if restarting `m` with `scene` has nothing left to run: the checkpoint is at the
/// scene's end (`time.t_end` or `time.max_steps`) and the run directory `dir` holds the
/// complete summary of that step. Such a restart changes nothing. (A run that ended there but
/// was stopped before its summary, or by a signal at its last step, is finished instead: its
/// series are cut back to the checkpoint and its last output written again.)
pub fn nothing_to_run(dir: &Path, scene: &Scene, m: &Manifest) -> Option<String> {
    if !scene.time.ended(m.step, m.t) {
        return None;
    }
    let path = dir.join("summary.json");
    let text = crate::limits::read_text(&path, "--restart").ok()?;
    let summary: serde_json::Value = serde_json::from_str(&text).ok()?;
    let complete = summary["complete"].as_bool() == Some(true) && summary["steps"].as_u64() == Some(m.step);
    let by_steps = scene.time.max_steps > 0 && m.step >= scene.time.max_steps;
    let raise = if by_steps {
        format!("--set time.max_steps={}", 2 * m.step.max(1))
    } else {
        format!("--set time.t_end={}", short(2.0 * scene.time.t_end.max(m.t)))
    };
    complete.then(|| {
        format!(
            "{} is complete at step {} (t = {:.6e} s): nothing left to run, nothing changed; to \
             continue it, raise its end, e.g. {raise}",
            dir.display(),
            m.step,
            m.t,
        )
    })
}

/// `x` with six decimals and no trailing zeros, for a `--set` the user can paste.
fn short(x: f64) -> String {
    let s = format!("{x:.6}");
    s.trim_end_matches('0').trim_end_matches('.').to_string()
}

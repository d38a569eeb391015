//! The names a run writes in its directory, and nothing else: what `--force` removes (a user's
//! own files stay, in any folder), and the paths a restart checks before it changes anything
//! (README, "Output"). A file is a run's by its name alone: a name of [`super::RUN_FILES`] at
//! the top, a probe's series under `probes/`, a snapshot's index or piece under `snapshots/`, a
//! checkpoint's manifest or part under `checkpoints/step-NNNNNNNNNN/`, a rank's final state
//! under `final/`, a flow frame's index under `frames/` and its pieces under
//! `frames/frame_KK/`, a chart or page of `hsph report` under `report/`; and the `.tmp` of any
//! of them (an atomic write that was cut short).

use super::{LOCK_FILE, RUN_FILES, RUN_FOLDERS};
use crate::error::{Error, Result};
use std::fs;
use std::io;
use std::path::Path;

/// The charts `hsph report` writes into `report/` (each as `.png` and `.svg`).
pub const REPORT_STEMS: &[&str] = &[
    "traffic_heatmap",
    "traffic_time",
    "ghosts_imbalance",
    "phase_times",
    "compare",
    "impact_top",
    "impact_side",
    "pressure_traces",
    "flow_final",
];
/// The pages `hsph report` writes into `report/`.
const REPORT_PAGES: &[&str] = &["report.md", "compare.md"];

/// `name` without a trailing `.tmp` (a cut-short atomic write of `name`).
fn untemp(name: &str) -> &str {
    name.strip_suffix(".tmp").unwrap_or(name)
}

/// True if `name` is `prefix` + at least `digits` decimal digits + `suffix`.
fn numbered(name: &str, prefix: &str, digits: usize, suffix: &str) -> bool {
    name.strip_prefix(prefix)
        .and_then(|r| r.strip_suffix(suffix))
        .is_some_and(|d| d.len() >= digits && d.len() <= 20 && d.bytes().all(|b| b.is_ascii_digit()))
}

/// Whether `name`, a file directly in the run directory, is one a run writes.
pub fn is_top_file(name: &str) -> bool {
    RUN_FILES.contains(&untemp(name))
}

/// Whether `name`, a file in the run's folder `folder` (one of [`RUN_FOLDERS`]) or in one of
/// its numbered subfolders (`sub`: `snapshot_NNNNN`, `step-NNNNNNNNNN`), is one a run writes.
/// `probes`: the probe names of the runs that wrote the directory.
pub fn is_folder_file(folder: &str, sub: Option<&str>, name: &str, probes: &[String]) -> bool {
    let name = untemp(name);
    match (folder, sub) {
        ("probes", None) => probes.iter().any(|p| {
            name == format!("{p}.csv") || name == format!("{p}.raw.csv") || name == format!("{p}.nc")
        }),
        ("snapshots", None) => {
            name == "series.pvd" || name == "series.json" || numbered(name, "snapshot_", 5, ".pvtu")
        }
        ("snapshots", Some(_)) => numbered(name, "rank_", 4, ".vtu") || numbered(name, "rank_", 4, ".nc"),
        ("checkpoints", Some(_)) => {
            // a part or the manifest, or their `.tmp` (`part-NNNNN.tmp`, `manifest.tmp`)
            ["manifest.json", "manifest"].contains(&name)
                || numbered(name, "part-", 5, ".bin")
                || numbered(name, "part-", 5, "")
        }
        ("final", None) => numbered(name, "rank_", 4, ".csv"),
        ("frames", None) => numbered(name, "frame_", 2, ".json"),
        ("frames", Some(_)) => numbered(name, "rank_", 4, ".csv"),
        ("report", None) => {
            REPORT_PAGES.contains(&name)
                || [".png", ".svg"].iter().any(|ext| {
                    REPORT_STEMS.iter().any(|s| name == format!("{s}{ext}"))
                        || numbered(name, "flow_", 2, ext)
                })
        }
        _ => false,
    }
}

/// Whether `name`, a folder inside the run's folder `folder`, is one a run makes.
pub fn is_subfolder(folder: &str, name: &str) -> bool {
    match folder {
        "snapshots" => numbered(name, "snapshot_", 5, ""),
        "checkpoints" => numbered(name, "step-", 10, ""),
        "frames" => numbered(name, "frame_", 2, ""),
        _ => false,
    }
}

/// The probe names of the run that wrote `dir`, read from its resolved `scene.toml` (empty if
/// it has none or cannot be read: its probe files then stay).
pub fn probe_names(dir: &Path) -> Vec<String> {
    let Ok(text) = crate::limits::read_text(&dir.join("scene.toml"), "--force") else {
        return Vec::new();
    };
    let Ok(value) = text.parse::<toml::Table>() else {
        return Vec::new();
    };
    value
        .get("probe")
        .and_then(|p| p.as_array())
        .map(|a| {
            a.iter()
                .filter_map(|p| p.get("name").and_then(|n| n.as_str()))
                .filter(|n| super::safe_name(n) == *n)
                .map(str::to_string)
                .collect()
        })
        .unwrap_or_default()
}

/// Remove `path` if it is there (a missing file is not an error).
fn remove(path: &Path, dir: bool) -> io::Result<()> {
    let r = if dir {
        fs::remove_dir(path)
    } else {
        fs::remove_file(path)
    };
    match r {
        Err(e) if e.kind() != io::ErrorKind::NotFound => Err(e),
        _ => Ok(()),
    }
}

/// Remove a folder if nothing (of the user's) is left in it.
fn remove_if_empty(path: &Path) -> io::Result<()> {
    if fs::read_dir(path).is_ok_and(|mut d| d.next().is_none()) {
        remove(path, true)?;
    }
    Ok(())
}

/// Remove every file of `folder` (a path) that a run wrote there, by [`is_folder_file`], and
/// then the folder itself if nothing else is in it.
fn clear_folder(path: &Path, folder: &str, sub: Option<&str>, probes: &[String]) -> io::Result<()> {
    let Ok(rd) = fs::read_dir(path) else {
        return Ok(());
    };
    for e in rd.flatten() {
        let name = e.file_name().to_string_lossy().into_owned();
        let ty = e.file_type()?;
        if ty.is_dir() && sub.is_none() && is_subfolder(folder, &name) {
            clear_folder(&e.path(), folder, Some(&name), probes)?;
        } else if !ty.is_dir() && is_folder_file(folder, sub, &name, probes) {
            remove(&e.path(), false)?;
        }
    }
    remove_if_empty(path)
}

/// Remove what a run wrote in `dir`, by name (and nothing else: a user's file in any folder
/// of the run directory stays, and so does the folder that holds it).
pub fn clear_run(dir: &Path) -> io::Result<()> {
    let probes = probe_names(dir);
    for folder in RUN_FOLDERS {
        let path = dir.join(folder);
        if fs::symlink_metadata(&path).is_ok_and(|m| m.is_dir()) {
            clear_folder(&path, folder, None, &probes)?;
        }
    }
    if let Ok(rd) = fs::read_dir(dir) {
        for e in rd.flatten() {
            let name = e.file_name().to_string_lossy().into_owned();
            if name != LOCK_FILE && is_top_file(&name) && !e.file_type()?.is_dir() {
                remove(&e.path(), false)?;
            }
        }
    }
    Ok(())
}

/// A path of the run directory that a run would write but cannot: it is there as something
/// else than a regular file (a FIFO, a device, a directory), or a run's folder is a file.
fn not_writable(path: &Path, want_dir: bool) -> Option<Error> {
    let m = fs::metadata(path).ok()?;
    let (ok, what) = if want_dir {
        (m.is_dir(), "a directory")
    } else {
        (m.is_file(), "a regular file")
    };
    (!ok).then(|| {
        Error::input(
            path.display().to_string(),
            format!(
                "is in the run directory where a run writes {what}, but it is not one; remove or \
                 rename it, then run again"
            ),
        )
    })
}

/// Every path of the run directory `dir` that a run writes (by [`is_top_file`],
/// [`is_folder_file`], [`is_subfolder`]; `probes`: the scene's probe names) and that is there,
/// is of the kind the run writes: checked before a restart changes anything, so that a FIFO
/// named `final.csv` or a directory named `summary.json` refuses it at once (exit 2), not
/// after the whole segment has run.
pub fn check_targets(dir: &Path, probes: &[String]) -> Result<()> {
    for name in RUN_FILES.iter().filter(|n| **n != LOCK_FILE) {
        if let Some(e) = not_writable(&dir.join(name), false) {
            return Err(e);
        }
    }
    for folder in RUN_FOLDERS {
        let path = dir.join(folder);
        if let Some(e) = not_writable(&path, true) {
            return Err(e);
        }
        let Ok(rd) = fs::read_dir(&path) else {
            continue;
        };
        for e in rd.flatten() {
            let name = e.file_name().to_string_lossy().into_owned();
            let p = e.path();
            if is_subfolder(folder, &name) {
                if let Some(err) = not_writable(&p, true) {
                    return Err(err);
                }
                for f in fs::read_dir(&p).into_iter().flatten().flatten() {
                    let n = f.file_name().to_string_lossy().into_owned();
                    if is_folder_file(folder, Some(&name), &n, probes) {
                        if let Some(err) = not_writable(&f.path(), false) {
                            return Err(err);
                        }
                    }
                }
            } else if is_folder_file(folder, None, &name, probes) {
                if let Some(err) = not_writable(&p, false) {
                    return Err(err);
                }
            }
        }
    }
    Ok(())
}

/// The final state is written one way (`final.csv`, or `final/rank_NNNN.csv` above
/// `output.gather_limit`): the other way's files, left by an earlier run or segment with
/// another limit, go (by name), so the directory never holds two final states.
pub fn remove_other_final(dir: &Path, gathered: bool) -> Result<()> {
    let r = if gathered {
        clear_folder(&dir.join("final"), "final", None, &[])
    } else {
        remove(&dir.join("final.csv"), false)
    };
    r.map_err(|e| Error::io(dir, e))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_are_a_runs_by_pattern_alone() {
        let probes = vec!["gauge".to_string()];
        assert!(is_top_file("final.csv") && is_top_file("summary.json.tmp"));
        assert!(!is_top_file("notes.txt") && !is_top_file(".hsph-write-test"));
        assert!(is_folder_file("probes", None, "gauge.csv", &probes));
        assert!(!is_folder_file("probes", None, "mine.csv", &probes));
        assert!(is_folder_file("snapshots", None, "snapshot_00012.pvtu", &probes));
        assert!(!is_folder_file("snapshots", None, "snapshot_12.pvtu", &probes));
        assert!(is_folder_file(
            "snapshots",
            Some("snapshot_00012"),
            "rank_0003.vtu",
            &probes
        ));
        assert!(is_folder_file(
            "checkpoints",
            Some("step-0000000030"),
            "part-00001.bin",
            &probes
        ));
        assert!(is_folder_file(
            "checkpoints",
            Some("step-0000000030"),
            "part-00001.tmp",
            &probes
        ));
        assert!(!is_folder_file(
            "checkpoints",
            Some("step-0000000030"),
            "notes",
            &probes
        ));
        assert!(is_subfolder("checkpoints", "step-0000000030") && !is_subfolder("checkpoints", "step-30"));
        assert!(is_folder_file("final", None, "rank_0000.csv", &probes));
        assert!(is_folder_file("report", None, "phase_times.svg", &probes));
        assert!(!is_folder_file("report", None, "my_plot.png", &probes));
        assert!(is_folder_file("report", None, "flow_03.png", &probes));
        assert!(is_folder_file("report", None, "flow_final.svg", &probes));
        assert!(is_folder_file("report", None, "pressure_traces.png", &probes));
        assert!(!is_folder_file("report", None, "flow_x.png", &probes));
        assert!(is_folder_file("frames", None, "frame_00.json", &probes));
        assert!(is_folder_file(
            "frames",
            Some("frame_00"),
            "rank_0002.csv",
            &probes
        ));
        assert!(!is_folder_file("frames", None, "frame_0.json", &probes));
        assert!(is_subfolder("frames", "frame_12") && !is_subfolder("frames", "mine"));
    }
}

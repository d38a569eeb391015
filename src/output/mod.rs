//! The run directory: what a run leaves behind (README, "Run directory").
//!
//! - `scene.toml` — the resolved scene, every default filled in;
//! - `timeseries.csv` — physics only, deterministic, bitwise comparable across threads/ranks;
//! - `diagnostics.csv` — wall-clock timers and anything machine- or layout-dependent;
//! - `final.csv` — every particle at the end, sorted by id, shortest round-trip floats;
//! - `probes/<name>.csv`, `snapshots/*.vtu` + `snapshots/series.pvd`;
//! - `summary.json` — written last and atomically: its presence marks a complete run.

pub mod cf;
pub mod names;
pub mod netcdf;
#[cfg(feature = "netcdf")]
pub mod netcdf4;
pub mod snapshot;
pub mod volume;
pub mod vtk;
pub mod writers;

pub(crate) use crate::files::{create, write_atomic};
pub use crate::files::{refuse_non_regular, write_file};

use crate::comm::TrafficEntry;
use crate::error::{Error, Result};
use crate::particles::Particles;
use crate::scene::Scene;
use crate::sim::Observables;
use std::fs::{self, File};
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};

/// Longest run-directory name made from a scene name (characters).
const MAX_NAME: usize = 64;

/// A scene name as one safe path component: letters, digits, `-`, `_` and inner dots kept,
/// everything else (separators, `..`, spaces, control characters) replaced by `_`, at most
/// [`MAX_NAME`] characters, never empty. `--out` is the only way to put a run elsewhere.
pub fn safe_name(name: &str) -> String {
    let mut s: String = name
        .chars()
        .map(|c| {
            if c.is_alphanumeric() || c == '-' || c == '_' || c == '.' {
                c
            } else {
                '_'
            }
        })
        .take(MAX_NAME)
        .collect();
    while s.contains("..") {
        s = s.replace("..", "_");
    }
    let s = s.trim_start_matches('.').to_string();
    if s.is_empty() {
        "run".into()
    } else {
        s
    }
}

/// What a run writes into its directory: the only names `--force` removes.
pub const RUN_FILES: &[&str] = &[
    "summary.json",
    "scene.toml",
    "timeseries.csv",
    "timeseries.nc",
    "diagnostics.csv",
    "final.csv",
    "traffic.csv",
    "removed.csv",
    LOCK_FILE,
];
/// The folders a run writes into (`--force` removes the files a run wrote there, by
/// [`names`], and a folder only once nothing else is left in it).
pub const RUN_FOLDERS: &[&str] = &["probes", "snapshots", "checkpoints", "final", "frames", "report"];
/// The lock a run holds on its directory while it runs (an empty file, kept).
pub const LOCK_FILE: &str = ".hsph.lock";

/// Most directories `runs/<name>-<time>-<k>` tried when runs start in the same second.
const MAX_SUFFIX: usize = 1000;

/// A run's exclusive hold on its directory: two runs (or a run and a restart of it) cannot
/// write one directory at once. Released when dropped (or when the process ends); dropped, it
/// also removes its file, so a finished run leaves no `.hsph.lock` behind.
#[derive(Debug)]
pub struct DirLock {
    file: File,
    path: PathBuf,
}

/// Tries to take a lock whose file a finishing run removed between our open and our lock.
const LOCK_TRIES: usize = 8;

impl DirLock {
    /// Take the lock of `dir` (which exists), or exit 2 naming `key` if another run holds it.
    /// A file system without locks (some network file systems) is let through. The lock held
    /// is on the file that `dir/.hsph.lock` names once it is held: one that a finishing run
    /// removed in between is not a lock, and is tried again.
    pub fn take(dir: &Path, key: &str) -> Result<DirLock> {
        let path = dir.join(LOCK_FILE);
        let cannot = |e: std::io::Error| {
            Error::input(
                key,
                format!("cannot use {} as the run directory: {e}", dir.display()),
            )
        };
        for _ in 0..LOCK_TRIES {
            let file = fs::OpenOptions::new()
                .create(true)
                .truncate(false)
                .write(true)
                .open(&path)
                .map_err(cannot)?;
            match file.try_lock() {
                Ok(()) if same_file(&file, &path) => return Ok(DirLock { file, path }),
                Ok(()) => continue,
                Err(fs::TryLockError::WouldBlock) => {
                    return Err(Error::input(
                        key,
                        format!(
                            "{} is in use by another hsph run (it holds {LOCK_FILE}); wait for it to end \
                             or choose another directory with --out DIR",
                            dir.display()
                        ),
                    ))
                }
                Err(fs::TryLockError::Error(_)) => return Ok(DirLock { file, path }),
            }
        }
        Err(cannot(std::io::Error::other(
            "its lock file keeps being replaced by other runs",
        )))
    }
}

impl Drop for DirLock {
    fn drop(&mut self) {
        // removed while still held, so no other run can hold this file at the same time
        if same_file(&self.file, &self.path) {
            let _ = fs::remove_file(&self.path);
        }
    }
}

/// Whether the open `file` is the file `path` names now.
#[cfg(unix)]
fn same_file(file: &File, path: &Path) -> bool {
    use std::os::unix::fs::MetadataExt;
    match (file.metadata(), fs::metadata(path)) {
        (Ok(a), Ok(b)) => a.dev() == b.dev() && a.ino() == b.ino(),
        _ => false,
    }
}

/// Whether the open `file` is the file `path` names now (no inode to compare: assumed).
#[cfg(not(unix))]
fn same_file(_file: &File, path: &Path) -> bool {
    path.is_file()
}

/// Choose, create and lock the output directory: `--out`, else `runs/<safe scene name>-<UTC
/// time>` (with `-2`, `-3`, … when another run took that name in the same second). A
/// non-empty directory is refused unless `force`, and `force` clears only a run directory
/// (one with a `scene.toml` or `summary.json`), removing only the files a run writes, by name
/// ([`names::clear_run`]: the old checkpoints too, so a restart cannot resume the old run);
/// a user's own files stay, in any folder. Every problem with the directory is an input
/// error (exit 2) naming it.
pub fn prepare_dir(out: Option<&Path>, scene_name: &str, force: bool) -> Result<(PathBuf, DirLock)> {
    let Some(dir) = out else {
        return fresh_default_dir(scene_name);
    };
    let key = "--out";
    let bad = |why: String| {
        Error::input(
            key,
            format!(
                "cannot use {} as the run directory: {why}; choose another with --out DIR",
                dir.display()
            ),
        )
    };
    if dir.exists() && !dir.is_dir() {
        return Err(bad("it is a file, not a directory".into()));
    }
    // refuse before writing anything (the lock file too) into a directory that is not ours
    let entries: Vec<std::ffi::OsString> = match fs::read_dir(dir) {
        Ok(rd) => rd
            .filter_map(|e| e.ok().map(|e| e.file_name()))
            .filter(|n| n != LOCK_FILE)
            .collect(),
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => Vec::new(),
        Err(e) => return Err(bad(e.to_string())),
    };
    if !entries.is_empty() {
        if !force {
            return Err(Error::input(
                key,
                format!(
                    "{} is not empty; choose another directory or pass --force to overwrite",
                    dir.display()
                ),
            ));
        }
        let is_run = ["scene.toml", "summary.json"]
            .iter()
            .any(|f| dir.join(f).is_file());
        if !is_run {
            return Err(bad(
                "it is not empty and not a run directory (no scene.toml or summary.json), so --force \
                 will not empty it"
                    .into(),
            ));
        }
    }
    fs::create_dir_all(dir).map_err(|e| bad(e.to_string()))?;
    // a run still writing there holds the lock: nothing is removed under it
    let lock = DirLock::take(dir, key)?;
    if !entries.is_empty() {
        names::clear_run(dir).map_err(|e| bad(e.to_string()))?;
    }
    check_writable(dir).map_err(|e| bad(e.to_string()))?;
    Ok((dir.to_path_buf(), lock))
}

/// Whether `file` (relative to a run directory, as a checkpoint's run state names it) is a
/// series a run appends to: one of [`RUN_FILES`] or `probes/<plain name>`; never absolute,
/// never with `..`.
pub fn is_series_path(file: &str) -> bool {
    use std::path::Component;
    let parts: Vec<Component> = Path::new(file).components().collect();
    let plain = |c: &Component| matches!(c, Component::Normal(_));
    match parts.as_slice() {
        [one] => plain(one) && RUN_FILES.contains(&file),
        [dir, name] => plain(dir) && plain(name) && dir.as_os_str() == "probes",
        _ => false,
    }
}

/// A directory we cannot write into fails here, not after the set-up.
fn check_writable(dir: &Path) -> std::io::Result<()> {
    let probe = dir.join(".hsph-write-test");
    fs::write(&probe, b"")?;
    fs::remove_file(&probe)
}

/// `runs/<name>-<time>`, created by this process alone (`create_dir` fails if another run made
/// it first; then `-2`, `-3`, …).
fn fresh_default_dir(scene_name: &str) -> Result<(PathBuf, DirLock)> {
    let base = format!("{}-{}", safe_name(scene_name), timestamp());
    let bad = |dir: &Path, why: String| {
        Error::input(
            "name",
            format!(
                "cannot create the run directory {}: {why}; choose one with --out DIR",
                dir.display()
            ),
        )
    };
    let runs = Path::new("runs");
    fs::create_dir_all(runs).map_err(|e| bad(runs, e.to_string()))?;
    for k in 1..=MAX_SUFFIX {
        let dir = if k == 1 {
            runs.join(&base)
        } else {
            runs.join(format!("{base}-{k}"))
        };
        match fs::create_dir(&dir) {
            Ok(()) => {
                let lock = DirLock::take(&dir, "name")?;
                check_writable(&dir).map_err(|e| bad(&dir, e.to_string()))?;
                return Ok((dir, lock));
            }
            Err(e) if e.kind() == std::io::ErrorKind::AlreadyExists => continue,
            Err(e) => return Err(bad(&dir, e.to_string())),
        }
    }
    Err(bad(
        &runs.join(&base),
        format!("{MAX_SUFFIX} runs of this scene started in the same second"),
    ))
}

/// Remove `dir` if a run that failed before writing anything left it empty (but for its lock).
pub fn remove_if_empty(dir: &Path) {
    let only_lock = fs::read_dir(dir).is_ok_and(|d| d.flatten().all(|e| e.file_name() == LOCK_FILE));
    if only_lock {
        let _ = fs::remove_file(dir.join(LOCK_FILE));
        let _ = fs::remove_dir(dir);
    }
}

/// UTC time as `YYYYMMDD-HHMMSS` (civil-from-days, no time-zone database needed).
pub fn timestamp() -> String {
    let secs = std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map(|d| d.as_secs() as i64)
        .unwrap_or(0);
    let (days, rem) = (secs.div_euclid(86_400), secs.rem_euclid(86_400));
    let z = days + 719_468;
    let era = z.div_euclid(146_097);
    let doe = z - era * 146_097;
    let yoe = (doe - doe / 1460 + doe / 36_524 - doe / 146_096) / 365;
    let doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
    let mp = (5 * doy + 2) / 153;
    let d = doy - (153 * mp + 2) / 5 + 1;
    let m = if mp < 10 { mp + 3 } else { mp - 9 };
    let y = yoe + era * 400 + i64::from(m <= 2);
    format!(
        "{y:04}{m:02}{d:02}-{:02}{:02}{:02}",
        rem / 3600,
        rem % 3600 / 60,
        rem % 60
    )
}

/// A series file: created afresh with `header` as its first line, or, when `append` (a
/// restart), the existing file opened for appending.
pub(crate) fn series(path: &Path, header: &str, append: bool) -> Result<BufWriter<File>> {
    if append {
        let f = fs::OpenOptions::new()
            .append(true)
            .open(path)
            .map_err(|e| Error::io(path, e))?;
        return Ok(BufWriter::new(f));
    }
    let mut f = create(path)?;
    writeln!(f, "{header}").map_err(|e| Error::io(path, e))?;
    Ok(f)
}

/// Writes everything of one run except `summary.json` (see [`write_summary`]).
pub struct RunWriter<const D: usize> {
    dir: PathBuf,
    timeseries: BufWriter<File>,
    diagnostics: BufWriter<File>,
    traffic: BufWriter<File>,
    removed: Option<BufWriter<File>>,
    /// Mirror the series into netCDF (`output.format = "netcdf"`).
    netcdf: bool,
    /// Scene name (the netCDF files' title).
    title: String,
    _dim: std::marker::PhantomData<[(); D]>,
}

impl<const D: usize> RunWriter<D> {
    /// Create the files of a run in `dir` (already prepared) and write `scene.toml`;
    /// `diag_header` is the header line of `diagnostics.csv`. With `append` (a restart) the
    /// series files already there are continued instead.
    pub fn new(dir: &Path, scene: &Scene, diag_header: &str, append: bool) -> Result<Self> {
        let d = D;
        let resolved = toml::to_string(scene).map_err(|e| Error::run(format!("scene.toml: {e}")))?;
        let header = "# Resolved scene written by hsph: every default filled in. Run it again with\n\
                      # `hsph run scene.toml`.\n";
        let sp = dir.join("scene.toml");
        write_atomic(&sp, |f| write!(f, "{header}{resolved}"))?;
        let axes = ["x", "y", "z"];
        let mom: Vec<String> = axes[..d].iter().map(|a| format!("momentum_{a}")).collect();
        let timeseries = series(
            &dir.join("timeseries.csv"),
            &format!(
                "step,t,dt,kinetic_energy,{},max_speed,potential_energy,internal_energy,total_energy,mass,\
                 removed_energy,removed_mass",
                mom.join(",")
            ),
            append,
        )?;
        let diagnostics = series(&dir.join("diagnostics.csv"), diag_header, append)?;
        let traffic = series(
            &dir.join("traffic.csv"),
            "step,phase,src_rank,dst_rank,src_node,dst_node,bytes,messages",
            append,
        )?;
        let removed = if scene.domain.outflow == crate::scene::Outflow::Remove {
            let xs: Vec<&str> = ["x", "y", "z"][..d].to_vec();
            let head = format!("step,t,id,reason,{},rho,mass,energy", xs.join(","));
            Some(series(&dir.join("removed.csv"), &head, append)?)
        } else {
            None
        };
        Ok(RunWriter {
            dir: dir.to_path_buf(),
            timeseries,
            diagnostics,
            traffic,
            removed,
            netcdf: matches!(
                scene.output.format,
                crate::scene::SnapshotFormat::Netcdf | crate::scene::SnapshotFormat::Netcdf4
            ),
            title: scene.name.clone(),
            _dim: std::marker::PhantomData,
        })
    }

    /// With `output.format = "netcdf"`: mirror `timeseries.csv` and the probe files
    /// (`probes`, relative to the run directory) into netCDF ([`netcdf::mirror_series`]).
    pub fn mirror_series(&self, probes: &[String]) -> Result<()> {
        if !self.netcdf {
            return Ok(());
        }
        let files = std::iter::once("timeseries.csv".to_string()).chain(probes.iter().cloned());
        for f in files {
            let csv = self.dir.join(&f);
            netcdf::mirror_series(&csv, &csv.with_extension("nc"), &self.title, D)?;
        }
        Ok(())
    }

    /// Write one output step: timeseries row (physics only) and the diagnostics row the driver
    /// composed (timers, ghosts, balance: machine and layout dependent). Every rank writes its
    /// snapshot piece ([`snapshot::SnapshotWriter`]); probes write their own files
    /// ([`crate::probes::ProbeSet`]).
    pub fn output_step(&mut self, sim: &Stamp, o: &Observables<D>, diag_row: &str) -> Result<()> {
        let io = |e| Error::io(&self.dir, e);
        let mom: Vec<String> = o.momentum.iter().map(|m| format!("{m}")).collect();
        writeln!(
            self.timeseries,
            "{},{},{},{},{},{},{},{},{},{},{},{}",
            sim.step,
            sim.t,
            sim.dt,
            o.kinetic_energy,
            mom.join(","),
            o.max_speed,
            o.potential_energy,
            o.internal_energy,
            o.total_energy(),
            o.mass,
            o.removed_energy,
            o.removed_mass
        )
        .map_err(io)?;
        writeln!(self.diagnostics, "{diag_row}").map_err(|e| Error::io(&self.dir, e))?;
        // a killed run loses at most the output interval since this step
        self.flush()
    }

    /// Append the traffic since the previous call, as of `step`, to `traffic.csv`.
    pub fn traffic_rows(&mut self, step: u64, entries: &[TrafficEntry], nodes: &[usize]) -> Result<()> {
        for e in entries {
            writeln!(
                self.traffic,
                "{step},{},{},{},{},{},{},{}",
                e.phase.name(),
                e.src,
                e.dst,
                nodes[e.src],
                nodes[e.dst],
                e.bytes,
                e.messages
            )
            .map_err(|e| Error::io(&self.dir, e))?;
        }
        self.traffic.flush().map_err(|e| Error::io(&self.dir, e))
    }

    /// Append removed particles (sorted by step, then id) to `removed.csv`.
    pub fn removed_rows(&mut self, rows: &[crate::sim::outflow::Removal]) -> Result<()> {
        let Some(f) = self.removed.as_mut() else {
            return Ok(());
        };
        for r in rows {
            let x: Vec<String> = r.x.iter().map(|c| format!("{c}")).collect();
            writeln!(
                f,
                "{},{},{},{},{},{},{},{}",
                r.step,
                r.t,
                r.id,
                r.reason,
                x.join(","),
                r.rho,
                r.mass,
                r.energy
            )
            .map_err(|e| Error::io(&self.dir, e))?;
        }
        Ok(())
    }

    /// Flush every CSV series to disk.
    pub fn flush(&mut self) -> Result<()> {
        let dir = self.dir.clone();
        let io = |e| Error::io(&dir, e);
        if let Some(f) = self.removed.as_mut() {
            f.flush().map_err(io)?;
        }
        self.timeseries.flush().map_err(io)?;
        self.diagnostics.flush().map_err(io)?;
        self.traffic.flush().map_err(io)?;
        Ok(())
    }
}

/// Where an output step stands: steps taken, simulated time (s), next time step (s).
#[derive(Debug, Clone, Copy)]
pub struct Stamp {
    /// Steps taken.
    pub step: u64,
    /// Simulated time (s).
    pub t: f64,
    /// Time step for the next step (s).
    pub dt: f64,
}

/// `final.csv` (or one rank's `final/rank_000r.csv`): the particles `order` of `p` (sorted by
/// id), the fields the particle table gives a CSV column (vectors one column per axis),
/// shortest round-trip floats.
pub fn write_final<const D: usize>(path: &Path, p: &Particles<D>, order: &[usize]) -> Result<()> {
    let cols: Vec<_> = Particles::<D>::field_table()
        .into_iter()
        .filter_map(|m| Some((m.csv?, p.column(m.name)?)))
        .collect();
    let header: Vec<String> = cols.iter().flat_map(|(stem, c)| c.headers(stem)).collect();
    write_atomic(path, |f| {
        writeln!(f, "{}", header.join(","))?;
        let mut line = String::new();
        for &i in order {
            line.clear();
            for (k, (_, c)) in cols.iter().enumerate() {
                if k > 0 {
                    line.push(',');
                }
                c.csv(i, &mut line);
            }
            writeln!(f, "{line}")?;
        }
        Ok(())
    })
}

/// Write `summary.json` atomically (temporary file, then rename).
pub fn write_summary(dir: &Path, summary: &serde_json::Value) -> Result<()> {
    let text = serde_json::to_string_pretty(summary).map_err(|e| Error::run(e.to_string()))?;
    write_atomic(&dir.join("summary.json"), |f| writeln!(f, "{text}"))
}

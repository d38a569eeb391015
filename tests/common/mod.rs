//! Helpers shared by the integration tests: a deterministic RNG and unique temp dirs.
#![allow(dead_code)]

pub mod cli;
pub mod mutate;

use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicUsize, Ordering};

/// splitmix64 (Steele, Lea & Flood 2014): tiny, deterministic, good enough for test data.
pub struct Rng(pub u64);

impl Rng {
    pub fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9e37_79b9_7f4a_7c15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        z ^ (z >> 31)
    }

    /// Uniform in [0, 1).
    pub fn uniform(&mut self) -> f64 {
        (self.next_u64() >> 11) as f64 * (1.0 / (1u64 << 53) as f64)
    }

    /// Uniform in [lo, hi).
    pub fn range(&mut self, lo: f64, hi: f64) -> f64 {
        lo + (hi - lo) * self.uniform()
    }

    /// Uniform integer in [0, n).
    pub fn below(&mut self, n: usize) -> usize {
        (self.next_u64() % n as u64) as usize
    }
}

/// A fresh, empty, unique directory, `hsph-tests-PID/TAG-N` under the system temp dir. The
/// directories stay after the run, for a look at a failure; the first call of a run removes
/// the `hsph-tests-PID` of runs whose process is gone, so they do not pile up.
pub fn temp_dir(tag: &str) -> PathBuf {
    static N: AtomicUsize = AtomicUsize::new(0);
    static ROOT: std::sync::OnceLock<PathBuf> = std::sync::OnceLock::new();
    let root = ROOT.get_or_init(|| {
        let tmp = std::env::temp_dir();
        remove_stale_runs(&tmp);
        tmp.join(format!("hsph-tests-{}", std::process::id()))
    });
    let d = root.join(format!("{tag}-{}", N.fetch_add(1, Ordering::SeqCst)));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// Remove `hsph-tests-PID` under `tmp` for each PID with no `/proc/PID` (Linux; elsewhere
/// nothing is removed).
fn remove_stale_runs(tmp: &Path) {
    if !Path::new("/proc/self").exists() {
        return;
    }
    let Ok(entries) = std::fs::read_dir(tmp) else {
        return;
    };
    for e in entries.flatten() {
        let name = e.file_name();
        let Some(pid) = name.to_str().and_then(|n| n.strip_prefix("hsph-tests-")) else {
            continue;
        };
        if pid.parse::<u32>().is_ok() && !Path::new("/proc").join(pid).exists() {
            let _ = std::fs::remove_dir_all(e.path());
        }
    }
}

/// Path of a file shipped with the crate.
pub fn repo_path(rel: &str) -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join(rel)
}

/// A run directory's `summary.json`, parsed.
pub fn summary(run: &Path) -> serde_json::Value {
    serde_json::from_str(&std::fs::read_to_string(run.join("summary.json")).unwrap()).unwrap()
}

/// Run the `hsph` binary from the crate root: exit status (−1 when killed), stdout, stderr.
///
/// The suite runs two tests at a time on CI's two cores, so a run of a small scene over many
/// steps passes `--threads 1`: a second thread gains little there and waits for the core the
/// other test holds (the 40 × 40 cavity to t = 3 s: 34.6 s on two threads, 47.7 s of CPU on
/// one, 58.2 s on two).
pub fn hsph(args: &[&str]) -> (i32, String, String) {
    let o = std::process::Command::new(env!("CARGO_BIN_EXE_hsph"))
        .args(args)
        .current_dir(repo_path(""))
        .output()
        .unwrap();
    (
        o.status.code().unwrap_or(-1),
        String::from_utf8_lossy(&o.stdout).into_owned(),
        String::from_utf8_lossy(&o.stderr).into_owned(),
    )
}

/// `hsph run --restart from -q --ranks R --set time.max_steps=0` (see [`hsph`]): continue the
/// run or checkpoint `from` to its end on `ranks` ranks.
pub fn restart_to_end(from: &Path, ranks: usize) -> (i32, String, String) {
    let ranks = ranks.to_string();
    let from = from.to_str().unwrap();
    hsph(&[
        "run",
        "--restart",
        from,
        "-q",
        "--ranks",
        &ranks,
        "--set",
        "time.max_steps=0",
    ])
}

/// `hsph run scene -q --out out --ranks R --threads T --set …` (see [`hsph`]).
pub fn run_file(
    scene: &str,
    out: &Path,
    (ranks, threads): (usize, usize),
    sets: &[&str],
) -> (i32, String, String) {
    let (out, r, t) = (out.to_str().unwrap(), ranks.to_string(), threads.to_string());
    let mut args = vec!["run", scene, "-q", "--out", out, "--ranks", &r, "--threads", &t];
    for s in sets {
        args.extend(["--set", s]);
    }
    hsph(&args)
}

/// A run of `scene` with `sets` to its end on one rank (`dir/ref`), and the same run cut by a
/// checkpoint after `steps` steps on 2 ranks (`dir/cut`): (reference, cut, its checkpoint).
/// Continue the checkpoint with [`restart_to_end`], then compare with [`assert_same_files`].
pub fn reference_and_cut(dir: &Path, scene: &str, sets: &[&str], steps: u64) -> (PathBuf, PathBuf, PathBuf) {
    let reference = dir.join("ref");
    let (code, _, err) = run_file(scene, &reference, (1, 1), sets);
    assert_eq!(code, 0, "{err}");
    let cut = dir.join("cut");
    let (max, every) = (
        format!("time.max_steps={steps}"),
        format!("checkpoint.every_steps={steps}"),
    );
    let mut first = sets.to_vec();
    first.extend([max.as_str(), every.as_str()]);
    let (code, _, err) = run_file(scene, &cut, (2, 1), &first);
    assert_eq!(code, 0, "{err}");
    let ck = cut.join(format!("checkpoints/step-{steps:010}"));
    (reference, cut, ck)
}

/// The files `files` of run directories `a` and `b` hold the same bytes.
pub fn assert_same_files(a: &Path, b: &Path, files: &[&str]) {
    for f in files {
        let read = |d: &Path| std::fs::read(d.join(f)).unwrap_or_else(|e| panic!("{}/{f}: {e}", d.display()));
        assert!(read(a) == read(b), "{f} differs after the restart");
    }
}

/// A column of `timeseries.csv` in the run directory `dir`.
pub fn series(dir: &Path, name: &str) -> Vec<f64> {
    let path = dir.join("timeseries.csv");
    let text = std::fs::read_to_string(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    let head: Vec<&str> = text.lines().next().unwrap().split(',').collect();
    let k = head.iter().position(|h| *h == name).unwrap();
    text.lines()
        .skip(1)
        .map(|l| l.split(',').nth(k).unwrap().parse().unwrap())
        .collect()
}

/// Run `scene` with `sets` on each (ranks, threads) of `layouts` into `dir/r{ranks}t{threads}`
/// and assert that its `timeseries.csv` and `final.csv` hold the bytes of the run in `base`.
pub fn assert_same_bits_on(scene: &str, dir: &Path, base: &Path, sets: &[&str], layouts: &[(usize, usize)]) {
    for &(ranks, threads) in layouts {
        let d = dir.join(format!("r{ranks}t{threads}"));
        let (code, _, err) = run_file(scene, &d, (ranks, threads), sets);
        assert_eq!(code, 0, "{err}");
        for f in ["timeseries.csv", "final.csv"] {
            let read =
                |d: &Path| std::fs::read(d.join(f)).unwrap_or_else(|e| panic!("{}/{f}: {e}", d.display()));
            assert!(
                read(&d) == read(base),
                "{f} differs on {ranks} ranks × {threads} threads"
            );
        }
    }
}

/// The lattice's id bound of the 2D scene file `scene` (the first id a created particle takes).
pub fn id_bound_2d(scene: &str) -> u64 {
    let text = std::fs::read_to_string(repo_path(scene)).unwrap();
    let (s, _) = hsph::scene::load_scene_str(&text, Path::new(scene), "scene", &[]).unwrap();
    hsph::scene::lattice::id_bound::<2>(&s)
}

/// The second column (the value after the time) of every row of the probe `probe`'s CSV in
/// the run directory `run`.
pub fn probe_values(run: &Path, probe: &str) -> Vec<f64> {
    let path = run.join("probes").join(format!("{probe}.csv"));
    let text = std::fs::read_to_string(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    text.lines()
        .skip(1)
        .map(|l| {
            let v = l
                .split(',')
                .nth(1)
                .unwrap_or_else(|| panic!("{}: row {l:?}", path.display()));
            v.parse()
                .unwrap_or_else(|e| panic!("{}: {v:?}: {e}", path.display()))
        })
        .collect()
}

/// Values of the `<DataArray Name="name">` of a `.vtu` piece, as text tokens (vectors give
/// three per point).
pub fn vtu_array(text: &str, name: &str) -> Vec<String> {
    let at = text
        .find(&format!("Name=\"{name}\""))
        .unwrap_or_else(|| panic!("no array {name}"));
    let body = &text[at..];
    let start = body.find('>').unwrap() + 1;
    let end = body.find("</DataArray>").unwrap();
    body[start..end].split_whitespace().map(String::from).collect()
}

/// The point coordinates of a `.vtu` piece, three tokens per point.
pub fn vtu_points(text: &str) -> Vec<String> {
    let at = text.find("<Points>").unwrap();
    let body = &text[at..];
    let start = body.find("format=\"ascii\">").unwrap() + "format=\"ascii\">".len();
    let end = body.find("</DataArray>").unwrap();
    body[start..end].split_whitespace().map(String::from).collect()
}

/// Run `scene` in a fresh temp dir on `ranks` ranks (serial back end for one, local above)
/// with `threads` threads each, quietly; the run directory.
pub fn run_layout(scene: &hsph::scene::Scene, ranks: usize, threads: usize, tag: &str) -> PathBuf {
    use hsph::driver::{run_scene, Backend, RunOptions};
    let out = temp_dir(tag).join("run");
    let opts = RunOptions {
        out: Some(out.clone()),
        threads,
        quiet: true,
        ranks,
        backend: if ranks == 1 {
            Backend::Serial
        } else {
            Backend::Local
        },
        ..Default::default()
    };
    run_scene(scene, &opts).unwrap_or_else(|e| panic!("{tag}: {e}"));
    out
}

/// `final.csv`: its header and its rows keyed by id.
pub type Table = (Vec<String>, std::collections::BTreeMap<u64, Vec<f64>>);

/// `final.csv` as (header, rows keyed by id).
pub fn table(dir: &Path) -> Table {
    let text = std::fs::read_to_string(dir.join("final.csv")).unwrap();
    let mut lines = text.lines();
    let head: Vec<String> = lines.next().unwrap().split(',').map(String::from).collect();
    let rows = lines
        .map(|l| {
            let v: Vec<f64> = l.split(',').map(|c| c.parse().unwrap()).collect();
            (v[0] as u64, v)
        })
        .collect();
    (head, rows)
}

/// Largest difference of column `col` between two `final.csv` tables with the same ids.
pub fn largest_difference(a: &Table, b: &Table, col: &str) -> f64 {
    let k = a.0.iter().position(|h| h == col).unwrap();
    assert_eq!(a.1.len(), b.1.len(), "the same particles");
    a.1.iter()
        .map(|(id, ra)| (ra[k] - b.1[id][k]).abs())
        .fold(0.0, f64::max)
}

/// The largest difference in x or y and in density (m, kg/m³) between the `final.csv` of two
/// runs of the same particles.
pub fn position_and_density_gap(a: &Path, b: &Path) -> (f64, f64) {
    let (a, b) = (table(a), table(b));
    let dx = largest_difference(&a, &b, "x").max(largest_difference(&a, &b, "y"));
    (dx, largest_difference(&a, &b, "rho"))
}

/// Every entry under `dir` by relative path: a file's bytes, a directory as `name/` and any
/// other kind as `name (special)` (both with no bytes). Tests that a run or a refused command
/// left a directory as it was compare two of these.
pub fn dir_snapshot(dir: &Path) -> std::collections::BTreeMap<String, Vec<u8>> {
    fn walk(root: &Path, d: &Path, out: &mut std::collections::BTreeMap<String, Vec<u8>>) {
        for e in std::fs::read_dir(d).unwrap().flatten() {
            let p = e.path();
            let rel = p.strip_prefix(root).unwrap().to_string_lossy().into_owned();
            let ty = std::fs::symlink_metadata(&p).unwrap().file_type();
            if ty.is_dir() {
                out.insert(format!("{rel}/"), Vec::new());
                walk(root, &p, out);
            } else if ty.is_file() {
                out.insert(rel, std::fs::read(&p).unwrap());
            } else {
                out.insert(format!("{rel} (special)"), Vec::new());
            }
        }
    }
    let mut out = std::collections::BTreeMap::new();
    walk(dir, dir, &mut out);
    out
}

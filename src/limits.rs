//! Every bound on a count or size taken from input, in one place.
//!
//! A scene file, a flag, a checkpoint manifest or a node-layout file can ask for anything: a
//! hundred thousand ranks, a probe of 10¹¹ points, a nested expression of a megabyte, a
//! "file" that is `/dev/zero`. Each command checks what it was given here, before anything
//! is allocated, and refuses what is beyond a bound with exit status 2 naming the key or flag,
//! the value and the limit. The README's "Exit status and limits" section lists every constant
//! below with its value; `tests/hardening.rs` and `tests/fuzz.rs` try each class.

use crate::error::{Error, Result};
use std::io::Read;
use std::path::Path;

/// Most ranks of a run, a plan, a model or a job script. The placement's pairwise tables grow
/// as P², which at this size is about 130 MiB each; the local back end runs every rank as a
/// thread of one process.
pub const MAX_RANKS: usize = 4096;

/// Most rayon threads of one rank (`--threads`, `--threads-per-rank`). More threads than
/// cores is allowed with a warning (it runs slower); above this it is refused.
pub const MAX_THREADS: usize = 1024;

/// Most threads in one process (ranks of the local back end × threads per rank), per core
/// this process may use; at least [`MIN_PROCESS_THREADS`]. Thousands of threads on a few
/// cores spend minutes starting and switching (8 ranks × 1000 threads took 437 s for five
/// steps on 2 cores).
pub const PROCESS_THREADS_PER_CORE: usize = 16;

/// The fewest threads in one process the limit allows, whatever the cores.
pub const MIN_PROCESS_THREADS: usize = 64;

/// Most threads in one process on this machine: [`PROCESS_THREADS_PER_CORE`] × cores, at
/// least [`MIN_PROCESS_THREADS`].
pub fn max_process_threads() -> usize {
    let cores = std::thread::available_parallelism().map_or(1, |n| n.get());
    (PROCESS_THREADS_PER_CORE * cores).max(MIN_PROCESS_THREADS)
}

/// Most particles a scene may build (2³¹: ids and counts fit in the wire format with room).
pub const MAX_PARTICLES: u64 = 1 << 31;

/// Most sample points of one probe (`points` of a line probe).
pub const MAX_PROBE_POINTS: u64 = 1_000_000;

/// Most sample points of a pressure sensor's face (`diameter`, sampled every dx/4): each is a
/// Shepard sum at every sample of the probe.
pub const MAX_FACE_POINTS: u64 = 10_000;

/// The step budget: a run estimated above this many steps is refused unless the scene sets
/// `time.max_steps` (which then bounds it).
pub const MAX_STEPS: f64 = 1e9;

/// Largest text file read as input (scene, node layout, checkpoint manifest, summary).
pub const MAX_INPUT_BYTES: u64 = 16 << 20;

/// Largest initial-field expression (characters).
pub const MAX_EXPR_CHARS: usize = 4096;

/// Deepest nesting of brackets in an initial-field expression.
pub const MAX_EXPR_DEPTH: usize = 64;

/// Longest wall-clock duration a flag may ask for (`--time`, `--max-wall`): 366 days.
pub const MAX_WALL_SECONDS: f64 = 366.0 * 86_400.0;

/// Fewest and most seconds of warning before a job's time limit (`--signal-before`): Slurm may
/// send the signal up to a minute early, and takes at most 65 535 s.
pub const SIGNAL_BEFORE_RANGE: (u64, u64) = (10, 65_535);

/// Most timed steps or repetitions of `hsph bench`, and most parallel jobs of `hsph validate`.
pub const MAX_BENCH_STEPS: u64 = 1_000_000;
/// Most repetitions of one `hsph bench` measurement.
pub const MAX_REPEAT: usize = 1000;
/// Most child runs `hsph validate --jobs` starts at once.
pub const MAX_JOBS: usize = 256;
/// Most flow frames a run writes (`output.frames`): each is a whole gathered state.
pub const MAX_FRAMES: usize = 100;
/// Most cells across a validation case's length scale (`hsph validate --resolutions`).
pub const MAX_RESOLUTION: u32 = 4096;

/// Most memory per node `hsph jobscript` asks Slurm for (MiB): 64 TiB, above any node built.
pub const MAX_NODE_MEMORY_MIB: u64 = 64 << 20;

/// Longest Slurm name `hsph jobscript` writes (job name from the scene's `name`, `--partition`
/// with its commas, `--account`); each is also held to letters, digits and `. _ + -`.
pub const MAX_SLURM_NAME: usize = 128;

// Physical ranges of the scene constants that enter the time step (README, "Limits"): generous
// beyond any real material or flow, so that only a typo or a hostile value is refused. The
// step budget ([`MAX_STEPS`]) then bounds what they allow together.

/// Sound speeds a material may give, `c0` of a fluid or a solid, and a solid's longitudinal
/// wave speed √((ρ0c0² + 4G/3)/ρ0) (m/s): from 1 µm/s (a numerical c0 of a creeping flow) to
/// 100 km/s (diamond's longitudinal speed is 18 km/s).
pub const SOUND_SPEED_RANGE: (f64, f64) = (1e-6, 1e5);
/// Reference densities ρ0 (kg/m³): from 1 mg/m³ to 10⁵ (osmium is 2.26 × 10⁴).
pub const DENSITY_RANGE: (f64, f64) = (1e-6, 1e5);
/// Largest modulus or stress constant of a solid: shear modulus G, Johnson–Cook A and B,
/// spall strength (Pa): 10 TPa (diamond's shear modulus is 0.5 TPa).
pub const MAX_MODULUS: f64 = 1e13;
/// Largest dimensionless EOS constant: the Tait exponent γ (water 7), a Hugoniot slope s
/// and a Grüneisen Γ0 (both below 5 in every tabulated metal).
pub const MAX_EOS_CONSTANT: f64 = 100.0;
/// Largest body force |g| (m/s²): 10⁶, about 10⁵ g, beyond any centrifuge.
pub const MAX_BODY_FORCE: f64 = 1e6;
/// Largest laminar kinematic viscosity ν (m²/s): 10⁶ (honey is 10⁻², a lava 10²).
pub const MAX_VISCOSITY: f64 = 1e6;
/// Largest dimensionless coefficient of a numerical term: artificial viscosity α and β,
/// density diffusion δ, artificial stress ε (usual values 0.01 to 2).
pub const MAX_COEFFICIENT: f64 = 100.0;
/// Largest speed a scene may give a body, a wall or a reference flow (m/s): the largest
/// sound speed.
pub const MAX_SPEED: f64 = 1e5;
/// Longest simulated time `time.t_end`, and longest fixed step `time.dt` (s): 10⁹ s, about
/// 32 years.
pub const MAX_T_END: f64 = 1e9;

/// Most cells of the global cell grid, cells of the kernel support over the whole domain
/// (1 GiB of u32 cell offsets).
pub const MAX_CELLS: u64 = 1 << 28;

/// Most characters of all the initial-field expressions of a scene together (16 of the
/// longest): each is parsed and sampled during validation, and evaluated at every site.
pub const MAX_EXPR_TOTAL_CHARS: usize = 16 * MAX_EXPR_CHARS;

/// Most bodies of one kind (`[[fluid]]`, `[[solid]]`, `[[wall]]`) and most materials of a
/// scene: a particle stores its body and material as 16-bit indices.
pub const MAX_BODIES: usize = 1 << 16;

/// Vertices of one polygon (`shape = "polygon"`): the outline's self-crossing check compares
/// every pair of edges, 5·10⁷ pairs at this limit.
pub const MAX_POLYGON_VERTICES: usize = 10_000;

/// Triangles of one mesh (`shape = "mesh"`): 10⁷ is a 500 MB binary STL and about 2.2 GB of
/// placed triangles and index per rank.
pub const MAX_MESH_TRIANGLES: u64 = 10_000_000;

/// Bytes of one mesh file, checked before it is read: a binary STL of
/// [`MAX_MESH_TRIANGLES`] (84 + 50 per triangle), or an ASCII one of about 2·10⁶ triangles.
pub const MAX_MESH_BYTES: u64 = 84 + 50 * MAX_MESH_TRIANGLES;

/// `value` of `key` within `1..=max`, else exit 2 naming both.
pub fn count(key: &str, value: u64, max: u64) -> Result<()> {
    if value == 0 {
        return Err(Error::input(
            key,
            format!("must be at least 1, got 0 (limit {max})"),
        ));
    }
    if value > max {
        return Err(Error::input(key, format!("{value} is above the limit of {max}")));
    }
    Ok(())
}

/// Ranks asked for by `key` (a flag or `--nodes × --ranks-per-node`).
pub fn ranks(key: &str, ranks: usize) -> Result<()> {
    count(key, ranks as u64, MAX_RANKS as u64)
}

/// Threads per rank asked for by `key`, with `ranks_in_process` ranks in this process; returns
/// a warning when they exceed the cores this process may use.
pub fn threads(key: &str, threads: usize, ranks_in_process: usize) -> Result<Option<String>> {
    count(key, threads as u64, MAX_THREADS as u64)?;
    let total = threads.saturating_mul(ranks_in_process.max(1));
    let most = max_process_threads();
    let cores = std::thread::available_parallelism().map_or(1, |n| n.get());
    if total > most {
        return Err(Error::input(
            key,
            format!(
                "{threads} thread(s) × {} rank(s) = {total} threads in one process, above the limit of {most} \
                 ({PROCESS_THREADS_PER_CORE} per core available, {cores} core(s)); use at most {} thread(s) per rank, \
                 or run the ranks under MPI",
                ranks_in_process.max(1),
                (most / ranks_in_process.max(1)).max(1)
            ),
        ));
    }
    Ok((total > cores).then(|| {
        // name the ranks too when they, not the threads, fill the cores (--ranks 3 --threads 1)
        let (asked, fewer) = if ranks_in_process > 1 {
            (
                format!("{threads} thread(s) per rank × {ranks_in_process} ranks in this process"),
                "fewer ranks or threads per rank, or the ranks under MPI on more cores",
            )
        } else {
            (format!("{key} {threads}"), "at most one thread per core")
        };
        format!(
            "{asked}: {total} threads on {cores} core(s) available; threads beyond the cores share them \
             and the run is slower, not faster (use {fewer})"
        )
    }))
}

/// The text of an input file, read with a bound: at most [`MAX_INPUT_BYTES`], and only from a
/// regular file or a pipe (`hsph check <(generate)`); a device such as `/dev/zero` is refused.
/// `key` names the file's role in the message (`SCENE`, `--topology`, ...).
pub fn read_text(path: &Path, key: &str) -> Result<String> {
    let bad = |m: String| file_error(path, key, None, m);
    let f = open_input(path, key, MAX_INPUT_BYTES)?;
    let mut bytes = Vec::new();
    f.take(MAX_INPUT_BYTES + 1)
        .read_to_end(&mut bytes)
        .map_err(|e| bad(format!("cannot read: {e}")))?;
    if bytes.len() as u64 > MAX_INPUT_BYTES {
        return Err(bad(format!(
            "is longer than the input limit of {MAX_INPUT_BYTES} bytes"
        )));
    }
    String::from_utf8(bytes).map_err(|e| bad(format!("is not UTF-8 text: {e}")))
}

/// An input error at `path` (and `line`), about `key`.
pub(crate) fn file_error(path: &Path, key: &str, line: Option<usize>, message: String) -> Error {
    Error::Input {
        at: Some(crate::error::Location {
            file: path.to_path_buf(),
            line,
        }),
        key: key.to_string(),
        message,
    }
}

/// `path` opened for reading after the checks every input file gets: a regular file or a pipe
/// (never a directory or a device), at most `max` bytes.
fn open_input(path: &Path, key: &str, max: u64) -> Result<std::fs::File> {
    let bad = |m: String| file_error(path, key, None, m);
    let meta = std::fs::metadata(path).map_err(|e| bad(format!("cannot read: {e}")))?;
    let ft = meta.file_type();
    if !(ft.is_file() || is_fifo(&ft)) {
        let example = if key == "SCENE" {
            "a TOML file, e.g. inputs/dam_break_2d.toml"
        } else {
            "a regular file or a pipe"
        };
        return Err(bad(format!(
            "is not a regular file (a directory or a device); give {example}"
        )));
    }
    if meta.len() > max {
        return Err(bad(format!(
            "is {} bytes, above the input limit of {max} bytes",
            meta.len()
        )));
    }
    std::fs::File::open(path).map_err(|e| bad(format!("cannot read: {e}")))
}

/// Largest series of a run directory read back (`diagnostics.csv`, `traffic.csv`,
/// `final.csv` by `hsph report`): 4 GiB, read a line at a time.
pub const MAX_SERIES_BYTES: u64 = 4 << 30;

/// Longest line of a series read back (bytes): a row of `final.csv` or `diagnostics.csv` is
/// a few hundred.
pub const MAX_LINE_BYTES: u64 = 1 << 20;

/// The lines of a text file hsph wrote and reads back (a CSV series of a run directory), one
/// at a time with its 1-based number: the file checked as [`read_text`]'s, at most
/// [`MAX_SERIES_BYTES`], each line at most [`MAX_LINE_BYTES`], so that nothing read is held
/// beyond one line unless `each` keeps it. `key` names the file's role in messages.
pub fn read_lines(path: &Path, key: &str, mut each: impl FnMut(usize, &str) -> Result<()>) -> Result<()> {
    use std::io::BufRead;
    let f = open_input(path, key, MAX_SERIES_BYTES)?;
    let mut r = std::io::BufReader::new(f);
    let (mut buf, mut total, mut n) = (Vec::new(), 0u64, 0usize);
    loop {
        buf.clear();
        let got = r
            .by_ref()
            .take(MAX_LINE_BYTES + 1)
            .read_until(b'\n', &mut buf)
            .map_err(|e| file_error(path, key, None, format!("cannot read: {e}")))?;
        if got == 0 {
            return Ok(());
        }
        n += 1;
        total += got as u64;
        if buf.len() as u64 > MAX_LINE_BYTES {
            return Err(file_error(
                path,
                key,
                Some(n),
                format!("line is longer than the limit of {MAX_LINE_BYTES} bytes: not a file hsph wrote"),
            ));
        }
        if total > MAX_SERIES_BYTES {
            return Err(file_error(
                path,
                key,
                Some(n),
                format!("is longer than the limit of {MAX_SERIES_BYTES} bytes"),
            ));
        }
        let line = std::str::from_utf8(&buf)
            .map_err(|_| file_error(path, key, Some(n), "is not UTF-8 text".into()))?;
        each(n, line.trim_end_matches(['\n', '\r']))?;
    }
}

// What `hsph model` may assume of a network between nodes: generous beyond any interconnect,
// so that only a typo or a unit slip is refused (`--latency 1e308` made every step last
// longer than the universe).

/// Bandwidth of one node's interface `hsph model --bandwidth` may assume (GB/s): from 1 MB/s
/// to 10 TB/s (a 400 Gb/s link is 50 GB/s).
pub const BANDWIDTH_RANGE: (f64, f64) = (1e-3, 1e4);
/// Latency of one message `hsph model --latency` may assume (µs): from 0 to 1 s (InfiniBand is
/// about 1 µs, Ethernet tens).
pub const LATENCY_RANGE: (f64, f64) = (0.0, 1e6);
/// Most cores `hsph model --cores` may share the predicted ranks over: a thread per core at
/// the most ranks and threads.
pub const MAX_CORES: u64 = MAX_RANKS as u64 * MAX_THREADS as u64;

/// `value` of flag `key` finite and within `range` (inclusive), in `unit`; else exit 2 naming
/// the flag, the value and the range, with `example`.
pub fn flag_in_range(key: &str, value: f64, range: (f64, f64), unit: &str, example: &str) -> Result<()> {
    if value.is_finite() && range.0 <= value && value <= range.1 {
        return Ok(());
    }
    Err(Error::input(
        key,
        format!(
            "{} {unit} is outside the range {} to {} {unit}; e.g. {key} {example}",
            show(value),
            show(range.0),
            show(range.1)
        ),
    ))
}

/// Largest byte or message count of a run's traffic read back: 2⁶² (sums of a few such
/// counts stay in 64 bits).
pub const MAX_TRAFFIC_BYTES: u64 = 1 << 62;

/// The numbers of a file that a run wrote and a later command reads back (`summary.json`,
/// `diagnostics.csv`, `traffic.csv`, `final.csv`), each checked where it is read against the
/// limits its flag has: a count is a whole number in its range, a real is finite in its
/// range. A value outside is exit 2 naming the file (and line), the key, the value and the
/// range a run of hsph writes, before anything is sized by it.
#[derive(Debug, Clone, Copy)]
pub struct FileNumbers<'a> {
    /// The file read.
    pub file: &'a Path,
    /// Its 1-based line, where it has lines.
    pub line: Option<usize>,
}

impl<'a> FileNumbers<'a> {
    /// The numbers of `file` (no line).
    pub fn of(file: &'a Path) -> Self {
        FileNumbers { file, line: None }
    }

    /// The numbers of `line` of `file`.
    pub fn at(file: &'a Path, line: usize) -> Self {
        FileNumbers {
            file,
            line: Some(line),
        }
    }

    /// An input error about `key` of this file.
    pub fn error(&self, key: &str, message: String) -> Error {
        file_error(self.file, key, self.line, message)
    }

    /// The number `key` holds, as written: a JSON number, or a CSV field's text.
    fn number(&self, key: &str, v: &Number<'_>) -> Result<f64> {
        match v {
            Number::Json(serde_json::Value::Number(n)) => n
                .as_f64()
                .ok_or_else(|| self.error(key, format!("{n} is not a number"))),
            Number::Json(other) => Err(self.error(key, format!("{other} is not a number"))),
            Number::Text(t) => t
                .parse::<f64>()
                .map_err(|_| self.error(key, format!("`{t}` is not a number"))),
        }
    }

    /// A count in `lo..=hi`: a whole number (`2`, `2.0`; not `2.5`, `-1` or `1e300`).
    pub fn count(&self, key: &str, v: Number<'_>, (lo, hi): (u64, u64)) -> Result<u64> {
        if let Number::Json(serde_json::Value::Number(n)) = &v {
            if let Some(u) = n.as_u64() {
                return self.count_range(key, u as f64, lo, hi).map(|_| u);
            }
        }
        let x = self.number(key, &v)?;
        self.count_range(key, x, lo, hi)?;
        Ok(x as u64)
    }

    fn count_range(&self, key: &str, x: f64, lo: u64, hi: u64) -> Result<()> {
        if x.fract() == 0.0 && x >= lo as f64 && x <= hi as f64 {
            return Ok(());
        }
        Err(self.error(
            key,
            format!(
                "{} is not a whole number from {lo} to {hi}, the range a run of hsph writes (the \
                 limits of its flags, src/limits.rs): the file is damaged or not one hsph wrote; \
                 run hsph again to write it",
                show(x)
            ),
        ))
    }

    /// A real in `lo..=hi`, finite.
    pub fn real(&self, key: &str, v: Number<'_>, (lo, hi): (f64, f64)) -> Result<f64> {
        let x = self.number(key, &v)?;
        if x.is_finite() && lo <= x && x <= hi {
            return Ok(x);
        }
        Err(self.error(
            key,
            format!(
                "{} is outside {} to {}, the range a run of hsph writes (src/limits.rs): the file \
                 is damaged or not one hsph wrote; run hsph again to write it",
                show(x),
                show(lo),
                show(hi)
            ),
        ))
    }
}

/// `x` as a message shows it: plain from 10⁻³ to 10¹⁰, else in scientific notation (a
/// `1e308` read is not printed as 309 digits).
fn show(x: f64) -> String {
    if x == 0.0 || !x.is_finite() || (1e-3..1e10).contains(&x.abs()) {
        format!("{x}")
    } else {
        format!("{x:e}")
    }
}

/// A number as a file holds it: a JSON value or a CSV field.
#[derive(Debug, Clone, Copy)]
pub enum Number<'v> {
    /// A JSON value (anything but a number is refused).
    Json(&'v serde_json::Value),
    /// The text of a CSV field.
    Text(&'v str),
}

/// Counts of a run's `summary.json` that `hsph model` and `hsph report` read, and their
/// ranges: the limits of the flags that set them.
pub const SUMMARY_COUNTS: [(&str, (u64, u64)); 9] = [
    ("ranks", (1, MAX_RANKS as u64)),
    ("threads", (1, MAX_THREADS as u64)),
    ("nodes", (1, MAX_RANKS as u64)),
    ("particles", (1, MAX_PARTICLES)),
    ("steps", (0, MAX_STEPS as u64)),
    ("dimension", (2, 3)),
    ("rebalances", (0, MAX_STEPS as u64)),
    ("segments", (1, MAX_STEPS as u64)),
    ("migrations", (0, MAX_TRAFFIC_BYTES)),
];

/// Reals of a run's `summary.json` that `hsph model` and `hsph report` read, and their ranges.
pub const SUMMARY_REALS: [(&str, (f64, f64)); 11] = [
    ("particles_mean", (1.0, MAX_PARTICLES as f64)),
    ("wall_s", (0.0, MAX_WALL_SECONDS)),
    ("t", (0.0, MAX_T_END)),
    ("t_end", (0.0, MAX_T_END)),
    ("particle_steps_per_s", (0.0, f64::MAX)),
    ("pair_interactions_per_s", (0.0, f64::MAX)),
    ("ghost_fraction", (0.0, f64::MAX)),
    ("imbalance", (0.0, MAX_RANKS as f64)),
    ("communication_fraction", (0.0, f64::MAX)),
    ("balance_fraction", (0.0, f64::MAX)),
    ("migrations_per_step", (0.0, f64::MAX)),
];

/// A run's `summary.json` read as `hsph model` and `hsph report` read it: through
/// [`read_text`] (at most [`MAX_INPUT_BYTES`]), a JSON object, every number they read within
/// its range ([`SUMMARY_COUNTS`], [`SUMMARY_REALS`]; the timers' seconds, the traffic's bytes
/// and messages, the decomposition's factors), and at most as many nodes as ranks. A key
/// absent is left to the reader (older runs lack some).
pub fn read_summary(path: &Path) -> Result<serde_json::Value> {
    let text = read_text(path, "summary.json")?;
    let s: serde_json::Value = serde_json::from_str(&text).map_err(|e| {
        file_error(
            path,
            "",
            Some(e.line()),
            format!("not valid JSON ({e}): not a summary.json hsph wrote"),
        )
    })?;
    let f = FileNumbers::of(path);
    let Some(map) = s.as_object() else {
        return Err(f.error("", "is not a JSON object: not a summary.json hsph wrote".into()));
    };
    let present = |k: &str| map.get(k).filter(|v| !v.is_null());
    for (k, range) in SUMMARY_COUNTS {
        if let Some(v) = present(k) {
            f.count(k, Number::Json(v), range)?;
        }
    }
    for (k, range) in SUMMARY_REALS {
        if let Some(v) = present(k) {
            f.real(k, Number::Json(v), range)?;
        }
    }
    if let (Some(r), Some(n)) = (present("ranks"), present("nodes")) {
        let (r, n) = (r.as_f64().unwrap_or(0.0), n.as_f64().unwrap_or(0.0));
        if n > r {
            return Err(f.error(
                "nodes",
                format!("{n} nodes for {r} ranks: a run has at most one node per rank"),
            ));
        }
    }
    if let Some(d) = present("decomposition") {
        let Some(a) = d.as_array().filter(|a| (1..=3).contains(&a.len())) else {
            return Err(f.error(
                "decomposition",
                "must list 1 to 3 factors (one per axis), as a run of hsph writes".into(),
            ));
        };
        for (i, x) in a.iter().enumerate() {
            f.count(
                &format!("decomposition[{i}]"),
                Number::Json(x),
                (1, MAX_RANKS as u64),
            )?;
        }
    }
    if let Some(t) = present("timers") {
        let Some(t) = t.as_object() else {
            return Err(f.error("timers", "must be a table of phases".into()));
        };
        for (phase, v) in t {
            for stat in ["min", "mean", "max"] {
                if let Some(x) = v.get(stat).filter(|x| !x.is_null()) {
                    f.real(
                        &format!("timers.{phase}.{stat}"),
                        Number::Json(x),
                        (0.0, MAX_WALL_SECONDS),
                    )?;
                }
            }
        }
    }
    if let Some(t) = present("traffic") {
        let bytes = (0, MAX_TRAFFIC_BYTES);
        for k in ["intra_node_bytes", "inter_node_bytes"] {
            if let Some(x) = t.get(k).filter(|x| !x.is_null()) {
                f.count(&format!("traffic.{k}"), Number::Json(x), bytes)?;
            }
        }
        if let Some(phases) = t.get("phases").and_then(|p| p.as_object()) {
            for (phase, v) in phases {
                for k in ["intra_node_bytes", "inter_node_bytes", "messages"] {
                    if let Some(x) = v.get(k).filter(|x| !x.is_null()) {
                        f.count(&format!("traffic.phases.{phase}.{k}"), Number::Json(x), bytes)?;
                    }
                }
            }
        }
        if let Some(c) = t.get("estimated_cost").and_then(|c| c.as_object()) {
            for (k, x) in c.iter().filter(|(_, x)| !x.is_null()) {
                f.real(
                    &format!("traffic.estimated_cost.{k}"),
                    Number::Json(x),
                    (f64::MIN, f64::MAX),
                )?;
            }
        }
    }
    Ok(s)
}

#[cfg(unix)]
fn is_fifo(ft: &std::fs::FileType) -> bool {
    std::os::unix::fs::FileTypeExt::is_fifo(ft)
}

#[cfg(not(unix))]
fn is_fifo(_: &std::fs::FileType) -> bool {
    false
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn counts_are_refused_at_zero_and_above_the_limit() {
        assert!(count("--x", 1, 3).is_ok());
        assert!(count("--x", 3, 3).is_ok());
        for v in [0, 4, u64::MAX] {
            let e = count("--x", v, 3).unwrap_err();
            assert_eq!(e.exit_code(), 2);
            assert!(e.to_string().contains("--x"), "{e}");
        }
        assert!(threads("--threads", MAX_THREADS + 1, 1).is_err());
        assert!(threads("--threads", 2, max_process_threads()).is_err());
        assert!(threads("--threads", 1, max_process_threads()).is_ok());
        assert!(ranks("--ranks", MAX_RANKS + 1).is_err());
    }

    /// More threads than cores is a warning that names what filled them: the threads of one
    /// rank, or the ranks of this process.
    #[test]
    fn oversubscription_names_the_ranks_or_the_threads() {
        let cores = std::thread::available_parallelism().map_or(1, |n| n.get());
        assert_eq!(threads("--threads", cores, 1).unwrap(), None);
        let one = threads("--threads", cores + 1, 1).unwrap().unwrap();
        assert!(
            one.starts_with(&format!("--threads {}: {} threads", cores + 1, cores + 1)),
            "{one}"
        );
        let ranks = threads("--threads", 1, cores + 1).unwrap().unwrap();
        assert!(
            ranks.starts_with(&format!(
                "1 thread(s) per rank × {} ranks in this process",
                cores + 1
            )) && ranks.contains("fewer ranks"),
            "{ranks}"
        );
    }

    #[test]
    fn devices_and_directories_are_not_read() {
        for p in ["/dev/zero", "/dev/null", "/"] {
            let e = read_text(Path::new(p), "SCENE").unwrap_err();
            assert_eq!(e.exit_code(), 2, "{p}: {e}");
        }
    }
}

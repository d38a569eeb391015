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
/// Most cells across a validation case's length scale (`hsph validate --resolutions`).
pub const MAX_RESOLUTION: u32 = 4096;

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
    let bad = |m: String| Error::Input {
        at: Some(crate::error::Location {
            file: path.to_path_buf(),
            line: None,
        }),
        key: key.to_string(),
        message: m,
    };
    let meta = std::fs::metadata(path).map_err(|e| bad(format!("cannot read: {e}")))?;
    let ft = meta.file_type();
    if !(ft.is_file() || is_fifo(&ft)) {
        return Err(bad(
            "is not a regular file (a directory or a device); give a TOML file, e.g. inputs/dam_break_2d.toml".into(),
        ));
    }
    if meta.len() > MAX_INPUT_BYTES {
        return Err(bad(format!(
            "is {} bytes, above the input limit of {MAX_INPUT_BYTES} bytes",
            meta.len()
        )));
    }
    let f = std::fs::File::open(path).map_err(|e| bad(format!("cannot read: {e}")))?;
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

//! Checkpoints: the complete state of a run at a step boundary, written by every rank in
//! parallel, and read back on any number of ranks.
//!
//! Layout: `<run>/checkpoints/step-<N>/part-<rank>.bin` (one per rank: its owned particles
//! sorted by id — every field of the particle table through the wire format, then the
//! acceleration a_n, which the next half kick needs and which cannot be recomputed because it
//! was evaluated with v_{n−½}, and with Verlet lists the positions at the last neighbour build,
//! from which a restart lists the same pairs in the same order) and `manifest.json` (format, code
//! version, step, t, dt, the resolved scene, the driver's state, and per part its particle count,
//! byte length and FNV-1a 64 checksum). Every file is written to a temporary name, synced and
//! renamed; the manifest is written last, so a checkpoint without one is incomplete and is skipped.
//! Once a manifest is in place the oldest checkpoints beyond `[checkpoint] keep` are deleted.
//!
//! Reading: every rank reads and checks every part (like the set-up, which builds the whole
//! lattice on every rank), then keeps the particles of its block. A missing, truncated or
//! corrupted part, a manifest that does not parse, or another dimension is bad input (exit 2)
//! naming the file.

pub mod compat;

use crate::comm::{Comm, Phase};
use crate::error::{Error, Location, Result};
use crate::particles::wire::{Reader, Words};
use crate::particles::{Particles, Record};
use crate::scene::Scene;
use crate::Vector;
use serde::{Deserialize, Serialize};
use std::fs;
use std::io::Write;
use std::path::{Path, PathBuf};

/// Version of the checkpoint layout.
/// 2: records carry the refinement level (docs/refinement.md §1).
pub const FORMAT: u32 = 2;
/// First bytes of a part file.
const MAGIC: &[u8; 8] = b"HSPHPART";

/// One rank's part as the manifest lists it.
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
pub struct PartInfo {
    /// File name inside the checkpoint directory.
    pub file: String,
    /// Particles in the part.
    pub particles: u64,
    /// Length of the file (bytes).
    pub bytes: u64,
    /// FNV-1a 64 of the whole file, hexadecimal.
    pub fnv1a64: String,
}

/// `manifest.json` of a checkpoint.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct Manifest {
    /// [`FORMAT`] of the writer.
    pub format: u32,
    /// Version of hsph that wrote it.
    pub hsph_version: String,
    /// Its git commit.
    pub git_commit: String,
    /// 2 or 3.
    pub dimension: usize,
    /// Steps taken.
    pub step: u64,
    /// Simulated time (s).
    pub t: f64,
    /// Time step of the next step (s).
    pub dt: f64,
    /// The id the next created particle takes ([`crate::ids`]); absent in checkpoints of
    /// hsph before splitting (docs/splitting.md §4), which created none (the set-up's id bound then).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub next_id: Option<u64>,
    /// True if each part ends with its particles' positions at the last neighbour build
    /// (Verlet lists, `performance.neighbours = "verlet"`).
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub build_positions: bool,
    /// Ranks that wrote it (one part each).
    pub ranks: usize,
    /// The parts.
    pub parts: Vec<PartInfo>,
    /// The resolved scene (TOML).
    pub scene: String,
    /// The driver's state: output and probe clocks, series lengths, reference history.
    pub run: serde_json::Value,
}

/// Where a run stands at a step boundary: what a checkpoint records besides the particles.
/// The caller (the driver, from its simulation) builds it; checkpoints know nothing of the
/// simulation's other state.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Clock {
    /// Steps taken.
    pub step: u64,
    /// Simulated time (s).
    pub t: f64,
    /// Time step of the next step (s).
    pub dt: f64,
    /// The id the next created particle takes ([`crate::ids::IdCounter::next`]).
    pub next_id: u64,
}

/// FNV-1a, 64 bit (Fowler, Noll & Vo): a checksum against torn and flipped bytes.
pub fn fnv1a64(bytes: &[u8]) -> u64 {
    let mut h: u64 = 0xcbf2_9ce4_8422_2325;
    for &b in bytes {
        h ^= b as u64;
        h = h.wrapping_mul(0x0000_0100_0000_01b3);
    }
    h
}

/// Write `bytes` to `path` through `<path>.tmp`, synced, then renamed. On any failure (a full
/// disk, a quota) the temporary file is removed, so a failed checkpoint leaves nothing that
/// holds space or a later restart would trip over.
fn write_synced(path: &Path, bytes: &[u8]) -> Result<()> {
    let tmp = path.with_extension("tmp");
    let io = |e| Error::io(path, e);
    let result = crate::files::create_file(&tmp).and_then(|mut f| {
        f.write_all(bytes).map_err(io)?;
        f.sync_all().map_err(io)?;
        drop(f);
        fs::rename(&tmp, path).map_err(io)
    });
    if result.is_err() {
        let _ = fs::remove_file(&tmp);
    }
    result
}

/// The directory of the checkpoint at `step` under the run directory `run`.
pub fn dir_of(run: &Path, step: u64) -> PathBuf {
    run.join("checkpoints").join(format!("step-{step:010}"))
}

/// This rank's part: header, owned records of `p` sorted by id, then their accelerations, then
/// (Verlet lists; `built` in storage order, empty otherwise) their positions at the last
/// neighbour build.
fn encode<const D: usize>(p: &Particles<D>, built: &[Vector<D>]) -> Vec<u8> {
    let mut order: Vec<usize> = (0..p.n_owned).collect();
    order.sort_unstable_by_key(|&i| p.id[i]);
    let mut buf = Vec::with_capacity(24 + order.len() * (Record::<D>::words() + D) * 8);
    buf.extend_from_slice(MAGIC);
    buf.extend_from_slice(&FORMAT.to_le_bytes());
    buf.extend_from_slice(&(D as u32).to_le_bytes());
    buf.extend_from_slice(&(order.len() as u64).to_le_bytes());
    for &i in &order {
        p.record(i).put(&mut Words::new(&mut buf));
    }
    for &i in &order {
        for a in 0..D {
            buf.extend_from_slice(&p.acc[i][a].to_le_bytes());
        }
    }
    if !built.is_empty() {
        for &i in &order {
            for c in built[i].iter() {
                buf.extend_from_slice(&c.to_le_bytes());
            }
        }
    }
    buf
}

/// A rank's share of a checkpoint: particles sorted by id, their accelerations (m/s²) and,
/// from a run with Verlet lists, their positions at the last neighbour build (m; else empty).
pub type Share<const D: usize> = (Particles<D>, Vec<Vector<D>>, Vec<Vector<D>>);

/// Collective: write the checkpoint of step `clock.step` under `run` — every rank its part
/// (its owned particles `p` with their accelerations and, with Verlet lists, `built`: their
/// positions at the last neighbour build, in storage order), then rank 0 the manifest with the
/// clock, the resolved `scene` and `state` (the driver's state, rank 0's) — and delete the
/// oldest beyond `keep`. Returns the checkpoint's directory.
pub fn write<const D: usize>(
    (p, clock, scene, built): (&Particles<D>, Clock, &Scene, &[Vector<D>]),
    comm: &dyn Comm,
    run: &Path,
    state: Option<serde_json::Value>,
    keep: usize,
) -> Result<PathBuf> {
    let dir = dir_of(run, clock.step);
    fs::create_dir_all(&dir).map_err(|e| Error::io(&dir, e))?;
    let bytes = encode(p, built);
    let file = part_name(comm.rank());
    if let Err(e) = write_synced(&dir.join(&file), &bytes) {
        // the checkpoint is incomplete (no manifest will follow): leave no empty directory
        let _ = fs::remove_dir(&dir);
        return Err(e);
    }
    let info = PartInfo {
        file,
        particles: p.n_owned as u64,
        bytes: bytes.len() as u64,
        fnv1a64: format!("{:016x}", fnv1a64(&bytes)),
    };
    let prev = comm.set_phase(Phase::Output);
    let infos = comm.all_gather_bytes(serde_json::to_vec(&info).map_err(|e| Error::run(e.to_string()))?);
    comm.set_phase(prev);
    let infos = infos?;
    if let Ok(step) = std::env::var("HSPH_TEST_ABORT_IN_CHECKPOINT") {
        // test-only: die like kill -9 after the parts, before the manifest
        if step.parse() == Ok(clock.step) {
            std::process::abort();
        }
    }
    if comm.rank() != 0 {
        return Ok(dir);
    }
    let parts = infos
        .iter()
        .map(|b| serde_json::from_slice(b).map_err(|e| Error::run(format!("checkpoint part list: {e}"))))
        .collect::<Result<Vec<PartInfo>>>()?;
    let manifest = Manifest {
        format: FORMAT,
        hsph_version: env!("CARGO_PKG_VERSION").into(),
        git_commit: env!("HSPH_GIT_COMMIT").into(),
        dimension: D,
        step: clock.step,
        t: clock.t,
        dt: clock.dt,
        next_id: Some(clock.next_id),
        build_positions: !built.is_empty(),
        ranks: comm.size(),
        parts,
        scene: toml::to_string(scene).map_err(|e| Error::run(format!("checkpoint scene: {e}")))?,
        run: state.unwrap_or(serde_json::Value::Null),
    };
    let text = serde_json::to_vec_pretty(&manifest).map_err(|e| Error::run(e.to_string()))?;
    write_synced(&dir.join("manifest.json"), &text)?;
    if let Ok(d) = fs::File::open(&dir) {
        let _ = d.sync_all();
    }
    prune(run, keep);
    Ok(dir)
}

/// Complete checkpoints under `run`, oldest first.
fn complete(run: &Path) -> Vec<PathBuf> {
    let mut dirs: Vec<PathBuf> = fs::read_dir(run.join("checkpoints"))
        .map(|rd| rd.filter_map(|e| e.ok().map(|e| e.path())).collect())
        .unwrap_or_default();
    dirs.retain(|d| d.join("manifest.json").is_file());
    dirs.sort();
    dirs
}

/// Delete the oldest complete checkpoints beyond `keep` and any incomplete one older than the
/// newest complete one.
fn prune(run: &Path, keep: usize) {
    let done = complete(run);
    let Some(newest) = done.last().cloned() else {
        return;
    };
    for d in done.iter().take(done.len().saturating_sub(keep)) {
        let _ = fs::remove_dir_all(d);
    }
    if let Ok(rd) = fs::read_dir(run.join("checkpoints")) {
        for e in rd.flatten() {
            let d = e.path();
            if d < newest && !d.join("manifest.json").is_file() {
                let _ = fs::remove_dir_all(&d);
            }
        }
    }
}

fn bad(path: &Path, message: impl Into<String>) -> Error {
    Error::Input {
        at: Some(Location {
            file: path.to_path_buf(),
            line: None,
        }),
        key: "--restart".into(),
        message: message.into(),
    }
}

/// The checkpoint `path` names: a checkpoint directory (with `manifest.json`), or a run
/// directory, whose newest complete checkpoint is taken.
pub fn locate(path: &Path) -> Result<PathBuf> {
    if path.join("manifest.json").is_file() {
        return Ok(path.to_path_buf());
    }
    if path.is_dir() {
        if let Some(d) = complete(path).pop() {
            return Ok(d);
        }
        return Err(bad(
            path,
            "holds no complete checkpoint (a checkpoint directory has a manifest.json; runs write \
             them with [checkpoint] every_steps or every, and when stopped by a signal)",
        ));
    }
    Err(bad(path, "no such checkpoint or run directory"))
}

/// The run directory a checkpoint directory belongs to: the parent of its `checkpoints/`
/// folder. A checkpoint anywhere else (copied out of its run, or into another run's folder
/// under another name) has no run directory whose series it may cut: bad input.
pub fn run_dir_of(checkpoint: &Path) -> Result<PathBuf> {
    let parent = checkpoint.parent().filter(|p| !p.as_os_str().is_empty());
    let named = |p: &Path| p.file_name().is_some_and(|n| n == "checkpoints");
    let step_dir = checkpoint
        .file_name()
        .and_then(|n| n.to_str())
        .and_then(|n| n.strip_prefix("step-"))
        .is_some_and(|d| d.len() == 10 && d.bytes().all(|b| b.is_ascii_digit()));
    match parent.and_then(|p| named(p).then(|| p.parent()).flatten()) {
        Some(run) if step_dir => Ok(if run.as_os_str().is_empty() {
            PathBuf::from(".")
        } else {
            run.to_path_buf()
        }),
        _ => Err(bad(
            checkpoint,
            "is not inside a run directory: a checkpoint continues the run it belongs to, \
             RUNDIR/checkpoints/step-NNNNNNNNNN; give that path or the run directory itself",
        )),
    }
}

/// Read a checkpoint's manifest.
pub fn manifest(dir: &Path) -> Result<Manifest> {
    let path = dir.join("manifest.json");
    let text = crate::limits::read_text(&path, "--restart")?;
    let m: Manifest =
        serde_json::from_str(&text).map_err(|e| bad(&path, format!("not a checkpoint manifest: {e}")))?;
    if m.format != FORMAT {
        return Err(bad(
            &path,
            format!("checkpoint format {} (this hsph reads format {FORMAT})", m.format),
        ));
    }
    m.check().map_err(|e| bad(&path, e))?;
    Ok(m)
}

/// The id counter a restart continues from: the manifest's `next_id`, or the set-up's id
/// `bound` for a checkpoint written before the counter was recorded (nothing was created
/// then). A counter below `bound` would give created particles the ids of lattice sites: bad
/// input.
pub fn next_id(dir: &Path, m: &Manifest, bound: u64) -> Result<u64> {
    match m.next_id {
        None => Ok(bound),
        Some(next) if next >= bound => Ok(next),
        Some(next) => Err(bad(
            &dir.join("manifest.json"),
            format!(
                "next_id = {next} is below the scene's lattice ids (up to {bound}): created \
                 particles would reuse them"
            ),
        )),
    }
}

/// The part file rank `rank` writes.
pub fn part_name(rank: usize) -> String {
    format!("part-{rank:05}.bin")
}

/// The ids of a share of a checkpoint (sorted, as [`share`] returns them) are unique and below
/// the id counter `next` ([`next_id`]): a part with an id twice, or with ids of created
/// particles but no counter that accounts for them, is bad input (it would give two particles
/// one id, or a created particle the id of another).
pub fn check_ids(dir: &Path, m: &Manifest, ids: &[u64], next: u64) -> Result<()> {
    let manifest = dir.join("manifest.json");
    if let Some(w) = ids.windows(2).find(|w| w[0] >= w[1]) {
        return Err(bad(
            &manifest,
            format!(
                "the parts hold particle id {} twice: each particle is in one part, once",
                w[1]
            ),
        ));
    }
    match ids.last() {
        Some(&last) if last >= next => Err(bad(
            &manifest,
            format!(
                "a part holds particle id {last}, not below the id counter {next} ({}): ids of \
                 particles created by splitting need the next_id that counted them",
                if m.next_id.is_some() {
                    "the manifest's next_id"
                } else {
                    "the scene's lattice id bound: the manifest has no next_id"
                }
            ),
        )),
        _ => Ok(()),
    }
}

/// Whether `name` is a part file name this hsph writes: `part-<digits>.bin`, a plain name
/// inside the checkpoint directory (no separator, no `..`, nothing absolute).
pub fn is_part_name(name: &str) -> bool {
    name.strip_prefix("part-")
        .and_then(|r| r.strip_suffix(".bin"))
        .is_some_and(|d| !d.is_empty() && d.len() <= 10 && d.bytes().all(|b| b.is_ascii_digit()))
}

impl Manifest {
    /// A manifest is input: its numbers must be finite and consistent, its part names plain
    /// file names, its counts within the limits, before any part is opened.
    pub fn check(&self) -> std::result::Result<(), String> {
        if !(self.dimension == 2 || self.dimension == 3) {
            return Err(format!("dimension {} (2 or 3)", self.dimension));
        }
        if !(self.t.is_finite() && self.t >= 0.0) {
            return Err(format!("t = {:e} is not a finite time ≥ 0 s", self.t));
        }
        if !(self.dt.is_finite() && self.dt > 0.0) {
            return Err(format!("dt = {:e} is not a finite time step > 0 s", self.dt));
        }
        if self.ranks == 0 || self.ranks > crate::limits::MAX_RANKS || self.parts.len() != self.ranks {
            return Err(format!(
                "{} parts for {} ranks (1 to {} ranks, one part each)",
                self.parts.len(),
                self.ranks,
                crate::limits::MAX_RANKS
            ));
        }
        if let Some(next) = self.next_id.filter(|&n| n > crate::ids::ID_LIMIT) {
            return Err(format!("next_id = {next} is above the id limit 2^54"));
        }
        let mut total = 0u64;
        for (k, p) in self.parts.iter().enumerate() {
            if !is_part_name(&p.file) {
                return Err(format!(
                    "parts[{k}].file = {:?} is not a part file name (part-NNNNN.bin inside the checkpoint)",
                    p.file
                ));
            }
            // rank k wrote part k: a part listed twice, or out of place, would load its
            // particles twice
            if p.file != part_name(k) {
                return Err(format!(
                    "parts[{k}].file = {:?}, but rank {k} writes {:?}: each part is listed once, in \
                     rank order",
                    p.file,
                    part_name(k)
                ));
            }
            total = total.saturating_add(p.particles);
        }
        if total > crate::limits::MAX_PARTICLES {
            return Err(format!(
                "{total} particles, above the limit of {}",
                crate::limits::MAX_PARTICLES
            ));
        }
        Ok(())
    }
}

/// Every particle of a checkpoint, sorted by id, with the acceleration of each (m/s²), after
/// checking every part against the manifest.
pub fn particles<const D: usize>(dir: &Path, m: &Manifest) -> Result<Share<D>> {
    particles_of_parts(dir, m, |_| true)
}

/// Rank `rank`'s share of a checkpoint among `ranks`: the particles of the parts `k` with
/// `k % ranks == rank` (sorted by id), each part checked against the manifest. A restart
/// reads the checkpoint this way, so no rank holds the whole of it (README, "Checkpoints and
/// restart"); the particles then migrate to their owners.
pub fn share<const D: usize>(dir: &Path, m: &Manifest, rank: usize, ranks: usize) -> Result<Share<D>> {
    particles_of_parts(dir, m, |k| k % ranks.max(1) == rank)
}

/// The particles of the parts that `read` selects (by index in the manifest), sorted by id,
/// with their accelerations (and build positions).
fn particles_of_parts<const D: usize>(
    dir: &Path,
    m: &Manifest,
    read: impl Fn(usize) -> bool,
) -> Result<Share<D>> {
    if m.dimension != D {
        return Err(bad(
            &dir.join("manifest.json"),
            format!("a {}D checkpoint, not {D}D", m.dimension),
        ));
    }
    let mut all = Particles::<D>::default();
    let mut acc = Vec::new();
    let mut built = Vec::new();
    // vectors per particle after its record: a, then the build position
    let vectors = 1 + usize::from(m.build_positions);
    for (k, part) in m.parts.iter().enumerate() {
        if !read(k) {
            continue;
        }
        let path = dir.join(&part.file);
        let need = 24 + part.particles as u128 * ((Record::<D>::words() + vectors * D) * 8) as u128;
        if need != part.bytes as u128 {
            return Err(bad(
                &path,
                format!(
                    "the manifest says {} bytes for {} particles, which take {need}",
                    part.bytes, part.particles
                ),
            ));
        }
        let len = fs::metadata(&path)
            .map_err(|e| bad(&path, format!("checkpoint part missing or unreadable: {e}")))?;
        if !len.is_file() || len.len() != part.bytes {
            return Err(bad(
                &path,
                format!(
                    "checkpoint part is {} bytes, the manifest says {} (truncated?)",
                    len.len(),
                    part.bytes
                ),
            ));
        }
        let bytes =
            fs::read(&path).map_err(|e| bad(&path, format!("checkpoint part missing or unreadable: {e}")))?;
        if bytes.len() as u64 != part.bytes {
            return Err(bad(
                &path,
                format!(
                    "checkpoint part is {} bytes, the manifest says {} (truncated?)",
                    bytes.len(),
                    part.bytes
                ),
            ));
        }
        if format!("{:016x}", fnv1a64(&bytes)) != part.fnv1a64 {
            return Err(bad(
                &path,
                "checkpoint part is corrupt: its checksum differs from the manifest's",
            ));
        }
        let into = (&mut acc, &mut built);
        decode(&bytes, part.particles as usize, &mut all, into, m.build_positions)
            .map_err(|e| bad(&path, e))?;
    }
    let mut perm: Vec<usize> = (0..all.n_owned).collect();
    perm.sort_unstable_by_key(|&i| all.id[i]);
    all.permute_owned(&perm);
    let acc = perm.iter().map(|&i| acc[i]).collect();
    let built = if built.is_empty() {
        built
    } else {
        perm.iter().map(|&i| built[i]).collect()
    };
    Ok((all, acc, built))
}

/// Append the particles of one part to `all`, their accelerations to `acc` and, if the part
/// holds them (`with_built`), their build positions to `built`.
fn decode<const D: usize>(
    bytes: &[u8],
    n: usize,
    all: &mut Particles<D>,
    (acc, built): (&mut Vec<Vector<D>>, &mut Vec<Vector<D>>),
    with_built: bool,
) -> std::result::Result<(), String> {
    let rec = Record::<D>::words() * 8;
    let need = 24 + n * (rec + (1 + usize::from(with_built)) * D * 8);
    if bytes.len() != need || &bytes[..8] != MAGIC {
        return Err(format!("not a {D}D checkpoint part of {n} particles"));
    }
    let word = |k: usize| u32::from_le_bytes(bytes[k..k + 4].try_into().unwrap());
    if word(8) != FORMAT || word(12) as usize != D {
        return Err("checkpoint part of another format or dimension".into());
    }
    let mut r = Reader::new(&bytes[24..24 + n * rec]);
    for _ in 0..n {
        all.push_owned(Record::get(&mut r).map_err(|e| e.to_string())?);
    }
    let vector = |k: usize| {
        Vector::<D>::from_fn(|a, _| {
            let o = 24 + n * rec + (k * D + a) * 8;
            f64::from_le_bytes(bytes[o..o + 8].try_into().unwrap())
        })
    };
    acc.extend((0..n).map(vector));
    if with_built {
        built.extend((n..2 * n).map(vector));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    /// Manifests and run states carry t, dt and sensor histories as JSON numbers: they must
    /// read back to the same bits. serde_json's default float parser is off by an ulp on
    /// values like this dt (a restart of the dam break at step 4791 drifted from it); the
    /// `float_roundtrip` feature parses exactly.
    #[test]
    fn json_floats_read_back_to_the_same_bits() {
        let mut x = 5.3538864107729036e-5_f64;
        let mut rng = 0x9e37_79b9_7f4a_7c15_u64;
        for _ in 0..20_000 {
            let text = serde_json::to_string(&serde_json::json!({ "dt": x })).unwrap();
            let back: serde_json::Value = serde_json::from_str(&text).unwrap();
            assert_eq!(back["dt"].as_f64().unwrap().to_bits(), x.to_bits(), "{text}");
            // splitmix64 over the exponent range of time steps and times (1e-9 .. 1e3)
            rng = rng.wrapping_add(0x9e37_79b9_7f4a_7c15);
            let mut z = rng;
            z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
            z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
            z ^= z >> 31;
            x = 10f64.powf(-9.0 + 12.0 * (z >> 11) as f64 / (1u64 << 53) as f64);
        }
    }
}

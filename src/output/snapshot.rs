//! The snapshot-writer seam: every snapshot format implements [`SnapshotWriter`] and every rank
//! holds one (made by [`super::writers::writer_for`], which knows the formats; this file names
//! none of them). Snapshots are written in parallel: each rank writes the piece it owns (its owned
//! particles in id order) and rank 0 writes the index that names every piece (`.pvtu` + `.pvd`
//! for VTK, `series.json` for netCDF), so no rank ever holds all particles for output.
//! Writers read fields through the particle table's columns
//! ([`crate::particles::Particles::column`]) with their units and long names
//! ([`crate::particles::FieldMeta`]).
//!
//! Layout of `snapshots/` (snapshot `k`, piece of rank `r`):
//! `snapshot_0000k/rank_000r.{vtu,nc}`, with `snapshot_0000k.pvtu` and `series.pvd` (VTK) or
//! `series.json` (netCDF) beside them.

use crate::error::{Error, Result};
use crate::particles::Particles;
use crate::scene::Scene;
use std::path::{Path, PathBuf};

/// One rank's share of a snapshot.
pub struct Piece<'a, const D: usize> {
    /// The rank's particle store (owned particles first).
    pub p: &'a Particles<D>,
    /// Indices of its owned particles in id order.
    pub order: Vec<usize>,
    /// Simulated time (s).
    pub t: f64,
    /// Steps taken.
    pub step: u64,
    /// This rank and the number of ranks (= pieces).
    pub rank: usize,
    /// Number of ranks.
    pub ranks: usize,
    /// The resolved scene.
    pub scene: &'a Scene,
}

impl<'a, const D: usize> Piece<'a, D> {
    /// The owned particles of `p` in id order, at `t` after `step` steps.
    pub fn new(
        p: &'a Particles<D>,
        (t, step): (f64, u64),
        (rank, ranks): (usize, usize),
        scene: &'a Scene,
    ) -> Self {
        let mut order: Vec<usize> = (0..p.n_owned).collect();
        order.sort_unstable_by_key(|&i| p.id[i]);
        Piece {
            p,
            order,
            t,
            step,
            rank,
            ranks,
            scene,
        }
    }
}

/// One snapshot in the index: its time, step and number of pieces.
#[derive(Debug, Clone, serde::Serialize, serde::Deserialize, PartialEq)]
pub struct Entry {
    /// Simulated time (s).
    pub t: f64,
    /// Steps taken.
    pub step: u64,
    /// Pieces (ranks that wrote it).
    pub pieces: usize,
}

/// Directory of snapshot `k`'s pieces, relative to `snapshots/`.
pub fn piece_dir(k: usize) -> String {
    format!("snapshot_{k:05}")
}

/// Piece of `rank` of snapshot `k` with extension `ext`, relative to `snapshots/`.
pub fn piece_name(k: usize, rank: usize, ext: &str) -> String {
    format!("{}/rank_{rank:04}.{ext}", piece_dir(k))
}

/// The bookkeeping every format shares: the directory, the snapshots written so far (each
/// rank keeps the list, rank 0 writes it into the index).
#[derive(Debug, Clone)]
pub struct Series {
    /// `snapshots/` of the run.
    pub dir: PathBuf,
    /// Snapshots written so far.
    pub entries: Vec<Entry>,
}

impl Series {
    /// Snapshots go into `dir` (created).
    pub fn new(dir: &Path) -> Result<Self> {
        std::fs::create_dir_all(dir).map_err(|e| Error::io(dir, e))?;
        Ok(Series {
            dir: dir.to_path_buf(),
            entries: Vec::new(),
        })
    }

    /// Start snapshot number `entries.len()` for `piece`: its directory (created) and the path
    /// of this rank's piece with extension `ext`.
    pub fn next_piece<const D: usize>(&self, piece: &Piece<D>, ext: &str) -> Result<PathBuf> {
        let k = self.entries.len();
        let d = self.dir.join(piece_dir(k));
        std::fs::create_dir_all(&d).map_err(|e| Error::io(&d, e))?;
        Ok(self.dir.join(piece_name(k, piece.rank, ext)))
    }

    /// Record the snapshot just written.
    pub fn push<const D: usize>(&mut self, piece: &Piece<D>) {
        self.entries.push(Entry {
            t: piece.t,
            step: piece.step,
            pieces: piece.ranks,
        });
    }

    /// The list for a checkpoint.
    pub fn state(&self) -> serde_json::Value {
        serde_json::json!(self.entries)
    }

    /// Continue from a checkpoint's list; false if the checkpoint has none (no snapshots).
    pub fn restore(&mut self, state: &serde_json::Value) -> Result<bool> {
        if state.is_null() {
            return Ok(false);
        }
        self.entries = serde_json::from_value(state.clone())
            .map_err(|e| Error::run(format!("checkpoint: snapshot list: {e}")))?;
        Ok(true)
    }

    /// Rank 0, on a restart, after the index was written again from the restored list: remove
    /// the snapshots an interrupted run wrote after the checkpoint, so that none of their
    /// pieces lingers beside the new ones (every rank's next write comes after a collective of
    /// the next step, hence after this).
    pub fn remove_later(&self) -> Result<()> {
        let rd = std::fs::read_dir(&self.dir).map_err(|e| Error::io(&self.dir, e))?;
        for e in rd.flatten() {
            let name = e.file_name().to_string_lossy().into_owned();
            let k = name
                .strip_prefix("snapshot_")
                .and_then(|s| s.split('.').next())
                .and_then(|s| s.parse::<usize>().ok());
            if k.is_some_and(|k| k >= self.entries.len()) {
                let p = e.path();
                let r = if p.is_dir() {
                    std::fs::remove_dir_all(&p)
                } else {
                    std::fs::remove_file(&p)
                };
                r.map_err(|e| Error::io(&p, e))?;
            }
        }
        Ok(())
    }
}

/// Writes one snapshot per output step, in parallel.
pub trait SnapshotWriter<const D: usize> {
    /// Every rank, at every output step: write this rank's `piece` with the snapshot `fields`
    /// (`output.fields`); rank 0 also updates the index that lists every piece.
    fn write(&mut self, piece: &Piece<D>, fields: &[String]) -> Result<()>;

    /// What a restart needs to continue the series (the snapshots written so far).
    fn state(&self) -> serde_json::Value;

    /// Continue from `state` (from [`SnapshotWriter::state`] of the same format); `clean` on
    /// rank 0 only: the index written again for the restored list, then the later snapshots
    /// removed ([`Series::remove_later`]), so the index never names a removed file.
    fn restore(&mut self, state: &serde_json::Value, clean: bool) -> Result<()>;
}

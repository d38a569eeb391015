//! Flow frames (`output.frames`): at the first step at or past each of the scene's times,
//! every rank writes its owned particles in id order as `frames/frame_KK/rank_RRRR.csv`
//! (the columns of `final.csv`), and rank 0 writes `frames/frame_KK.json` (the time asked
//! for, the step's time and number, the pieces). `hsph report` draws each frame coloured by
//! pressure (`crate::report::flow`).
//!
//! No rank gathers another's particles and no collective is needed: every rank knows from
//! the step's times alone which frames are due. Which frames a step writes depends on the
//! times before and after it only, so a run continued from a checkpoint writes the frames
//! after the checkpoint again, with the same bits.

use super::rank::RankRun;
use crate::error::{Error, Result};
use crate::output::snapshot::Piece;
use std::ops::Range;
use std::path::PathBuf;

/// The frames (indices into the ascending `frames`) that a step from `t0` to `t1` (s) is the
/// first at or past: those whose time lies in (t0, t1], with the output schedule's relative
/// tolerance of 1e-12.
pub fn due(frames: &[f64], t0: f64, t1: f64) -> Range<usize> {
    let reached = |t: f64| frames.partition_point(|&f| f * (1.0 - 1e-12) <= t);
    reached(t0)..reached(t1)
}

/// The directory of frame `k`'s pieces, under the run directory.
pub fn frame_dir(k: usize) -> PathBuf {
    PathBuf::from("frames").join(format!("frame_{k:02}"))
}

impl<const D: usize> RankRun<'_, D> {
    /// The frames due after a step that began at `t0` (s): this rank's pieces, and on rank 0
    /// their index entries.
    pub(super) fn write_frames(&mut self, t0: f64) -> Result<()> {
        let frames = self.scene.output.frames.as_deref().unwrap_or_default();
        let ks = due(frames, t0, self.sim.t);
        if ks.is_empty() {
            return Ok(());
        }
        let sim = &self.sim;
        let (rank, ranks) = (self.comm.rank(), self.comm.size());
        let piece = Piece::new(&sim.p, (sim.t, sim.step), (rank, ranks), &sim.scene);
        for k in ks {
            let dir = self.dir.join(frame_dir(k));
            std::fs::create_dir_all(&dir).map_err(|e| Error::io(&dir, e))?;
            let path = dir.join(format!("rank_{rank:04}.csv"));
            crate::output::write_final(&path, &sim.p, &piece.order)?;
            if rank == 0 {
                let entry = serde_json::json!({
                    "requested_t": frames[k],
                    "t": sim.t,
                    "step": sim.step,
                    "pieces": ranks,
                });
                let text = serde_json::to_string_pretty(&entry).map_err(|e| Error::run(e.to_string()))?;
                let index = self.dir.join("frames").join(format!("frame_{k:02}.json"));
                crate::files::write_file(&index, format!("{text}\n").as_bytes())?;
            }
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::due;

    /// A step writes the frames whose times it reaches, each once: none before the first,
    /// two when one step passes both, none again at the next step, and a time reached to
    /// within 1e-12 counts as reached.
    #[test]
    fn a_step_writes_the_frames_it_reaches_once() {
        let f = [0.1, 0.2, 0.25, 0.5];
        assert_eq!(due(&f, 0.0, 0.05), 0..0);
        assert_eq!(due(&f, 0.05, 0.1), 0..1);
        assert_eq!(due(&f, 0.1, 0.15), 1..1);
        assert_eq!(due(&f, 0.15, 0.26), 1..3);
        assert_eq!(due(&f, 0.26, 0.5 * (1.0 - 1e-13)), 3..4);
        assert_eq!(due(&f, 0.5, 0.6), 4..4);
        assert_eq!(due(&[], 0.0, 1.0), 0..0);
    }
}

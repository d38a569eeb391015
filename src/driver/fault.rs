//! Test-only fault injection: a rank that panics, a non-finite position or a SIGTERM at a
//! given step (and `HSPH_TEST_STEP_DELAY_MS`), so tests can make a run fail.

use super::rank::RankRun;

/// A test-only fault: make `rank` fail at `step`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Fault {
    /// Failing rank.
    pub rank: usize,
    /// Step at which it fails.
    pub step: u64,
    /// How it fails.
    pub kind: FaultKind,
}

impl Fault {
    /// The fault named by the test-only environment variable `HSPH_TEST_FAULT=RANK:STEP:KIND`
    /// (KIND `panic` or `nan`), so tests can make a rank of an `mpirun` job fail.
    pub fn from_env() -> Option<Fault> {
        let v = std::env::var("HSPH_TEST_FAULT").ok()?;
        let f: Vec<&str> = v.split(':').collect();
        let kind = match f.get(2).copied() {
            Some("panic") => FaultKind::Panic,
            Some("nan") => FaultKind::Nan,
            Some("signal") => FaultKind::Signal,
            _ => return None,
        };
        Some(Fault {
            rank: f.first()?.parse().ok()?,
            step: f.get(1)?.parse().ok()?,
            kind,
        })
    }
}

/// How an injected fault fails.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum FaultKind {
    /// The rank panics.
    Panic,
    /// One of the rank's particles gets a non-finite position (caught by the state check).
    Nan,
    /// The rank records a SIGTERM at that step, as if one had arrived (the stop contract), for
    /// this run only: other runs in the process (the test suite's) never see it.
    Signal,
}

impl<'a, const D: usize> RankRun<'a, D> {
    /// The test-only fault of `opts`, if it is due on this rank now.
    pub(super) fn inject_fault(&mut self) {
        // test-only: `HSPH_TEST_STEP_DELAY_MS=N` sleeps N ms before every step, so that a
        // small run outlasts a real scheduler time limit on any machine (the Slurm CI test);
        // the physics and its bits are untouched
        static DELAY: std::sync::OnceLock<Option<u64>> = std::sync::OnceLock::new();
        let delay = DELAY.get_or_init(|| {
            std::env::var("HSPH_TEST_STEP_DELAY_MS")
                .ok()
                .and_then(|v| v.parse::<u64>().ok())
        });
        if let Some(ms) = *delay {
            std::thread::sleep(std::time::Duration::from_millis(ms));
        }
        if let Some(f) = self.opts.fault {
            if f.rank == self.comm.rank() && f.step == self.sim.step + 1 {
                match f.kind {
                    FaultKind::Panic => panic!("injected fault on rank {} at step {}", f.rank, f.step),
                    FaultKind::Nan => self.sim.p.x[0][0] = f64::NAN,
                    FaultKind::Signal => self.injected_signal = signal_hook::consts::SIGTERM as usize,
                }
            }
        }
    }
}

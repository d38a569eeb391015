//! Wall-clock timers of the step's phases (`diagnostics.csv`, `summary.json`): machine
//! dependent, so never in the files compared for determinism.

use std::time::Instant;

/// A timed phase of the step.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Timer {
    /// Reordering, binning and neighbour lists.
    Neighbours,
    /// The passes that walk neighbour lists.
    Forces,
    /// Kicks, drift, density update, checks.
    Integrate,
    /// Ghost builds and refreshes.
    Halo,
    /// Migration of particles between ranks.
    Migration,
    /// Load-balance checks and rebalancing.
    Balance,
    /// Output steps.
    Output,
}

impl Timer {
    /// Every phase, in the order of `diagnostics.csv`.
    pub const ALL: [Timer; 7] = [
        Timer::Neighbours,
        Timer::Forces,
        Timer::Integrate,
        Timer::Halo,
        Timer::Migration,
        Timer::Balance,
        Timer::Output,
    ];

    /// Column stem in `diagnostics.csv` and key in `summary.json` (`<name>_s`).
    pub const fn name(self) -> &'static str {
        PHASES[self as usize]
    }
}

/// Names of the timed phases, in the order of [`Timer::ALL`].
pub const PHASES: [&str; 7] = [
    "neighbours",
    "forces",
    "integrate",
    "halo",
    "migration",
    "balance",
    "output",
];

/// Wall-clock seconds spent per phase.
#[derive(Debug, Clone, Default)]
pub struct PhaseTimers {
    /// Seconds per phase, indexed by [`Timer`].
    pub seconds: [f64; 7],
}

impl PhaseTimers {
    /// Add the time since `t0` to `phase`.
    #[inline]
    pub fn add(&mut self, phase: Timer, t0: Instant) {
        self.seconds[phase as usize] += t0.elapsed().as_secs_f64();
    }

    /// Seconds of `phase` so far.
    pub fn get(&self, phase: Timer) -> f64 {
        self.seconds[phase as usize]
    }
}

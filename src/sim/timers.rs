//! Wall-clock timers of the step's phases (`diagnostics.csv`, `summary.json`) and of each
//! pass of the step (`summary.json`'s `pass_timers`): machine dependent, so never in the
//! files compared for determinism.

use crate::physics::passes::{self, Pass};
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

/// Wall-clock seconds spent per phase, and per pass of the step.
#[derive(Debug, Clone, Default)]
pub struct PhaseTimers {
    /// Seconds per phase, indexed by [`Timer`].
    pub seconds: [f64; 7],
    /// Seconds per pass, indexed by [`Pass`] (the order of [`passes::ALL`]). A pass's time is
    /// also in its phase's: `forces` for the passes that walk neighbours, `integrate` for the
    /// others.
    pub passes: [f64; passes::COUNT],
}

impl PhaseTimers {
    /// Add the time since `t0` to `phase`.
    #[inline]
    pub fn add(&mut self, phase: Timer, t0: Instant) {
        self.seconds[phase as usize] += t0.elapsed().as_secs_f64();
    }

    /// Add the time since `t0` to `pass` and to its `phase` (one reading of the clock for both).
    #[inline]
    pub fn add_pass(&mut self, phase: Timer, pass: Pass, t0: Instant) {
        let s = t0.elapsed().as_secs_f64();
        self.seconds[phase as usize] += s;
        self.passes[pass as usize] += s;
    }

    /// Seconds of `phase` so far.
    pub fn get(&self, phase: Timer) -> f64 {
        self.seconds[phase as usize]
    }
}

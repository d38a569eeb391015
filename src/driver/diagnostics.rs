//! Per-rank figures reduced over ranks (phase timers, ghosts, migrations, high-water marks)
//! and the rows of `diagnostics.csv` made of them; `summary.json` reads the same reduction.

use crate::comm::{Comm, Phase};
use crate::error::Result;
use crate::physics::passes::{self, Pass};
use crate::sim::{Simulation, Timer, PHASES};

/// Header of `diagnostics.csv`.
pub(super) fn diag_header() -> String {
    let mut h = String::from("step,t,wall_s");
    for p in PHASES {
        for s in ["min", "mean", "max"] {
            h.push_str(&format!(",{p}_s_{s}"));
        }
    }
    h.push_str(
        ",ghosts,remote_ghosts,ghost_fraction,imbalance,count_imbalance,migrated,rebalances,particle_steps_per_s,removed",
    );
    h
}

/// Per-rank figures reduced over ranks (collective).
pub(super) struct Reduced {
    /// Per phase ([`PHASES`]), then per pass ([`passes::ALL`]): min, mean, max over ranks (s).
    pub(super) timers: Vec<[f64; 3]>,
    pub(super) ghosts: u64,
    pub(super) remote: u64,
    pub(super) particles: u64,
    /// The most particles a rank owns.
    pub(super) most_owned: u64,
    pub(super) migrated: u64,
    /// Per rank: most particles held at once, most ghosts held at once, the process's peak
    /// RSS (bytes; 0 where unknown; local ranks share one process), then the bytes its table,
    /// lists, cells and scratch hold at the end ([`Simulation::memory_parts`]). Empty unless
    /// asked for.
    pub(super) high_water: Vec<[u64; 7]>,
}

impl Reduced {
    /// Mean seconds of `phase` over ranks.
    pub(super) fn mean(&self, phase: Timer) -> f64 {
        self.timers[phase as usize][1]
    }

    /// The count imbalance: max/mean of the particles the ranks own (their memory's share;
    /// `imbalance` is the balanced load's).
    pub(super) fn count_imbalance(&self, ranks: usize) -> f64 {
        if self.particles == 0 {
            return 1.0;
        }
        self.most_owned as f64 * ranks as f64 / self.particles as f64
    }

    /// Min, mean and max over ranks of the phases' seconds, in the order of [`PHASES`].
    pub(super) fn phases(&self) -> &[[f64; 3]] {
        &self.timers[..PHASES.len()]
    }

    /// Min, mean and max over ranks of `pass`'s seconds.
    pub(super) fn pass(&self, pass: Pass) -> [f64; 3] {
        self.timers[PHASES.len() + pass as usize]
    }
}

/// Reduce this rank's timers, counts and, with `high_water` (the summary), its high-water marks
/// over ranks (collective: one all-gather, so an output at every step pays one message round;
/// the peak RSS is read from `/proc` only when asked).
pub(super) fn reduce<const D: usize>(
    sim: &Simulation<D>,
    comm: &dyn Comm,
    high_water: Option<Option<u64>>,
) -> Result<Reduced> {
    let prev = comm.set_phase(Phase::Output);
    let mut mine: Vec<u8> = Vec::new();
    for s in sim.timers.seconds.iter().chain(&sim.timers.passes) {
        mine.extend_from_slice(&s.to_le_bytes());
    }
    let counts = [
        sim.halo.len() as u64,
        sim.halo.remote() as u64,
        sim.p.n_owned as u64,
        sim.balance.migrated,
    ];
    let high = high_water.map(|setup_peak| {
        let [table, lists, cells, scratch] = sim.memory_parts();
        [
            sim.balance.particle_high_water,
            sim.balance.ghost_high_water,
            crate::memory::peak_rss().max(setup_peak).unwrap_or(0),
            table,
            lists,
            cells,
            scratch,
        ]
    });
    for c in counts.iter().chain(high.iter().flatten()) {
        mine.extend_from_slice(&c.to_le_bytes());
    }
    let all = comm.all_gather_bytes(mine)?;
    comm.set_phase(prev);
    let word = |b: &[u8], k: usize| -> [u8; 8] { b[8 * k..8 * k + 8].try_into().expect("8 bytes") };
    let n = PHASES.len() + passes::COUNT;
    let timers = (0..n)
        .map(|k| {
            let (mut lo, mut hi, mut sum) = (f64::INFINITY, 0.0f64, 0.0);
            for b in &all {
                let x = f64::from_le_bytes(word(b, k));
                lo = lo.min(x);
                hi = hi.max(x);
                sum += x;
            }
            [lo, sum / all.len() as f64, hi]
        })
        .collect();
    let count = |k: usize| {
        all.iter()
            .map(|b| u64::from_le_bytes(word(b, n + k)))
            .sum::<u64>()
    };
    let high_water = match high {
        Some(_) => all
            .iter()
            .map(|b| std::array::from_fn(|a| u64::from_le_bytes(word(b, n + 4 + a))))
            .collect(),
        None => Vec::new(),
    };
    let most_owned = all
        .iter()
        .map(|b| u64::from_le_bytes(word(b, n + 2)))
        .max()
        .unwrap_or(0);
    Ok(Reduced {
        timers,
        most_owned,
        ghosts: count(0),
        remote: count(1),
        particles: count(2),
        migrated: count(3),
        high_water,
    })
}

/// A row of `diagnostics.csv` (the columns of [`diag_header`]) at `step`, `t` and `wall`
/// seconds into the output steps, with `removed` particles so far.
pub(super) fn diag_row<const D: usize>(r: &Reduced, sim: &Simulation<D>, wall: f64, removed: u64) -> String {
    let mut row = format!("{},{},{wall:.6}", sim.step, sim.t);
    for t in r.phases() {
        row.push_str(&format!(",{:.6},{:.6},{:.6}", t[0], t[1], t[2]));
    }
    let rate = if wall > 0.0 {
        r.particles as f64 * sim.step as f64 / wall
    } else {
        0.0
    };
    let b = &sim.balance;
    row.push_str(&format!(
        ",{},{},{:.6},{:.6},{:.6},{},{},{rate:.1},{}",
        r.ghosts,
        r.remote,
        r.remote as f64 / r.particles.max(1) as f64,
        b.imbalance,
        r.count_imbalance(sim.ranks),
        r.migrated,
        b.rebalance_steps.len(),
        removed
    ));
    row
}

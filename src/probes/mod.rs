//! Probes on their own clock: each `[[probe]]` writes `probes/<name>.csv` (first column `t`)
//! every `interval` seconds of simulated time (default: at the output steps; 0 = every step),
//! independently of snapshots. Rows are buffered and flushed at output steps and at the end.
//!
//! A probe never needs the whole state: at a sampling step every rank sends rank 0 only its
//! owned particles inside the probes' regions (a box around a pressure point or a velocity line,
//! the vertical column under a gauge, a force probe's wall with the fluid in reach of it; a
//! front needs every fluid particle, but only where it is), and only the fields the probes
//! read, and rank 0 samples them sorted by id — the same particles in the same order on any
//! number of ranks, so probe files keep their bits.
//!
//! A probe with an averaging `window` samples every step and writes, at its rows, the mean of
//! its samples over the last `window` seconds (trapezoid rule in time).
//!
//! A pressure probe whose rows are not its every-step samples (a window, or an interval) also
//! samples every step and writes them to `probes/<name>.raw.csv` ([`Probe::raw_series`]): the
//! loads of `summary.json` are read from that series ([`loads_file`]).

mod bins;
pub mod disorder;
pub mod hole;
pub mod loads;
pub mod sensors;

use crate::comm::{Comm, Phase};
use crate::error::{Error, Result};
use crate::output::series;
use crate::particles::{Fields, Particles};
use crate::scene::{Probe, Scene};
use crate::sim::{Simulation, View};
use crate::Vector;
use std::collections::VecDeque;
use std::fs::File;
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};

pub use sensors::sample;
use sensors::{fields_of, Reach};

/// The fields a probe or the reference tracker reads from the gathered view: all but the sort
/// key, the density gradient and the solid fields (a force probe evaluates the solver's own
/// pair force, which reads the material, the wall velocity and the lattice moment; a hole
/// probe reads the solids' positions alone). A probe that reads one of the excluded fields
/// takes it out of this list: the view holds no other, and a missing one fails every test of
/// that probe at its first sample.
const PROBED: Fields = Fields::ALL.without(Fields::KEY.or(Fields::GRAD_RHO).or(Fields::SOLID));

/// When a probe writes a row.
#[derive(Debug, Clone, Copy, serde::Serialize, serde::Deserialize)]
enum Clock {
    /// At the output steps.
    Output,
    /// Every step.
    Step,
    /// At the first step at or after each multiple of the interval (s); the next such time.
    Every { interval: f64, next: f64 },
}

/// The particles a probe reads, as a box (m) and which kinds.
#[derive(Debug, Clone, Copy)]
struct Region<const D: usize> {
    min: Vector<D>,
    max: Vector<D>,
    /// Wall particles too (a gauge finds the bed; φ counts walls).
    walls: bool,
    /// Only the walls of this body (a force probe), with every fluid particle in the box.
    body: Option<u16>,
    /// Solid particles instead of fluid ones (a hole probe).
    solids: bool,
}

impl<const D: usize> Region<D> {
    fn contains(&self, p: &Particles<D>, i: usize) -> bool {
        let k = p.kind[i];
        if self.solids {
            return k.is_solid();
        }
        let kind_ok = k.is_fluid() || (k.is_wall() && self.body.map_or(self.walls, |b| p.body[i] == b));
        if !kind_ok {
            return false;
        }
        if k.is_wall() && self.body.is_some() {
            return true;
        }
        (0..D).all(|a| p.x[i][a] >= self.min[a] && p.x[i][a] <= self.max[a])
    }
}

/// A time-averaged sensor's recent samples (t, values).
type Window = VecDeque<(f64, Vec<f64>)>;

/// Every probe of a run: clocks, averaging windows and (rank 0) the files.
pub struct ProbeSet<const D: usize> {
    probes: Vec<Probe>,
    clocks: Vec<Clock>,
    windows: Vec<Window>,
    /// Wall body index of each force probe (0 for the others).
    walls: Vec<u16>,
    /// The motion of the wall each pressure sensor rides on ([`Probe::rides_on`]).
    movers: Vec<Option<crate::boundary::motion::WallKinematics>>,
    /// Rank 0 only: one file per probe.
    files: Vec<BufWriter<File>>,
    /// Rank 0 only, one per probe: the every-step series of a [`Probe::raw_series`] probe
    /// (`None` for the others, and on a restart from a checkpoint written before raw series
    /// existed, whose run has no such file to continue).
    raw: Vec<Option<BufWriter<File>>>,
    dir: PathBuf,
}

impl<const D: usize> ProbeSet<D> {
    /// The probes of `scene`; with `dir` (rank 0) their files are created under `dir/probes`,
    /// or with `append` (a restart) continued.
    pub fn new(scene: &Scene, dir: Option<&Path>, append: bool) -> Result<Self> {
        let probes = scene.probes.clone();
        let clocks = probes
            .iter()
            .map(|p| match p.interval() {
                None => Clock::Output,
                Some(iv) if iv <= 0.0 => Clock::Step,
                Some(iv) => Clock::Every {
                    interval: iv,
                    next: 0.0,
                },
            })
            .collect();
        let walls = probes
            .iter()
            .map(|p| {
                p.force_body()
                    .and_then(|body| scene.walls.iter().position(|w| w.name == body))
                    .unwrap_or(0) as u16
            })
            .collect();
        let kinematics = crate::boundary::motion::WallKinematics::of(scene);
        let movers = (probes.iter())
            .map(|p| {
                let b = p.rides_on()?;
                kinematics.iter().find(|w| scene.walls[w.body].name == b).cloned()
            })
            .collect();
        let mut files = Vec::new();
        let mut raw = Vec::new();
        let pd = dir.map(|d| d.join("probes")).unwrap_or_default();
        if let (Some(_), false) = (dir, probes.is_empty()) {
            std::fs::create_dir_all(&pd).map_err(|e| Error::io(&pd, e))?;
            for pr in &probes {
                let head = pr.header(D);
                files.push(series(&pd.join(format!("{}.csv", pr.name())), &head, append)?);
                let path = raw_path(&pd, pr.name());
                raw.push(match pr.raw_series() && (!append || path.is_file()) {
                    true => Some(series(&path, &head, append)?),
                    false => None,
                });
            }
        }
        Ok(ProbeSet {
            windows: vec![Window::new(); probes.len()],
            probes,
            clocks,
            walls,
            movers,
            files,
            raw,
            dir: pd,
        })
    }

    /// True if [`ProbeSet::after_step`] with the same arguments at time `t` (s) gathers a
    /// view: a probe is due or averages over a window, or `fluid` asks for the fluid. The
    /// driver frees the step's buffers first ([`Simulation::release_step_buffers`]).
    pub fn gathers(&self, t: f64, (output, output_only): (bool, bool), fluid: bool) -> bool {
        fluid
            || self
                .clocks
                .iter()
                .zip(&self.probes)
                .any(|(c, probe)| samples(clock_is_due(c, t, (output, output_only)), probe, output_only))
    }

    /// Collective, after each step (and once at the start, with `output`): sample the probes
    /// that are due now or average over a window, and write the rows of those that are due.
    /// `output` says this is an output step. With `output_only` (a second call for the same
    /// step: the run's last state, off the output schedule) only the probes on the output clock
    /// write, and windows are not sampled again. The probes that read the same fields
    /// ([`fields_of`]) share one gather, so a front probe's view of every fluid particle holds
    /// only positions. With `fluid` a single gather takes every fluid particle with every
    /// probed field, and the gathered particles are returned (rank 0) for the reference
    /// tracker, so an output step gathers once. A probe reads the same bits with or without
    /// the extra particles and fields: each sums over what lies within its reach, in id order.
    pub fn after_step<'s>(
        &mut self,
        sim: &'s Simulation<D>,
        comm: &dyn Comm,
        (output, output_only): (bool, bool),
        fluid: bool,
    ) -> Result<Option<View<'s, D>>> {
        let t = sim.t;
        if !self.gathers(t, (output, output_only), fluid) {
            return Ok(None);
        }
        let due: Vec<bool> = self
            .clocks
            .iter_mut()
            .map(|c| clock_due(c, t, (output, output_only)))
            .collect();
        let sampled: Vec<bool> = (0..self.probes.len())
            .map(|k| samples(due[k], &self.probes[k], output_only))
            .collect();
        // one gather per set of fields, the probes that read it sampled from it and the view
        // dropped before the next (in the probes' order: the same collectives on every rank);
        // with `fluid` one gather of every field serves every probe and the tracker
        let mut groups: Vec<(Fields, Vec<usize>)> = Vec::new();
        for k in (0..self.probes.len()).filter(|&k| sampled[k]) {
            let f = if fluid { PROBED } else { fields_of(&self.probes[k]) };
            match groups.iter_mut().find(|(g, _)| *g == f) {
                Some((_, ks)) => ks.push(k),
                None => groups.push((f, vec![k])),
            }
        }
        if fluid && groups.is_empty() {
            groups.push((PROBED, Vec::new()));
        }
        let mut last = None;
        for (fields, ks) in groups {
            let mut regions = Vec::new();
            for &k in &ks {
                regions.push(self.region(k, sim, comm)?);
            }
            let keep = |p: &Particles<D>, i: usize| {
                (fluid && p.kind[i].is_fluid()) || regions.iter().any(|r| r.contains(p, i))
            };
            drop(last.take());
            let Some(view) = sim.gather_where(comm, &keep, fields)? else {
                continue;
            };
            for k in ks {
                self.sample_into(k, &view, t, due[k], output_only)?;
            }
            last = Some(view);
        }
        Ok(last)
    }

    /// Sample probe `k` from `view` at time `t` (s), fold the sample into its window, and write
    /// its row if it is `due`.
    fn sample_into(&mut self, k: usize, view: &View<D>, t: f64, due: bool, output_only: bool) -> Result<()> {
        let mut values = sample(view, &self.placed(k, t), self.walls[k]);
        if let (false, Some(Some(f))) = (output_only, self.raw.get_mut(k)) {
            let row: Vec<String> = values.iter().map(|v| format!("{v}")).collect();
            writeln!(f, "{t},{}", row.join(",")).map_err(|e| Error::io(&self.dir, e))?;
        }
        let window = self.probes[k].window();
        if window > 0.0 {
            if !output_only {
                push(&mut self.windows[k], t, values, window);
            }
            values = mean(&self.windows[k]);
        }
        if due {
            if let Some(f) = self.files.get_mut(k) {
                let row: Vec<String> = values.iter().map(|v| format!("{v}")).collect();
                writeln!(f, "{t},{}", row.join(",")).map_err(|e| Error::io(&self.dir, e))?;
            }
        }
        Ok(())
    }

    /// Clocks and averaging windows, for a checkpoint.
    pub fn state(&self) -> serde_json::Value {
        serde_json::json!({"clocks": self.clocks, "windows": self.windows})
    }

    /// Continue from a checkpoint's [`ProbeSet::state`].
    pub fn restore(&mut self, state: &serde_json::Value) -> Result<()> {
        let bad = |e: serde_json::Error| Error::run(format!("checkpoint: probe state: {e}"));
        let clocks: Vec<Clock> = serde_json::from_value(state["clocks"].clone()).map_err(bad)?;
        let windows: Vec<Window> = serde_json::from_value(state["windows"].clone()).map_err(bad)?;
        if clocks.len() != self.probes.len() || windows.len() != self.probes.len() {
            return Err(Error::run("checkpoint: the probes differ from the checkpoint's"));
        }
        (self.clocks, self.windows) = (clocks, windows);
        Ok(())
    }

    /// The probe files (relative to the run directory), for a checkpoint's series lengths.
    pub fn files(&self) -> Vec<String> {
        let rows = self.probes.iter().map(|p| format!("probes/{}.csv", p.name()));
        let raw = (self.probes.iter().zip(&self.raw))
            .filter(|(_, f)| f.is_some())
            .map(|(p, _)| format!("probes/{}.raw.csv", p.name()));
        rows.chain(raw).collect()
    }

    /// Flush every probe file (rank 0; a no-op elsewhere).
    pub fn flush(&mut self) -> Result<()> {
        for f in self.files.iter_mut().chain(self.raw.iter_mut().flatten()) {
            f.flush().map_err(|e| Error::io(&self.dir, e))?;
        }
        Ok(())
    }

    /// Probe `k` where it is at time `t` (s): a sensor on a moving wall displaced with it
    /// (rigidly: the laws translate), every other probe as the scene gives it.
    fn placed(&self, k: usize, t: f64) -> std::borrow::Cow<'_, Probe> {
        match &self.movers[k] {
            Some(m) => std::borrow::Cow::Owned(self.probes[k].moved(m.at::<D>(t).0.as_slice())),
            None => std::borrow::Cow::Borrowed(&self.probes[k]),
        }
    }

    /// The region probe `k` reads now. A force probe's box is its wall's current extent
    /// (all-reduced: walls may move) grown by the interaction reach.
    fn region(&self, k: usize, sim: &Simulation<D>, comm: &dyn Comm) -> Result<Region<D>> {
        let reach = sim.model.kernel.support.max(sim.model.repulsive.r0);
        let everywhere = Region {
            min: Vector::from_element(f64::NEG_INFINITY),
            max: Vector::from_element(f64::INFINITY),
            walls: false,
            body: None,
            solids: false,
        };
        let around = |lo: Vector<D>, hi: Vector<D>, grow: f64| Region {
            min: lo.add_scalar(-grow),
            max: hi.add_scalar(grow),
            ..everywhere
        };
        Ok(match sensors::reach::<D>(&self.placed(k, sim.t)) {
            Reach::Box { lo, hi, margin } => around(lo, hi, reach + margin),
            Reach::Column(at) => {
                let mut r = around(at, at, reach);
                r.min[D - 1] = f64::NEG_INFINITY;
                r.max[D - 1] = f64::INFINITY;
                r.walls = true;
                r
            }
            Reach::Fluid => everywhere,
            Reach::Solids => Region {
                solids: true,
                ..everywhere
            },
            Reach::Wall => {
                let b = self.walls[k];
                let p = &sim.p;
                let (mut lo, mut hi) = ([f64::INFINITY; D], [f64::NEG_INFINITY; D]);
                for i in (0..p.n_owned).filter(|&i| p.kind[i].is_wall() && p.body[i] == b) {
                    for a in 0..D {
                        lo[a] = lo[a].min(p.x[i][a]);
                        hi[a] = hi[a].max(p.x[i][a]);
                    }
                }
                // one collective: the largest coordinate is the smallest of its negation
                let mut both: Vec<f64> = lo.iter().chain(hi.iter()).copied().collect();
                both[D..].iter_mut().for_each(|h| *h = -*h);
                let prev = comm.set_phase(Phase::Output);
                comm.all_reduce_min_f64(&mut both)?;
                comm.set_phase(prev);
                lo.copy_from_slice(&both[..D]);
                hi.iter_mut().zip(&both[D..]).for_each(|(h, b)| *h = -b);
                Region {
                    body: Some(b),
                    ..around(Vector::from(lo), Vector::from(hi), reach)
                }
            }
        })
    }
}

/// Move an interval clock's `next` time (s) past `t` (s) by whole `interval`s, in O(1) whatever
/// the ratio of the step to the interval: a few additions (the usual case: the same times as
/// always), then, for a clock far behind (an interval far below dt, or one below the spacing
/// of floats at `t`), a jump to the first multiple of the interval after `t`. A clock fires at
/// most once per step.
pub fn advance_past(next: &mut f64, interval: f64, t: f64) {
    let limit = t * (1.0 + 1e-12);
    for _ in 0..4 {
        if *next > limit {
            return;
        }
        *next += interval;
    }
    if *next <= limit {
        let k = (limit / interval).floor() + 1.0;
        *next = (k * interval).max(limit.next_up());
    }
}

/// Whether a clock writes a row at time `t` (s), without advancing it; on an `output_only` call
/// (the run's last state, off the schedule) only the output clock writes.
fn clock_is_due(c: &Clock, t: f64, (output, output_only): (bool, bool)) -> bool {
    match (c, output_only) {
        (Clock::Output, _) => output,
        (_, true) => false,
        (Clock::Step, false) => true,
        (Clock::Every { next, .. }, false) => t >= *next * (1.0 - 1e-12) - 1e-300,
    }
}

/// Whether a probe samples the particles now: its row is `due`, or it averages over a window
/// or keeps a raw series (sampled once per step: not again on the `output_only` call).
fn samples(due: bool, probe: &Probe, output_only: bool) -> bool {
    due || (!output_only && (probe.window() > 0.0 || probe.raw_series()))
}

/// `probes/<name>.raw.csv` in the probe directory `dir` ([`Probe::raw_series`]).
fn raw_path(dir: &Path, name: &str) -> PathBuf {
    dir.join(format!("{name}.raw.csv"))
}

/// The file in the probe directory `dir` that a pressure probe's loads are read from: its
/// every-step series `<name>.raw.csv` where the run wrote one, else its rows `<name>.csv`
/// (sampled every step with no window, or from a run before raw series), and whether it is
/// the raw one.
pub fn loads_file(dir: &Path, probe: &Probe) -> (PathBuf, bool) {
    let raw = raw_path(dir, probe.name());
    match probe.raw_series() && raw.is_file() {
        true => (raw, true),
        false => (dir.join(format!("{}.csv", probe.name())), false),
    }
}

/// Whether a clock writes a row at time `t` (s); advances an interval clock past `t`.
fn clock_due(c: &mut Clock, t: f64, flags: (bool, bool)) -> bool {
    let due = clock_is_due(c, t, flags);
    if let (true, Clock::Every { interval, next }) = (due, c) {
        advance_past(next, *interval, t);
    }
    due
}

/// Push a sample (t, values), keeping the samples of [t − window, t] (and the one just before).
fn push(w: &mut Window, t: f64, values: Vec<f64>, window: f64) {
    w.push_back((t, values));
    while w.len() > 1 && w[1].0 <= t - window {
        w.pop_front();
    }
}

/// The time average of the samples kept (trapezoid rule; the sample itself when it is the
/// only one).
fn mean(w: &Window) -> Vec<f64> {
    let span = w[w.len() - 1].0 - w[0].0;
    if w.len() < 2 || span <= 0.0 {
        return w[w.len() - 1].1.clone();
    }
    let mut sum = vec![0.0; w[0].1.len()];
    for (a, b) in w.iter().zip(w.iter().skip(1)) {
        let dt = b.0 - a.0;
        for (s, (x, y)) in sum.iter_mut().zip(a.1.iter().zip(&b.1)) {
            *s += 0.5 * (x + y) * dt;
        }
    }
    sum.iter().map(|s| s / span).collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_clock_far_behind_catches_up_in_one_step() {
        for (interval, t) in [(1e-30, 1e-5), (1e-15, 0.47), (1e-300, 1.0), (0.1, 1e6)] {
            let mut next = interval;
            advance_past(&mut next, interval, t);
            assert!(next > t * (1.0 + 1e-12), "{interval} {t}: {next}");
            assert!(
                next <= t * (1.0 + 1e-12) + interval.max(t * 1e-15),
                "{interval} {t}: {next}"
            );
        }
        // the usual case: the same times as repeated addition
        let (mut a, mut b) = (0.1, 0.1);
        for step in 1..100 {
            let t = step as f64 * 0.037;
            advance_past(&mut a, 0.1, t);
            while b <= t * (1.0 + 1e-12) {
                b += 0.1;
            }
            assert_eq!(a.to_bits(), b.to_bits());
        }
    }

    #[test]
    fn an_interval_clock_fires_at_the_first_step_past_each_multiple() {
        let mut c = Clock::Every {
            interval: 0.1,
            next: 0.0,
        };
        let fired: Vec<f64> = [0.0, 0.04, 0.08, 0.12, 0.16, 0.2, 0.24, 0.31]
            .into_iter()
            .filter(|&t| clock_due(&mut c, t, (false, false)))
            .collect();
        assert_eq!(fired, vec![0.0, 0.12, 0.2, 0.31]);
        let mut o = Clock::Output;
        assert!(!clock_due(&mut o, 0.5, (false, false)) && clock_due(&mut o, 0.5, (true, false)));
        assert!(clock_due(&mut Clock::Step, 0.5, (false, false)));
        // the last state's extra call: only the output clock writes, and no clock advances
        assert!(clock_due(&mut o, 0.5, (true, true)));
        assert!(!clock_due(&mut Clock::Step, 0.5, (true, true)));
        assert!(!clock_due(&mut c, 0.5, (true, true)) && clock_due(&mut c, 0.5, (false, false)));
    }

    #[test]
    fn the_window_average_is_the_trapezoid_mean_of_the_last_window() {
        let mut w = Window::new();
        // a linear ramp f = t averages to its midpoint value over any window
        let mut last = vec![];
        for k in 0..=20 {
            let t = k as f64 * 0.01;
            push(&mut w, t, vec![t], 0.05);
            last = mean(&w);
        }
        assert!((last[0] - 0.175).abs() < 1e-12, "{last:?}");
        // a constant stays itself
        let mut w = Window::new();
        for k in 0..5 {
            push(&mut w, k as f64, vec![3.0, -1.0], 2.5);
            last = mean(&w);
        }
        assert_eq!(last, vec![3.0, -1.0]);
    }
}

//! Progress reporting: a redrawn status line on a terminal, plain periodic log lines otherwise.

use std::io::{IsTerminal, Write};
use std::time::Instant;

/// Progress reporter for a run.
pub struct Progress {
    tty: bool,
    quiet: bool,
    start: Instant,
    last: Instant,
    /// Fraction of `t_end` done when the reporter was made (a restart's starting point).
    first_frac: f64,
    last_frac_logged: f64,
}

impl Progress {
    /// New reporter for a run that stands at time `t` of `t_end` (s): a restarted run's
    /// rate and ETA count only the steps done since; `quiet` silences it.
    pub fn new(quiet: bool, t: f64, t_end: f64) -> Self {
        let now = Instant::now();
        let first_frac = fraction(t, t_end);
        Progress {
            tty: std::io::stderr().is_terminal(),
            quiet,
            start: now,
            last: now,
            first_frac,
            last_frac_logged: first_frac,
        }
    }

    /// Report after a step, with the particle-steps done since the reporter was made (every
    /// step's particles: a population that changes is counted as it is).
    pub fn update(&mut self, step: u64, t: f64, t_end: f64, particle_steps: f64) {
        if self.quiet {
            return;
        }
        let now = Instant::now();
        let frac = fraction(t, t_end);
        let elapsed = now.duration_since(self.start).as_secs_f64();
        let due = if self.tty {
            now.duration_since(self.last).as_secs_f64() > 0.2
        } else {
            frac - self.last_frac_logged >= 0.1 || now.duration_since(self.last).as_secs_f64() > 30.0
        };
        if !due {
            return;
        }
        self.last = now;
        let eta = eta(elapsed, self.first_frac, frac);
        let rate = particle_steps / elapsed.max(1e-9);
        let mut err = std::io::stderr();
        if self.tty {
            let width = 24;
            let filled = (frac * width as f64) as usize;
            let bar: String = "#".repeat(filled) + &" ".repeat(width - filled);
            let _ = write!(
                err,
                "\r  step {step:>7}  t = {t:.4e}/{t_end:.3e} s  [{bar}] {:>3.0}%  ETA {}  {rate:.2e} particle-steps/s ",
                frac * 100.0,
                hms(eta)
            );
        } else {
            self.last_frac_logged = frac;
            let _ = writeln!(
                err,
                "hsph: step {step}, t = {t:.4e} s of {t_end:.3e} s ({:.0}%), elapsed {}, ETA {}, {rate:.3e} particle-steps/s",
                frac * 100.0,
                hms(elapsed),
                hms(eta)
            );
        }
    }

    /// End the status line.
    pub fn finish(&self) {
        if self.tty && !self.quiet {
            eprintln!();
        }
    }
}

/// Fraction of the run's time done, in [0, 1].
fn fraction(t: f64, t_end: f64) -> f64 {
    (t / t_end).clamp(0.0, 1.0)
}

/// Seconds left when `elapsed` seconds took the run from fraction `first` to `now` of its
/// time, at the same pace (0 before any progress).
fn eta(elapsed: f64, first: f64, now: f64) -> f64 {
    if now > first {
        elapsed * (1.0 - now) / (now - first)
    } else {
        0.0
    }
}

fn hms(s: f64) -> String {
    let s = s.max(0.0).round() as u64;
    if s >= 3600 {
        format!("{}h{:02}m", s / 3600, s % 3600 / 60)
    } else if s >= 60 {
        format!("{}m{:02}s", s / 60, s % 60)
    } else {
        format!("{s}s")
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_restarted_run_extrapolates_from_the_progress_since_it_started() {
        // from the start: 10 s for 25 % leaves 30 s
        assert_eq!(eta(10.0, 0.0, 0.25), 30.0);
        // restarted at 70 %: 10 s took it to 75 %, so 50 s are left (not 10·0.25/0.75 = 3.3 s)
        assert!((eta(10.0, 0.7, 0.75) - 50.0).abs() < 1e-9);
        assert_eq!(eta(5.0, 0.7, 0.7), 0.0);
        assert_eq!(fraction(2.0, 1.0), 1.0);
        assert_eq!(hms(3725.0), "1h02m");
    }
}

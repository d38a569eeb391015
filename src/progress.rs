//! Progress reporting: a redrawn status line on a terminal, plain periodic log lines otherwise.

use std::io::{IsTerminal, Write};
use std::time::Instant;

/// Progress reporter for a run.
pub struct Progress {
    tty: bool,
    quiet: bool,
    start: Instant,
    last: Instant,
    last_frac_logged: f64,
}

impl Progress {
    /// New reporter; `quiet` silences it.
    pub fn new(quiet: bool) -> Self {
        let now = Instant::now();
        Progress {
            tty: std::io::stderr().is_terminal(),
            quiet,
            start: now,
            last: now,
            last_frac_logged: 0.0,
        }
    }

    /// Report after a step, with the particle-steps done since the reporter was made (every
    /// step's particles: a population that changes is counted as it is).
    pub fn update(&mut self, step: u64, t: f64, t_end: f64, particle_steps: f64) {
        if self.quiet {
            return;
        }
        let now = Instant::now();
        let frac = (t / t_end).clamp(0.0, 1.0);
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
        let eta = if frac > 0.0 {
            elapsed * (1.0 - frac) / frac
        } else {
            0.0
        };
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

//! Checks before anything is allocated: ranks, threads, memory and probe sizes against the
//! limits of `crate::limits` and the machine (exit 2 when a run cannot fit).

use super::RunOptions;
use crate::error::{Error, Result};
use crate::scene::Scene;

/// Default fewest particles per rank: below it halos cost more than the rank computes.
pub const MIN_PARTICLES_PER_RANK: usize = 16;

/// Most ranks of the local back end (threads of one process); more is a job for MPI.
pub const MAX_LOCAL_RANKS: usize = crate::limits::MAX_RANKS;

/// `--threads` against the limits (exit 2 above [`crate::limits::MAX_THREADS`]); more threads
/// than cores is said on standard error (when `say`: rank 0) and run.
pub fn check_threads(threads: usize, ranks_in_process: usize, say: bool) -> Result<()> {
    if threads == 0 {
        return Ok(());
    }
    let warning = crate::limits::threads("--threads", threads, ranks_in_process)?;
    if let (Some(w), true) = (warning, say) {
        eprintln!("hsph: warning: {w}");
    }
    Ok(())
}

/// Check a layout of `ranks` ranks, `ranks_in_process` of them in this process, against the
/// scene's particle count (counted without building particles) and the memory this process
/// may use, before anything is allocated. Returns the estimate; exit 2 when it does not fit.
pub fn check_limits(
    scene: &Scene,
    ranks: usize,
    ranks_in_process: usize,
    opts: &RunOptions,
) -> Result<crate::memory::Estimate> {
    use crate::memory::{available, human};
    crate::limits::ranks("--ranks", ranks)?;
    check_probe_sizes(scene)?;
    super::sweeps::check_wall_sweeps(scene)?;
    let pair_mode = scene.performance.interactions == crate::scene::Interactions::Pairs;
    crate::with_dim!(scene.dimension, D => crate::physics::passes::check_pair_mode(
        &crate::physics::Model::<D>::new(scene),
        pair_mode
    ))?;
    let n = crate::with_dim!(scene.dimension, D => Ok(crate::scene::lattice::count_particles::<D>(scene)))?;
    let min = if opts.min_particles_per_rank == 0 {
        MIN_PARTICLES_PER_RANK
    } else {
        opts.min_particles_per_rank
    };
    let most = (n / min as u64).max(1);
    if ranks as u64 > most {
        return Err(Error::input(
            "--ranks",
            format!(
                "{ranks} ranks for {n} particles: at most {most} ranks (≥ {min} particles per rank; \
                 lower the minimum with --min-particles-per-rank)"
            ),
        ));
    }
    if ranks_in_process > MAX_LOCAL_RANKS {
        return Err(Error::input(
            "--ranks",
            format!(
                "{ranks_in_process} ranks in one process: the local back end runs at most {MAX_LOCAL_RANKS} \
                 (each rank is a thread); run more ranks under MPI (mpirun -np {ranks_in_process})"
            ),
        ));
    }
    // the largest population: the set-up's, and what the adaptive regions can add
    let peak = n + crate::scene::refine::adaptive_growth(scene);
    let est = crate::with_dim!(scene.dimension, D => Ok(crate::memory::estimate::<D>(scene, peak, ranks, ranks_in_process)))?;
    let limit = match opts.max_memory {
        Some(m) => Some((m, "--max-memory")),
        None => available(),
    };
    if let Some((avail, what)) = limit {
        if est.process > avail {
            let key = if ranks_in_process > 1 {
                "--ranks"
            } else {
                "discretisation.dx"
            };
            let cap = match scene.balance.count_cap() {
                Some(c) if ranks > 1 && c > 1.05 => format!(
                    "; balanced on pairs a rank may own up to balance.max_count = {c} times the \
                     mean particle count (1 splits by counts)"
                ),
                _ => String::new(),
            };
            return Err(Error::input(
                key,
                format!(
                    "this run needs about {} per process ({n} particles, {ranks_in_process} rank(s) in this \
                     process at about {} each at its peak), more than the {} of {what}; {}use a coarser \
                     dx, fewer ranks per process (MPI spreads them over processes), or --max-memory to override{cap}",
                    human(est.process),
                    human(est.rank_setup.max(est.rank_run)),
                    human(avail),
                    what_fits(scene, peak, (ranks, ranks_in_process), avail)
                ),
            ));
        }
    }
    Ok(est)
}

/// The layouts that would fit in `avail` bytes per process, as the start of a sentence
/// ("it fits …; "), or empty: the list-free mode (`neighbours = "cells"`) on the same layout,
/// and the fewest MPI processes of one rank each (up to [`crate::limits::MAX_RANKS`]).
fn what_fits(scene: &Scene, peak: u64, (ranks, in_process): (usize, usize), avail: f64) -> String {
    use crate::memory::human;
    let process = |s: &Scene, ranks: usize, k: usize| {
        crate::with_dim!(s.dimension, D => Ok(crate::memory::estimate::<D>(s, peak, ranks, k).process))
            .unwrap_or(f64::INFINITY)
    };
    let mut fits = Vec::new();
    if scene.performance.neighbours != crate::scene::NeighbourMode::Cells {
        let mut lean = scene.clone();
        lean.performance.neighbours = crate::scene::NeighbourMode::Cells;
        let b = process(&lean, ranks, in_process);
        if b <= avail {
            fits.push(format!(
                "with --set 'performance.neighbours=\"cells\"' (no stored lists, about {} per process)",
                human(b)
            ));
        }
    }
    // one rank per process: the estimate falls with the ranks, so the first that fits is found
    // by doubling and then halving the interval
    let per = |p: usize| process(scene, p, 1);
    let max = crate::limits::MAX_RANKS.min((peak / MIN_PARTICLES_PER_RANK as u64).max(1) as usize);
    let mut hi = ranks.max(1);
    while hi < max && per(hi) > avail {
        hi = (2 * hi).min(max);
    }
    if per(hi) <= avail {
        let mut lo = hi / 2;
        while hi - lo > 1 {
            let mid = (lo + hi) / 2;
            if per(mid) <= avail {
                hi = mid;
            } else {
                lo = mid;
            }
        }
        fits.push(format!(
            "under MPI on {hi} processes of one rank each (mpirun -np {hi}; about {} each)",
            human(per(hi))
        ));
    }
    match fits.is_empty() {
        true => String::new(),
        false => format!("it fits {}; or ", fits.join(", or ")),
    }
}

/// Every probe's sample count within [`crate::limits::MAX_PROBE_POINTS`] (a line probe holds
/// its points and their values in memory).
fn check_probe_sizes(scene: &Scene) -> Result<()> {
    for (k, p) in scene.probes.iter().enumerate() {
        if let Some(points) = p.line_points() {
            crate::limits::count(
                &format!("probe[{k}].points"),
                points as u64,
                crate::limits::MAX_PROBE_POINTS,
            )?;
        }
        if let Some((diameter, normal)) = p.face() {
            face_points(k, diameter, normal, scene)?
        }
    }
    Ok(())
}

/// A pressure sensor's face: a finite diameter whose samples (every dx/4 across it, a disc in
/// 3D) stay within [`crate::limits::MAX_FACE_POINTS`], and a normal of a length that can be
/// normalised.
fn face_points(k: usize, diameter: f64, normal: Option<&[f64]>, scene: &Scene) -> Result<()> {
    let dx = scene.discretisation.dx;
    let m = (0.5 * diameter / (0.25 * dx)).ceil();
    let points = (2.0 * m + 1.0).powi(scene.dimension as i32 - 1);
    let most = crate::limits::MAX_FACE_POINTS;
    if !(diameter.is_finite() && diameter > 0.0 && points <= most as f64) {
        let largest = if scene.dimension == 3 {
            ((most as f64).sqrt() - 1.0) / 2.0 * 0.5 * dx
        } else {
            (most as f64 - 1.0) / 2.0 * 0.5 * dx
        };
        return Err(Error::input(
            format!("probe[{k}].diameter"),
            format!(
                "{diameter:e} m: the sensing face is sampled every dx/4 and may have at most {most} samples; \
                 give a diameter ≥ 0 and at most {largest:.3e} m at dx = {dx} m"
            ),
        ));
    }
    let len = normal.map_or(0.0, |n| n.iter().map(|x| x * x).sum::<f64>().sqrt());
    if !(len.is_finite() && (1e-100..=1e100).contains(&len)) {
        return Err(Error::input(
            format!("probe[{k}].normal"),
            format!(
                "a sensing face of diameter {diameter} m needs a normal of length between 1e-100 and 1e100, \
                 e.g. normal = [1, 0{}]",
                if scene.dimension == 3 { ", 0" } else { "" }
            ),
        ));
    }
    Ok(())
}

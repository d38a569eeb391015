//! Self-checking test of hsph's communicator back ends (`hsph::comm::selftest`).
//!
//! ```text
//! comm_selftest [--backend auto|serial|local|mpi] [--ranks N] [--threads T]
//!               [--repeat K] [--fail-rank R]
//! ```
//! - local (default outside MPI): `--ranks` (default 4) ranks × `--threads` (default 2);
//! - mpi (needs `--features mpi`; the default when started by mpirun/srun):
//!   `mpirun --allow-run-as-root --oversubscribe --bind-to none -np 4 comm_selftest`;
//! - `--fail-rank R`: after the checks, rank R aborts while the other ranks wait in an
//!   all-reduce; the run must stop with an error naming rank R (exit status 1), not hang.
//!
//! Prints `comm selftest ok: …` (rank 0) and exits 0 when every check passed.

use hsph::comm::{launched_by_mpi, selftest, Comm};
use hsph::error::{Error, Result};

struct Args {
    backend: String,
    ranks: usize,
    threads: usize,
    repeat: usize,
    fail_rank: Option<usize>,
}

fn parse() -> Result<Args> {
    let mut a = Args {
        backend: "auto".into(),
        ranks: 4,
        threads: 2,
        repeat: 3,
        fail_rank: None,
    };
    let mut it = std::env::args().skip(1);
    while let Some(flag) = it.next() {
        let mut value = || {
            it.next()
                .ok_or_else(|| Error::input(flag.trim_start_matches('-'), "needs a value"))
        };
        let number = |s: String, key: &str| {
            s.parse::<usize>()
                .map_err(|_| Error::input(key, format!("`{s}` is not a whole number")))
        };
        match flag.as_str() {
            "--backend" => a.backend = value()?,
            "--ranks" => a.ranks = number(value()?, "ranks")?,
            "--threads" => a.threads = number(value()?, "threads")?,
            "--repeat" => a.repeat = number(value()?, "repeat")?,
            "--fail-rank" => a.fail_rank = Some(number(value()?, "fail-rank")?),
            other => return Err(Error::input(other, "unknown option")),
        }
    }
    Ok(a)
}

/// The rank body: the checks, a little rayon work, then the optional injected failure.
fn body(comm: &dyn Comm, args: &Args) -> Result<usize> {
    for _ in 0..args.repeat {
        selftest::run(comm)?;
    }
    let sum: u64 = {
        use rayon::prelude::*;
        (0..100_000u64).into_par_iter().map(|x| x % 7).sum()
    };
    let mut s = [sum];
    comm.all_reduce_sum_u64(&mut s)?;
    if s[0] != sum * comm.size() as u64 {
        return Err(Error::run("rayon work inside ranks gave a wrong sum"));
    }
    if let Some(bad) = args.fail_rank {
        comm.barrier()?;
        if comm.rank() == bad {
            std::thread::sleep(std::time::Duration::from_millis(100));
            return Err(comm.abort("injected failure (comm_selftest --fail-rank)"));
        }
        // Blocks until the abort reaches this rank.
        comm.all_reduce_sum_u64(&mut [1])?;
    }
    Ok(rayon::current_num_threads())
}

fn run(args: &Args) -> Result<String> {
    let backend = match args.backend.as_str() {
        "auto" if launched_by_mpi() => "mpi",
        "auto" if args.ranks > 1 => "local",
        "auto" => "serial",
        b => b,
    };
    match backend {
        "serial" => {
            let threads = body(&hsph::comm::serial::SerialComm::new(), args)?;
            Ok(format!("backend serial, 1 rank, {threads} rayon threads"))
        }
        "local" => {
            let threads = hsph::comm::local::run_local(args.ranks, args.threads, |c| body(c, args))?;
            Ok(format!(
                "backend local, {} ranks, {} rayon threads per rank",
                args.ranks, threads[0]
            ))
        }
        "mpi" => run_mpi(args),
        other => Err(Error::input(
            "backend",
            format!("`{other}` is not one of auto, serial, local, mpi"),
        )),
    }
}

#[cfg(feature = "mpi")]
fn run_mpi(args: &Args) -> Result<String> {
    let comm = hsph::comm::mpi::MpiComm::init()?;
    let threads = match body(&comm, args) {
        Ok(t) => t,
        // Any failed check stops every rank (MPI_Abort), with the message on stderr.
        Err(e) => return Err(comm.abort(&e.to_string())),
    };
    let mut all = [threads as f64];
    comm.all_reduce_min_f64(&mut all)?;
    let out = format!(
        "backend mpi, {} ranks, thread multiple {}, {} rayon threads per rank (min), {}",
        comm.size(),
        comm.thread_multiple(),
        all[0],
        hsph::comm::mpi::MpiComm::library_version()
            .lines()
            .next()
            .unwrap_or("")
    );
    if comm.rank() == 0 {
        Ok(out)
    } else {
        Ok(String::new())
    }
}

#[cfg(not(feature = "mpi"))]
fn run_mpi(_args: &Args) -> Result<String> {
    Err(Error::missing_feature("backend", "mpi"))
}

fn main() {
    let result = parse().and_then(|a| run(&a));
    match result {
        Ok(s) if s.is_empty() => {}
        Ok(s) => println!("comm selftest ok: {s}"),
        Err(e) => {
            eprintln!("{e}");
            std::process::exit(e.exit_code());
        }
    }
}

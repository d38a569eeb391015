//! Stopping early on a signal (the signal contract, README "Exit status").
//!
//! `hsph run` installs handlers for SIGINT, SIGTERM, SIGUSR1 (Slurm's early warning, with
//! `--signal=B:USR1@…`) and SIGHUP (a closed terminal or ssh session). A handler only records
//! the signal; the step loop asks every rank at each step boundary — and the set-up at each
//! relaxation or settling iteration — whether any rank has seen one (one max all-reduce, so all
//! ranks stop at the same point), then flushes every CSV, writes `final.csv` and a
//! `summary.json` with `"complete": false` and `"stopped_by"`, says where it stopped and exits
//! with [`EXIT_STOPPED`]. A second signal within [`SAME_SIGNAL_S`] of the first is the same
//! stop (a wrapper that signals the whole process group, like GNU `timeout`, delivers two at
//! once); one later ends the process at once (the signal's default action), so an impatient
//! Ctrl-C still works.

use crate::comm::{Comm, Phase};
use crate::error::{Error, Result};
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::{Arc, OnceLock};

/// Exit status of a run stopped early by a signal: its files are complete up to the last
/// output step and `summary.json` says `"complete": false`.
pub const EXIT_STOPPED: i32 = 3;

/// The signals that stop a run: (number, name).
const SIGNALS: [(i32, &str); 4] = [
    (signal_hook::consts::SIGINT, "SIGINT"),
    (signal_hook::consts::SIGTERM, "SIGTERM"),
    (signal_hook::consts::SIGUSR1, "SIGUSR1"),
    (signal_hook::consts::SIGHUP, "SIGHUP"),
];

/// Seconds after a first stopping signal during which another is taken as the same stop.
pub const SAME_SIGNAL_S: f64 = 1.0;

fn flag() -> &'static Arc<AtomicUsize> {
    static FLAG: OnceLock<Arc<AtomicUsize>> = OnceLock::new();
    FLAG.get_or_init(|| Arc::new(AtomicUsize::new(0)))
}

/// Install the handlers, once per process (later calls return the first call's result). A
/// thread of their own receives the signals: the first is recorded, a second within
/// [`SAME_SIGNAL_S`] is the same stop, a later one takes the signal's default action.
pub fn install() -> Result<()> {
    static INSTALLED: OnceLock<std::result::Result<(), String>> = OnceLock::new();
    INSTALLED
        .get_or_init(|| {
            let mut signals = signal_hook::iterator::Signals::new(SIGNALS.iter().map(|(s, _)| *s))
                .map_err(|e| format!("cannot install the stopping signals' handlers: {e}"))?;
            let f = Arc::clone(flag());
            std::thread::Builder::new()
                .name("hsph-signals".into())
                .spawn(move || {
                    let mut first: Option<std::time::Instant> = None;
                    for sig in signals.forever() {
                        match first {
                            None => {
                                f.store(sig as usize, Ordering::SeqCst);
                                first = Some(std::time::Instant::now());
                            }
                            Some(at) if at.elapsed().as_secs_f64() <= SAME_SIGNAL_S => {}
                            Some(_) => {
                                // the default action ends the process; if it could not, exit
                                // as the shell reports a death by this signal
                                let _ = signal_hook::low_level::emulate_default_handler(sig);
                                std::process::exit(128 + sig);
                            }
                        }
                    }
                })
                .map(drop)
                .map_err(|e| format!("cannot start the signal thread: {e}"))
        })
        .clone()
        .map_err(Error::run)
}

/// Under a file-size limit (`ulimit -f`, a quota that signals), the kernel sends SIGXFSZ to a
/// process whose write crosses it, and its default action kills the process with no message
/// and `.tmp` files left behind. Caught instead (a handler that records nothing), the write
/// fails with EFBIG and is an ordinary write error: exit 1, a message naming the file, every
/// temporary file removed. Every command calls this first.
pub fn catch_file_size_limit() {
    // a failure leaves the default action, which is what hsph had before
    let _ = signal_hook::flag::register(
        signal_hook::consts::SIGXFSZ,
        Arc::new(std::sync::atomic::AtomicBool::new(false)),
    );
}

/// The signal this process has received, if any (0: none).
pub fn pending() -> usize {
    flag().load(Ordering::SeqCst)
}

/// Name of a stopping signal.
pub fn name(sig: usize) -> &'static str {
    SIGNALS
        .iter()
        .find(|(s, _)| *s as usize == sig)
        .map_or("signal", |(_, n)| n)
}

/// Collective: the signal any rank has received (the largest number), or `None`. Every rank
/// gets the same answer, so all stop after the same step.
pub fn agreed_stop(comm: &dyn Comm) -> Result<Option<&'static str>> {
    agreed_stop_with(comm, 0, &mut [])
}

/// [`agreed_stop`], with `injected` (a signal number, 0 for none) taken as received on this
/// rank besides the process's own (the test-only fault `signal`, scoped to one run), and
/// max-reducing this rank's `flags` (wall-clock decisions) in the same collective: on return
/// they hold the largest value over the ranks.
pub fn agreed_stop_with(comm: &dyn Comm, injected: usize, flags: &mut [f64]) -> Result<Option<&'static str>> {
    let mut m = vec![pending().max(injected) as f64];
    m.extend_from_slice(flags);
    let prev = comm.set_phase(Phase::Other);
    comm.all_reduce_max_f64(&mut m)?;
    comm.set_phase(prev);
    flags.copy_from_slice(&m[1..]);
    Ok((m[0] > 0.0).then(|| name(m[0] as usize)))
}

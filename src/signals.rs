//! Stopping early on a signal (the signal contract, README "Exit status").
//!
//! `hsph run` installs handlers for SIGINT, SIGTERM and SIGUSR1 (Slurm's early warning, with
//! `--signal=B:USR1@…`). A handler only records the signal; the step loop asks every rank at
//! each step boundary whether any rank has seen one (one max all-reduce, so all ranks stop
//! after the same step), then flushes every CSV, writes `final.csv` and a `summary.json` with
//! `"complete": false` and `"stopped_by"`, says where it stopped and exits with
//! [`EXIT_STOPPED`]. A second signal of the same kind ends the process at once (the default
//! action), so an impatient Ctrl-C still works.

use crate::comm::{Comm, Phase};
use crate::error::{Error, Result};
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::{Arc, OnceLock};

/// Exit status of a run stopped early by a signal: its files are complete up to the last
/// output step and `summary.json` says `"complete": false`.
pub const EXIT_STOPPED: i32 = 3;

/// The signals that stop a run: (number, name).
const SIGNALS: [(i32, &str); 3] = [
    (signal_hook::consts::SIGINT, "SIGINT"),
    (signal_hook::consts::SIGTERM, "SIGTERM"),
    (signal_hook::consts::SIGUSR1, "SIGUSR1"),
];

fn flag() -> &'static Arc<AtomicUsize> {
    static FLAG: OnceLock<Arc<AtomicUsize>> = OnceLock::new();
    FLAG.get_or_init(|| Arc::new(AtomicUsize::new(0)))
}

/// Install the handlers (idempotent in effect: the flag is shared).
pub fn install() -> Result<()> {
    for (sig, name) in SIGNALS {
        let f = Arc::clone(flag());
        // a second signal while one is pending: the default action (terminate)
        let as_bool = Arc::new(std::sync::atomic::AtomicBool::new(false));
        signal_hook::flag::register_conditional_default(sig, Arc::clone(&as_bool))
            .and_then(|_| signal_hook::flag::register(sig, as_bool))
            .and_then(|_| signal_hook::flag::register_usize(sig, f, sig as usize))
            .map_err(|e| Error::run(format!("cannot install the {name} handler: {e}")))?;
    }
    Ok(())
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

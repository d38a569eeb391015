//! Stopping a sweep on a signal (README, "Exit status"): `hsph validate` records SIGINT,
//! SIGTERM, SIGUSR1 and SIGHUP instead of dying, forwards each to every child `hsph run` it is
//! waiting for, starts no further run, waits for the children (each writes its checkpoint and
//! `summary.json` and exits 3) and then exits 3 itself. A stopped configuration gets no row in
//! `sweep.csv`, so running the same command again resumes the sweep: finished configurations
//! are skipped, stopped ones run again. The children run in a process group of their own, so a
//! signal to validate's group (Ctrl-C at a terminal, `timeout`) reaches them once, through
//! validate, and no child outlives it holding a run directory's lock.

use crate::error::{Error, Result};
use signal_hook::consts::{SIGHUP, SIGINT, SIGTERM, SIGUSR1};
use std::sync::atomic::{AtomicI32, AtomicUsize, Ordering};
use std::sync::OnceLock;

/// Signals received so far.
static COUNT: AtomicUsize = AtomicUsize::new(0);
/// The last signal received.
static LAST: AtomicI32 = AtomicI32::new(0);

/// Record the stopping signals from now on (once per process; later calls do nothing).
pub fn install() -> Result<()> {
    static INSTALLED: OnceLock<std::result::Result<(), String>> = OnceLock::new();
    INSTALLED
        .get_or_init(|| {
            let mut signals = signal_hook::iterator::Signals::new([SIGINT, SIGTERM, SIGUSR1, SIGHUP])
                .map_err(|e| e.to_string())?;
            std::thread::Builder::new()
                .name("validate-signals".into())
                .spawn(move || {
                    for sig in signals.forever() {
                        LAST.store(sig, Ordering::SeqCst);
                        COUNT.fetch_add(1, Ordering::SeqCst);
                    }
                })
                .map(|_| ())
                .map_err(|e| e.to_string())
        })
        .clone()
        .map_err(|e| Error::run(format!("validate: cannot install the signal handlers: {e}")))
}

/// How many stopping signals arrived, and the last one (0: none).
pub fn received() -> (usize, i32) {
    (COUNT.load(Ordering::SeqCst), LAST.load(Ordering::SeqCst))
}

/// True once a stopping signal arrived.
pub fn stopping() -> bool {
    received().0 > 0
}

/// The name of the last signal received.
pub fn name() -> &'static str {
    match received().1 {
        SIGINT => "SIGINT",
        SIGTERM => "SIGTERM",
        SIGUSR1 => "SIGUSR1",
        SIGHUP => "SIGHUP",
        _ => "a signal",
    }
}

/// The signal a child gets for `sig`: the same, but SIGHUP (validate's terminal closed, not
/// the child's) as SIGTERM, which every `hsph run` takes as a stop with a checkpoint.
fn for_child(sig: i32) -> i32 {
    if sig == SIGHUP {
        SIGTERM
    } else {
        sig
    }
}

/// A child `hsph run`, with the signals already forwarded to it.
pub struct Child {
    child: std::process::Child,
    forwarded: usize,
}

impl Child {
    /// Start `cmd` in a process group of its own, its input closed and its output piped.
    pub fn spawn(mut cmd: std::process::Command, exe: &std::path::Path) -> Result<Self> {
        use std::process::Stdio;
        cmd.stdin(Stdio::null())
            .stdout(Stdio::piped())
            .stderr(Stdio::piped());
        #[cfg(unix)]
        std::os::unix::process::CommandExt::process_group(&mut cmd, 0);
        let child = cmd.spawn().map_err(|e| Error::io(exe, e))?;
        Ok(Child { child, forwarded: 0 })
    }

    /// Wait for the child, forwarding every stopping signal this process receives meanwhile;
    /// its output (exit status, stdout, stderr). The pipes are read on threads of their own,
    /// so a child that writes much never blocks.
    pub fn wait(mut self) -> Result<std::process::Output> {
        use std::io::Read;
        fn drain<R: Read + Send + 'static>(r: Option<R>) -> std::thread::JoinHandle<Vec<u8>> {
            std::thread::spawn(move || {
                let mut v = Vec::new();
                if let Some(mut r) = r {
                    let _ = r.read_to_end(&mut v);
                }
                v
            })
        }
        let out = drain(self.child.stdout.take());
        let err = drain(self.child.stderr.take());
        let status = loop {
            // try_wait reaps the child only once it has exited: until then its pid is ours,
            // so the signal below cannot reach another process
            match self.child.try_wait() {
                Ok(Some(s)) => break s,
                Ok(None) => {}
                Err(e) => return Err(Error::run(format!("validate: waiting for a run: {e}"))),
            }
            let (n, sig) = received();
            if n > self.forwarded {
                self.forwarded = n;
                send(&self.child, for_child(sig));
            }
            std::thread::sleep(std::time::Duration::from_millis(20));
        };
        Ok(std::process::Output {
            status,
            stdout: out.join().unwrap_or_default(),
            stderr: err.join().unwrap_or_default(),
        })
    }
}

/// Send `sig` to `child`, which has not been reaped.
#[cfg(unix)]
#[allow(unsafe_code)]
fn send(child: &std::process::Child, sig: i32) {
    let Ok(pid) = libc::pid_t::try_from(child.id()) else {
        return;
    };
    // SAFETY: kill(2) with a pid of our own unreaped child and a valid signal number; it
    // touches no memory of this process
    unsafe {
        libc::kill(pid, sig);
    }
}

#[cfg(not(unix))]
fn send(_: &std::process::Child, _: i32) {}

//! Stopping a render by signal: the first SIGINT, SIGTERM or SIGHUP asks the render to finish
//! the pixels in flight and write a checkpoint, and ember then exits with 128 + the signal's
//! number (130 for SIGINT, 143 for SIGTERM, 129 for SIGHUP); a second one quits at once with
//! that code, after removing the temporary and lock files still open
//! ([`crate::atomic_write::remove_live_files`]).

use signal_hook::consts::{SIGHUP, SIGINT, SIGTERM};
use std::io::Write;
use std::sync::atomic::{AtomicBool, AtomicI32, Ordering};

/// The render was stopped by a signal; a checkpoint was written.
#[derive(Debug, thiserror::Error)]
#[error("{message}")]
pub struct Interrupted {
    pub message: String,
    /// The signal that stopped it.
    pub signal: i32,
}

impl Interrupted {
    /// 128 + the signal's number, as a shell reports a process the signal killed.
    pub fn exit_code(&self) -> u8 {
        (128 + self.signal).clamp(0, 255) as u8
    }
}

/// Set by the first signal.
pub(super) static STOP: AtomicBool = AtomicBool::new(false);
/// The first signal's number (set before [`STOP`]).
static SIGNAL: AtomicI32 = AtomicI32::new(SIGINT);

/// The signal that set [`STOP`].
pub(super) fn signal() -> i32 {
    SIGNAL.load(Ordering::SeqCst)
}

fn name(signal: i32) -> &'static str {
    match signal {
        SIGINT => "interrupt",
        SIGTERM => "SIGTERM",
        SIGHUP => "SIGHUP",
        _ => "signal",
    }
}

pub(super) fn install_handler() {
    let mut signals = match signal_hook::iterator::Signals::new([SIGINT, SIGTERM, SIGHUP]) {
        Ok(s) => s,
        Err(e) => {
            eprintln!("warning: cannot catch interrupts ({e}); an interrupted render will be lost");
            return;
        }
    };
    // Signals are delivered to this thread as ordinary values (signal-hook's handler only
    // wakes it), so it may lock, print and remove files.
    let spawned = std::thread::Builder::new().name("signals".into()).spawn(move || {
        for sig in signals.forever() {
            // Not eprintln!: stderr may be gone (SIGHUP), and printing must not panic.
            let mut err = std::io::stderr();
            if STOP.load(Ordering::SeqCst) {
                let _ = writeln!(err, "\n{} again: quitting without a checkpoint", name(sig));
                // Held until the process is gone: no temporary file is renamed meanwhile.
                let _held = crate::atomic_write::remove_live_files();
                std::process::exit(128 + sig);
            }
            SIGNAL.store(sig, Ordering::SeqCst);
            STOP.store(true, Ordering::SeqCst);
            let _ = writeln!(
                err,
                "\n{}: finishing the pixels in flight, then writing a checkpoint (interrupt again to quit at once)",
                name(sig)
            );
        }
    });
    if let Err(e) = spawned {
        eprintln!("warning: cannot catch interrupts ({e}); an interrupted render will be lost");
    }
}

/// The command line that continues this render.
pub(super) fn resume_command() -> String {
    let mut args: Vec<String> = std::env::args().collect();
    if !args.iter().any(|a| a == "--resume") {
        args.push("--resume".into());
    }
    args.iter().map(|a| if a.contains(' ') { format!("'{a}'") } else { a.clone() }).collect::<Vec<_>>().join(" ")
}

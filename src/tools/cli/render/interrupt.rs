//! Stopping a render by signal: the first SIGINT or SIGTERM asks the render to finish the
//! pixels in flight and write a checkpoint; a second one quits at once.

use std::sync::atomic::{AtomicBool, Ordering};

/// The render was stopped by a signal; a checkpoint was written.
#[derive(Debug, thiserror::Error)]
#[error("{0}")]
pub struct Interrupted(pub String);

/// Set by the first SIGINT/SIGTERM.
pub(super) static STOP: AtomicBool = AtomicBool::new(false);

pub(super) fn install_handler() {
    let result = ctrlc::set_handler(|| {
        if STOP.swap(true, Ordering::SeqCst) {
            eprintln!("\ninterrupted again: quitting without a checkpoint");
            std::process::exit(130);
        }
        eprintln!(
            "\ninterrupt: finishing the pixels in flight, then writing a checkpoint (interrupt again to quit at once)"
        );
    });
    if let Err(e) = result {
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

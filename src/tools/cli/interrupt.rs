//! Stopping `ember render` and `ember merge` by signal. What the first SIGINT, SIGTERM or
//! SIGHUP does depends on the [`Phase`] the command is in:
//!
//! - before a render has anything to keep (loading, building the BVH) and throughout a merge
//!   (its inputs are its state): ember quits at once, removing the temporary and lock files
//!   still open ([`crate::atomic_write::remove_live_files`]); nothing was written;
//! - while rendering: the render stops within a group of samples (inside a pixel too), writes
//!   a checkpoint and prints the command that resumes;
//! - while denoising a finished render: the denoiser is cancelled and a checkpoint of the
//!   finished render is written instead (resuming it denoises and writes the image);
//! - while writing the finished image: the write completes (the image is worth more than a
//!   checkpoint, and takes about as long), and ember says so.
//!
//! Whichever way, ember then exits with 128 + the signal's number (130 for SIGINT, 143 for
//! SIGTERM, 129 for SIGHUP); a second signal quits at once with that code, after removing the
//! temporary and lock files still open.

use crate::tools::say;
use signal_hook::consts::{SIGHUP, SIGINT, SIGTERM};
use std::io::Write;
use std::sync::atomic::{AtomicBool, AtomicI32, AtomicU8, Ordering};

/// The command was stopped by a signal; what it did about it is in the message.
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

    /// The command stopped by the signal that set [`STOP`], saying `message`.
    pub(super) fn by_signal(message: String) -> Interrupted {
        Interrupted { message, signal: signal() }
    }
}

/// What a command is doing, and so what a first signal does (see the module documentation).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[repr(u8)]
pub(super) enum Phase {
    /// Nothing to keep: quit at once.
    Preparing = 0,
    Rendering = 1,
    Denoising = 2,
    Writing = 3,
}

/// Set by the first signal (in every phase but [`Phase::Preparing`]).
pub(super) static STOP: AtomicBool = AtomicBool::new(false);
/// The first signal's number (set before [`STOP`]).
static SIGNAL: AtomicI32 = AtomicI32::new(SIGINT);
/// The current [`Phase`].
static PHASE: AtomicU8 = AtomicU8::new(Phase::Preparing as u8);

/// The signal that set [`STOP`].
pub(super) fn signal() -> i32 {
    SIGNAL.load(Ordering::SeqCst)
}

/// Whether a signal asked the command to stop.
pub(super) fn stop_requested() -> bool {
    STOP.load(Ordering::SeqCst)
}

/// Enters `phase`.
pub(super) fn set_phase(phase: Phase) {
    PHASE.store(phase as u8, Ordering::SeqCst);
}

/// The signal's name as messages give it.
pub(super) fn name(signal: i32) -> &'static str {
    match signal {
        SIGINT => "interrupt",
        SIGTERM => "SIGTERM",
        SIGHUP => "SIGHUP",
        _ => "signal",
    }
}

/// Removes the files still open and exits with 128 + `sig`.
fn quit(sig: i32) -> ! {
    // Held until the process is gone: no temporary file is renamed meanwhile.
    let _held = crate::atomic_write::remove_live_files();
    crate::posix::exit_now(128 + sig);
}

/// Catches SIGINT, SIGTERM and SIGHUP from here on, in [`Phase::Preparing`]; `output` is what
/// the command writes and `work` what it does ("render", "merge"), for messages.
pub(super) fn install_handler(output: &std::path::Path, work: &'static str) {
    let output = output.display().to_string();
    let mut signals = match signal_hook::iterator::Signals::new([SIGINT, SIGTERM, SIGHUP]) {
        Ok(s) => s,
        Err(e) => {
            say!("warning: cannot catch interrupts ({e}); an interrupted render will be lost");
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
                quit(sig);
            }
            let phase = PHASE.load(Ordering::SeqCst);
            if phase == Phase::Preparing as u8 {
                let _ = writeln!(err, "\n{}: quitting; {output} was not written", name(sig));
                quit(sig);
            }
            SIGNAL.store(sig, Ordering::SeqCst);
            STOP.store(true, Ordering::SeqCst);
            let doing = match phase {
                p if p == Phase::Rendering as u8 => "finishing the samples in flight, then writing a checkpoint",
                p if p == Phase::Denoising as u8 => {
                    "stopping the denoiser, then writing a checkpoint of the finished render"
                }
                _ => &format!("the {work} is finished: completing the image being written, then quitting"),
            };
            let _ = writeln!(err, "\n{}: {doing} ({} again to quit at once)", name(sig), name(sig));
        }
    });
    if let Err(e) = spawned {
        say!("warning: cannot catch interrupts ({e}); an interrupted render will be lost");
    }
}

/// The command line that continues this render, quoted for a POSIX shell.
pub(super) fn resume_command() -> String {
    let mut args: Vec<std::ffi::OsString> = std::env::args_os().collect();
    if !args.iter().any(|a| a == "--resume") {
        args.push("--resume".into());
    }
    args.iter().map(|a| shell_quote(a.as_encoded_bytes())).collect::<Vec<_>>().join(" ")
}

/// `arg` as a POSIX shell reads it back, byte for byte: as it is if it is made only of
/// characters no shell treats specially, else in single quotes (a quote as `'\''`); bytes that
/// are not UTF-8 as `"$(printf '\ooo')"`, so that the line stays text.
pub(super) fn shell_quote(arg: &[u8]) -> String {
    let plain = |c: u8| c.is_ascii_alphanumeric() || b"_./,=:+-".contains(&c);
    if !arg.is_empty() && arg.iter().all(|&c| plain(c)) {
        return String::from_utf8_lossy(arg).into_owned();
    }
    let mut out = String::new();
    for chunk in arg.utf8_chunks() {
        if !chunk.valid().is_empty() {
            out.push('\'');
            out.push_str(&chunk.valid().replace('\'', r"'\''"));
            out.push('\'');
        }
        if !chunk.invalid().is_empty() {
            let octal: String = chunk.invalid().iter().map(|b| format!("\\{b:03o}")).collect();
            out.push_str(&format!("\"$(printf '{octal}')\""));
        }
    }
    if out.is_empty() { "''".into() } else { out }
}

#[cfg(test)]
mod tests {
    use super::shell_quote;

    /// Every quoted argument, given to `sh -c 'printf %s "$1"'`, comes back byte for byte.
    #[test]
    fn quoted_arguments_read_back_exactly_in_a_posix_shell() {
        let args: [&[u8]; 10] = [
            b"plain/path_1.png",
            b"a'$(touch PWNED)'b.png",
            b"two words",
            b"",
            b"it's",
            b"$HOME;`id`|&<>*?[]{}~#!\"\\",
            b"new\nline",
            b"caf\xc3\xa9",
            b"bad\xffbyte\xfe",
            b"--spp=4",
        ];
        for arg in args {
            let quoted = shell_quote(arg);
            let out = std::process::Command::new("sh")
                .arg("-c")
                .arg(format!("printf %s {quoted}"))
                .current_dir(std::env::temp_dir())
                .output()
                .unwrap();
            assert_eq!(out.stdout, arg, "{quoted}");
        }
        assert_eq!(shell_quote(b"a'$(touch PWNED)'b.png"), r"'a'\''$(touch PWNED)'\''b.png'");
        assert_eq!(shell_quote(b"scenes/teapot.toml"), "scenes/teapot.toml");
    }
}

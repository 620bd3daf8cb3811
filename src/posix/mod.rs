//! The FFI module for the C library (POSIX), as `src/embree/` and `src/oidn/` are for theirs:
//! the one call ember makes to it that std does not offer, ending the process at once, and
//! the `unsafe` it needs.

/// Ends the process with `code` as `_exit(2)` does: no `atexit` handlers and no C++ static
/// destructors run. A process quitting from its signal thread must end this way: other
/// threads may still be inside Embree or OIDN, and `exit` would run those libraries'
/// destructors under them (a crash, SIGSEGV, in 2 of 40 `ember merge --denoise` runs
/// interrupted while preparing). Standard output is flushed first; standard error has no
/// buffer.
pub fn exit_now(code: i32) -> ! {
    let _ = std::io::Write::flush(&mut std::io::stdout());
    // SAFETY: `_exit` accepts any status, never returns, and reads no memory of ours.
    unsafe { libc::_exit(code) }
}

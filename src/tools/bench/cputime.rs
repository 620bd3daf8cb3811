//! CPU time consumed by this process, read from Linux's /proc (`None` elsewhere).
//!
//! On a machine shared with other work, wall time per ray measures the share of the CPU the
//! benchmark got as much as the work it did; CPU time per ray is much less sensitive to that,
//! so speedups computed from it stay meaningful when the load changes during a run.

use std::time::Duration;

/// How long [`cpu_of`] lets worker threads fall asleep before reading the clock.
pub const SETTLE: Duration = Duration::from_millis(3);

/// CPU time (user + system) of the live threads of this process, in nanoseconds: the sum of
/// the first field of `/proc/self/task/*/schedstat`. Threads that have exited are not counted,
/// so use it only across work done by threads that outlive the measurement (a rayon pool).
pub fn threads_cpu_time() -> Option<Duration> {
    let mut total = 0u64;
    for entry in std::fs::read_dir("/proc/self/task").ok()? {
        let path = entry.ok()?.path().join("schedstat");
        // A thread may exit between listing and reading: skip it.
        let Ok(text) = std::fs::read_to_string(path) else { continue };
        total += text.split_whitespace().next()?.parse::<u64>().ok()?;
    }
    Some(Duration::from_nanos(total))
}

/// The result of `work` and the CPU time it took (by [`threads_cpu_time`]).
///
/// The kernel brings a thread's count up to date when the thread is descheduled or at a timer
/// tick (4 ms here), so a reading lags a running thread by up to a tick. Pool workers go to
/// sleep soon after their work ends: waiting [`SETTLE`] before the second reading lets them,
/// so the count is exact to within the little spinning they do before sleeping.
pub fn cpu_of<T>(work: impl FnOnce() -> T) -> (T, Option<Duration>) {
    std::thread::sleep(SETTLE);
    let before = threads_cpu_time();
    let r = work();
    std::thread::sleep(SETTLE);
    let after = threads_cpu_time();
    (r, before.zip(after).map(|(b, a)| a.saturating_sub(b)))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// CPU time of the calling thread alone (other tests' threads come and go, so the sum
    /// over live threads may fall while this test runs).
    fn this_thread() -> Option<Duration> {
        let text = std::fs::read_to_string("/proc/thread-self/schedstat").ok()?;
        Some(Duration::from_nanos(text.split_whitespace().next()?.parse().ok()?))
    }

    /// Spins until this thread's clock has advanced by `amount`; false if that takes over 30 s
    /// of wall time.
    fn spin_until(amount: Duration) -> bool {
        let clock = this_thread;
        let start = std::time::Instant::now();
        let from = clock().unwrap();
        let mut x = 0u64;
        while start.elapsed() < Duration::from_secs(30) {
            for _ in 0..10_000 {
                x = std::hint::black_box(x.wrapping_add(1));
            }
            let now = clock().unwrap();
            assert!(now >= from, "clock went back");
            if now - from >= amount {
                return true;
            }
        }
        false
    }

    #[test]
    fn the_clock_advances_with_work() {
        if threads_cpu_time().is_none() {
            eprintln!("no /proc here: skipped");
            return;
        }
        assert!(spin_until(Duration::from_millis(20)));
        // The sum over live threads includes this one.
        let mine = this_thread().unwrap();
        assert!(threads_cpu_time().unwrap() >= mine);
        let (x, d) = cpu_of(|| 7);
        assert_eq!(x, 7);
        assert!(d.is_some());
    }
}

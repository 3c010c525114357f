//! The calling thread's CPU time, for timing the safety path's compute.
//!
//! Why not the wall clock: a step timed by the wall clock also counts the
//! time the thread waited while the OS ran something else (another world's
//! thread on a shared core, a timer tick: one tick is 4 ms at 250 Hz), so a
//! batch's maximum says more about the machine's load than about the
//! algorithm. The thread's CPU time counts only what the step computed.

// clock_gettime is a foreign function: the workspace denies unsafe code
// everywhere else.
#![allow(unsafe_code)]

use std::sync::OnceLock;
use std::time::Instant;

/// The calling thread's CPU time (µs, from an unspecified start), or `None`
/// where the OS has no per-thread CPU clock.
pub fn thread_cpu_us() -> Option<f64> {
    let mut ts = libc::timespec { tv_sec: 0, tv_nsec: 0 };
    // SAFETY: `ts` is a valid, writable timespec for the call's duration.
    let rc = unsafe { libc::clock_gettime(libc::CLOCK_THREAD_CPUTIME_ID, &mut ts) };
    (rc == 0).then_some(ts.tv_sec as f64 * 1e6 + ts.tv_nsec as f64 * 1e-3)
}

/// The clock steps are timed with (µs, from an unspecified start): the
/// thread's CPU time, else (no such clock) the wall clock since the first call.
pub fn step_clock_us() -> f64 {
    static HAS_CPU_CLOCK: OnceLock<bool> = OnceLock::new();
    static EPOCH: OnceLock<Instant> = OnceLock::new();
    if *HAS_CPU_CLOCK.get_or_init(|| thread_cpu_us().is_some()) {
        if let Some(us) = thread_cpu_us() {
            return us;
        }
    }
    EPOCH.get_or_init(Instant::now).elapsed().as_secs_f64() * 1e6
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn cpu_time_counts_work_not_sleep() {
        let t0 = thread_cpu_us().expect("Linux has a per-thread CPU clock");
        std::thread::sleep(std::time::Duration::from_millis(50));
        let slept = thread_cpu_us().unwrap() - t0;
        assert!(slept < 5_000.0, "50 ms asleep counted {slept} µs of CPU");
        // Work until the clock has counted 20 ms of it. On a loaded machine that takes
        // longer than 20 ms of wall time, so the wall clock only bounds the wait: a
        // clock that does not count work never gets there.
        let (w0, c0) = (Instant::now(), thread_cpu_us().unwrap());
        let mut x = 0u64;
        while thread_cpu_us().unwrap() - c0 < 20_000.0 && w0.elapsed().as_secs() < 60 {
            for _ in 0..1000 {
                x = std::hint::black_box(x.wrapping_add(1));
            }
        }
        let worked = thread_cpu_us().unwrap() - c0;
        assert!(worked >= 20_000.0, "a minute of spinning counted only {worked} µs");
    }
}

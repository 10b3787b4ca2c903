//! CPU-time clocks for benches that run on a shared machine: wall time there measures
//! the other jobs as much as ours, the CPU time of the bench thread (or process) does
//! not. Used through criterion's `iter_custom`, so the reports read as times.
//!
//! Linux only (`clock_gettime` with `CLOCK_THREAD_CPUTIME_ID` /
//! `CLOCK_PROCESS_CPUTIME_ID`, through rustix's safe wrapper).

use std::time::Duration;

use rustix::time::{ClockId, clock_gettime};

fn read(clock: ClockId) -> Duration {
    let t = clock_gettime(clock);
    Duration::new(t.tv_sec as u64, t.tv_nsec as u32)
}

/// CPU time consumed so far by the calling thread.
pub fn thread_cpu() -> Duration {
    read(ClockId::ThreadCPUTime)
}

/// CPU time consumed so far by every thread of this process.
#[allow(dead_code)] // not every bench that includes this module runs threads
pub fn process_cpu() -> Duration {
    read(ClockId::ProcessCPUTime)
}

/// Runs `f` `iters` times and returns the calling thread's CPU time for them.
pub fn thread_cpu_of<R>(iters: u64, mut f: impl FnMut() -> R) -> Duration {
    let start = thread_cpu();
    for _ in 0..iters {
        std::hint::black_box(f());
    }
    thread_cpu() - start
}

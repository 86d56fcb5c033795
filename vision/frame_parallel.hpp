#pragma once
// Per-frame work of a shot's analysis spread over the CPU cores this process
// may use: frames are independent in the detect and dot stages, so a shot is
// analysed about twice as fast on two cores, with the same results (each
// frame's work is the same whichever thread does it).
//
// The cores are those the process is allowed to run on (sched_getaffinity:
// a Slurm task or `taskset` limits them), at most COLLIDE_THREADS when that
// is set (1: no threads at all).
#include <cstddef>
#include <functional>

namespace collide::vision {

/// Threads the per-frame stages use: the cores this process may run on,
/// capped by the environment variable COLLIDE_THREADS when it holds a positive
/// integer; at least 1.
int frameThreads();

/// Runs work(k) for every k in [0, n), on up to frameThreads() threads (the
/// calling thread is one of them). `progress(done, n)` is called only on the
/// calling thread, with done increasing, and last with done == n. The first
/// exception thrown by `work` stops the remaining frames and is rethrown here
/// once every thread has finished.
void forEachFrame(std::size_t n, const std::function<void(std::size_t)>& work,
                  const std::function<void(int, int)>& progress = {});

}  // namespace collide::vision

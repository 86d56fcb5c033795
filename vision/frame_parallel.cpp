#include "vision/frame_parallel.hpp"

#include <sched.h>

#include <algorithm>
#include <atomic>
#include <cstdlib>
#include <exception>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

namespace collide::vision {

int frameThreads() {
  int cores = 0;
  cpu_set_t set;
  CPU_ZERO(&set);
  if (sched_getaffinity(0, sizeof set, &set) == 0) cores = CPU_COUNT(&set);
  if (cores <= 0) cores = static_cast<int>(std::thread::hardware_concurrency());
  if (const char* env = std::getenv("COLLIDE_THREADS")) {
    char* end = nullptr;
    const long cap = std::strtol(env, &end, 10);
    if (end != env && *end == '\0' && cap > 0) cores = std::min<long>(cores > 0 ? cores : cap, cap);
  }
  return std::max(1, cores);
}

void forEachFrame(std::size_t n, const std::function<void(std::size_t)>& work,
                  const std::function<void(int, int)>& progress) {
  const int total = static_cast<int>(n);
  const std::size_t threads = std::min<std::size_t>(static_cast<std::size_t>(frameThreads()), n);
  std::atomic<std::size_t> next{0}, done{0};
  std::exception_ptr error;
  std::mutex error_mutex;
  int reported = 0;
  const auto run = [&](bool calling_thread) {
    for (std::size_t k = next.fetch_add(1); k < n; k = next.fetch_add(1)) {
      try {
        work(k);
      } catch (...) {
        std::lock_guard lock(error_mutex);
        if (!error) error = std::current_exception();
        next.store(n);  // no new frames
      }
      const int d = static_cast<int>(done.fetch_add(1) + 1);
      if (calling_thread && progress && d > reported) progress(reported = d, total);
    }
  };
  std::vector<std::thread> pool;
  for (std::size_t i = 1; i < threads; ++i) pool.emplace_back(run, false);
  run(true);
  for (std::thread& t : pool) t.join();
  if (error) std::rethrow_exception(error);
  if (progress && reported < total) progress(total, total);
}

}  // namespace collide::vision

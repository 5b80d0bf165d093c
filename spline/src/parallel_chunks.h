#pragma once
// Internal to the spline module: a fixed split of [0, count) over threads.
#include <algorithm>
#include <functional>
#include <thread>
#include <vector>

namespace tet2spline::spline::detail {

/// Runs fn(begin, end, chunk) on `threads` contiguous chunks of [0, count)
/// (fewer when count is smaller), the chunks in order of begin.
inline void parallelChunks(int threads, long count, const std::function<void(long, long, int)>& fn) {
  threads = std::max(1, std::min<int>(threads, static_cast<int>(std::max<long>(1, count))));
  if (threads == 1) {
    fn(0, count, 0);
    return;
  }
  std::vector<std::thread> pool;
  for (int t = 0; t < threads; ++t) {
    const long b = count * t / threads, e = count * (t + 1) / threads;
    pool.emplace_back(fn, b, e, t);
  }
  for (auto& th : pool) th.join();
}

}  // namespace tet2spline::spline::detail

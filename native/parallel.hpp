// Threads for the kernels: a range cut into pieces run on one thread a core, the calling
// thread taking the first. The GIL is released by the binding (nb::call_guard) before this.
#pragma once
#include <algorithm>
#include <atomic>
#include <cstddef>
#include <thread>
#include <vector>

namespace texbake {

// below this many items a kernel runs on the calling thread: a thread's start costs more
constexpr std::ptrdiff_t MIN_PIECE = 32768;

inline int cores() {
  static const int n = std::max(1u, std::thread::hardware_concurrency());
  return n;
}

// fn(begin, end) over [0, n) in at most cores() contiguous pieces
template <class Fn>
void parallel_for(std::ptrdiff_t n, Fn&& fn, std::ptrdiff_t min_piece = MIN_PIECE) {
  const std::ptrdiff_t pieces = std::max<std::ptrdiff_t>(1, std::min<std::ptrdiff_t>(cores(), n / min_piece));
  if (pieces <= 1) {
    if (n > 0) fn(std::ptrdiff_t(0), n);
    return;
  }
  std::vector<std::thread> threads;
  threads.reserve(pieces - 1);
  const std::ptrdiff_t step = (n + pieces - 1) / pieces;
  for (std::ptrdiff_t p = 1; p < pieces; ++p) {
    const std::ptrdiff_t b = p * step, e = std::min(n, b + step);
    if (b < e) threads.emplace_back([&fn, b, e] { fn(b, e); });
  }
  fn(std::ptrdiff_t(0), std::min(n, step));
  for (auto& t : threads) t.join();
}

// fn(begin, end) over [0, n) in chunks of chunk items that cores() threads take in turn
// (the calling thread one of them): on a machine other processes load, a thread that gets
// less of a core takes fewer chunks instead of holding up the call (parallel_for's equal
// pieces wait for the slowest). Only for kernels whose items do not depend on the piece.
template <class Fn>
void parallel_chunks(std::ptrdiff_t n, Fn&& fn, std::ptrdiff_t chunk, std::ptrdiff_t min_piece = MIN_PIECE) {
  const std::ptrdiff_t threads = std::max<std::ptrdiff_t>(1, std::min<std::ptrdiff_t>(cores(), n / min_piece));
  if (threads <= 1) {
    if (n > 0) fn(std::ptrdiff_t(0), n);
    return;
  }
  std::atomic<std::ptrdiff_t> next{0};
  const auto run = [&] {
    for (;;) {
      const std::ptrdiff_t b = next.fetch_add(chunk, std::memory_order_relaxed);
      if (b >= n) return;
      fn(b, std::min(n, b + chunk));
    }
  };
  std::vector<std::thread> pool;
  pool.reserve(threads - 1);
  for (std::ptrdiff_t t = 1; t < threads; ++t) pool.emplace_back(run);
  run();
  for (auto& t : pool) t.join();
}

}  // namespace texbake

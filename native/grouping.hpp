// Grouping in linear time, where sorts are n log n: rows of 64-bit words grouped by exact
// equality (an open-addressing hash table, groups numbered in the order of their first row),
// and edges paired by their two ends (bucketed by the smaller end: the mesh's own order
// keeps those buckets near each other in memory, where a hash scatters them).
#pragma once
#include <algorithm>
#include <cstdint>
#include <cstring>
#include <numeric>
#include <vector>

namespace texbake {

inline uint64_t mix64(uint64_t h) {  // splitmix64's finaliser
  h ^= h >> 30;
  h *= 0xBF58476D1CE4E5B9ULL;
  h ^= h >> 27;
  h *= 0x94D049BB133111EBULL;
  return h ^ (h >> 31);
}

inline uint64_t hash_words(const uint64_t* row, int64_t d) {
  uint64_t h = 0x9E3779B97F4A7C15ULL;
  for (int64_t k = 0; k < d; ++k) h = mix64(h ^ row[k]) + 0x9E3779B97F4A7C15ULL * uint64_t(k + 1);
  return h;
}

// inverse[i] (n,) := the group of row i, of n rows of d <= 8 words that row(i, words) writes;
// returns each group's first row. The rows' slots are prefetched a block ahead (the table is
// larger than the caches), and a slot holds 32 bits of its row's hash beside the group, so
// that rows are compared only where those bits agree.
template <class Row>
inline std::vector<int64_t> group_rows_of(int64_t n, int64_t d, Row&& row, int64_t* inverse) {
  uint64_t cap = 2;
  while (cap < uint64_t(2 * n)) cap <<= 1;
  const uint64_t mask = cap - 1;
  constexpr uint64_t EMPTY = ~uint64_t(0);
  std::vector<uint64_t> slot(cap, EMPTY);  // hash bits << 32 | group
  std::vector<int64_t> first;
  constexpr int64_t BLOCK = 32;
  uint64_t hashes[BLOCK], words[BLOCK][8], other[8];
  for (int64_t b = 0; b < n; b += BLOCK) {
    const int64_t e = std::min(n, b + BLOCK);
    for (int64_t i = b; i < e; ++i) {
      row(i, words[i - b]);
      hashes[i - b] = hash_words(words[i - b], d);
      __builtin_prefetch(&slot[hashes[i - b] & mask]);
    }
    for (int64_t i = b; i < e; ++i) {
      const uint64_t h = hashes[i - b], tag = h >> 32;
      for (uint64_t j = h & mask;; j = (j + 1) & mask) {
        const uint64_t s = slot[j];
        if (s == EMPTY) {
          slot[j] = tag << 32 | uint64_t(first.size());
          inverse[i] = int64_t(first.size());
          first.push_back(i);
          break;
        }
        const int64_t g = int64_t(s & 0xFFFFFFFFu);
        if ((s >> 32) == tag) {
          row(first[g], other);
          if (std::memcmp(other, words[i - b], size_t(d) * 8) == 0) {
            inverse[i] = g;
            break;
          }
        }
      }
    }
  }
  return first;
}

// group_rows_of the rows (n, d) of words
inline std::vector<int64_t> group_words(const uint64_t* rows, int64_t n, int64_t d, int64_t* inverse) {
  return group_rows_of(n, d, [rows, d](int64_t i, uint64_t* out) { std::memcpy(out, rows + d * i, size_t(d) * 8); }, inverse);
}

// For the edges (a(h), b(h)) of ends in [0, ends) with take(h): pair(h, k) for each k whose
// ends (either way round) an earlier taken edge h has, h the latest such (the edges of one
// pair of ends paired in index order: (h0, h1), (h1, h2), ...), as a stable sort by the
// ends pairs neighbours. n < 2**31.
template <class A, class B, class Take, class Pair>
inline void edge_pairs(A&& a, B&& b, int64_t n, int64_t ends, Take&& take, Pair&& pair) {
  std::vector<int32_t> offset(ends + 1, 0);
  for (int64_t h = 0; h < n; ++h) {
    if (take(h)) ++offset[std::min(a(h), b(h)) + 1];
  }
  std::partial_sum(offset.begin(), offset.end(), offset.begin());
  std::vector<int32_t> bucket(offset.back()), fill(offset.begin(), offset.end() - 1);
  for (int64_t h = 0; h < n; ++h) {  // each bucket in index order
    if (take(h)) bucket[fill[std::min(a(h), b(h))]++] = int32_t(h);
  }
  std::vector<int32_t> sorted;
  auto other = [&](int64_t h) { return std::max(a(h), b(h)); };
  for (int64_t u = 0; u < ends; ++u) {
    int32_t* items = bucket.data() + offset[u];
    const int64_t size = offset[u + 1] - offset[u];
    if (size <= 16) {  // a vertex's few edges: the latest earlier one of the same other end
      for (int64_t i = 1; i < size; ++i) {
        const int64_t end = other(items[i]);
        for (int64_t j = i - 1; j >= 0; --j) {
          if (other(items[j]) == end) {
            pair(items[j], items[i]);
            break;
          }
        }
      }
      continue;
    }
    sorted.assign(items, items + size);  // a vertex of many edges: sorted by the other end, stably
    std::stable_sort(sorted.begin(), sorted.end(), [&](int32_t x, int32_t y) { return other(x) < other(y); });
    for (int64_t i = 1; i < size; ++i) {
      if (other(sorted[i - 1]) == other(sorted[i])) pair(sorted[i - 1], sorted[i]);
    }
  }
}

}  // namespace texbake

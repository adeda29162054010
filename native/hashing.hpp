// Rows of 64-bit words grouped by exact equality with one open-addressing hash table: linear
// time where a sort is n log n. Groups are numbered in the order of their first row.
#pragma once
#include <cstdint>
#include <cstring>
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

// inverse[i] (n,) := the group of row i of rows (n, d); returns each group's first row
inline std::vector<int64_t> group_words(const uint64_t* rows, int64_t n, int64_t d, int64_t* inverse) {
  uint64_t cap = 2;
  while (cap < uint64_t(2 * n)) cap <<= 1;
  const uint64_t mask = cap - 1;
  std::vector<uint32_t> slot(cap, UINT32_MAX);  // a group's number, or empty
  std::vector<int64_t> first;
  for (int64_t i = 0; i < n; ++i) {
    const uint64_t* row = rows + d * i;
    for (uint64_t j = hash_words(row, d) & mask;; j = (j + 1) & mask) {
      const uint32_t g = slot[j];
      if (g == UINT32_MAX) {
        slot[j] = uint32_t(first.size());
        inverse[i] = int64_t(first.size());
        first.push_back(i);
        break;
      }
      if (std::memcmp(rows + d * first[g], row, size_t(d) * 8) == 0) {
        inverse[i] = g;
        break;
      }
    }
  }
  return first;
}

// For keys (n,): call pair(h, k) for each k whose key an earlier taken item h has, h the
// latest such (items of one key paired in index order: (h0, h1), (h1, h2), ...), as a
// stable sort by key pairs neighbours
template <class Take, class Pair>
inline void consecutive_pairs(const uint64_t* key, int64_t n, Take&& take, Pair&& pair) {
  uint64_t cap = 2;
  while (cap < uint64_t(2 * n)) cap <<= 1;
  const uint64_t mask = cap - 1;
  std::vector<uint64_t> keys(cap);
  std::vector<int64_t> last(cap, -1);
  for (int64_t i = 0; i < n; ++i) {
    if (!take(i)) continue;
    for (uint64_t j = mix64(key[i]) & mask;; j = (j + 1) & mask) {
      if (last[j] < 0) {
        keys[j] = key[i];
        last[j] = i;
        break;
      }
      if (keys[j] == key[i]) {
        pair(last[j], i);
        last[j] = i;
        break;
      }
    }
  }
}

}  // namespace texbake

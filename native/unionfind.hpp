// Union-find over int64 node arrays: each set's root is its smallest node, and sets are
// numbered in the order of their smallest node (scipy.sparse.csgraph's labels). Shared by
// the connected components (components.cpp) and the normals' fans (normals.cpp).
#pragma once
#include <algorithm>
#include <cstdint>

namespace texbake {

// the root of node i, halving the path to it on the way
inline int64_t root(int64_t* parent, int64_t i) {
  while (parent[i] != i) {
    parent[i] = parent[parent[i]];
    i = parent[i];
  }
  return i;
}

// join the sets of i and j; the smaller root stays the root, and is returned
inline int64_t join(int64_t* parent, int64_t i, int64_t j) {
  const int64_t x = root(parent, i), y = root(parent, j);
  if (x != y) parent[std::max(x, y)] = std::min(x, y);
  return std::min(x, y);
}

// labels of the sets, in the order of their smallest node (a set's label is given there)
inline void number(int64_t* parent, int64_t n, int64_t* label) {
  std::fill(label, label + n, -1);
  int64_t count = 0;
  for (int64_t i = 0; i < n; ++i) {
    const int64_t r = root(parent, i);
    if (label[r] < 0) label[r] = count++;
    label[i] = label[r];
  }
}

}  // namespace texbake

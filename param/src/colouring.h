#pragma once
// Internal: the greedy colouring behind the sweeps that move the vertices of
// one colour at once on all cores (boundary_smoothing.cpp, and the local
// max-min repair in untangle.cpp). Vertices of one colour share no tet, so
// each move reads and writes only its own star, and a sweep's result does
// not depend on the threads.
#include <algorithm>
#include <cstddef>
#include <vector>

namespace tet2spline::detail {

/// The vertices of `order` in colour classes (each class in `order`'s
/// order): each vertex in turn takes the smallest colour that none of the
/// vertices already coloured among its neighbours has. forEachNeighbour(v,
/// f) calls f(u) for every vertex u that may not share v's colour (repeats
/// allowed). `colour`, indexed by vertex, must be −1 at `order`'s vertices
/// and their neighbours; the vertices of `order` are set back to −1 at the
/// end.
template <class ForEachNeighbour>
std::vector<std::vector<int>> greedyColourClasses(const std::vector<int>& order, std::vector<int>& colour,
                                                  const ForEachNeighbour& forEachNeighbour) {
  std::vector<std::vector<int>> classes;
  std::vector<char> taken;
  for (int v : order) {
    taken.assign(taken.size(), 0);
    forEachNeighbour(v, [&](int u) {
      const int c = colour[static_cast<size_t>(u)];
      if (c < 0) return;
      if (static_cast<size_t>(c) >= taken.size()) taken.resize(static_cast<size_t>(c) + 1, 0);
      taken[static_cast<size_t>(c)] = 1;
    });
    const auto c = static_cast<size_t>(std::find(taken.begin(), taken.end(), 0) - taken.begin());
    colour[static_cast<size_t>(v)] = static_cast<int>(c);
    if (c >= classes.size()) classes.resize(c + 1);
    classes[c].push_back(v);
  }
  for (int v : order) colour[static_cast<size_t>(v)] = -1;
  return classes;
}

}  // namespace tet2spline::detail

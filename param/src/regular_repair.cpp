// Flip repair of regular triangulations (see regular_repair.h). Only CGAL's
// kernel predicates are used here (no triangulation package).
#include "regular_repair.h"

#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <tbb/blocked_range.h>
#include <tbb/enumerable_thread_specific.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <atomic>
#include <utility>

namespace tet2spline {
namespace {

using K = CGAL::Exact_predicates_inexact_constructions_kernel;

// The slot of u whose neighbour is t.
int mirrorSlot(const TetArrays& tets, int u, int t) {
  for (int s = 0; s < 4; ++s)
    if (tets.neighbour[u][s] == t) return s;
  return -1;
}

int slotOf(const std::array<int, 4>& tet, int v) {
  for (int s = 0; s < 4; ++s)
    if (tet[s] == v) return s;
  return -1;
}

class FlipRepair {
 public:
  FlipRepair(const Eigen::MatrixX3d& points, const Eigen::VectorXd& weights, TetArrays& tets)
      : tets_(tets), alive_(tets.vertex.size(), 1) {
    const int n = static_cast<int>(points.rows());
    site_.reserve(n);
    for (int i = 0; i < n; ++i) site_.emplace_back(K::Point_3(points(i, 0), points(i, 1), points(i, 2)), weights[i]);
  }

  // Whether the facet opposite slot q of t is locally regular (hull facets are).
  bool regular(int t, int q) const {
    const int u = tets_.neighbour[t][q];
    if (u < 0) return true;
    const int b = tets_.vertex[u][mirrorSlot(tets_, u, t)];
    const auto& v = tets_.vertex[t];
    return powerSide_(site_[v[0]], site_[v[1]], site_[v[2]], site_[v[3]], site_[b]) != CGAL::ON_POSITIVE_SIDE;
  }

  // Whether no two hull facets sharing an edge are coplanar. Flips never
  // touch the hull, which the weights cannot change unless sites lie on it
  // without being its corners (4 coplanar sites on a hull plane: a grid in
  // a cube); then the hull's own triangulation must be regular too, which
  // flips of interior facets cannot arrange.
  bool hullInGeneralPosition() const {
    struct HullEdge {
      long long key;
      int t, q, apex;  // the hull facet opposite slot q of t, and its third vertex
    };
    std::vector<HullEdge> edges;
    const int nt = static_cast<int>(tets_.vertex.size());
    for (int t = 0; t < nt; ++t)
      for (int q = 0; q < 4; ++q) {
        if (tets_.neighbour[t][q] >= 0) continue;
        int f[3], k = 0;
        for (int s = 0; s < 4; ++s)
          if (s != q) f[k++] = tets_.vertex[t][s];
        for (int e = 0; e < 3; ++e) {
          const long long i = std::min(f[e], f[(e + 1) % 3]), j = std::max(f[e], f[(e + 1) % 3]);
          edges.push_back({(i << 32) | j, t, q, f[(e + 2) % 3]});
        }
      }
    std::sort(edges.begin(), edges.end(), [](const HullEdge& a, const HullEdge& b) { return a.key < b.key; });
    for (size_t e = 0; e + 1 < edges.size(); ++e) {
      if (edges[e].key != edges[e + 1].key) continue;
      const auto& v = tets_.vertex[edges[e].t];
      int f[3], k = 0;
      for (int s = 0; s < 4; ++s)
        if (s != edges[e].q) f[k++] = v[s];
      if (orientation_(site_[f[0]].point(), site_[f[1]].point(), site_[f[2]].point(),
                       site_[edges[e + 1].apex].point()) == CGAL::COPLANAR)
        return false;
    }
    return true;
  }

  bool run(long maxFlips, long& flips, std::vector<int>* suspects) {
    flips = 0;
    if (!hullInGeneralPosition()) return false;
    const int nt = static_cast<int>(tets_.vertex.size());
    // Every facet once (from its lower-numbered tet), in parallel.
    // A tet that is not positive in these sites means the seed was not a
    // triangulation of them: given up.
    tbb::enumerable_thread_specific<std::vector<std::pair<int, int>>> found;
    std::atomic<bool> positive{true};
    tbb::parallel_for(tbb::blocked_range<int>(0, nt, 4096), [&](const tbb::blocked_range<int>& range) {
      auto& local = found.local();
      for (int t = range.begin(); t != range.end(); ++t) {
        const auto& v = tets_.vertex[t];
        if (orientation_(site_[v[0]].point(), site_[v[1]].point(), site_[v[2]].point(), site_[v[3]].point()) !=
            CGAL::POSITIVE)
          positive = false;
        for (int q = 0; q < 4; ++q)
          if (tets_.neighbour[t][q] > t && !regular(t, q)) local.emplace_back(t, q);
      }
    });
    if (!positive) return false;
    for (const auto& local : found) stack_.insert(stack_.end(), local.begin(), local.end());
    std::sort(stack_.begin(), stack_.end(), std::greater<>());  // popped in increasing order: deterministic
    std::vector<std::pair<int, int>> deferred;
    while (true) {
      long flipsBefore = flips;
      while (!stack_.empty()) {
        const auto [t, q] = stack_.back();
        stack_.pop_back();
        if (!alive_[t] || regular(t, q)) continue;
        if (flip(t, q)) {
          if (++flips > maxFlips) {
            stack_.insert(stack_.end(), deferred.begin(), deferred.end());
            giveUp(stack_, suspects);
            return false;
          }
        } else {
          deferred.emplace_back(t, q);
        }
      }
      if (deferred.empty()) break;
      // Facets no flip could remove yet: later flips may have made them
      // regular or flippable. Stalled when a whole round flips nothing.
      if (flips == flipsBefore) {
        for (const auto& [t, q] : deferred)
          if (alive_[t] && !regular(t, q)) {
            giveUp(deferred, suspects);
            return false;
          }
        break;
      }
      stack_.assign(deferred.rbegin(), deferred.rend());
      deferred.clear();
    }
    compact();
    return true;
  }

 private:
  // After a stall or at the flip limit: the sites of the facets in
  // `facets` that are not locally regular (sorted, unique) into
  // `suspects`, and the tets compacted (a valid triangulation).
  void giveUp(const std::vector<std::pair<int, int>>& facets, std::vector<int>* suspects) {
    if (suspects) {
      suspects->clear();
      for (const auto& [t, q] : facets) {
        if (!alive_[t] || regular(t, q)) continue;
        const int u = tets_.neighbour[t][q];
        suspects->insert(suspects->end(), tets_.vertex[t].begin(), tets_.vertex[t].end());
        suspects->push_back(tets_.vertex[u][mirrorSlot(tets_, u, t)]);
      }
      std::sort(suspects->begin(), suspects->end());
      suspects->erase(std::unique(suspects->begin(), suspects->end()), suspects->end());
    }
    compact();
  }

  // Tet t with slot r's vertex replaced by site b, oriented?
  CGAL::Orientation orientationWith(int t, int r, int b) const {
    std::array<int, 4> v = tets_.vertex[t];
    v[r] = b;
    return orientation_(site_[v[0]].point(), site_[v[1]].point(), site_[v[2]].point(), site_[v[3]].point());
  }

  int newTet() {
    if (!free_.empty()) {
      const int t = free_.back();
      free_.pop_back();
      alive_[t] = 1;
      return t;
    }
    tets_.vertex.emplace_back();
    tets_.neighbour.emplace_back();
    alive_.push_back(1);
    return static_cast<int>(tets_.vertex.size()) - 1;
  }

  void link(int outer, int outerSlot, int t) {
    if (outer >= 0) tets_.neighbour[outer][outerSlot] = t;
  }

  void pushFacets(int t) {
    for (int s = 0; s < 4; ++s) stack_.emplace_back(t, s);
  }

  // Removes the non-regular facet opposite slot q of t by a 2-3 or a 3-2
  // flip when the tets involved are in convex position; false otherwise.
  bool flip(int t, int q) {
    const int u = tets_.neighbour[t][q];
    const int uq = mirrorSlot(tets_, u, t);
    const std::array<int, 4> tv = tets_.vertex[t], uv = tets_.vertex[u];
    const int b = uv[uq];
    int negative = -1, positives = 0;
    for (int r = 0; r < 4; ++r) {
      if (r == q) continue;
      const CGAL::Orientation o = orientationWith(t, r, b);
      if (o == CGAL::POSITIVE) ++positives;
      else if (o == CGAL::NEGATIVE && negative < 0) negative = r;
      else return false;  // coplanar (a 4-4 flip) or two negatives
    }
    int outT[4], outU[4], mirrorT[4], mirrorU[4];
    for (int r = 0; r < 4; ++r) {
      if (r == q) continue;
      outT[r] = tets_.neighbour[t][r];
      mirrorT[r] = outT[r] >= 0 ? mirrorSlot(tets_, outT[r], t) : -1;
      const int us = slotOf(uv, tv[r]);
      outU[r] = tets_.neighbour[u][us];
      mirrorU[r] = outU[r] >= 0 ? mirrorSlot(tets_, outU[r], u) : -1;
    }
    if (positives == 3) {
      // 2-3: the tets N_r = t with its slot r (r ≠ q) taken by b, around the
      // new edge ab. N_r meets t's outer tet opposite v_r across the slot r,
      // u's outer tet opposite v_r across slot q, and N_s across slot s.
      int made[4] = {-1, -1, -1, -1};
      int rs[3], k = 0;
      for (int r = 0; r < 4; ++r)
        if (r != q) rs[k++] = r;
      made[rs[0]] = t;
      made[rs[1]] = u;
      made[rs[2]] = newTet();
      for (int r : rs) {
        const int m = made[r];
        std::array<int, 4> v = tv;
        v[r] = b;
        tets_.vertex[m] = v;
        for (int s : rs) tets_.neighbour[m][s] = made[s];
        tets_.neighbour[m][r] = outT[r];
        tets_.neighbour[m][q] = outU[r];
      }
      for (int r : rs) {
        link(outT[r], mirrorT[r], made[r]);
        link(outU[r], mirrorU[r], made[r]);
      }
      for (int r : rs) pushFacets(made[r]);
      return true;
    }
    // 3-2 when the segment ab leaves the shared triangle across the edge
    // (v_s, v_w) opposite v_r (r = negative) and exactly three tets t, u, x
    // surround that edge: x = (a, b, v_s, v_w) becomes the two tets
    // M_s, M_w = t with slot s resp. w taken by b, sharing the face (a, b, v_r).
    const int r = negative;
    const int x = outT[r];
    if (x < 0 || x != outU[r] || slotOf(tets_.vertex[x], b) < 0) return false;
    const std::array<int, 4> xv = tets_.vertex[x];
    int sw[2], k = 0;
    for (int s = 0; s < 4; ++s)
      if (s != q && s != r) sw[k++] = s;
    int outX[4], mirrorX[4];
    for (int s : sw) {
      outX[s] = tets_.neighbour[x][slotOf(xv, tv[s])];
      mirrorX[s] = outX[s] >= 0 ? mirrorSlot(tets_, outX[s], x) : -1;
    }
    const int made[2] = {t, u};
    for (int c = 0; c < 2; ++c) {
      const int s = sw[c], other = sw[1 - c], m = made[c];
      std::array<int, 4> v = tv;
      v[s] = b;
      tets_.vertex[m] = v;
      tets_.neighbour[m][s] = outT[s];
      tets_.neighbour[m][q] = outU[s];
      tets_.neighbour[m][r] = outX[s];
      tets_.neighbour[m][other] = made[1 - c];
    }
    for (int c = 0; c < 2; ++c) {
      const int s = sw[c];
      link(outT[s], mirrorT[s], made[c]);
      link(outU[s], mirrorU[s], made[c]);
      link(outX[s], mirrorX[s], made[c]);
    }
    alive_[x] = 0;
    free_.push_back(x);
    pushFacets(t);
    pushFacets(u);
    return true;
  }

  // Drops the freed slots, renumbering the tets.
  void compact() {
    const int nt = static_cast<int>(tets_.vertex.size());
    std::vector<int> index(nt, -1);
    int kept = 0;
    for (int t = 0; t < nt; ++t)
      if (alive_[t]) index[t] = kept++;
    if (kept == nt) return;
    for (int t = 0; t < nt; ++t) {
      if (!alive_[t]) continue;
      const int m = index[t];
      tets_.vertex[m] = tets_.vertex[t];
      for (int q = 0; q < 4; ++q) {
        const int u = tets_.neighbour[t][q];
        tets_.neighbour[m][q] = u >= 0 ? index[u] : -1;
      }
    }
    tets_.vertex.resize(kept);
    tets_.neighbour.resize(kept);
  }

  TetArrays& tets_;
  std::vector<K::Weighted_point_3> site_;
  std::vector<char> alive_;
  std::vector<int> free_;
  std::vector<std::pair<int, int>> stack_;
  K::Power_side_of_oriented_power_sphere_3 powerSide_ = K().power_side_of_oriented_power_sphere_3_object();
  K::Orientation_3 orientation_ = K().orientation_3_object();
};

// The 12 even permutations of (0, 1, 2, 3).
constexpr int kEvenPermutations[12][4] = {{0, 1, 2, 3}, {0, 2, 3, 1}, {0, 3, 1, 2}, {1, 0, 3, 2},
                                          {1, 2, 0, 3}, {1, 3, 2, 0}, {2, 0, 1, 3}, {2, 1, 3, 0},
                                          {2, 3, 0, 1}, {3, 0, 2, 1}, {3, 1, 0, 2}, {3, 2, 1, 0}};

}  // namespace

bool repairRegularTriangulation(const Eigen::MatrixX3d& points, const Eigen::VectorXd& weights, TetArrays& tets,
                                long maxFlips, long* flips, std::vector<int>* suspects) {
  if (suspects) suspects->clear();
  FlipRepair repair(points, weights, tets);
  long count = 0;
  const bool ok = repair.run(maxFlips, count, suspects);
  if (flips) *flips = count;
  return ok;
}

void canonicalizeTets(TetArrays& tets, int sites) {
  const int nt = static_cast<int>(tets.vertex.size());
  // Each tet turned to its smallest even permutation.
  tbb::parallel_for(tbb::blocked_range<int>(0, nt, 8192), [&](const tbb::blocked_range<int>& range) {
    for (int t = range.begin(); t != range.end(); ++t) {
      const std::array<int, 4> v = tets.vertex[t], nb = tets.neighbour[t];
      int best = 0;
      std::array<int, 4> bestV = v;
      for (int p = 1; p < 12; ++p) {
        std::array<int, 4> w;
        for (int s = 0; s < 4; ++s) w[s] = v[kEvenPermutations[p][s]];
        if (w < bestV) {
          bestV = w;
          best = p;
        }
      }
      tets.vertex[t] = bestV;
      for (int s = 0; s < 4; ++s) tets.neighbour[t][s] = nb[kEvenPermutations[best][s]];
    }
  });
  // Counting sort by the first vertex, then each (small) bucket by the rest.
  std::vector<int> start(sites + 1, 0);
  for (int t = 0; t < nt; ++t) ++start[tets.vertex[t][0] + 1];
  for (int i = 0; i < sites; ++i) start[i + 1] += start[i];
  std::vector<int> order(nt);
  {
    std::vector<int> fill(start.begin(), start.end() - 1);
    for (int t = 0; t < nt; ++t) order[fill[tets.vertex[t][0]]++] = t;
  }
  tbb::parallel_for(tbb::blocked_range<int>(0, sites, 4096), [&](const tbb::blocked_range<int>& range) {
    for (int i = range.begin(); i != range.end(); ++i)
      std::sort(order.begin() + start[i], order.begin() + start[i + 1],
                [&](int a, int c) { return tets.vertex[a] < tets.vertex[c]; });
  });
  std::vector<int> index(nt);
  for (int m = 0; m < nt; ++m) index[order[m]] = m;
  TetArrays sorted;
  sorted.vertex.resize(nt);
  sorted.neighbour.resize(nt);
  tbb::parallel_for(tbb::blocked_range<int>(0, nt, 8192), [&](const tbb::blocked_range<int>& range) {
    for (int m = range.begin(); m != range.end(); ++m) {
      const int t = order[m];
      sorted.vertex[m] = tets.vertex[t];
      for (int s = 0; s < 4; ++s) {
        const int u = tets.neighbour[t][s];
        sorted.neighbour[m][s] = u >= 0 ? index[u] : -1;
      }
    }
  });
  tets = std::move(sorted);
}

}  // namespace tet2spline

// Foldover-free untangling (Garanzha et al. 2021) with a compact L-BFGS.
#include "tet2spline/param/untangle.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_reduce.h>
#include <tbb/partitioner.h>

#include <Eigen/Dense>
#include <algorithm>
#include <array>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <limits>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "block_hessian.h"
#include "colouring.h"
#include "lbfgs.h"
#include "max_min_barrier.h"
#include "part_gradients.h"
#include "sliding.h"
#include "spd_solver.h"
#include "tet2spline/param/topology.h"
#include "untangle_energy.h"
#include "untangle_kernel.h"

namespace tet2spline {

namespace detail {

double cubeRootOutOfLine(double x) { return cubeRoot(x); }

#if defined(T2S_HAVE_AVX2_KERNEL)
namespace {
// Whether the AVX2 loops may run: the processor has AVX2 and the
// environment does not set TET2SPLINE_SIMD=0.
bool avx2LoopsEnabled() {
  const char* setting = std::getenv("TET2SPLINE_SIMD");
  if (setting && std::string(setting) == "0") return false;
  return __builtin_cpu_supports("avx2");
}
}  // namespace
#endif

UntangleKernel simdUntangleKernel() {
#if defined(T2S_HAVE_AVX2_KERNEL)
  return avx2LoopsEnabled() ? &untangleKernelAvx2 : nullptr;
#else
  return nullptr;
#endif
}

BarrierSums simdBarrierSums() {
#if defined(T2S_HAVE_AVX2_KERNEL)
  return avx2LoopsEnabled() ? &barrierSumsAvx2 : nullptr;
#else
  return nullptr;
#endif
}

}  // namespace detail

namespace {

// Work done so far, in evaluations of the whole mesh (tet evaluations / #tets).
std::string formatWork(double tetEvaluations, Eigen::Index nt) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.1f", nt > 0 ? tetEvaluations / static_cast<double>(nt) : 0.0);
  return buf;
}

// Whether tet t of T is positively oriented at positions W, exactly.
bool positiveTet(const Eigen::MatrixX3d& W, const Eigen::MatrixX4i& T, Eigen::Index t) {
  Eigen::Vector3d p[4];
  for (int k = 0; k < 4; ++k) p[k] = W.row(T(t, k)).transpose();
  return orient3d(p[0].data(), p[1].data(), p[2].data(), p[3].data()) > 0;
}

// Adds `rings` vertex rings to `mark`, growing from the first `sources`
// vertices only (not from the cones' apex, which touches every boundary
// vertex).
void growRings(std::vector<char>& mark, const Eigen::MatrixX4i& T, const detail::VertexTets& vt, Eigen::Index sources,
               int rings) {
  for (int r = 0; r < rings; ++r) {
    std::vector<char> next = mark;
    for (Eigen::Index v = 0; v < sources; ++v)
      if (mark[static_cast<size_t>(v)])
        for (int e = vt.offset[static_cast<size_t>(v)]; e < vt.offset[static_cast<size_t>(v) + 1]; ++e)
          for (int k = 0; k < 4; ++k) next[static_cast<size_t>(T(vt.corner[static_cast<size_t>(e)] / 4, k))] = 1;
    mark.swap(next);
  }
}

}  // namespace

namespace detail {
namespace {

// maxMinBarrier's dense products up to this many unknowns (a tet's patch:
// 4 vertices, 13 unknowns at most); sums over the nonzeros beyond.
constexpr Eigen::Index kDenseProductsUpTo = 16;

// The barrier's gradient and Hessian as sums over the rows j of `a`:
// g_p −= a_jp / r_j and H_pq += (a_jp a_jq) / r_j² (the lower triangle: all
// that LDLT reads), each in row order. For N columns known at compile time
// the sums stay in registers (a dynamic H was a load and a store per term:
// most of the local repair's time); the same operations in the same order,
// so the same bits as the loops over Eigen's dynamic H (N = Dynamic).
template <int N>
void barrierSums(const Eigen::MatrixXd& a, const Eigen::VectorXd& r, Eigen::VectorXd& g, Eigen::MatrixXd& H) {
  const Eigen::Index m = a.rows(), n = a.cols();
  if constexpr (N == Eigen::Dynamic) {
    for (Eigen::Index j = 0; j < m; ++j) {
      const double rj = r(j), rr = rj * rj;
      for (Eigen::Index p = 0; p < n; ++p) g(p) -= a(j, p) / rj;
      for (Eigen::Index q = 0; q < n; ++q)
        for (Eigen::Index p = q; p < n; ++p) H(p, q) += (a(j, p) * a(j, q)) / rr;
    }
  } else {
    double gs[N], hs[N][N];
    for (int p = 0; p < N; ++p) {
      gs[p] = g(p);
      for (int q = 0; q < N; ++q) hs[p][q] = H(p, q);
    }
    const double* col[N];
    for (int p = 0; p < N; ++p) col[p] = a.data() + p * m;
    for (Eigen::Index j = 0; j < m; ++j) {
      const double rj = r(j), rr = rj * rj;
      double aj[N];
      for (int p = 0; p < N; ++p) aj[p] = col[p][j];
      for (int p = 0; p < N; ++p) gs[p] -= aj[p] / rj;
      for (int q = 0; q < N; ++q)
        for (int p = q; p < N; ++p) hs[p][q] += (aj[p] * aj[q]) / rr;
    }
    for (int p = 0; p < N; ++p) {
      g(p) = gs[p];
      for (int q = p; q < N; ++q) H(q, p) = hs[q][p];
    }
  }
}

}  // namespace

Eigen::VectorXd maxMinBarrier(const Eigen::MatrixXd& a, const Eigen::VectorXd& b, Eigen::VectorXd z, bool products,
                              double gap) {
  // Every buffer is allocated once: the local repair solves hundreds of
  // thousands of these small problems, and a temporary per expression made
  // a fifth of its time malloc and free (bunny00 scaled by 1 + 2·10⁻⁹:
  // 197k moves in 29 s). Each expression is evaluated as Eigen evaluates
  // the temporaries it replaces (a product into a zeroed vector, then the
  // element-wise rest), so the results are the same bits.
  const Eigen::Index n = z.size(), m = a.rows();
  Eigen::VectorXd product(m), r(m), trial(n), g(n), dz(n), column(n);
  Eigen::MatrixXd H(n, n), scaled;
  Eigen::VectorXd ones;
  // A large patch's rows are sparse: a tet's row has the unknowns of its
  // patch vertices (at most 12) and t, a bound's one. Its products then go
  // over the nonzeros (rows in compressed form), not the dense m × n.
  // Measured on spool's ball-domain `param` (perf: the dense Hessian
  // product 49% of the samples): its final untangling's local repairs
  // 13.7, 12.6 and 18.7 s -> 1 to 2.5 s each, `param` 58.6 -> 18.7 s, the
  // same file; hand's ball map the same file; homer's (whose repair uses
  // large patches) another valid path, 48.7 -> 37.6 s. Problems of up to
  // kDenseProductsUpTo unknowns keep the dense products' bits.
  const bool sparse = products && n > kDenseProductsUpTo;
  std::vector<int> rowStart, nzColumn;
  std::vector<double> nzValue;
  if (sparse) {
    rowStart.reserve(static_cast<size_t>(m) + 1);
    for (Eigen::Index i = 0; i < m; ++i) {
      rowStart.push_back(static_cast<int>(nzColumn.size()));
      for (Eigen::Index j = 0; j < n; ++j)
        if (a(i, j) != 0) nzColumn.push_back(static_cast<int>(j)), nzValue.push_back(a(i, j));
    }
    rowStart.push_back(static_cast<int>(nzColumn.size()));
  } else if (products) {
    scaled.resize(m, n), ones = Eigen::VectorXd::Ones(m);
  }
  Eigen::LDLT<Eigen::MatrixXd> ldlt(n);
  // A vertex's sums with one entry per AVX2 lane where the processor has
  // them (untangle_kernel.h): the same operations per entry, so the same
  // bits, with a quarter of the divisions' instructions. Measured alone
  // (25 rows, 4 unknowns): 1.04 -> 0.37 s for 2M sums; the local repair on
  // bunny00.off scaled by 1 + 2·10⁻⁹ (`param`, 190646 moves, 12944 -> 32
  // tets): 13.2, 10.6 -> 10.8, 9.2 s in alternating runs, the same file.
  static const BarrierSums simdSums = simdBarrierSums();
  auto slackInto = [&](const Eigen::VectorXd& y, Eigen::VectorXd& out) {
    if (sparse) {
      for (Eigen::Index i = 0; i < m; ++i) {
        double sum = 0;
        for (int k = rowStart[static_cast<size_t>(i)]; k < rowStart[static_cast<size_t>(i) + 1]; ++k)
          sum += nzValue[static_cast<size_t>(k)] * y(nzColumn[static_cast<size_t>(k)]);
        out(i) = sum + b(i);
      }
      return;
    }
    product.noalias() = a * y;
    out = product + b;
  };
  // r = slack(y) and, when it is positive, the sum of its logs.
  double lastLogSum = 0;
  auto phi = [&](const Eigen::VectorXd& y, double tau, bool& ok) {
    slackInto(y, r);
    ok = (r.array() > 0).all();
    if (ok) lastLogSum = r.array().log().sum();
    return ok ? -tau * y(n - 1) - lastLogSum : std::numeric_limits<double>::infinity();
  };
  // Whether r is z's slack and zLogSum its log sum (zOk: r > 0). An accepted
  // trial point is z's next value bit for bit (z + step·dz either way), so
  // its slack and log sum carry over: each Newton iteration computes the
  // slack and logs once for its start (they were three slacks and two log
  // sums, about half the repair's time).
  bool current = false, zOk = false;
  double zLogSum = 0;
  // (τ up to 1e9 at the default gap, as before; smaller gaps go further)
  for (double tau = 1; tau < (gap < 1e-7 ? 1e3 / gap : 1e9) && static_cast<double>(m) / tau > gap; tau *= 8) {
    for (int it = 0; it < 40; ++it) {
      if (!current) {
        phi(z, tau, zOk);  // (sets r and, where zOk, lastLogSum)
        zLogSum = lastLogSum;
        current = true;
      }
      g.setZero();
      g(n - 1) = -tau;
      H.setZero();
      if (sparse) {  // g −= Σ_i a_i / r_i, H += Σ_i (a_i / r_i)ᵀ (a_i / r_i) (the lower triangle)
        for (Eigen::Index i = 0; i < m; ++i) {
          const double w = 1 / r(i);
          const int begin = rowStart[static_cast<size_t>(i)], end = rowStart[static_cast<size_t>(i) + 1];
          for (int k = begin; k < end; ++k) {
            const double sk = nzValue[static_cast<size_t>(k)] * w;
            const int p = nzColumn[static_cast<size_t>(k)];
            g(p) -= sk;
            for (int l = begin; l <= k; ++l) H(p, nzColumn[static_cast<size_t>(l)]) += sk * (nzValue[static_cast<size_t>(l)] * w);
          }
        }
      } else if (products) {
        scaled.noalias() = r.cwiseInverse().asDiagonal() * a;
        column.noalias() = scaled.transpose() * ones;
        g -= column;
        H.noalias() = scaled.transpose() * scaled;
      } else {
        switch (n) {  // the sums in registers for a vertex's 2 to 4 unknowns
          case 2: barrierSums<2>(a, r, g, H); break;
          case 3:
            if (simdSums) simdSums(3, a.data(), m, r.data(), g.data(), H.data());
            else barrierSums<3>(a, r, g, H);
            break;
          case 4:
            if (simdSums) simdSums(4, a.data(), m, r.data(), g.data(), H.data());
            else barrierSums<4>(a, r, g, H);
            break;
          default: barrierSums<Eigen::Dynamic>(a, r, g, H);
        }
      }
      ldlt.compute(H);
      dz = ldlt.solve(g);
      dz = -dz;
      const double decrement = -g.dot(dz);
      if (!dz.allFinite() || !(decrement > 1e-12)) break;
      const double f0 = zOk ? -tau * z(n - 1) - zLogSum : std::numeric_limits<double>::infinity();
      bool ok = false;
      double step = 1;
      current = false;  // the trials overwrite r
      for (; step > 1e-12; step *= 0.5) {
        trial = z + step * dz;
        const double f = phi(trial, tau, ok);
        if (ok && f <= f0 - 0.25 * step * decrement) break;
      }
      if (!(step > 1e-12)) break;
      z += step * dz;
      current = true, zOk = true, zLogSum = lastLogSum;
    }
  }
  return z;
}

}  // namespace detail

namespace {

using detail::maxMinBarrier;

constexpr std::uint8_t kMoveOnSphere = 8;
constexpr int kPatchRepairAtMost = 100;  // tets and triangles left, for the patch moves

// Tet t's signed volume at positions W.
double tetVolume(const Eigen::MatrixX3d& W, const Eigen::MatrixX4i& T, Eigen::Index t) {
  const Eigen::Vector3d p0 = W.row(T(t, 0)), p1 = W.row(T(t, 1)), p2 = W.row(T(t, 2)), p3 = W.row(T(t, 3));
  return (p1 - p0).cross(p2 - p0).dot(p3 - p0) / 6;
}

// The gradient of tet t's volume in its corner k's position:
// vol = (−1)^k (a − p)·n / 6 with (a, b, c) the next three corners (a cyclic
// shift of four is odd), n = (b − a) × (c − a).
Eigen::Vector3d volumeGradient(const Eigen::MatrixX3d& W, const Eigen::MatrixX4i& T, Eigen::Index t, int k) {
  const Eigen::Vector3d pa = W.row(T(t, (k + 1) % 4)), pb = W.row(T(t, (k + 2) % 4)), pc = W.row(T(t, (k + 3) % 4));
  return -((k % 2) ? -1.0 : 1.0) * (pb - pa).cross(pc - pa) / 6;
}

// How vertex v may move in a max-min step: directions (coordinate axes, or
// an orthonormal basis of the sphere's tangent plane at it) and, per
// direction, how far it may go down and up: to [lo, hi] along an axis,
// `reach` along a tangent. reach = a quarter of the shortest edge of v's
// star: the linearised volumes hold to about that distance.
struct VertexMoves {
  Eigen::Matrix<double, 3, Eigen::Dynamic> dirs;
  Eigen::VectorXd below, above;
  double reach = 0;
  bool onSphere = false;
};

VertexMoves vertexMoves(const Eigen::MatrixX3d& W, const Eigen::MatrixX4i& T, const detail::VertexTets& vt, int v,
                        std::uint8_t bits, double lo, double hi) {
  VertexMoves m;
  const Eigen::Vector3d p0 = W.row(v);
  double shortest = std::numeric_limits<double>::infinity();
  for (int e = vt.offset[static_cast<size_t>(v)]; e < vt.offset[static_cast<size_t>(v) + 1]; ++e) {
    const int t = vt.corner[static_cast<size_t>(e)] / 4;
    for (int k = 0; k < 4; ++k)
      if (T(t, k) != v) shortest = std::min(shortest, (W.row(T(t, k)).transpose() - p0).norm());
  }
  m.reach = 0.25 * shortest;
  m.onSphere = bits == kMoveOnSphere;
  if (m.onSphere) {
    const Eigen::Vector3d n = p0.normalized();
    const Eigen::Vector3d e1 = n.unitOrthogonal(), e2 = n.cross(e1);
    m.dirs.resize(3, 2);
    m.dirs << e1, e2;
    m.below = m.above = Eigen::Vector2d::Constant(m.reach);
    return m;
  }
  std::vector<int> dims;
  for (int d = 0; d < 3; ++d)
    if ((bits >> d) & 1) dims.push_back(d);
  const auto nd = static_cast<Eigen::Index>(dims.size());
  m.dirs = Eigen::Matrix<double, 3, Eigen::Dynamic>::Zero(3, nd);
  m.below.resize(nd), m.above.resize(nd);
  for (Eigen::Index i = 0; i < nd; ++i) {
    const int d = dims[static_cast<size_t>(i)];
    m.dirs(d, i) = 1;
    m.below(i) = p0(d) - lo, m.above(i) = hi - p0(d);
  }
  return m;
}

// For joint moves: every bound within `reach` (along axes too), and the
// directions with no room on one side dropped (a barrier needs a strictly
// feasible start).
void withinReach(VertexMoves& m) {
  Eigen::Index kept = 0;
  for (Eigen::Index i = 0; i < m.below.size(); ++i) {
    const double below = std::min(m.below(i), m.reach), above = std::min(m.above(i), m.reach);
    if (!(below > 0 && above > 0)) continue;
    m.dirs.col(kept) = m.dirs.col(i);
    m.below(kept) = below, m.above(kept) = above;
    ++kept;
  }
  m.dirs.conservativeResize(3, kept);
  m.below.conservativeResize(kept), m.above.conservativeResize(kept);
}

// p0 moved by `fraction` of the step z along the directions of `moves`: on
// the sphere projected back onto it; along axes only the free coordinates
// change (each by exactly fraction·z_i).
Eigen::Vector3d movedTo(const Eigen::Vector3d& p0, const VertexMoves& moves, const Eigen::VectorXd& z, double fraction) {
  Eigen::Vector3d p = p0;
  if (moves.onSphere) {
    p += fraction * (moves.dirs * z);
    return p / p.norm();
  }
  for (Eigen::Index i = 0; i < z.size(); ++i)
    for (int d = 0; d < 3; ++d)
      if (moves.dirs(d, i) == 1) p(d) += fraction * z(i);
  return p;
}

// Local repair by max-min volume (Freitag and Plassmann, "Local
// optimization-based simplicial mesh untangling and improvement", IJNME
// 2000): each movable vertex of an inverted tet goes where the least
// normalised volume of its star is largest, the other vertices held. Its
// star's worst tet never gets worse and tets outside its star do not change,
// but a star's other tets may drop below zero (still above the old worst):
// the count of inverted tets can grow, so the caller keeps the result only
// when it drops. While a sweep neither lowers the count nor raises the
// worst volume (three times), or moves nothing, the vertices within one more
// ring of the inverted tets join (at most four rings, or one while at most
// `fewTets` are inverted; those with a well-shaped star are left alone).
// The one ring: measured on bunny00's final untangling (draws scaled by
// 1 + k·10⁻⁹), the repairs of its finishing rounds (1 to 5 tets) made
// 4000-11000 moves each, most at rings 2 to 4 (up to 1900 vertices a
// sweep), in 0.2-0.5 s; over 34 repairs logged while ten or fewer were
// left (twelve runs), the count reached a new low 17 times at ring 0, 6
// times at ring 1 and once beyond (ring 4: 5 -> 4 in a repair of 59 -> 4).
// `movable` per vertex: bits of the coordinates that may change (0 = held),
// positions kept in [lo, hi]; or kMoveOnSphere: the vertex slides on the
// unit sphere. Such a vertex moves in its tangent plane, at most a quarter
// of its shortest star edge along each tangent, and is then projected back
// onto the sphere (p/|p|); the max-min solution is of the linearised problem,
// so the projected move is halved until its star's worst volume rises (at
// most eight times), else the vertex stays. Volumes are normalised by
// `scale` (per tet). Returns the number of vertex moves.
int maxMinSweeps(Eigen::MatrixX3d& W, const Eigen::MatrixX4i& T, const detail::VertexTets& vt,
                 const std::vector<std::uint8_t>& movable, const Eigen::VectorXd& scale, double lo, double hi,
                 int maxSweeps, int fewTets) {
  const Eigen::Index ntx = T.rows();
  auto volume = [&](Eigen::Index t) { return tetVolume(W, T, t); };
  auto positive = [&](Eigen::Index t) { return positiveTet(W, T, t); };
  int moved = 0, rings = 0, stalled = 0;
  double bestWorst = -std::numeric_limits<double>::infinity();
  int bestCount = std::numeric_limits<int>::max();
  // Which tets are inverted (not positive, exactly): every tet tested once,
  // on both cores, and after that only the stars of the vertices a sweep
  // moved (bunny00 scaled by 1 + 2·10⁻⁹: a tenth of the repair's 21 s went
  // to testing every tet every sweep).
  std::vector<char> inverted(static_cast<size_t>(ntx), 0);
  tbb::parallel_for(tbb::blocked_range<Eigen::Index>(0, ntx, 8192), [&](const tbb::blocked_range<Eigen::Index>& r) {
    for (Eigen::Index t = r.begin(); t != r.end(); ++t) inverted[static_cast<size_t>(t)] = !positive(t);
  });
  auto widest = [&](int count) { return count <= fewTets ? 1 : 4; };
  std::vector<int> movedVerts;
  std::vector<int> sweepColour(static_cast<size_t>(W.rows()), -1);
  for (int sweep = 0; sweep < maxSweeps; ++sweep) {
    for (int v : movedVerts)
      for (int e = vt.offset[static_cast<size_t>(v)]; e < vt.offset[static_cast<size_t>(v) + 1]; ++e) {
        const int t = vt.corner[static_cast<size_t>(e)] / 4;
        inverted[static_cast<size_t>(t)] = !positive(t);
      }
    movedVerts.clear();
    std::vector<char> mark(static_cast<size_t>(W.rows()), 0);
    int count = 0;
    double globalWorst = std::numeric_limits<double>::infinity();
    for (Eigen::Index t = 0; t < ntx; ++t)
      if (inverted[static_cast<size_t>(t)]) {
        ++count;
        globalWorst = std::min(globalWorst, volume(t) / scale(t));
        for (int k = 0; k < 4; ++k) mark[static_cast<size_t>(T(t, k))] = 1;
      }
    if (count == 0) break;
    // Progress: fewer inversions or a better worst one; else widen the set.
    if (count < bestCount || globalWorst > bestWorst + 1e-3 * std::abs(bestWorst)) {
      stalled = 0;
    } else if (++stalled >= 3) {
      if (rings >= widest(count)) break;
      ++rings, stalled = 0;
    }
    bestCount = std::min(bestCount, count);
    bestWorst = std::max(bestWorst, globalWorst);
    growRings(mark, T, vt, W.rows() - 1, rings);  // the last row is the cones' apex
    std::vector<int> verts;
    for (Eigen::Index v = 0; v < W.rows(); ++v)
      if (mark[static_cast<size_t>(v)] && movable[static_cast<size_t>(v)]) verts.push_back(static_cast<int>(v));
    // The sweep's vertices by colour (greedy in their order; no two of a
    // tet alike): a move reads and changes only its own star, so the
    // vertices of one colour move at once on both cores, and the result
    // does not depend on the threads. Measured on bunny00's cube map (the
    // final untangling's first local repair): 3.1 s on one core in the
    // vertices' order (930 -> 86 tets), 2.5 s by colour (930 -> 112; the
    // order of the moves changes the path).
    const std::vector<std::vector<int>> colourClasses =
        detail::greedyColourClasses(verts, sweepColour, [&](int v, const auto& visit) {
          for (int e = vt.offset[static_cast<size_t>(v)]; e < vt.offset[static_cast<size_t>(v) + 1]; ++e) {
            const int t = vt.corner[static_cast<size_t>(e)] / 4;
            for (int k = 0; k < 4; ++k) {
              const int u = T(t, k);
              if (u != v && mark[static_cast<size_t>(u)] && movable[static_cast<size_t>(u)]) visit(u);
            }
          }
        });
    std::vector<char> movedFlag(W.rows(), 0);
    auto tryMove = [&](int v) {
      const std::uint8_t bits = movable[static_cast<size_t>(v)];
      const int first = vt.offset[static_cast<size_t>(v)], last = vt.offset[static_cast<size_t>(v) + 1];
      const Eigen::Vector3d p0 = W.row(v);
      const VertexMoves moves = vertexMoves(W, T, vt, v, bits, lo, hi);
      const bool onSphere = moves.onSphere;
      const auto& dirs = moves.dirs;
      const Eigen::Index nd = dirs.cols();
      const Eigen::Index m = (last - first) + 1 + 2 * nd;
      Eigen::MatrixXd a = Eigen::MatrixXd::Zero(m, nd + 1);
      Eigen::VectorXd b(m);
      double worst = std::numeric_limits<double>::infinity();
      Eigen::Index row = 0;
      for (int e = first; e < last; ++e) {
        const int t = vt.corner[static_cast<size_t>(e)] / 4, k = vt.corner[static_cast<size_t>(e)] % 4;
        const Eigen::Vector3d grad = volumeGradient(W, T, t, k);
        const double s = scale(t);
        const double v0 = volume(t) / s;
        for (Eigen::Index i = 0; i < nd; ++i) a(row, i) = grad.dot(dirs.col(i)) / s;
        a(row, nd) = -1;
        b(row) = v0;
        worst = std::min(worst, v0);
        ++row;
      }
      a(row, nd) = -1, b(row) = 1, ++row;  // t <= 1
      bool inside = true;
      for (Eigen::Index i = 0; i < nd; ++i) {
        inside = inside && moves.below(i) > 0 && moves.above(i) > 0;
        a(row, i) = 1, b(row) = moves.below(i), ++row;
        a(row, i) = -1, b(row) = moves.above(i), ++row;
      }
      if (!inside || nd == 0 || !(worst < 1)) return;
      if (rings > 0 && worst > 0.5) return;  // a well-shaped star around: leave it
      Eigen::VectorXd z = Eigen::VectorXd::Zero(nd + 1);
      z(nd) = worst - 1;
      z = maxMinBarrier(a, b, z);
      if (!(z(nd) > worst)) return;
      auto starWorst = [&] {
        double least = std::numeric_limits<double>::infinity();
        for (int e = first; e < last; ++e) {
          const int t = vt.corner[static_cast<size_t>(e)] / 4;
          least = std::min(least, volume(t) / scale(t));
        }
        return least;
      };
      bool better = false;
      for (int halving = 0; halving <= (onSphere ? 8 : 0) && !better; ++halving) {
        W.row(v) = movedTo(p0, moves, z.head(nd), std::ldexp(1.0, -halving)).transpose();
        better = starWorst() > worst;
      }
      if (better) movedFlag[static_cast<size_t>(v)] = 1;
      else W.row(v) = p0.transpose();
    };
    for (const std::vector<int>& cls : colourClasses)
      tbb::parallel_for(tbb::blocked_range<size_t>(0, cls.size(), 16), [&](const tbb::blocked_range<size_t>& r) {
        for (size_t q = r.begin(); q != r.end(); ++q) tryMove(cls[q]);
      });
    int movedNow = 0;
    for (int v : verts)
      if (movedFlag[static_cast<size_t>(v)]) ++movedNow, movedVerts.push_back(v);
    moved += movedNow;
    if (movedNow == 0 && rings >= widest(count)) break;
    if (movedNow == 0) ++rings, stalled = 0;
  }
  return moved;
}

// Joint max-min moves of small patches, for what the single-vertex sweeps
// leave: there each vertex's star holds another tet that a move repairing
// the inverted one would invert (bunny00 on the ball: the sweeps left 2 of
// 6 tets, the patches all). It is no cure for every configuration: spool's
// ball-domain final untangling ends with four tets at −10⁻⁸ of their
// target volume, each with one sphere and three interior vertices, whose
// patches' linearised optimum is itself about 10⁻⁹: the tets are pinched
// flat by their surroundings, and the patches drive them towards zero
// volume from below without making them positive. For
// each non-positive tet, its movable vertices (level 0), then also every
// movable vertex of the tets sharing a vertex with it (level 1), move
// together: the largest t with every tet touching them at normalised
// volume ≥ t (linearised, each displacement within its vertex's reach, so
// bilinear terms stay small), t ≤ 1; the step is halved until the true
// least volume over those tets rises (at most eight times). Repeated while
// the least volume rises, at most `maxRounds` times over the tets left.
// Tets outside the patches' stars do not change, and no tet touching a
// patch falls below the least volume it had. Returns the number of patch
// moves.
int patchMaxMin(Eigen::MatrixX3d& W, const Eigen::MatrixX4i& T, const detail::VertexTets& vt,
                const std::vector<std::uint8_t>& movable, const Eigen::VectorXd& scale, double lo, double hi,
                int maxRounds) {
  const Eigen::Index ntx = T.rows();
  auto volume = [&](Eigen::Index t) { return tetVolume(W, T, t); };
  int moved = 0;
  for (int round = 0; round < maxRounds; ++round) {
    std::vector<Eigen::Index> bad;
    for (Eigen::Index t = 0; t < ntx; ++t)
      if (!positiveTet(W, T, t)) bad.push_back(t);
    if (bad.empty()) break;
    const int movedBefore = moved;
    for (const Eigen::Index b : bad) {
      for (int level = 0; level < 2 && !positiveTet(W, T, b); ++level) {
        std::vector<int> patch;
        auto add = [&](int v) {
          if (movable[static_cast<size_t>(v)] && std::find(patch.begin(), patch.end(), v) == patch.end()) patch.push_back(v);
        };
        for (int k = 0; k < 4; ++k) {
          add(T(b, k));
          if (level == 0) continue;
          const int v = T(b, k);
          if (v == W.rows() - 1) continue;  // the cones' apex touches every boundary vertex
          for (int e = vt.offset[static_cast<size_t>(v)]; e < vt.offset[static_cast<size_t>(v) + 1]; ++e)
            for (int j = 0; j < 4; ++j) add(T(vt.corner[static_cast<size_t>(e)] / 4, j));
        }
        if (patch.empty()) continue;
        // The tets touching the patch.
        std::vector<int> tets;
        for (int v : patch)
          for (int e = vt.offset[static_cast<size_t>(v)]; e < vt.offset[static_cast<size_t>(v) + 1]; ++e)
            tets.push_back(vt.corner[static_cast<size_t>(e)] / 4);
        // Each patch vertex's moves at its current position and its first
        // unknown; nz unknowns in all.
        std::vector<VertexMoves> moves(patch.size());
        std::vector<int> column(patch.size());
        Eigen::Index nz = 0;
        auto setMoves = [&] {
          nz = 0;
          for (size_t p = 0; p < patch.size(); ++p) {
            moves[p] = vertexMoves(W, T, vt, patch[p], movable[static_cast<size_t>(patch[p])], lo, hi);
            withinReach(moves[p]);
            column[p] = static_cast<int>(nz);
            nz += moves[p].dirs.cols();
          }
        };
        setMoves();
        std::sort(tets.begin(), tets.end());
        tets.erase(std::unique(tets.begin(), tets.end()), tets.end());
        auto leastVolume = [&] {
          double least = std::numeric_limits<double>::infinity();
          for (int t : tets) least = std::min(least, volume(t) / scale(t));
          return least;
        };
        if (nz == 0) continue;
        for (int iteration = 0; iteration < 20; ++iteration) {
          const double worst = leastVolume();
          if (worst > 0 && positiveTet(W, T, b)) break;
          const auto nt = static_cast<Eigen::Index>(tets.size());
          Eigen::MatrixXd a = Eigen::MatrixXd::Zero(nt + 1 + 2 * nz, nz + 1);
          Eigen::VectorXd rhs(a.rows());
          for (Eigen::Index r = 0; r < nt; ++r) {
            const int t = tets[static_cast<size_t>(r)];
            const double s = scale(t);
            for (int k = 0; k < 4; ++k) {
              const auto at = std::find(patch.begin(), patch.end(), T(t, k));
              if (at == patch.end()) continue;
              const auto p = static_cast<size_t>(at - patch.begin());
              const Eigen::Vector3d grad = volumeGradient(W, T, t, k);
              for (Eigen::Index i = 0; i < moves[p].dirs.cols(); ++i) a(r, column[p] + i) = grad.dot(moves[p].dirs.col(i)) / s;
            }
            a(r, nz) = -1;
            rhs(r) = volume(t) / s;
          }
          Eigen::Index row = nt;
          a(row, nz) = -1, rhs(row) = 1, ++row;  // t <= 1
          for (size_t p = 0; p < patch.size(); ++p)
            for (Eigen::Index i = 0; i < moves[p].dirs.cols(); ++i) {
              a(row, column[p] + i) = 1, rhs(row) = moves[p].below(i), ++row;
              a(row, column[p] + i) = -1, rhs(row) = moves[p].above(i), ++row;
            }
          Eigen::VectorXd z = Eigen::VectorXd::Zero(nz + 1);
          z(nz) = worst - 1;
          z = maxMinBarrier(a, rhs, z, true, std::clamp(1e-2 * std::abs(worst), 1e-14, 1e-7));
          if (!(z(nz) > worst)) break;
          std::vector<Eigen::Vector3d> start;
          for (int v : patch) start.push_back(W.row(v).transpose());
          bool better = false;
          for (int halving = 0; halving <= 8 && !better; ++halving) {
            for (size_t p = 0; p < patch.size(); ++p)
              W.row(patch[p]) =
                  movedTo(start[p], moves[p], z.segment(column[p], moves[p].dirs.cols()), std::ldexp(1.0, -halving)).transpose();
            better = leastVolume() > worst;
          }
          if (!better) {
            for (size_t p = 0; p < patch.size(); ++p) W.row(patch[p]) = start[p].transpose();
            break;
          }
          ++moved;
          setMoves();  // (the next iteration's, at the new positions)
          if (nz == 0) break;
        }
      }
    }
    if (moved == movedBefore) break;
  }
  return moved;
}

// Per row of T, the Morton code (21 bits per axis over the bounding box of
// `points`) of the centroid of the row's vertices that index `points` (rows
// past them, the cones' apex, are left out).
std::vector<std::uint64_t> mortonKeys(const Eigen::MatrixX3d& points, const Eigen::MatrixX4i& T) {
  const Eigen::Index n = points.rows();
  const Eigen::RowVector3d lo = points.colwise().minCoeff();
  const Eigen::RowVector3d span = (points.colwise().maxCoeff() - lo).cwiseMax(1e-300);
  auto spread = [](std::uint64_t x) {  // the low 21 bits of x to every third bit
    x &= 0x1fffff;
    x = (x | x << 32) & 0x1f00000000ffffULL;
    x = (x | x << 16) & 0x1f0000ff0000ffULL;
    x = (x | x << 8) & 0x100f00f00f00f00fULL;
    x = (x | x << 4) & 0x10c30c30c30c30c3ULL;
    x = (x | x << 2) & 0x1249249249249249ULL;
    return x;
  };
  std::vector<std::uint64_t> keys(static_cast<size_t>(T.rows()));
  tbb::parallel_for(tbb::blocked_range<Eigen::Index>(0, T.rows(), 4096), [&](const tbb::blocked_range<Eigen::Index>& r) {
    for (Eigen::Index t = r.begin(); t != r.end(); ++t) {
      Eigen::RowVector3d c = Eigen::RowVector3d::Zero();
      int k = 0;
      for (int j = 0; j < 4; ++j)
        if (T(t, j) < n) c += points.row(T(t, j)), ++k;
      Eigen::RowVector3d q = (c / std::max(k, 1) - lo).cwiseQuotient(span) * 2097151.0;
      for (int d = 0; d < 3; ++d) q[d] = std::isfinite(q[d]) ? std::clamp(q[d], 0.0, 2097151.0) : 0.0;  // (a NaN sorts first)
      keys[static_cast<size_t>(t)] = spread(static_cast<std::uint64_t>(q[0])) | spread(static_cast<std::uint64_t>(q[1])) << 1 |
                                     spread(static_cast<std::uint64_t>(q[2])) << 2;
    }
  });
  return keys;
}

}  // namespace

UntangleResult untangle(const Eigen::MatrixX3d& reference, const Eigen::MatrixX4i& T0, const Eigen::MatrixX3d& U0,
                        const std::vector<bool>& fixed0, const UntangleOptions& options) {
  const Eigen::Index nv = reference.rows(), nt = T0.rows();
  if (U0.rows() != nv || static_cast<Eigen::Index>(fixed0.size()) != nv)
    throw Error(ErrorKind::Input, "untangle: reference has " + std::to_string(nv) + " vertices, U " +
                                      std::to_string(U0.rows()) + ", fixed mask " + std::to_string(fixed0.size()));
  if (nt > 0 && (T0.minCoeff() < 0 || T0.maxCoeff() >= nv))
    throw Error(ErrorKind::Input, "untangle: tet vertex index out of range");
  const bool onCube = options.cubeFaces.rows() > 0;
  const bool clampIn = onCube && options.keepInteriorInCube;
  if (onCube && options.sphereFaces.rows() > 0)
    throw Error(ErrorKind::Usage, "untangle: sphereFaces (" + std::to_string(options.sphereFaces.rows()) +
                                      ") and cubeFaces (" + std::to_string(options.cubeFaces.rows()) +
                                      ") are mutually exclusive");
  const Eigen::MatrixX3i& faces = onCube ? options.cubeFaces : options.sphereFaces;
  const Eigen::Index nc = faces.rows();
  if (nc > 0 && (faces.minCoeff() < 0 || faces.maxCoeff() >= nv))
    throw Error(ErrorKind::Input, std::string("untangle: ") + (onCube ? "cube" : "sphere") +
                                      " face vertex index out of range");
  if (!options.cubeLocks.empty() && static_cast<Eigen::Index>(options.cubeLocks.size()) != nv)
    throw Error(ErrorKind::Input, "untangle: cubeLocks has " + std::to_string(options.cubeLocks.size()) +
                                      " entries for " + std::to_string(nv) + " vertices");
  if (options.targetVolumes.size() != 0 && options.targetVolumes.size() != nt)
    throw Error(ErrorKind::Usage, "untangle: " + std::to_string(options.targetVolumes.size()) + " target volumes for " +
                                      std::to_string(nt) + " tets");
  UntangleResult result;
  result.U = U0;
  result.invertedBefore = countNonPositiveTets(U0, T0);
  result.invertedAfter = result.invertedBefore;
  // Extended problem: vertex nv is the (fixed) apex, tets nt.. are the cones
  // (apex, a, b, c) over the boundary faces.
  const Eigen::Index nvx = nv + 1, ntx = nt + nc;
  const Eigen::RowVector3d apex = onCube ? Eigen::RowVector3d(0.5, 0.5, 0.5) : Eigen::RowVector3d(0, 0, 0);
  const double apexHeight = onCube ? 0.5 : 1;  // distance from the apex to a small boundary face
  Eigen::MatrixX4i T(ntx, 4);
  T.topRows(nt) = T0;
  for (Eigen::Index f = 0; f < nc; ++f) T.row(nt + f) << static_cast<int>(nv), faces(f, 0), faces(f, 1), faces(f, 2);
  Eigen::MatrixX3d W(nvx, 3);  // working positions
  W.topRows(nv) = U0;
  W.row(nv) = apex;
  std::vector<bool> fixed(fixed0);
  fixed.push_back(true);
  // kCubeRadial: a cube-face vertex that may cross onto another face
  // (options.cubeAcrossEdges), at p(y) = c + (y − c) ½ / max_k |y_k − c_k|.
  enum Slide : char { kInterior = 0, kSphere = 1, kCube = 2, kCubeRadial = 3 };
  std::vector<char> slide(static_cast<size_t>(nvx), kInterior);
  std::vector<std::uint8_t> locks(static_cast<size_t>(nvx), 0);
  for (Eigen::Index f = 0; f < nc; ++f)
    for (int k = 0; k < 3; ++k) {
      const int v = faces(f, k);
      if (fixed[v] || slide[v] != kInterior) continue;
      slide[v] = onCube ? kCube : kSphere;
      if (!onCube) continue;
      // Locks: given, or the coordinates that are exactly 0 or 1.
      std::uint8_t lock = 0;
      for (int d = 0; d < 3; ++d)
        if (options.cubeLocks.empty() ? (U0(v, d) == 0 || U0(v, d) == 1) : ((options.cubeLocks[v] >> d) & 1))
          lock |= static_cast<std::uint8_t>(1u << d);
      if (lock == 0)
        throw Error(ErrorKind::Input, "untangle: cube face vertex " + std::to_string(v) +
                                          " has no locked coordinate (it would leave the cube's boundary)");
      locks[v] = lock;
      if (options.cubeAcrossEdges && __builtin_popcount(lock) == 1) slide[v] = kCubeRadial;
    }
  // keepInteriorInCube: interior vertices that start outside the cube are
  // mirrored in through the face (untangle.h).
  if (clampIn)
    for (Eigen::Index v = 0; v < nv; ++v) {
      if (fixed[v] || slide[v] != kInterior) continue;
      for (int d = 0; d < 3; ++d) {
        double& c = W(v, d);
        if (c < 0) c = std::min(-c, 1.0);
        if (c > 1) c = std::max(2.0 - c, 0.0);
      }
    }
  // A radially sliding cube vertex (kCubeRadial) at unknown position y: where
  // the ray from the centre through y leaves the cube (sliding.h).
  auto cubeRay = [&](const Eigen::Vector3d& y) { return detail::cubeRay(y, apex.transpose()); };
  auto positive = [&](Eigen::Index t) { return positiveTet(W, T, t); };
  auto countBad = [&](Eigen::Index from, Eigen::Index to) {
    int bad = 0;
    for (Eigen::Index t = from; t < to; ++t) bad += !positive(t);
    return bad;
  };
  const int flippedBefore = countBad(nt, ntx);
  result.flippedBoundaryTriangles = flippedBefore;
  if ((result.invertedBefore == 0 && flippedBefore == 0 && !options.relax) || nt == 0) {
    result.flippedSphereTriangles = onCube ? 0 : result.flippedBoundaryTriangles;
    return result;
  }

  // Reference shapes. Each reference tet is the input tet scaled by its own
  // map scale s_t = sqrt(Σ|Δu|² / Σ|Δx|²) over its six edges, so that
  // det J ≈ 1 for a well-shaped image at any scale. Measured: conformal
  // sphere maps shrink horns and fingers by up to 10⁸ in length
  // (triceratops), and neighbouring tets of one vertex star differ by 10³;
  // a per-vertex volume average left those tets with det J ≈ 10⁻¹⁰, where
  // the barrier swamps everything. Edge lengths stay meaningful for inverted
  // and flat tets, volumes do not.
  std::vector<Eigen::Matrix<double, 3, 4>> grad(static_cast<size_t>(ntx));
  Eigen::VectorXd weight(ntx);
  auto gradients = [](const Eigen::Vector3d& a, const Eigen::Vector3d& b, const Eigen::Vector3d& c,
                      const Eigen::Vector3d& d, double vol) {
    Eigen::Matrix<double, 3, 4> G;  // ∇φ_k = −(outward area vector of the face opposite k) / (3 vol)
    G.col(0) = 0.5 * (d - b).cross(c - b) / (3 * vol);
    G.col(1) = 0.5 * (c - a).cross(d - a) / (3 * vol);
    G.col(2) = 0.5 * (d - a).cross(b - a) / (3 * vol);
    G.col(3) = 0.5 * (b - a).cross(c - a) / (3 * vol);
    return G;
  };
  constexpr int kEdges[6][2] = {{0, 1}, {0, 2}, {0, 3}, {1, 2}, {1, 3}, {2, 3}};
  std::vector<double> scale(static_cast<size_t>(nt));
  // (The set-up's per-tet and per-vertex loops run on both cores: each
  // element's values do not depend on the split, and the sums over the
  // tets (refSq, mapSq) are taken afterwards in order, so the bits are the
  // same. Measured on bunny00: every untangle call spent 0.7-0.8 s here on
  // one core, five calls per run.)
  std::vector<double> refEdges(static_cast<size_t>(nt)), mapEdges(static_cast<size_t>(nt));
  std::atomic<Eigen::Index> firstFlat{nt};
  tbb::parallel_for(tbb::blocked_range<Eigen::Index>(0, nt, 4096), [&](const tbb::blocked_range<Eigen::Index>& range) {
    for (Eigen::Index t = range.begin(); t != range.end(); ++t) {
      const Eigen::Vector3d a = reference.row(T(t, 0)), b = reference.row(T(t, 1)), c = reference.row(T(t, 2)),
                            d = reference.row(T(t, 3));
      const double vol = (b - a).cross(c - a).dot(d - a) / 6;
      if (!(vol > 0)) {
        Eigen::Index seen = firstFlat.load();
        while (t < seen && !firstFlat.compare_exchange_weak(seen, t)) {
        }
        continue;
      }
      grad[static_cast<size_t>(t)] = gradients(a, b, c, d, vol);
      weight[t] = vol;
      double r = 0, m = 0;
      for (const auto& e : kEdges) {
        r += (reference.row(T(t, e[0])) - reference.row(T(t, e[1]))).squaredNorm();
        m += (U0.row(T(t, e[0])) - U0.row(T(t, e[1]))).squaredNorm();
      }
      // With target volumes (the measure relaxation), the tet's own scale is
      // the one that gives it its target volume.
      scale[static_cast<size_t>(t)] =
          options.targetVolumes.size() == nt ? std::cbrt(options.targetVolumes(t) / vol) : std::sqrt(m / r);
      refEdges[static_cast<size_t>(t)] = r, mapEdges[static_cast<size_t>(t)] = m;
    }
  });
  if (firstFlat.load() < nt)
    throw Error(ErrorKind::Input, "untangle: reference tet " + std::to_string(firstFlat.load()) + " has non-positive volume");
  double refSq = 0, mapSq = 0;
  for (Eigen::Index t = 0; t < nt; ++t) refSq += refEdges[static_cast<size_t>(t)], mapSq += mapEdges[static_cast<size_t>(t)];
  const double globalScale = std::sqrt(mapSq / refSq);
  tbb::parallel_for(tbb::blocked_range<Eigen::Index>(0, nt, 4096), [&](const tbb::blocked_range<Eigen::Index>& range) {
    for (Eigen::Index t = range.begin(); t != range.end(); ++t) {
      const double st = scale[static_cast<size_t>(t)] > 0 ? scale[static_cast<size_t>(t)] : globalScale;
      grad[static_cast<size_t>(t)] /= st;
    }
  });
  // Weights: one per tet. Measured: with Garanzha's reference-volume weights
  // (or mapped volumes), tets in small features weigh 10⁻⁶ of the mean, and
  // L-BFGS traded their inversion for energy elsewhere (triceratops: min
  // det J went from −3.6 to −700 in the first 100 iterations).
  weight.head(nt).setOnes();
  // The measure relaxation minimises an integral over the domain: weights
  // are then the target volumes (measured on the density-4 sphere: region
  // fraction 0.1975 with unit weights, see parameterize.h for the target).
  if (options.relax && options.targetVolumes.size() == nt)
    weight.head(nt) = options.targetVolumes / options.targetVolumes.mean();
  const detail::VertexTets vt = detail::vertexTets(nvx, T);
  // Per-vertex mean weight of the incident tets (cones get their vertices').
  Eigen::VectorXd starWeight = Eigen::VectorXd::Zero(nvx);
  tbb::parallel_for(tbb::blocked_range<Eigen::Index>(0, nv, 4096), [&](const tbb::blocked_range<Eigen::Index>& range) {
    for (Eigen::Index v = range.begin(); v != range.end(); ++v) {
      int n = 0;
      for (int e = vt.offset[v]; e < vt.offset[v + 1]; ++e)
        if (vt.corner[e] / 4 < nt) starWeight[v] += weight[vt.corner[e] / 4], ++n;
      if (n > 0) starWeight[v] /= n;
    }
  });
  // Cones: apex over an equilateral triangle whose squared edge is the mean
  // squared edge of the initial face, at the apex's height.
  tbb::parallel_for(tbb::blocked_range<Eigen::Index>(0, nc, 2048), [&](const tbb::blocked_range<Eigen::Index>& range) {
    for (Eigen::Index f = range.begin(); f != range.end(); ++f) {
      const Eigen::Index t = nt + f;
      double sq = 0;
      for (int k = 1; k <= 3; ++k) sq += (U0.row(T(t, k)) - U0.row(T(t, k % 3 + 1))).squaredNorm();
      const double edge = std::sqrt(std::max(sq / 3, 1e-300));
      const double r = edge / std::sqrt(3.0);
      const Eigen::Vector3d o(0, 0, 0), a(r, 0, apexHeight),
          b(r * std::cos(2 * M_PI / 3), r * std::sin(2 * M_PI / 3), apexHeight),
          c(r * std::cos(4 * M_PI / 3), r * std::sin(4 * M_PI / 3), apexHeight);
      grad[static_cast<size_t>(t)] = gradients(o, a, b, c, (a - o).cross(b - o).dot(c - o) / 6);
      weight[t] = (starWeight[T(t, 1)] + starWeight[T(t, 2)] + starWeight[T(t, 3)]) / 3;
    }
  });
  // Diagonal preconditioner: the unknowns are displacements in units of
  // p_v = h_v / sqrt(Σ_{t∋v} w_t), h_v the geometric mean of the mapped
  // edges at v, so that the energy's Hessian is O(1) at every vertex. Without
  // it, L-BFGS on a region whose edges span 10⁻⁸ .. 10⁻¹ (homer, triceratops)
  // spent thousands of iterations and still failed.
  Eigen::VectorXd precond = Eigen::VectorXd::Ones(nvx);
  // p_v is set for the vertices a region frees, when one first frees them
  // (setPreconditioners, from U0 as before, so the same bits): no other
  // vertex's is read. Measured on bunny00 (767k tets): every untangle call
  // computed it for all 181k vertices, and the final untangling's finishing
  // rounds make about ten calls whose regions free about a thousand
  // (perf of that tail: this loop and the edge logs, 11% of its samples).
  const double meanEdge = globalScale * std::sqrt(refSq / (6.0 * static_cast<double>(std::max<Eigen::Index>(nt, 1))));
  // log |u_a − u_b| of each tet's six edges (kEdges), −∞ where the length
  // is not positive, once per tet that a region makes active; the
  // vertices' sums read them in the order in which they computed them, so
  // the bits are the same. Measured on bunny00 (767k tets): computing them
  // per vertex and corner (12 logs a tet, the tet's corners gathered through
  // T per star) took 0.6 s of both cores for every vertex.
  constexpr int kEdgeOf[4][4] = {{-1, 0, 1, 2}, {0, -1, 3, 4}, {1, 3, -1, 5}, {2, 4, 5, -1}};
  constexpr double kNoEdge = -std::numeric_limits<double>::infinity();
  std::vector<std::array<double, 6>> edgeLog;  // (allocated when the first region needs them)
  std::vector<char> edgeLogSet, precondSet;
  auto setPreconditioners = [&](const std::vector<int>& activeTets, const std::vector<int>& verts) {
    if (edgeLog.empty()) {
      edgeLog.resize(static_cast<size_t>(nt));
      edgeLogSet.assign(static_cast<size_t>(nt), 0);
      precondSet.assign(static_cast<size_t>(nvx), 0);
    }
    tbb::parallel_for(tbb::blocked_range<size_t>(0, activeTets.size(), 4096), [&](const tbb::blocked_range<size_t>& range) {
      for (size_t a = range.begin(); a != range.end(); ++a) {
        const int t = activeTets[a];
        if (t >= nt || edgeLogSet[static_cast<size_t>(t)]) continue;
        for (int e = 0; e < 6; ++e) {
          // (the norm of b − a and of a − b are the same bits)
          const double len = (U0.row(T(t, kEdges[e][1])) - U0.row(T(t, kEdges[e][0]))).norm();
          edgeLog[static_cast<size_t>(t)][static_cast<size_t>(e)] = len > 0 ? std::log(len) : kNoEdge;
        }
        edgeLogSet[static_cast<size_t>(t)] = 1;
      }
    });
    // (every tet of a free vertex's star is active: the logs it reads are set)
    tbb::parallel_for(tbb::blocked_range<size_t>(0, verts.size(), 2048), [&](const tbb::blocked_range<size_t>& range) {
      for (size_t i = range.begin(); i != range.end(); ++i) {
        const int v = verts[i];
        if (v >= nv || precondSet[static_cast<size_t>(v)]) continue;
        double logSum = 0, w = 0;
        int n = 0;
        for (int e = vt.offset[static_cast<size_t>(v)]; e < vt.offset[static_cast<size_t>(v) + 1]; ++e) {
          const int t = vt.corner[static_cast<size_t>(e)] / 4, k = vt.corner[static_cast<size_t>(e)] % 4;
          if (t >= nt) continue;
          w += weight[t];
          for (int j = 0; j < 4; ++j)
            if (j != k) {
              const double logLen = edgeLog[static_cast<size_t>(t)][static_cast<size_t>(kEdgeOf[k][j])];
              if (logLen != kNoEdge) logSum += logLen, ++n;
            }
        }
        const double h = n > 0 ? std::exp(logSum / n) : meanEdge;
        precond[v] = w > 0 ? h / std::sqrt(w) : h;
        precondSet[static_cast<size_t>(v)] = 1;
      }
    });
  };

  // The tets in a spatial order (Morton order of their reference centroids;
  // cones by their face's, ties by index), sorted once: each region takes
  // its active tets in this order, so
  // that the tets of one vertex star are evaluated close together and its
  // row and its corners' gradient slots stay in cache. Measured on bunny00's
  // final untangling (767k tets, 176k of 181k vertices free, 2 cores):
  // 12.6 -> 10.2 s per ε round of 100 L-BFGS iterations, the counts of
  // inverted tets the same to the last printed digit (only the order of the
  // energy's sum changes), and the bench's three draws of bunny00 and homer
  // on the same paths as before (the same misplaced volume and fit error).
  std::vector<int> spatialOrder(static_cast<size_t>(ntx));
  {
    // By key, ties by index: a stable radix sort (8-bit digits, least
    // significant first) of the tets in index order, which is that order.
    // Measured on bunny00 (767k tets; the final untangling's finishing
    // rounds call untangle about ten times): the comparison sort was 6% of
    // that tail's samples.
    struct Keyed {
      std::uint64_t key;
      int tet;
    };
    std::vector<Keyed> keyed(static_cast<size_t>(ntx));
    {  // (the keys alone are freed before the sort's second buffer exists)
      const std::vector<std::uint64_t> key = mortonKeys(reference, T);
      for (size_t t = 0; t < keyed.size(); ++t) keyed[t] = {key[t], static_cast<int>(t)};
    }
    std::vector<Keyed> scattered(keyed.size());
    for (int shift = 0; shift < 64; shift += 8) {
      std::array<size_t, 257> start{};
      for (const Keyed& k : keyed) ++start[((k.key >> shift) & 0xff) + 1];
      if (std::any_of(start.begin() + 1, start.end(), [&](size_t c) { return c == keyed.size(); })) continue;  // one digit
      for (size_t d = 1; d < start.size(); ++d) start[d] += start[d - 1];
      for (const Keyed& k : keyed) scattered[start[(k.key >> shift) & 0xff]++] = k;
      keyed.swap(scattered);
    }
    for (size_t i = 0; i < keyed.size(); ++i) spatialOrder[i] = keyed[i].tet;
  }
  // The vertices' storage rank for the evaluation loop: in the order in
  // which the tets in spatial order first reach them (then the vertices of
  // no tet). The rows of a tet's corners in the copy of W that the loop
  // reads then lie close together in memory, as the tet order alone does
  // not make them (TetGen numbers its Steiner points in insertion order).
  // Only where the values are stored changes,
  // not which values are combined or in what order, so the map is bitwise
  // the one without it (a renumbering of the vertices themselves changes
  // the order of L-BFGS's sums, hence the path: branch
  // experiment/vertex-morton). Measured on bunny00 (as given, one run
  // each, the report the same to the last digit): the final untangling's
  // held phase 31.7 -> 27.6 s, the ball map's untangling 14.3 -> 12.9 s.
  std::vector<int> storageRank(static_cast<size_t>(nvx), -1);
  {
    int next = 0;
    for (int t : spatialOrder)
      for (int k = 0; k < 4; ++k)
        if (storageRank[static_cast<size_t>(T(t, k))] < 0) storageRank[static_cast<size_t>(T(t, k))] = next++;
    for (int& r : storageRank)
      if (r < 0) r = next++;
  }
  std::vector<int> inRegion(static_cast<size_t>(nvx), -1);  // variable index of a free vertex
  int rings = options.relax ? -1 : options.rings;
  size_t previousFree = 0;
  int fewestBad = result.invertedBefore + flippedBefore;  // (exact: at the start and each region's end)
  for (;;) {
    // Free region: `rings` rings around the vertices of inverted tets.
    std::vector<int> freeVerts;
    std::fill(inRegion.begin(), inRegion.end(), -1);
    std::vector<char> mark(static_cast<size_t>(nvx), 0);
    if (rings < 0) {
      std::fill(mark.begin(), mark.end(), 1);
    } else {
      for (Eigen::Index t = 0; t < ntx; ++t)
        if (!positive(t))
          for (int k = 0; k < 4; ++k) mark[T(t, k)] = 1;
      growRings(mark, T, vt, nv, rings);
    }
    for (Eigen::Index v = 0; v < nvx; ++v)
      if (mark[v] && !fixed[v]) inRegion[v] = static_cast<int>(freeVerts.size()), freeVerts.push_back(static_cast<int>(v));
    std::vector<int> active;  // tets with a free vertex, in spatial order
    for (int t : spatialOrder)
      for (int k = 0; k < 4; ++k)
        if (inRegion[T(t, k)] >= 0) {
          active.push_back(t);
          break;
        }
    result.freeVertices = static_cast<int>(freeVerts.size());
    if (freeVerts.empty() || freeVerts.size() == previousFree) break;  // nothing new to move
    previousFree = freeVerts.size();
    setPreconditioners(active, freeVerts);

    // The active tets' data in their order, contiguous: on a small region
    // (bunny00's ball map: 6446 to 7843 free vertices, their tets scattered
    // over 767k) reading them from the per-tet arrays missed the cache for
    // every tet. Measured, bitwise the same map: that untangling 29.8 ->
    // 18.9 s, homer's ball map 9.3, 9.5 -> 8.2, 8.4 s (perf had the loop's
    // own time at 4.6 times the energy's there). Costs a copy of the active
    // tets' gradients per region (~100 MB when all of bunny00's are active).
    const size_t na = active.size();
    std::vector<Eigen::Matrix<double, 3, 4>> activeGrad(na);
    std::vector<std::array<int, 4>> activeVertices(na);
    std::vector<double> activeWeight(na);
    tbb::parallel_for(tbb::blocked_range<size_t>(0, na, 4096), [&](const tbb::blocked_range<size_t>& r) {
      for (size_t a = r.begin(); a != r.end(); ++a) {
        const int t = active[a];
        activeGrad[a] = grad[static_cast<size_t>(t)];
        for (int k = 0; k < 4; ++k)  // (rows of rowMajorW)
          activeVertices[a][k] = storageRank[static_cast<size_t>(T(t, k))];
        activeWeight[a] = weight[t];
      }
    });
    // The free vertices in storageRank's order, the order in which the
    // active tets first reach them: the evaluation's per-vertex loops
    // (placing the vertices, summing their gradients from the parts' rows)
    // walk them so, reading memory in order, while the unknowns keep the
    // vertices' order (L-BFGS's sums run over them: the same bits). Walked
    // by vertex index, every vertex missed the cache in the per-vertex
    // arrays, the row-major copy and the parts' rows (TetGen numbers its
    // vertices in insertion order). Measured on bunny00 (`param` on its
    // TetGen mesh, alternating runs, the same file): the final untangling
    // 25.7, 26.2 -> 23.8, 20.7 s. (Sorting the unknowns themselves, which
    // changes L-BFGS's sums, made other paths: on bunny00.off scaled by
    // 1 + 10⁻⁹ the first local repair then left 1540 tets instead of 15,
    // and the run took 30 s more.)
    std::vector<int> walk(freeVerts.size());  // walk[j]: the free index k of the j-th by rank
    for (size_t k = 0; k < freeVerts.size(); ++k) walk[k] = static_cast<int>(k);
    std::sort(walk.begin(), walk.end(), [&](int a, int b) {
      return storageRank[static_cast<size_t>(freeVerts[static_cast<size_t>(a)])] <
             storageRank[static_cast<size_t>(freeVerts[static_cast<size_t>(b)])];
    });
    // The energy's gradient, summed part by part (part_gradients.h), its
    // rows numbered by storage rank and its vertices in the walk's order.
    std::unique_ptr<detail::PartGradients> gradientParts;
    {
      std::vector<int> walkByRank(static_cast<size_t>(nvx), -1);
      for (size_t j = 0; j < walk.size(); ++j)
        walkByRank[static_cast<size_t>(storageRank[static_cast<size_t>(freeVerts[static_cast<size_t>(walk[j])])])] =
            static_cast<int>(j);
      gradientParts = std::make_unique<detail::PartGradients>(activeVertices, walkByRank, freeVerts.size());
    }
    std::vector<double> partEnergy(gradientParts->parts());
    std::vector<double> det(active.size());
    double e0 = 1e-3;
    double eps = 1;
    // Unknowns: x, with vertex v at base_v + p_v x_v before its constraint
    // (displacements keep full precision where the region is 10⁻⁸ wide).
    Eigen::MatrixX3d base(static_cast<Eigen::Index>(freeVerts.size()), 3);
    for (size_t k = 0; k < freeVerts.size(); ++k) base.row(static_cast<Eigen::Index>(k)) = W.row(freeVerts[k]);
    // What the evaluation reads of each free vertex, in the walk's order.
    struct FreeVertex {
      Eigen::Vector3d base;  // unknown(k)
      double precond;
      int k;     // its free index: unknowns 3k .. 3k + 2
      int rank;  // its row of rowMajorW
      char slide;
      std::uint8_t locks;
    };
    std::vector<FreeVertex> freeInfo(freeVerts.size());
    for (size_t j = 0; j < walk.size(); ++j) {
      const int k = walk[j];
      const auto v = static_cast<size_t>(freeVerts[static_cast<size_t>(k)]);
      freeInfo[j] = {base.row(k).transpose(), precond[static_cast<Eigen::Index>(v)], k, storageRank[v], slide[v], locks[v]};
    }
    // The tets read their corners from a row-major copy of W: each
    // vertex's three coordinates in one cache line, not three. Measured
    // (cube parameterization, bitwise the same map): homer's final
    // untangling (181k tets) 39.3 and 34.0 -> 34.6 and 32.3 s, bunny00's
    // (767k) 291.7 -> 280.5 s.
    // Its rows are in storageRank's order. The free vertices are placed in
    // it, and W follows only where W is read (syncW): after each L-BFGS run
    // or Newton step, before the Hessian, at the region's end.
    Eigen::Matrix<double, Eigen::Dynamic, 3, Eigen::RowMajor> rowMajorW(nvx, 3);
    for (Eigen::Index v = 0; v < nvx; ++v) rowMajorW.row(storageRank[static_cast<size_t>(v)]) = W.row(v);
    auto place = [&](const FreeVertex& f, const Eigen::Vector3d& y) {
      auto out = rowMajorW.row(f.rank);
      if (f.slide == kSphere) {
        out = (y / y.norm()).transpose();
      } else if (f.slide == kCube) {  // locked coordinates keep their bits, free ones stay in [0, 1]
        for (int d = 0; d < 3; ++d)
          out(d) = (f.locks >> d) & 1 ? f.base[d] : std::clamp(y[d], 0.0, 1.0);
      } else if (f.slide == kCubeRadial) {  // onto the face that the ray from the centre meets, exactly
        const detail::CubeRay r = cubeRay(y);
        if (!(r.extent > 0)) return;  // at the centre: no ray; keep the last position
        out = detail::cubeRayPoint(r);
      } else if (clampIn) {  // interior, kept in the cube (keepInteriorInCube)
        for (int d = 0; d < 3; ++d) out(d) = std::clamp(y[d], 0.0, 1.0);
      } else {
        out = y.transpose();
      }
    };
    auto syncW = [&] {
      tbb::parallel_for(tbb::blocked_range<size_t>(0, freeVerts.size(), 2048), [&](const tbb::blocked_range<size_t>& r) {
        for (size_t j = r.begin(); j != r.end(); ++j)
          W.row(freeVerts[static_cast<size_t>(freeInfo[j].k)]) = rowMajorW.row(freeInfo[j].rank);
      });
    };
    auto unknown = [&](size_t k) -> Eigen::Vector3d {
      return base.row(static_cast<Eigen::Index>(k)).transpose();
    };

    const bool holdAtBounds = options.method == UntangleMethod::Newton;
    // The loop over the active tets four at a time in AVX2 registers, where
    // the processor has them: the same operations lane by lane, so bitwise
    // the same maps (untangle_kernel.h).
    const detail::UntangleKernel simdKernel = detail::simdUntangleKernel();
    // Its arrays, fixed for the region (ε and the gradient's terms are set per evaluation).
    detail::UntangleKernelData data;
    if (simdKernel && !active.empty()) {  // (an empty region's vectors have no first element to point at)
      data.positions = rowMajorW.data();
      data.vertices = activeVertices.front().data();
      data.gradients = activeGrad.front().data();
      data.weights = activeWeight.data();
      data.rows = gradientParts->rows();
      data.det = det.data();
      data.theta = options.theta;
    }
    auto evaluate = [&](const Eigen::VectorXd& x, Eigen::VectorXd* g) -> double {
      result.tetEvaluations += static_cast<double>(active.size());
      // The free vertices' positions, on both cores (each writes its own
      // rows). On one core this loop was a serial stretch of every
      // evaluation: on bunny00's held phase (122k free vertices) a sixth of
      // the final untangling's samples.
      tbb::parallel_for(tbb::blocked_range<size_t>(0, freeVerts.size(), 2048), [&](const tbb::blocked_range<size_t>& r) {
        for (size_t j = r.begin(); j != r.end(); ++j) {
          const FreeVertex& f = freeInfo[j];
          place(f, f.base + f.precond * x.segment<3>(3 * static_cast<Eigen::Index>(f.k)));
        }
      });
      data.acc = g ? gradientParts->data() : nullptr;
      data.eps = eps;
      // Part by part (each on one core; their sums in order, below).
      tbb::parallel_for(tbb::blocked_range<size_t>(0, gradientParts->parts(), 1), [&](const tbb::blocked_range<size_t>& r) {
        for (size_t p = r.begin(); p != r.end(); ++p) {
          if (g) gradientParts->zero(p);
          const size_t begin = gradientParts->partBegin(p), end = gradientParts->partEnd(p);
          if (simdKernel) {
            partEnergy[p] = simdKernel(data, begin, end, 0.0);
            continue;
          }
          double sum = 0;
          for (size_t a = begin; a != end; ++a) {
            const auto& G = activeGrad[a];
            const Eigen::Matrix3d J = detail::tetJacobian(rowMajorW, activeVertices[a], G);
            det[a] = J.determinant();
            Eigen::Matrix3d dJ;
            sum += activeWeight[a] * detail::untangleEnergy(J, eps, options.theta, g ? &dJ : nullptr);
            // column k: gradient with respect to vertex k
            if (g) gradientParts->addProduct(a, activeWeight[a], dJ, G);
          }
          partEnergy[p] = sum;
        }
      });
      double E = 0;
      for (double e : partEnergy) E += e;
      if (g) {
        tbb::parallel_for(tbb::blocked_range<size_t>(0, freeVerts.size(), 1024), [&](const tbb::blocked_range<size_t>& r) {
          for (size_t j = r.begin(); j != r.end(); ++j) {
            const FreeVertex& f = freeInfo[j];
            Eigen::Vector3d s = Eigen::Vector3d::Zero();
            gradientParts->addTo(j, s);  // (every tet of a free vertex is active)
            // (The unknowns only where a constraint needs them: an interior
            // vertex's chain rule is the identity.)
            if (f.slide != kInterior || clampIn) {
              const Eigen::Vector3d y = f.base + f.precond * x.segment<3>(3 * static_cast<Eigen::Index>(f.k));
              if (f.slide == kSphere) {  // chain rule through y ↦ y/|y|
                s = detail::sphereGradient(y, s);
              } else if (f.slide == kCubeRadial) {  // chain rule through the ray's exit point
                const detail::CubeRay r = cubeRay(y);
                s = r.extent > 0 ? detail::cubeRayGradient(r, s) : Eigen::Vector3d::Zero();
              } else if (f.slide == kCube) {  // chain rule through the lock and the clamp
                // Beyond a bound the clamp makes E flat in that coordinate; at
                // a bound that descent would push further out its derivative
                // is one-sided, so it is held there (active set, as in
                // L-BFGS-B). Measured: without the second, Newton steps pushed
                // vertices into the cube's faces and no step decreased E.
                for (int d = 0; d < 3; ++d)
                  if ((f.locks >> d) & 1 || y[d] < 0 || y[d] > 1 ||
                      (holdAtBounds && ((y[d] == 0 && s[d] > 0) || (y[d] == 1 && s[d] < 0))))
                    s[d] = 0;
              } else if (clampIn) {  // interior: beyond a face the clamp makes E flat
                for (int d = 0; d < 3; ++d)
                  if (y[d] < 0 || y[d] > 1) s[d] = 0;
              }
            }
            g->segment<3>(3 * static_cast<Eigen::Index>(f.k)) = f.precond * s;
          }
        });
      }
      return E;
    };

    // Sliding vertices (and with keepInteriorInCube the interior ones) restart
    // from their constrained position (after each L-BFGS run, after each
    // Newton step); true if there are any.
    auto restartSliding = [&](Eigen::VectorXd& x) {
      syncW();
      bool any = false;
      for (size_t k = 0; k < freeVerts.size(); ++k)
        if (slide[freeVerts[k]] != kInterior || clampIn) {
          x.segment<3>(3 * static_cast<Eigen::Index>(k)) = (W.row(freeVerts[k]).transpose() - unknown(k)) / precond[freeVerts[k]];
          any = true;
        }
      return any;
    };
    // Projected Newton (options.method == Newton): the Hessian of every tet's
    // energy in J projected onto the PSD cone (untangle_energy.h), mapped to
    // its vertices (H₁₂ = Bᵀ H₉ B) and to the unknowns through the
    // preconditioner and the sliding constraints (Gauss–Newton for y ↦ y/|y|),
    // assembled once per iteration into a fixed block pattern and factorised
    // with CHOLMOD (the symbolic analysis once per region).
    auto detMin = [&]() { return active.empty() ? 1.0 : *std::min_element(det.begin(), det.end()); };
    const bool useNewton = options.method == UntangleMethod::Newton;
    const Eigen::Index nFree = static_cast<Eigen::Index>(freeVerts.size());
    std::unique_ptr<detail::BlockHessian> hessian;
    if (useNewton) hessian = std::make_unique<detail::BlockHessian>(T, vt, freeVerts, inRegion, active);
    // dW_v = M dx_v for free vertex k = inRegion[v], at unknowns x, and C,
    // the projector onto the directions the constraints remove (the sphere's
    // normal, locked or held cube coordinates): M C = 0.
    struct Chain {
      Eigen::Matrix3d M, C;
    };
    auto chain = [&](size_t k, const Eigen::VectorXd& x, const Eigen::VectorXd& g) -> Chain {
      const int v = freeVerts[k];
      const Eigen::Vector3d y = unknown(k) + precond[v] * x.segment<3>(3 * static_cast<Eigen::Index>(k));
      Chain c{precond[v] * Eigen::Matrix3d::Identity(), Eigen::Matrix3d::Zero()};
      if (slide[v] == kSphere) {
        detail::sphereLinearisation(y, precond[v], c.M, c.C);
      } else if (slide[v] == kCubeRadial) {
        const detail::CubeRay r = cubeRay(y);
        if (r.extent > 0) detail::cubeRayLinearisation(r, precond[v], c.M, c.C);
      } else if (slide[v] == kCube) {
        for (int d = 0; d < 3; ++d)  // locked, or held at a bound (the gradient's active set)
          if ((locks[v] >> d) & 1 || g[3 * static_cast<Eigen::Index>(k) + d] == 0) c.M(d, d) = 0, c.C(d, d) = 1;
      } else if (clampIn) {  // interior, clamped beyond a face
        for (int d = 0; d < 3; ++d)
          if (y[d] < 0 || y[d] > 1) c.M(d, d) = 0, c.C(d, d) = 1;
      }
      return c;
    };
    // Assembles the projected Hessian at x (W and eps as left by evaluate(x, &g)).
    // Directions the constraints remove (the sphere's normal, locked or
    // clamped cube coordinates) get a unit curvature of their own: the
    // gradient has no component there, so neither has the step.
    auto assemble = [&](const Eigen::VectorXd& x, const Eigen::VectorXd& g) {
      syncW();
      std::vector<Eigen::Matrix3d> M(static_cast<size_t>(nFree)), C(static_cast<size_t>(nFree));
      tbb::parallel_for(tbb::blocked_range<size_t>(0, static_cast<size_t>(nFree), 1024), [&](const tbb::blocked_range<size_t>& r) {
        for (size_t k = r.begin(); k != r.end(); ++k) {
          const Chain c = chain(k, x, g);
          M[k] = c.M, C[k] = c.C;
        }
      });
      hessian->assemble(
          [&](size_t a) {
            const int t = active[a];
            const auto& G = grad[static_cast<size_t>(t)];
            const Eigen::Matrix3d J = detail::tetJacobian(W, T, t, G);
            return detail::vertexHessian(weight[t] * detail::untangleHessianProjected(J, eps, options.theta), G);
          },
          M, C);
    };
    // Minimises E_eps from x; returns the Newton iterations used.
    auto newton = [&](Eigen::VectorXd& x) {
      const Eigen::Index n = x.size();
      Eigen::VectorXd g(n), gNew(n), xNew(n);
      int it = 0;
      double f = evaluate(x, &g);
      for (; it < options.maxNewtonIterations; ++it) {
        if (!options.relax && detMin() > 0) break;  // untangled (the caller confirms exactly)
        assemble(x, g);
        Eigen::VectorXd d;
        if (!hessian->descent(g, d)) d = -g;
        double fNew = f, slope = 0;
        if (!detail::armijoStep(evaluate, x, g, d, f, xNew, gNew, fNew, &slope)) break;  // (positions and det restored)
        x.swap(xNew);
        g.swap(gNew);
        const double decrease = f - fNew;
        f = fNew;
        if (restartSliding(x)) f = evaluate(x, &g);
        if (decrease <= 1e-9 * std::abs(f) || -slope <= 1e-12 * std::abs(f)) {
          ++it;
          break;
        }
      }
      return it;
    };

    Eigen::VectorXd x = Eigen::VectorXd::Zero(3 * static_cast<Eigen::Index>(freeVerts.size()));
    // The region's fewest inverted after a round; the count after its last
    // round of progress (at most three quarters of the one before), and the
    // rounds since (regionStallRounds).
    long regionFewest = std::numeric_limits<long>::max(), progressMark = std::numeric_limits<long>::max();
    int sinceProgress = 0;
    for (int outer = 0; outer < options.maxOuterIterations; ++outer) {
      // ε from the smallest determinant (the reference code's eq. (7)): large
      // enough that χ stays smooth around the worst tet, halved base every 10.
      evaluate(x, nullptr);
      if (outer > 0 && outer % 10 == 0 && e0 > 1e-8) e0 /= 2;
      const double d0 = detMin();
      const double proposed = d0 > 0 ? e0 : std::sqrt(e0 * e0 + 0.04 * d0 * d0);
      // Never relax the barrier again, and tighten it while inversions remain.
      eps = outer == 0 ? proposed : std::min(d0 > 0 ? eps : 0.7 * eps, proposed);
      if (useNewton)
        result.newtonIterations += newton(x);
      else
        result.lbfgsIterations += detail::lbfgs([&](const Eigen::VectorXd& y, Eigen::VectorXd& g) { return evaluate(y, &g); }, x,
                                        options.maxLbfgsIterations, options.lbfgsMemory);
      const double E = evaluate(x, nullptr);
      restartSliding(x);
      const double dmin = detMin();
      ++result.outerIterations;
      result.minDet = dmin;
      // (the message counts the region's tets and boundary cones with
      // det J <= 0 in floating point; the exact count comes at the region's end)
      const long invertedNow = std::count_if(det.begin(), det.end(), [](double d) { return d <= 0; });
      regionFewest = std::min(regionFewest, invertedNow);
      if (progressMark == std::numeric_limits<long>::max() || 4 * invertedNow <= 3 * progressMark)
        progressMark = invertedNow, sinceProgress = 0;
      else
        ++sinceProgress;
      if (options.progress &&
          !options.progress(-1, "untangle: eps " + std::to_string(eps) + ", min det " + std::to_string(dmin) + ", E " +
                                  std::to_string(E) + ", L-BFGS iterations " + std::to_string(result.lbfgsIterations) +
                                  ", Newton iterations " + std::to_string(result.newtonIterations) +
                                  ", free " + std::to_string(freeVerts.size()) + ", inverted " +
                                  std::to_string(invertedNow) + ", work " + formatWork(result.tetEvaluations, nt))) {
        result.status = Status::failure("untangle: stopped by the progress callback");
        result.stopped = true;
        break;
      }
      if (dmin <= 0 && options.maxTetEvaluations > 0 && result.tetEvaluations >= options.maxTetEvaluations) {
        result.budgetExhausted = true;
        break;
      }
      if (dmin <= 0 && outer + 1 >= options.regionRounds) break;  // this region has had its rounds: grow it
      // Few left and none of the last rounds took a quarter off: the rest of
      // the rounds rarely do (bunny00's final untangling, cube: 22 inverted
      // for 12 of 16 rounds in a region of 2556 free vertices, 20 -> 19 over
      // the last 10 in one of 9347; 1 for 15 of 16 in one of 752). With a
      // new fewest as the bar, the region of 9520 went 26 -> 20 one at a
      // time over 15 rounds (3.8 s); with a quarter off, 5 rounds, and the
      // final untangling after the held phase's repair 7.4 -> 5.2 s (93 tets
      // left then, one edge split at the end either way).
      if (dmin <= 0 && options.regionStallRounds > 0 && regionFewest <= options.stallBelow &&
          sinceProgress >= options.regionStallRounds)
        break;
      // Floating point says untangled: confirm exactly on the active tets.
      if (dmin > 0) {
        int bad = 0;
        for (int t : active) bad += !positive(t);
        if (bad == 0) break;
      }
    }
    result.U = W.topRows(nv);
    result.invertedAfter = countNonPositiveTets(result.U, T0);
    result.flippedBoundaryTriangles = countBad(nt, ntx);
    if ((result.invertedAfter == 0 && result.flippedBoundaryTriangles == 0) || !result.status.ok || rings < 0 ||
        result.budgetExhausted)
      break;
    const int regionEndBad = result.invertedAfter + result.flippedBoundaryTriangles;
    // Measured against the fewest so far: a few tets left come and go by
    // several between regions (bunny00 scaled by 1 + 10⁻⁹: 59 after one
    // region, 67 after the next, 58 after a third). A region must halve them:
    // with a tenth fewer as the bar, bunny00's sliding phase (41 left after
    // the held phase's local repair) grew its regions from 3128 to 16891 and
    // 72221 free vertices for 26 -> 21 -> 21 left (the last two 98 s), before the phase
    // across cube edges repaired them in 3 s.
    if (fewestBad <= options.stallBelow && 2 * regionEndBad > fewestBad) {
      result.stalled = true;
      break;
    }
    fewestBad = std::min(fewestBad, regionEndBad);
    // Tets whose four vertices are fixed cannot be repaired by any region.
    int locked = 0;
    for (Eigen::Index t = 0; t < ntx; ++t) {
      bool allFixed = true;
      for (int k = 0; k < 4; ++k) allFixed = allFixed && fixed[T(t, k)];
      if (allFixed) locked += !positive(t);
    }
    if (locked == result.invertedAfter + result.flippedBoundaryTriangles) break;
    // Grow the region; once it would hold (nearly) everything, free it all.
    rings = rings == 0 ? 1 : 2 * rings;
    if (static_cast<Eigen::Index>(freeVerts.size()) * 2 > nv) rings = -1;
  }
  // Last resort: local max-min moves over what the energy left, when that is
  // a few tets (at most localRepairFraction of them). Measured: the ball
  // maps of hand (25 left) and spool (1) repaired in 0.06 s and 0.004 s;
  // on bracket.step's cube map (33746 left of 300k) the moves took 74 s for
  // 9921 left, and the run failed all the same.
  const int left = result.invertedAfter + result.flippedBoundaryTriangles;
  if (left > 0 && result.status.ok && !options.relax && options.localRepairSweeps > 0 &&
      left <= std::max(100.0, options.localRepairFraction * static_cast<double>(nt))) {
    W.topRows(nv) = result.U;
    std::vector<std::uint8_t> movable(static_cast<size_t>(nvx), 0);
    for (Eigen::Index v = 0; v < nv; ++v) {
      if (fixed[v]) continue;
      if (slide[v] == kInterior) movable[v] = 7;
      else if (slide[v] == kCube || slide[v] == kCubeRadial) movable[v] = static_cast<std::uint8_t>(7u & ~locks[v]);
    }
    Eigen::VectorXd tetScale(ntx);
    const double meanTarget = options.targetVolumes.size() == nt && nt > 0 ? options.targetVolumes.mean() : 0;
    for (Eigen::Index t = 0; t < ntx; ++t) {
      double s = 0;
      if (t < nt) {
        s = options.targetVolumes.size() == nt ? options.targetVolumes(t) : 0;
        if (!(s > 0)) {  // the reference tet's volume at the map's scale: |J| = 1
          const double sc = 1.0 / std::cbrt(std::abs(grad[static_cast<size_t>(t)].topRightCorner<3, 3>().determinant()));
          s = sc * sc * sc / 6;
        }
      } else {  // a cone: its triangle's area times the apex height / 3
        const Eigen::Vector3d pa = W.row(T(t, 1)), pb = W.row(T(t, 2)), pc = W.row(T(t, 3));
        s = 0.5 * (pb - pa).cross(pc - pa).norm() * apexHeight / 3;
      }
      tetScale(t) = s > 0 && std::isfinite(s) ? s : (meanTarget > 0 ? meanTarget : 1.0);
    }
    const auto repairStart = std::chrono::steady_clock::now();
    // The sweeps of single moves; their result is the start of the later
    // passes even when it counts more inversions (no move lowers its star's
    // least volume). The whole is kept only when it leaves fewer (below).
    const double lo = onCube ? 0.0 : -1.0;
    int moved = maxMinSweeps(W, T, vt, movable, tetScale, lo, 1.0, options.localRepairSweeps, options.localRepairFewTets);
    int inverted = moved > 0 ? countNonPositiveTets(W.topRows(nv), T0) : result.invertedAfter;
    int flipped = moved > 0 ? countBad(nt, ntx) : result.flippedBoundaryTriangles;
    // Each later pass is kept only when it leaves fewer than before it.
    auto pass = [&](auto&& run) {
      const Eigen::MatrixX3d kept = W;
      const int movedNow = run();
      const int invertedNow = movedNow > 0 ? countNonPositiveTets(W.topRows(nv), T0) : inverted;
      const int flippedNow = movedNow > 0 ? countBad(nt, ntx) : flipped;
      if (invertedNow + flippedNow < inverted + flipped) {
        moved += movedNow, inverted = invertedNow, flipped = flippedNow;
      } else {
        W = kept;
      }
    };
    // On the sphere, what the interior moves left gets a second pass in
    // which the sliding sphere vertices move too (tangent moves, projected):
    // folds of the boundary surface on the sphere (no interior move repairs
    // a flipped triangle's cone). A second pass, not one with every vertex,
    // so that what the first repairs stays as it was.
    const bool anySphere = std::any_of(slide.begin(), slide.end(), [](char c) { return c == kSphere; });
    if (inverted + flipped > 0 && anySphere) {
      for (Eigen::Index v = 0; v < nv; ++v)
        if (!fixed[v] && slide[v] == kSphere) movable[v] = kMoveOnSphere;
      pass([&] { return maxMinSweeps(W, T, vt, movable, tetScale, lo, 1.0, options.localRepairSweeps, options.localRepairFewTets); });
    }
    // Then joint moves of the patches around what is left, where every
    // single move is blocked, when that is a few (each tet's patch problem
    // is dense: a 3×3×3 grid tangled with 20 left takes about 0.2 s).
    if (inverted + flipped > 0 && inverted + flipped <= kPatchRepairAtMost && options.localRepairPatches)
      pass([&] { return patchMaxMin(W, T, vt, movable, tetScale, lo, 1.0, 10); });
    if (options.progress &&
        !options.progress(-1, "untangle: local max-min repair: " + std::to_string(moved) + " vertex moves, " +
                                  std::to_string(left) + " -> " + std::to_string(inverted + flipped) +
                                  " inverted tets and flipped triangles, " +
                                  std::to_string(std::chrono::duration<double>(std::chrono::steady_clock::now() - repairStart).count()) +
                                  " s")) {
      result.status = Status::failure("untangle: stopped by the progress callback");
      result.stopped = true;
    }
    if (inverted + flipped < result.invertedAfter + result.flippedBoundaryTriangles) {
      result.U = W.topRows(nv);
      result.invertedAfter = inverted;
      result.flippedBoundaryTriangles = flipped;
    }
  }
  // Never hand back something worse than what came in.
  if (result.invertedAfter + result.flippedBoundaryTriangles > result.invertedBefore + flippedBefore) {
    result.U = U0;
    result.invertedAfter = result.invertedBefore;
    result.flippedBoundaryTriangles = flippedBefore;
  }
  result.flippedSphereTriangles = onCube ? 0 : result.flippedBoundaryTriangles;
  if ((result.invertedAfter > 0 || result.flippedBoundaryTriangles > 0) && result.status.ok)
    result.status = Status::failure("untangle: " + std::to_string(result.invertedAfter) + " tets remain inverted and " +
                                    std::to_string(result.flippedBoundaryTriangles) +
                                    " boundary triangles flipped (some may have only fixed vertices)" +
                                    (result.budgetExhausted ? "; work budget (maxTetEvaluations) spent" : ""));
  return result;
}

std::vector<bool> holdBoundaryAwayFromFlips(const Eigen::MatrixX3d& U, const Eigen::MatrixX3i& faces,
                                            const Eigen::Vector3d& apex, int rings) {
  const Eigen::Index nv = U.rows();
  if (faces.rows() > 0 && (faces.minCoeff() < 0 || faces.maxCoeff() >= nv))
    throw Error(ErrorKind::Input, "holdBoundaryAwayFromFlips: face vertex index out of range");
  std::vector<char> near(static_cast<size_t>(nv), 0);
  for (Eigen::Index f = 0; f < faces.rows(); ++f) {
    const Eigen::Vector3d a = U.row(faces(f, 0)), b = U.row(faces(f, 1)), c = U.row(faces(f, 2));
    if (orient3d(apex.data(), a.data(), b.data(), c.data()) <= 0)
      for (int k = 0; k < 3; ++k) near[static_cast<size_t>(faces(f, k))] = 1;
  }
  for (int ring = 0; ring < rings; ++ring) {
    std::vector<char> next = near;
    for (Eigen::Index f = 0; f < faces.rows(); ++f)
      if (near[static_cast<size_t>(faces(f, 0))] || near[static_cast<size_t>(faces(f, 1))] ||
          near[static_cast<size_t>(faces(f, 2))])
        for (int k = 0; k < 3; ++k) next[static_cast<size_t>(faces(f, k))] = 1;
    near.swap(next);
  }
  std::vector<bool> held(static_cast<size_t>(nv), false);
  for (Eigen::Index f = 0; f < faces.rows(); ++f)
    for (int k = 0; k < 3; ++k) {
      const auto v = static_cast<size_t>(faces(f, k));
      held[v] = !near[v];
    }
  return held;
}

}  // namespace tet2spline

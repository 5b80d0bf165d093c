// The untangler's L-BFGS (param/src/lbfgs.h) keeps its history in a ring
// allocated once and runs its element-wise updates and its dot products
// (in fixed chunks, added in order) on both cores above 65536 unknowns,
// each update of the recursion in one pass with the dot product after it
// (updateThenDot). Its iterates must be bitwise those of the plain two-loop
// recursion on Eigen temporaries that it replaced (kept below as the
// reference): the untangler's maps depend chaotically on the last bits.
// Checked on a spring energy over a real mesh's edges (serial updates) and
// on a coupled non-convex function of 240k unknowns (parallel updates),
// with a history short enough to wrap around, and with a barrier that
// rejects trial steps.
#include "../../param/src/lbfgs.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <deque>
#include <limits>
#include <random>
#include <vector>

#include "test_data.h"
#include "tet2spline/io/mesh_io.h"
#include "tet2spline/param/tetrahedralize.h"

using namespace tet2spline;

namespace {

// The dot products as the ring's are defined (parallelDot): Eigen's below
// 65536 elements, else Eigen's over chunks of 16384 added in order, here
// in one thread.
double chunkedDot(const Eigen::VectorXd& a, const Eigen::VectorXd& b) {
  const Eigen::Index n = a.size(), chunk = 1 << 14;
  if (n < (1 << 16)) return a.dot(b);
  double sum = 0;
  for (Eigen::Index begin = 0; begin < n; begin += chunk) {
    const Eigen::Index size = std::min(chunk, n - begin);
    sum += a.segment(begin, size).dot(b.segment(begin, size));
  }
  return sum;
}
double chunkedSquaredNorm(const Eigen::VectorXd& a) {
  const Eigen::Index n = a.size(), chunk = 1 << 14;
  if (n < (1 << 16)) return a.squaredNorm();
  double sum = 0;
  for (Eigen::Index begin = 0; begin < n; begin += chunk) sum += a.segment(begin, std::min(chunk, n - begin)).squaredNorm();
  return sum;
}

// The recursion as it was before the ring (same operations, Eigen
// temporaries; the dot products chunked as above).
template <class FunGrad>
int referenceLbfgs(FunGrad&& fg, Eigen::VectorXd& x, int maxIter, int memory) {
  Eigen::VectorXd g(x.size()), gNew(x.size()), xNew(x.size());
  double f = fg(x, g);
  std::deque<Eigen::VectorXd> S, Y;
  std::deque<double> rho;
  int it = 0;
  for (; it < maxIter; ++it) {
    if (!(chunkedSquaredNorm(g) > 0)) break;
    Eigen::VectorXd d = -g;
    std::vector<double> alpha(S.size());
    for (int k = static_cast<int>(S.size()) - 1; k >= 0; --k) {
      alpha[k] = rho[k] * chunkedDot(S[k], d);
      d -= alpha[k] * Y[k];
    }
    double gamma = S.empty() ? 1.0 / std::max(std::sqrt(chunkedSquaredNorm(g)), 1e-300)
                             : chunkedDot(S.back(), Y.back()) / chunkedSquaredNorm(Y.back());
    d *= gamma;
    for (size_t k = 0; k < S.size(); ++k) d += S[k] * (alpha[k] - rho[k] * chunkedDot(Y[k], d));
    double slope = chunkedDot(g, d);
    if (!(slope < 0)) {
      S.clear(), Y.clear(), rho.clear();
      d = -g / std::max(std::sqrt(chunkedSquaredNorm(g)), 1e-300);
      slope = chunkedDot(g, d);
    }
    double step = 1, fNew = 0;
    bool accepted = false;
    for (int ls = 0; ls < 40; ++ls, step *= 0.5) {
      xNew = x + step * d;
      fNew = fg(xNew, gNew);
      if (std::isfinite(fNew) && fNew <= f + 1e-4 * step * slope) {
        accepted = true;
        break;
      }
    }
    if (!accepted) {
      if (S.empty()) break;
      S.clear(), Y.clear(), rho.clear();
      continue;
    }
    const Eigen::VectorXd s = xNew - x, y = gNew - g;
    const double sy = chunkedDot(s, y);
    x.swap(xNew);
    g.swap(gNew);
    const double decrease = f - fNew;
    f = fNew;
    if (sy > 1e-12 * std::sqrt(chunkedSquaredNorm(s)) * std::sqrt(chunkedSquaredNorm(y))) {
      S.push_back(s), Y.push_back(y), rho.push_back(1 / sy);
      if (static_cast<int>(S.size()) > memory) S.pop_front(), Y.pop_front(), rho.pop_front();
    }
    if (decrease <= 1e-12 * std::abs(f)) {
      ++it;
      break;
    }
  }
  return it;
}

void expectSameBits(const Eigen::VectorXd& a, const Eigen::VectorXd& b) {
  ASSERT_EQ(a.size(), b.size());
  for (Eigen::Index i = 0; i < a.size(); ++i)
    ASSERT_EQ(std::memcmp(&a[i], &b[i], sizeof(double)), 0) << "unknown " << i << ": " << a[i] << " against " << b[i];
}

}  // namespace

TEST(Lbfgs, RingGivesThePlainRecursionsIteratesOnARealMeshsSprings) {
  const TetMesh m = tetrahedralize(readSurface(t2stest::cgalMesh("blobby")), {}, "blobby");
  const Eigen::Index nv = m.V.rows();
  // Springs along the tets' edges with rest lengths 1.3 times the input's,
  // the first vertex pinned softly: a non-convex energy of the positions.
  std::vector<std::array<int, 2>> edges;
  for (Eigen::Index t = 0; t < m.T.rows(); ++t)
    for (int a = 0; a < 4; ++a)
      for (int b = a + 1; b < 4; ++b)
        if (m.T(t, a) < m.T(t, b)) edges.push_back({m.T(t, a), m.T(t, b)});
  std::vector<double> rest(edges.size());
  for (size_t e = 0; e < edges.size(); ++e) rest[e] = 1.3 * (m.V.row(edges[e][0]) - m.V.row(edges[e][1])).norm();
  auto springs = [&](const Eigen::VectorXd& x, Eigen::VectorXd& g) {
    g.setZero();
    double f = 0;
    for (size_t e = 0; e < edges.size(); ++e) {
      const Eigen::Vector3d d = x.segment<3>(3 * edges[e][0]) - x.segment<3>(3 * edges[e][1]);
      const double l2 = d.squaredNorm(), r = l2 - rest[e] * rest[e];
      f += r * r;
      g.segment<3>(3 * edges[e][0]) += 4 * r * d;
      g.segment<3>(3 * edges[e][1]) -= 4 * r * d;
    }
    const Eigen::Vector3d p = x.head<3>() - m.V.row(0).transpose();
    f += p.squaredNorm();
    g.head<3>() += 2 * p;
    return f;
  };
  Eigen::VectorXd start(3 * nv);
  for (Eigen::Index v = 0; v < nv; ++v) start.segment<3>(3 * v) = m.V.row(v).transpose();
  ASSERT_LT(start.size(), 1 << 16);  // (the serial updates)
  for (int memory : {3, 10}) {
    Eigen::VectorXd ring = start, plain = start;
    const int a = detail::lbfgs(springs, ring, 60, memory), b = referenceLbfgs(springs, plain, 60, memory);
    EXPECT_EQ(a, b) << "memory " << memory;
    EXPECT_GT(a, 2 * memory) << "the history wraps around";
    expectSameBits(ring, plain);
  }
}

TEST(Lbfgs, RingGivesThePlainRecursionsIteratesWithParallelUpdatesAndRejectedSteps) {
  // 240k unknowns, coupled to their neighbours, pulled towards ±1.6 beyond
  // a barrier: the value is +inf where an unknown leaves (−1.5, 1.5), so
  // some trial steps are rejected and halved.
  const Eigen::Index n = 240000;
  std::mt19937 rng(9);
  std::uniform_real_distribution<double> u(-1, 1);
  Eigen::VectorXd c(n), start(n);
  for (Eigen::Index i = 0; i < n; ++i) c[i] = (u(rng) < 0 ? -1.6 : 1.6), start[i] = 0.5 * u(rng);
  int infinite = 0;
  auto fg = [&](const Eigen::VectorXd& x, Eigen::VectorXd& g) {
    double f = 0;
    for (Eigen::Index i = 0; i < n; ++i) {
      if (std::abs(x[i]) >= 1.5) {
        ++infinite;
        return std::numeric_limits<double>::infinity();
      }
      const double next = x[(i + 1) % n], d = x[i] - next, w = 1.5 * 1.5 - x[i] * x[i];
      f += 0.5 * (x[i] - c[i]) * (x[i] - c[i]) + 0.25 * d * d * d * d + 0.05 * std::cos(3 * x[i]) - 0.01 * std::log(w);
      g[i] = (x[i] - c[i]) - 0.15 * std::sin(3 * x[i]) + 0.02 * x[i] / w;
    }
    for (Eigen::Index i = 0; i < n; ++i) {
      const double d = x[i] - x[(i + 1) % n];
      g[i] += d * d * d;
      g[(i + 1) % n] -= d * d * d;
    }
    return f;
  };
  Eigen::VectorXd ring = start, plain = start;
  const int a = detail::lbfgs(fg, ring, 40, 4);
  const int rejectedByRing = infinite;
  infinite = 0;
  const int b = referenceLbfgs(fg, plain, 40, 4);
  EXPECT_EQ(a, b);
  EXPECT_GT(a, 8);
  EXPECT_GT(rejectedByRing, 0) << "no trial step met the barrier";
  EXPECT_EQ(rejectedByRing, infinite);
  expectSameBits(ring, plain);
}

// The local repair's max-min barrier (param/src/max_min_barrier.h) sums its
// Hessian in registers for a vertex's 2 to 4 unknowns (for 3 and 4 in AVX2
// lanes where the processor has them, untangle_kernel.h) and carries each
// accepted trial's slack and log sum into the next Newton iteration. Its
// results must be bitwise those of the code it replaced (kept below as the
// reference): the untangler's maps depend chaotically on the last bits.
// Checked on the problems the repair builds on a real mesh with inverted
// tets: single vertices moving along 1, 2 or 3 axes (sums over the rows),
// and the four vertices of a tet moving together (dense products, the
// patches' smaller gaps; and the row sums for more than 4 unknowns).
// Larger patches go over their rows' nonzeros: the second test holds them
// to the dense products' least volume, within the barrier's gap.
#include "../../param/src/max_min_barrier.h"

#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>
#include <random>
#include <vector>

#include "test_data.h"
#include "tet2spline/io/mesh_io.h"
#include "tet2spline/param/tetrahedralize.h"

using namespace tet2spline;

namespace {

// The barrier as it was before (every Newton iteration recomputed z's slack
// and log sum; the row sums went through the dynamic H).
Eigen::VectorXd referenceBarrier(const Eigen::MatrixXd& a, const Eigen::VectorXd& b, Eigen::VectorXd z, bool products,
                                 double gap) {
  const Eigen::Index n = z.size(), m = a.rows();
  Eigen::VectorXd product(m), r(m), trial(n), g(n), dz(n), column(n);
  Eigen::MatrixXd H(n, n), scaled;
  Eigen::VectorXd ones;
  if (products) scaled.resize(m, n), ones = Eigen::VectorXd::Ones(m);
  Eigen::LDLT<Eigen::MatrixXd> ldlt(n);
  auto slackInto = [&](const Eigen::VectorXd& y, Eigen::VectorXd& out) {
    product.noalias() = a * y;
    out = product + b;
  };
  auto phi = [&](const Eigen::VectorXd& y, double tau, bool& ok) {
    slackInto(y, r);
    ok = (r.array() > 0).all();
    return ok ? -tau * y(n - 1) - r.array().log().sum() : std::numeric_limits<double>::infinity();
  };
  for (double tau = 1; tau < (gap < 1e-7 ? 1e3 / gap : 1e9) && static_cast<double>(m) / tau > gap; tau *= 8) {
    for (int it = 0; it < 40; ++it) {
      slackInto(z, r);
      g.setZero();
      g(n - 1) = -tau;
      H.setZero();
      if (products) {
        scaled.noalias() = r.cwiseInverse().asDiagonal() * a;
        column.noalias() = scaled.transpose() * ones;
        g -= column;
        H.noalias() = scaled.transpose() * scaled;
      } else {
        for (Eigen::Index j = 0; j < m; ++j) {
          const double rj = r(j), rr = rj * rj;
          for (Eigen::Index p = 0; p < n; ++p) g(p) -= a(j, p) / rj;
          for (Eigen::Index q = 0; q < n; ++q)
            for (Eigen::Index p = q; p < n; ++p) H(p, q) += (a(j, p) * a(j, q)) / rr;
        }
      }
      ldlt.compute(H);
      dz = ldlt.solve(g);
      dz = -dz;
      const double decrement = -g.dot(dz);
      if (!dz.allFinite() || !(decrement > 1e-12)) break;
      bool ok = false;
      const double f0 = phi(z, tau, ok);
      double step = 1;
      for (; step > 1e-12; step *= 0.5) {
        trial = z + step * dz;
        const double f = phi(trial, tau, ok);
        if (ok && f <= f0 - 0.25 * step * decrement) break;
      }
      if (!(step > 1e-12)) break;
      z += step * dz;
    }
  }
  return z;
}

bool sameBits(const Eigen::VectorXd& a, const Eigen::VectorXd& b) {
  return a.size() == b.size() && std::memcmp(a.data(), b.data(), sizeof(double) * static_cast<size_t>(a.size())) == 0;
}

double volume(const Eigen::MatrixX3d& W, const Eigen::MatrixX4i& T, Eigen::Index t) {
  const Eigen::Vector3d p0 = W.row(T(t, 0)), p1 = W.row(T(t, 1)), p2 = W.row(T(t, 2)), p3 = W.row(T(t, 3));
  return (p1 - p0).cross(p2 - p0).dot(p3 - p0) / 6;
}

// ∂ volume(t) / ∂ (position of corner k).
Eigen::Vector3d volumeGradient(const Eigen::MatrixX3d& W, const Eigen::MatrixX4i& T, Eigen::Index t, int k) {
  const Eigen::Vector3d pa = W.row(T(t, (k + 1) % 4)), pb = W.row(T(t, (k + 2) % 4)), pc = W.row(T(t, (k + 3) % 4));
  return -((k % 2) ? -1.0 : 1.0) * (pb - pa).cross(pc - pa) / 6;
}

// After the volume rows from `row` on: t <= 1 and a box of ±half per
// displacement, as the repair adds them; returns the feasible start
// (no move, t one below the worst volume).
Eigen::VectorXd closeProblem(Eigen::MatrixXd& a, Eigen::VectorXd& b, Eigen::Index row, double worst, double half) {
  const Eigen::Index unknowns = a.cols() - 1;
  a(row, unknowns) = -1, b(row) = 1, ++row;
  for (Eigen::Index i = 0; i < unknowns; ++i) {
    a(row, i) = 1, b(row) = half, ++row;
    a(row, i) = -1, b(row) = half, ++row;
  }
  Eigen::VectorXd z = Eigen::VectorXd::Zero(unknowns + 1);
  z(unknowns) = worst - 1;
  return z;
}

// blobby's TetGen mesh and a map of it with inverted tets: the mesh
// jittered by about half an edge.
struct Jittered {
  TetMesh m;
  Eigen::MatrixX3d W;
  double edge = 0, scale = 1;
  std::vector<std::vector<int>> corners;  // per vertex: 4t + k
  std::vector<Eigen::Index> inverted;
  Jittered() : m(tetrahedralize(readSurface(t2stest::cgalMesh("blobby")), {}, "blobby")) {
    const Eigen::Index nv = m.V.rows(), nt = m.T.rows();
    std::mt19937 rng(5);
    std::uniform_real_distribution<double> u(-1, 1);
    for (Eigen::Index t = 0; t < nt; ++t) edge += (m.V.row(m.T(t, 0)) - m.V.row(m.T(t, 1))).norm();
    edge /= static_cast<double>(nt);
    W = m.V;
    for (Eigen::Index v = 0; v < nv; ++v) W.row(v) += 0.45 * edge * Eigen::RowVector3d(u(rng), u(rng), u(rng));
    scale = std::abs(volume(m.V, m.T, 0)) + 1e-300;  // volumes normalised as the repair does
    corners.resize(static_cast<size_t>(nv));
    for (Eigen::Index t = 0; t < nt; ++t)
      for (int k = 0; k < 4; ++k) corners[static_cast<size_t>(m.T(t, k))].push_back(static_cast<int>(4 * t + k));
    for (Eigen::Index t = 0; t < nt; ++t)
      if (volume(W, m.T, t) <= 0) inverted.push_back(t);
  }
};

}  // namespace

TEST(MaxMinBarrier, GivesTheBitsOfTheCodeItReplacedOnARealMeshsRepairProblems) {
  const Jittered j;
  const TetMesh& m = j.m;
  const Eigen::MatrixX3d& W = j.W;
  const double edge = j.edge, scale = j.scale;
  const std::vector<std::vector<int>>& corners = j.corners;
  const std::vector<Eigen::Index>& inverted = j.inverted;
  ASSERT_GT(inverted.size(), 50u);

  int singles = 0, patches = 0, improved = 0;
  const std::vector<std::vector<int>> axes = {{0, 1, 2}, {0, 2}, {1}};
  for (size_t q = 0; q < inverted.size() && q < 60; ++q) {
    const Eigen::Index bad = inverted[q];
    // Each corner alone, along 3, 2 or 1 axes (the sweeps' problem): a row
    // per tet of its star, t <= 1, and a box of a quarter of an edge.
    for (int c = 0; c < 4; ++c) {
      const int v = m.T(bad, c);
      const std::vector<int>& dims = axes[static_cast<size_t>((q + static_cast<size_t>(c)) % 3)];
      const auto nd = static_cast<Eigen::Index>(dims.size());
      const std::vector<int>& around = corners[static_cast<size_t>(v)];
      const Eigen::Index rows = static_cast<Eigen::Index>(around.size()) + 1 + 2 * nd;
      Eigen::MatrixXd a = Eigen::MatrixXd::Zero(rows, nd + 1);
      Eigen::VectorXd b(rows);
      double worst = std::numeric_limits<double>::infinity();
      Eigen::Index row = 0;
      for (int corner : around) {
        const int t = corner / 4, k = corner % 4;
        const Eigen::Vector3d grad = volumeGradient(W, m.T, t, k);
        for (Eigen::Index i = 0; i < nd; ++i) a(row, i) = grad[dims[static_cast<size_t>(i)]] / scale;
        a(row, nd) = -1;
        b(row) = volume(W, m.T, t) / scale;
        worst = std::min(worst, b(row));
        ++row;
      }
      const Eigen::VectorXd z = closeProblem(a, b, row, worst, 0.25 * edge);
      const Eigen::VectorXd got = detail::maxMinBarrier(a, b, z), want = referenceBarrier(a, b, z, false, 1e-7);
      ASSERT_TRUE(sameBits(got, want)) << "tet " << bad << " corner " << c << " (" << nd << " axes): " << got.transpose()
                                       << " against " << want.transpose();
      improved += got(nd) > worst;
      ++singles;
    }
    // The tet's four corners together (the patches' problem): every tet
    // touching them, linear in the 12 displacements.
    std::vector<int> star;
    for (int c = 0; c < 4; ++c) {
      const int v = m.T(bad, c);
      for (int corner : corners[static_cast<size_t>(v)]) star.push_back(corner / 4);
    }
    std::sort(star.begin(), star.end());
    star.erase(std::unique(star.begin(), star.end()), star.end());
    const Eigen::Index unknowns = 12, rows = static_cast<Eigen::Index>(star.size()) + 1 + 2 * unknowns;
    Eigen::MatrixXd a = Eigen::MatrixXd::Zero(rows, unknowns + 1);
    Eigen::VectorXd b(rows);
    double worst = std::numeric_limits<double>::infinity();
    Eigen::Index row = 0;
    for (int t : star) {
      for (int k = 0; k < 4; ++k)
        for (int c = 0; c < 4; ++c)
          if (m.T(t, k) == m.T(bad, c)) a.block<1, 3>(row, 3 * c) = volumeGradient(W, m.T, t, k).transpose() / scale;
      a(row, unknowns) = -1;
      b(row) = volume(W, m.T, t) / scale;
      worst = std::min(worst, b(row));
      ++row;
    }
    const Eigen::VectorXd z = closeProblem(a, b, row, worst, 0.25 * edge);
    const double gap = std::clamp(1e-2 * std::abs(worst), 1e-14, 1e-7);
    for (bool products : {true, false}) {
      const Eigen::VectorXd got = detail::maxMinBarrier(a, b, z, products, gap),
                            want = referenceBarrier(a, b, z, products, gap);
      ASSERT_TRUE(sameBits(got, want)) << "patch of tet " << bad << (products ? " (products)" : " (row sums)");
      improved += got(unknowns) > worst;
    }
    ++patches;
  }
  EXPECT_GE(singles, 200);
  EXPECT_GE(patches, 50);
  EXPECT_GT(improved, (singles + 2 * patches) / 2) << "most problems should raise their least volume";
}

// A larger patch (the repair's level 1: every vertex of the tets around the
// inverted tet's corners, about 20 vertices and 60 unknowns) goes over the
// nonzeros of its rows, not dense products: not the dense code's bits, but
// the same problem solved. Both end strictly feasible, and their least
// volumes agree to within the barrier's duality gap (m/τ at the last τ is
// at most `gap`, so each is within about `gap` of the optimum).
TEST(MaxMinBarrier, SolvesLargePatchesOverTheirNonzerosAsTheDenseProductsDo) {
  const Jittered j;
  const TetMesh& m = j.m;
  ASSERT_GT(j.inverted.size(), 50u);
  int solved = 0, improved = 0;
  for (size_t q = 0; q < j.inverted.size() && q < 20; ++q) {
    const Eigen::Index bad = j.inverted[q];
    std::vector<int> patch, star;
    for (int c = 0; c < 4; ++c)
      for (int corner : j.corners[static_cast<size_t>(m.T(bad, c))])
        for (int k = 0; k < 4; ++k) patch.push_back(m.T(corner / 4, k));
    std::sort(patch.begin(), patch.end());
    patch.erase(std::unique(patch.begin(), patch.end()), patch.end());
    for (int v : patch)
      for (int corner : j.corners[static_cast<size_t>(v)]) star.push_back(corner / 4);
    std::sort(star.begin(), star.end());
    star.erase(std::unique(star.begin(), star.end()), star.end());
    const auto unknowns = static_cast<Eigen::Index>(3 * patch.size()),
               rows = static_cast<Eigen::Index>(star.size()) + 1 + 2 * unknowns;
    ASSERT_GT(unknowns, 16) << "a patch this size goes over the nonzeros";
    Eigen::MatrixXd a = Eigen::MatrixXd::Zero(rows, unknowns + 1);
    Eigen::VectorXd b(rows);
    double worst = std::numeric_limits<double>::infinity();
    Eigen::Index row = 0;
    for (int t : star) {
      for (int k = 0; k < 4; ++k) {
        const auto at = std::lower_bound(patch.begin(), patch.end(), m.T(t, k));
        if (at != patch.end() && *at == m.T(t, k))
          a.block<1, 3>(row, 3 * (at - patch.begin())) = volumeGradient(j.W, m.T, t, k).transpose() / j.scale;
      }
      a(row, unknowns) = -1;
      b(row) = volume(j.W, m.T, t) / j.scale;
      worst = std::min(worst, b(row));
      ++row;
    }
    const Eigen::VectorXd z = closeProblem(a, b, row, worst, 0.25 * j.edge);
    const double gap = std::clamp(1e-2 * std::abs(worst), 1e-14, 1e-7);
    const Eigen::VectorXd got = detail::maxMinBarrier(a, b, z, true, gap), want = referenceBarrier(a, b, z, true, gap);
    ASSERT_EQ(got.size(), want.size());
    EXPECT_GT(((a * got + b).array()).minCoeff(), 0) << "patch of tet " << bad << ": infeasible";
    EXPECT_NEAR(got(unknowns), want(unknowns), 4 * gap + 1e-12 * std::abs(want(unknowns))) << "patch of tet " << bad;
    EXPECT_FALSE(std::memcmp(got.data(), z.data(), sizeof(double) * static_cast<size_t>(z.size())) == 0)
        << "patch of tet " << bad << ": no move";
    improved += got(unknowns) > worst;
    ++solved;
  }
  EXPECT_EQ(solved, 20);
  EXPECT_GT(improved, solved / 2) << "most patches should raise their least volume";
}

// The untangler's per-tet loop in AVX2 registers (param/src/untangle_kernel.h)
// must give the scalar loop's bits: the energy's partial sums, det J and
// every corner's gradient term (added to its vertex's row in the same order),
// for inverted and positive tets, barriers
// from 10⁻¹⁶⁰ to 5, and ranges of any length (the spare lanes of a last
// group of fewer than four must write nothing). (At ε = 10⁻¹⁶⁰ the inverted
// tets' χ underflows, so their lanes take the scalar cube root; e is then
// infinite or NaN whatever the root, so there it is only the same
// non-finite bits that are checked.) And a whole untangling of a real mesh must be
// bitwise the same with the loop and without it (TET2SPLINE_SIMD=0).
#include "../../param/src/untangle_kernel.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <numeric>
#include <random>
#include <vector>

#include "../../param/src/part_gradients.h"
#include "../../param/src/untangle_energy.h"
#include "test_data.h"
#include "tet2spline/io/mesh_io.h"
#include "tet2spline/param/tetrahedralize.h"
#include "tet2spline/param/topology.h"
#include "tet2spline/param/untangle.h"

using namespace tet2spline;

namespace {

bool sameBits(double a, double b) { return std::memcmp(&a, &b, sizeof a) == 0; }

// Restores TET2SPLINE_SIMD's absence at the end of a test.
struct SimdSetting {
  explicit SimdSetting(const char* value) { setenv("TET2SPLINE_SIMD", value, 1); }
  ~SimdSetting() { unsetenv("TET2SPLINE_SIMD"); }
};

}  // namespace

TEST(UntangleKernel, SimdLoopGivesTheScalarLoopsBits) {
  const detail::UntangleKernel simd = detail::simdUntangleKernel();
  if (!simd) GTEST_SKIP() << "no AVX2 on this processor";
  const TetMesh m = tetrahedralize(readSurface(t2stest::cgalMesh("blobby")), {}, "blobby");
  const Eigen::Index nv = m.V.rows(), nt = m.T.rows();
  ASSERT_GT(nt, 1000);
  // The map: a random linear map of the mesh, each vertex jittered by about
  // an edge (many tets inverted), rows in a shuffled storage order.
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> u(-1, 1);
  Eigen::Matrix3d A;
  for (int i = 0; i < 9; ++i) A.data()[i] = (i % 4 == 0 ? 1.5 : 0) + 0.3 * u(rng);
  double edge = 0;
  for (Eigen::Index t = 0; t < nt; ++t) edge += (m.V.row(m.T(t, 0)) - m.V.row(m.T(t, 1))).norm();
  edge /= static_cast<double>(nt);
  std::vector<int> rank(static_cast<size_t>(nv));
  std::iota(rank.begin(), rank.end(), 0);
  std::shuffle(rank.begin(), rank.end(), rng);
  Eigen::Matrix<double, Eigen::Dynamic, 3, Eigen::RowMajor> W(nv, 3);
  for (Eigen::Index v = 0; v < nv; ++v)
    W.row(rank[static_cast<size_t>(v)]) =
        (A * m.V.row(v).transpose()).transpose() + 0.6 * edge * Eigen::RowVector3d(u(rng), u(rng), u(rng));
  // The tets' data as the untangler lays it out: reference gradients scaled
  // per tet, weights, the corners' rows and slots.
  std::vector<Eigen::Matrix<double, 3, 4>> G(static_cast<size_t>(nt));
  std::vector<std::array<int, 4>> vertices(static_cast<size_t>(nt));
  std::vector<double> weights(static_cast<size_t>(nt));
  int inverted = 0;
  for (Eigen::Index t = 0; t < nt; ++t) {
    const size_t s = static_cast<size_t>(t);
    Eigen::Matrix3d E;
    for (int k = 1; k < 4; ++k) E.col(k - 1) = (m.V.row(m.T(t, k)) - m.V.row(m.T(t, 0))).transpose();
    const Eigen::Matrix3d Einv = E.inverse();
    for (int k = 1; k < 4; ++k) G[s].col(k) = Einv.row(k - 1).transpose();
    G[s].col(0) = -(G[s].col(1) + G[s].col(2) + G[s].col(3));
    G[s] /= 1 + 0.5 * u(rng);
    weights[s] = t % 3 == 0 ? 1.0 : 1 + u(rng);
    for (int k = 0; k < 4; ++k) vertices[s][k] = rank[static_cast<size_t>(m.T(t, k))];
    inverted += detail::tetJacobian(W, vertices[s], G[s]).determinant() <= 0;
  }
  ASSERT_GT(inverted, nt / 20);
  ASSERT_LT(inverted, nt / 2);
  // Every fifth vertex held (its corners go to the parts' sinks).
  std::vector<int> freeIndex(static_cast<size_t>(nv), -1);
  int numFree = 0;
  for (Eigen::Index v = 0; v < nv; ++v)
    if (v % 5 != 0) freeIndex[static_cast<size_t>(v)] = numFree++;
  detail::PartGradients scalarTerms(vertices, freeIndex, static_cast<size_t>(numFree)),
      simdTerms(vertices, freeIndex, static_cast<size_t>(numFree));
  ASSERT_GT(scalarTerms.parts(), 1u);
  const size_t termCount = detail::PartGradients::kStride * scalarTerms.numRows();
  int specialChecked = 0;
  for (double eps : {1e-160, 1e-9, 1e-3, 0.3, 5.0})
    for (double theta : {0.0, 0.5}) {
      for (bool gradient : {true, false}) {
        std::vector<double> scalarDet(static_cast<size_t>(nt), -7.0), simdDet(static_cast<size_t>(nt), -7.0);
        std::fill(scalarTerms.data(), scalarTerms.data() + termCount, -3.0);
        std::fill(simdTerms.data(), simdTerms.data() + termCount, -3.0);
        detail::UntangleKernelData d;
        d.positions = W.data();
        d.vertices = vertices.data()->data();
        d.gradients = G.data()->data();
        d.weights = weights.data();
        d.rows = simdTerms.rows();
        d.acc = gradient ? simdTerms.data() : nullptr;
        d.det = simdDet.data();
        d.eps = eps, d.theta = theta;
        // Ranges of every length mod 4, and one left out (its tets' outputs untouched).
        size_t begin = 0;
        int range = 0;
        const size_t lengths[] = {1, 2, 3, 5, 7, 1024, 333};
        while (begin < static_cast<size_t>(nt)) {
          const size_t end = std::min<size_t>(nt, begin + lengths[range % 7]);
          const bool skipped = range == 4;
          ++range;
          if (skipped) {
            begin = end;
            continue;
          }
          double scalarSum = 0.25 * static_cast<double>(range);
          for (size_t a = begin; a < end; ++a) {
            const Eigen::Matrix3d J = detail::tetJacobian(W, vertices[a], G[a]);
            scalarDet[a] = J.determinant();
            Eigen::Matrix3d dJ;
            scalarSum += weights[a] * detail::untangleEnergy(J, eps, theta, gradient ? &dJ : nullptr);
            if (gradient) scalarTerms.addProduct(a, weights[a], dJ, G[a]);
          }
          const double simdSum = simd(d, begin, end, 0.25 * static_cast<double>(range));
          ASSERT_TRUE(sameBits(simdSum, scalarSum))
              << "eps " << eps << " theta " << theta << " tets " << begin << ".." << end << ": " << simdSum << " against "
              << scalarSum;
          begin = end;
        }
        for (Eigen::Index t = 0; t < nt; ++t)
          ASSERT_TRUE(sameBits(simdDet[static_cast<size_t>(t)], scalarDet[static_cast<size_t>(t)])) << "tet " << t;
        for (size_t i = 0; i < termCount; ++i)
          ASSERT_TRUE(sameBits(simdTerms.data()[i], scalarTerms.data()[i]))
              << "eps " << eps << " theta " << theta << " term " << i;
        EXPECT_EQ(std::count(simdDet.begin(), simdDet.end(), -7.0), lengths[4]);  // the range left out
        if (eps < 1e-100 && gradient) {
          // χ = ε²/(2(r − D)) underflows for the inverted tets: lanes the scalar cube root takes.
          for (Eigen::Index t = 0; t < nt; ++t) {
            const double D = scalarDet[static_cast<size_t>(t)];
            specialChecked += D < 0 && std::fpclassify(detail::untangleChi(eps, D)) != FP_NORMAL;
          }
        }
      }
    }
  EXPECT_GT(specialChecked, 0);
}

TEST(UntangleKernel, UntanglingARealMeshIsBitwiseTheSameWithAndWithoutSimd) {
  if (!detail::simdUntangleKernel()) GTEST_SKIP() << "no AVX2 on this processor";
  const TetMesh m = tetrahedralize(readSurface(t2stest::cgalMesh("blobby")), {}, "blobby");
  std::vector<bool> fixed(static_cast<size_t>(m.V.rows()), false);
  const Eigen::MatrixX3i F = boundaryFaces(m);
  for (Eigen::Index f = 0; f < F.rows(); ++f)
    for (int k = 0; k < 3; ++k) fixed[static_cast<size_t>(F(f, k))] = true;
  double edge = 0;
  for (Eigen::Index t = 0; t < m.T.rows(); ++t) edge += (m.V.row(m.T(t, 0)) - m.V.row(m.T(t, 1))).norm();
  edge /= static_cast<double>(m.T.rows());
  Eigen::MatrixX3d U = m.V;
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> u(-1, 1);
  for (Eigen::Index v = 0; v < U.rows(); ++v)
    if (!fixed[static_cast<size_t>(v)] && v % 7 == 0) U.row(v) += 0.8 * edge * Eigen::RowVector3d(u(rng), u(rng), u(rng));
  ASSERT_GT(countNonPositiveTets(U, m.T), 20);
  const UntangleResult simd = untangle(m.V, m.T, U, fixed, UntangleOptions());
  UntangleResult scalar;
  {
    SimdSetting off("0");
    ASSERT_EQ(detail::simdUntangleKernel(), nullptr);
    scalar = untangle(m.V, m.T, U, fixed, UntangleOptions());
  }
  ASSERT_TRUE(simd.status.ok) << simd.status.message;
  EXPECT_EQ(simd.invertedAfter, 0);
  EXPECT_GT(simd.lbfgsIterations, 0);
  EXPECT_EQ(simd.lbfgsIterations, scalar.lbfgsIterations);
  EXPECT_EQ(simd.outerIterations, scalar.outerIterations);
  ASSERT_EQ(simd.U.rows(), scalar.U.rows());
  for (Eigen::Index i = 0; i < simd.U.size(); ++i)
    ASSERT_TRUE(sameBits(simd.U.data()[i], scalar.U.data()[i])) << "coordinate " << i;
}

// The gradient's parts (param/src/part_gradients.h): every free vertex gets
// the sum of its corners' terms over all the tets, whichever parts they fall
// in, and held vertices' corners count nowhere. Tets of a real mesh in a
// shuffled order, so that a vertex's tets fall in several parts.
TEST(PartGradients, EveryFreeVertexGetsTheSumOfItsCornersTerms) {
  const TetMesh m = tetrahedralize(readSurface(t2stest::cgalMesh("blobby")), {}, "blobby");
  const Eigen::Index nv = m.V.rows(), nt = m.T.rows();
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> u(-1, 1);
  std::vector<size_t> order(static_cast<size_t>(nt));
  std::iota(order.begin(), order.end(), size_t{0});
  std::shuffle(order.begin(), order.end(), rng);
  std::vector<std::array<int, 4>> vertices(order.size());
  for (size_t a = 0; a < order.size(); ++a)
    for (int k = 0; k < 4; ++k) vertices[a][k] = m.T(static_cast<Eigen::Index>(order[a]), k);
  std::vector<int> freeIndex(static_cast<size_t>(nv), -1);
  const Eigen::MatrixX3i F = boundaryFaces(m);
  std::vector<char> held(static_cast<size_t>(nv), 0);
  for (Eigen::Index f = 0; f < F.rows(); ++f)
    for (int k = 0; k < 3; ++k) held[static_cast<size_t>(F(f, k))] = 1;
  int numFree = 0;
  for (Eigen::Index v = 0; v < nv; ++v)
    if (!held[static_cast<size_t>(v)]) freeIndex[static_cast<size_t>(v)] = numFree++;
  detail::PartGradients parts(vertices, freeIndex, static_cast<size_t>(numFree));
  ASSERT_GT(parts.parts(), 2u);
  // Rows touched by several parts: more rows than free vertices plus sinks.
  EXPECT_GT(parts.numRows(), static_cast<size_t>(numFree) + parts.parts());
  std::vector<Eigen::Vector3d> expected(static_cast<size_t>(nv), Eigen::Vector3d::Zero());
  std::vector<double> scale(static_cast<size_t>(nv), 0.0);
  for (size_t p = 0; p < parts.parts(); ++p) parts.zero(p);
  for (size_t a = 0; a < vertices.size(); ++a) {
    Eigen::Matrix3d A;
    Eigen::Matrix<double, 3, 4> G;
    for (int i = 0; i < 9; ++i) A.data()[i] = u(rng);
    for (int i = 0; i < 12; ++i) G.data()[i] = u(rng);
    const double w = 1 + u(rng);
    parts.addProduct(a, w, A, G);
    const Eigen::Matrix<double, 3, 4> terms = (w * A) * G;
    for (int k = 0; k < 4; ++k) {
      expected[static_cast<size_t>(vertices[a][k])] += terms.col(k);
      scale[static_cast<size_t>(vertices[a][k])] += terms.col(k).norm();
    }
  }
  for (Eigen::Index v = 0; v < nv; ++v) {
    const int f = freeIndex[static_cast<size_t>(v)];
    if (f < 0) continue;
    Eigen::Vector3d s = Eigen::Vector3d::Zero();
    parts.addTo(static_cast<size_t>(f), s);
    ASSERT_LE((s - expected[static_cast<size_t>(v)]).norm(), 1e-13 * scale[static_cast<size_t>(v)]) << "vertex " << v;
  }
  // Each part zeroes its own rows only.
  const size_t stride = detail::PartGradients::kStride;
  std::fill(parts.data(), parts.data() + stride * parts.numRows(), 1.0);
  parts.zero(1);
  const long zeros = std::count(parts.data(), parts.data() + stride * parts.numRows(), 0.0);
  EXPECT_GT(zeros, 0);
  EXPECT_LT(static_cast<size_t>(zeros), stride * parts.numRows() / 2);
  for (int k = 0; k < 4; ++k)
    EXPECT_EQ(parts.data()[stride * static_cast<size_t>(parts.rows()[4 * parts.partBegin(1) + static_cast<size_t>(k)])], 0.0);
}

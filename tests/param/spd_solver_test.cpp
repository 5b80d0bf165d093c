// The internal sparse Cholesky wrapper's refactorisation: a solver that keeps
// CHOLMOD's symbolic analysis and factorises a new matrix of the same pattern
// must give the same bits as a fresh factorisation of that matrix (the
// spherical map's area correction relies on it to stay bitwise what it was),
// and must fall back to a fresh one when the pattern's size differs.
// Also the per-corner gradient terms (CornerTerms) the barrier morph sums,
// and CHOLMOD's OpenMP teams run on the calling thread
// (tet2spline/param/openmp_threads.h).
#include "../../param/src/spd_solver.h"

#include <dlfcn.h>
#include <gtest/gtest.h>
#include <tet2spline/param/openmp_threads.h>

#include <algorithm>
#include <cmath>
#include <random>
#include <string>
#include <thread>
#include <vector>

#include "test_data.h"
#include "tet2spline/io/mesh_io.h"
#include "tet2spline/param/harmonic_map.h"
#include "tet2spline/param/tetrahedralize.h"
#include "tet2spline/param/topology.h"

using namespace tet2spline;

namespace {

// The block of the cotangent stiffness over the vertices not on the boundary
// (symmetric positive definite).
Eigen::SparseMatrix<double> interiorBlock(const Eigen::MatrixX3d& V, const TetMesh& m) {
  const Eigen::SparseMatrix<double> L = cotangentStiffness(V, m.T);
  std::vector<int> index(static_cast<size_t>(V.rows()), 0);
  const Eigen::MatrixX3i F = boundaryFaces(m);
  for (Eigen::Index f = 0; f < F.rows(); ++f)
    for (int k = 0; k < 3; ++k) index[static_cast<size_t>(F(f, k))] = -1;
  int n = 0;
  for (auto& i : index)
    if (i == 0) i = n++;
  std::vector<Eigen::Triplet<double>> entries;
  for (Eigen::Index j = 0; j < L.outerSize(); ++j)
    for (Eigen::SparseMatrix<double>::InnerIterator it(L, j); it; ++it)
      if (index[static_cast<size_t>(it.row())] >= 0 && index[static_cast<size_t>(j)] >= 0)
        entries.emplace_back(index[static_cast<size_t>(it.row())], index[static_cast<size_t>(j)], it.value());
  Eigen::SparseMatrix<double> A(n, n);
  A.setFromTriplets(entries.begin(), entries.end());
  return A;
}

}  // namespace

TEST(SpdSolver, RefactorizingTheSamePatternGivesTheBitsOfAFreshFactorisation) {
  const TetMesh m = tetrahedralize(readSurface(t2stest::cgalMesh("blobby")), {}, "blobby");
  // Two geometries of the same tets (the second sheared and stretched, so
  // the cotangent weights change): the same pattern, other values.
  Eigen::Matrix3d M;
  M << 1.3, 0.2, 0.0, 0.0, 0.8, 0.1, 0.0, 0.0, 1.1;
  const Eigen::MatrixX3d moved = m.V * M;
  ASSERT_EQ(countNonPositiveTets(moved, m.T), 0);
  const Eigen::SparseMatrix<double> A = interiorBlock(m.V, m), B = interiorBlock(moved, m);
  ASSERT_GT(A.rows(), 1000);
  ASSERT_EQ(A.nonZeros(), B.nonZeros());
  ASSERT_GT((A - B).norm(), 0.0);
  Eigen::MatrixXd rhs = Eigen::MatrixXd::Random(A.rows(), 3);

  detail::SpdSolver reused, fresh;
  ASSERT_TRUE(reused.compute(A));
  ASSERT_TRUE(reused.refactorize(B));
  ASSERT_TRUE(fresh.compute(B));
  EXPECT_EQ(reused.name(), "cholmod");
  const Eigen::MatrixXd x = reused.solve(rhs), y = fresh.solve(rhs);
  EXPECT_EQ((x - y).cwiseAbs().maxCoeff(), 0.0);
  EXPECT_LT((B * x - rhs).norm(), 1e-8 * rhs.norm());

  // Back to A: still A's solution, not B's.
  ASSERT_TRUE(reused.refactorize(A));
  EXPECT_LT((A * reused.solve(rhs) - rhs).norm(), 1e-8 * rhs.norm());

  // Without an analysis, or for a matrix of another size, it factorises afresh.
  detail::SpdSolver first;
  ASSERT_TRUE(first.refactorize(B));
  EXPECT_EQ((first.solve(rhs) - y).cwiseAbs().maxCoeff(), 0.0);
  const Eigen::SparseMatrix<double> smaller = B.topLeftCorner(B.rows() / 2, B.cols() / 2);
  ASSERT_TRUE(reused.refactorize(smaller));
  const Eigen::MatrixXd r = rhs.topRows(smaller.rows());
  EXPECT_LT((smaller * reused.solve(r) - r).norm(), 1e-8 * r.norm());
}

// With CHOLMOD's OpenMP regions on the calling thread, the supernodal factor
// is the same bits as with its default teams (the maps may not change), and
// the setting holds for the calling thread only (so the library makes it in
// whichever thread factorises).
TEST(SpdSolver, OpenMpRegionsOnTheCallingThreadGiveTheSameFactor) {
  using GetLevels = int (*)();
  const auto maxActiveLevels = reinterpret_cast<GetLevels>(dlsym(RTLD_DEFAULT, "omp_get_max_active_levels"));
  ASSERT_NE(maxActiveLevels, nullptr) << "CHOLMOD's OpenMP runtime is not loaded";
  const TetMesh m = tetrahedralize(readSurface(t2stest::cgalMesh("blobby")), {}, "blobby");
  const Eigen::SparseMatrix<double> A = interiorBlock(m.V, m);
  ASSERT_GT(A.rows(), 1000);
  const Eigen::MatrixXd rhs = Eigen::MatrixXd::Random(A.rows(), 2);
  // Each solve in a thread of its own, so that neither inherits the other's setting.
  auto solveIn = [&](bool serial, int& levels) {
    Eigen::MatrixXd x;
    std::thread worker([&] {
      if (serial) {
        EXPECT_TRUE(runOpenMpRegionsOnCallingThread());
      }
      levels = maxActiveLevels();
      Eigen::CholmodSupernodalLLT<Eigen::SparseMatrix<double>> llt;
      llt.compute(A);
      ASSERT_EQ(llt.info(), Eigen::Success);
      x = llt.solve(rhs);
    });
    worker.join();
    return x;
  };
  int teamLevels = -1, serialLevels = -1;
  const Eigen::MatrixXd teams = solveIn(false, teamLevels), serial = solveIn(true, serialLevels);
  EXPECT_GT(teamLevels, 0);  // a fresh thread keeps the runtime's default
  EXPECT_EQ(serialLevels, 0);
  ASSERT_EQ(teams.rows(), A.rows());
  EXPECT_EQ((teams - serial).cwiseAbs().maxCoeff(), 0.0);
  EXPECT_LT((A * serial - rhs).norm(), 1e-8 * rhs.norm());
}

// A matrix that is not positive definite: CHOLMOD fails, the LDLT fallback
// solves, and the library prints nothing (CHOLMOD's default is a warning line
// per failed factorisation on the terminal: the morph printed dozens).
TEST(SpdSolver, FallsBackSilentlyWhenTheMatrixIsNotPositiveDefinite) {
  const TetMesh m = tetrahedralize(readSurface(t2stest::cgalMesh("blobby")), {}, "blobby");
  const Eigen::SparseMatrix<double> A = -interiorBlock(m.V, m);  // negative definite
  const Eigen::MatrixXd rhs = Eigen::MatrixXd::Random(A.rows(), 2);
  testing::internal::CaptureStdout();
  testing::internal::CaptureStderr();
  detail::SpdSolver solver;
  const bool ok = solver.compute(A);
  const bool again = solver.refactorize(A);
  const std::string out = testing::internal::GetCapturedStdout(), err = testing::internal::GetCapturedStderr();
  EXPECT_EQ(out, "");
  EXPECT_EQ(err, "");
  ASSERT_TRUE(ok);
  ASSERT_TRUE(again);
  EXPECT_EQ(solver.name(), "simplicial_ldlt (cholmod failed)");
  EXPECT_LT((A * solver.solve(rhs) - rhs).norm(), 1e-8 * rhs.norm());
}

// Per-corner terms: every vertex's sum is, to rounding, the plain sum of
// w·A·G's column k over the vertex's corners.
TEST(CornerTerms, EveryVertexGetsTheSumOfItsCornersTerms) {
  const TetMesh m = tetrahedralize(readSurface(t2stest::cgalMesh("blobby")), {}, "blobby");
  const Eigen::Index nv = m.V.rows(), nt = m.T.rows();
  ASSERT_GT(nt, 1000);
  const detail::VertexTets vt = detail::vertexTets(nv, m.T);
  std::mt19937 rng(7);
  detail::CornerTerms inOrder(vt);
  // Terms of mixed magnitudes, so that the order of a sum shows in its bits.
  std::uniform_real_distribution<double> u(-1, 1);
  std::vector<Eigen::Matrix3d> A(static_cast<size_t>(nt));
  std::vector<Eigen::Matrix<double, 3, 4>> G(static_cast<size_t>(nt));
  std::vector<double> w(static_cast<size_t>(nt));
  for (Eigen::Index t = 0; t < nt; ++t) {
    const size_t s = static_cast<size_t>(t);
    for (int i = 0; i < 9; ++i) A[s].data()[i] = u(rng) * std::pow(10.0, 8 * u(rng));
    for (int i = 0; i < 12; ++i) G[s].data()[i] = u(rng);
    w[s] = 1 + u(rng);
    inOrder.setProduct(static_cast<int>(t), w[s], A[s], G[s]);
  }
  for (Eigen::Index v = 0; v < nv; ++v) {
    Eigen::Vector3d a = Eigen::Vector3d::Zero(), plain = Eigen::Vector3d::Zero();
    inOrder.addTo(static_cast<int>(v), a);
    double magnitude = 0;
    for (int e = vt.offset[static_cast<size_t>(v)]; e < vt.offset[static_cast<size_t>(v) + 1]; ++e) {
      const size_t t = static_cast<size_t>(vt.corner[static_cast<size_t>(e)] / 4);
      const int k = vt.corner[static_cast<size_t>(e)] % 4;
      const Eigen::Vector3d term = w[t] * A[t] * G[t].col(k);
      plain += term;
      magnitude += (w[t] * A[t]).cwiseAbs().maxCoeff() * G[t].col(k).cwiseAbs().sum();
    }
    ASSERT_LE((a - plain).cwiseAbs().maxCoeff(), 1e-14 * magnitude) << "vertex " << v;
  }
}

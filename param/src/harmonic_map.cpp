// Volumetric harmonic map: P1 stiffness assembly and one Dirichlet solve.
#include "tet2spline/param/harmonic_map.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <atomic>
#include <cmath>
#include <chrono>
#include <sstream>

#include "harmonic_system.h"
#include "spd_solver.h"

namespace tet2spline {

namespace {

double secondsSince(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

// Local edge k of a tet joins corners kEdge[k][0], kEdge[k][1].
constexpr int kEdge[6][2] = {{0, 1}, {0, 2}, {0, 3}, {1, 2}, {1, 3}, {2, 3}};

int edgeIndex(int a, int b) {
  if (a > b) std::swap(a, b);
  for (int k = 0; k < 6; ++k)
    if (kEdge[k][0] == a && kEdge[k][1] == b) return k;
  return -1;
}

}  // namespace

Eigen::SparseMatrix<double> cotangentStiffness(const Eigen::MatrixX3d& V, const Eigen::MatrixX4i& T) {
  const Eigen::Index nv = V.rows(), nt = T.rows();
  if (nt > 0 && (T.minCoeff() < 0 || T.maxCoeff() >= nv))
    throw Error(ErrorKind::Input, "cotangentStiffness: tet vertex index out of range [0, " +
                                      std::to_string(nv) + ")");
  // Per tet, the six edge weights w_ij = −vol ∇φ_i·∇φ_j = −(n_i·n_j)/(9 vol),
  // with n_i the area vector of the face opposite i (outward, |n_i| = area).
  std::vector<double> w(static_cast<size_t>(nt) * 6);
  std::atomic<Eigen::Index> firstFlat{nt};  // lowest index of a non-positive tet, nt if none
  tbb::parallel_for(tbb::blocked_range<Eigen::Index>(0, nt, 2048), [&](const tbb::blocked_range<Eigen::Index>& r) {
    for (Eigen::Index t = r.begin(); t != r.end(); ++t) {
      const Eigen::Vector3d a = V.row(T(t, 0)), b = V.row(T(t, 1)), c = V.row(T(t, 2)), d = V.row(T(t, 3));
      const double vol = (b - a).cross(c - a).dot(d - a) / 6.0;
      if (!(vol > 0)) {
        Eigen::Index seen = firstFlat.load();
        while (t < seen && !firstFlat.compare_exchange_weak(seen, t)) {
        }
        continue;
      }
      Eigen::Vector3d n[4];
      n[0] = 0.5 * (d - b).cross(c - b);
      n[1] = 0.5 * (c - a).cross(d - a);
      n[2] = 0.5 * (d - a).cross(b - a);
      n[3] = 0.5 * (b - a).cross(c - a);
      for (int k = 0; k < 6; ++k)
        w[static_cast<size_t>(6 * t + k)] = -n[kEdge[k][0]].dot(n[kEdge[k][1]]) / (9.0 * vol);
    }
  });
  if (firstFlat.load() < nt) {
    std::ostringstream s;
    s << "cotangentStiffness: tet " << firstFlat.load() << " has non-positive volume";
    throw Error(ErrorKind::Input, s.str());
  }

  // Row by row (parallel over vertices, tets in increasing order so that
  // (i,j) and (j,i) add the same numbers in the same order: exact symmetry).
  const detail::VertexTets vt = detail::vertexTets(nv, T);
  std::vector<std::vector<std::pair<int, double>>> rows(static_cast<size_t>(nv));
  tbb::parallel_for(tbb::blocked_range<Eigen::Index>(0, nv, 1024), [&](const tbb::blocked_range<Eigen::Index>& r) {
    std::vector<std::pair<int, double>> entries;
    for (Eigen::Index i = r.begin(); i != r.end(); ++i) {
      entries.clear();
      for (int e = vt.offset[i]; e < vt.offset[i + 1]; ++e) {
        const int t = vt.corner[e] / 4, k = vt.corner[e] % 4;
        for (int m = 0; m < 4; ++m)
          if (m != k) entries.emplace_back(T(t, m), w[static_cast<size_t>(6 * t + edgeIndex(k, m))]);
      }
      std::stable_sort(entries.begin(), entries.end(),
                       [](const auto& x, const auto& y) { return x.first < y.first; });
      auto& row = rows[static_cast<size_t>(i)];
      double diagonal = 0;
      for (size_t e = 0; e < entries.size();) {
        double sum = 0;
        const int j = entries[e].first;
        for (; e < entries.size() && entries[e].first == j; ++e) sum += entries[e].second;
        row.emplace_back(j, -sum);
        diagonal += sum;
      }
      row.emplace_back(static_cast<int>(i), diagonal);
      std::inplace_merge(row.begin(), row.end() - 1, row.end(),
                         [](const auto& x, const auto& y) { return x.first < y.first; });
    }
  });
  // Symmetric, so the rows are the columns of the compressed column matrix.
  Eigen::SparseMatrix<double> L(nv, nv);
  Eigen::Index nnz = 0;
  for (const auto& row : rows) nnz += static_cast<Eigen::Index>(row.size());
  L.resizeNonZeros(nnz);
  Eigen::Index p = 0;
  for (Eigen::Index i = 0; i < nv; ++i) {
    L.outerIndexPtr()[i] = static_cast<int>(p);
    for (const auto& [j, value] : rows[static_cast<size_t>(i)]) {
      L.innerIndexPtr()[p] = j;
      L.valuePtr()[p] = value;
      ++p;
    }
  }
  L.outerIndexPtr()[nv] = static_cast<int>(p);
  return L;
}

namespace detail {

HarmonicSystem::HarmonicSystem(const Eigen::MatrixX3d& V, const Eigen::MatrixX4i& T, const Eigen::VectorXi& fixedVertices,
                               const HarmonicMapOptions& options)
    : nv_(V.rows()), fixedVertices_(fixedVertices), freeIndex_(static_cast<size_t>(V.rows()), 0), options_(options) {
  for (Eigen::Index b = 0; b < fixedVertices.size(); ++b) {
    const int i = fixedVertices[b];
    if (i < 0 || i >= nv_) throw Error(ErrorKind::Input, "harmonicMap: fixed vertex " + std::to_string(i) + " out of range");
    if (freeIndex_[static_cast<size_t>(i)] < 0)
      throw Error(ErrorKind::Input, "harmonicMap: fixed vertex " + std::to_string(i) + " listed twice");
    freeIndex_[static_cast<size_t>(i)] = -1;
  }
  for (auto& f : freeIndex_)
    if (f == 0) f = numFree_++;

  HarmonicMapResult& result = prepared_;
  auto stopped = [&](double fraction, const std::string& what) {
    if (options_.progress && !options_.progress(fraction, what)) {
      result.status = Status::failure("harmonicMap: stopped by the progress callback after " + what);
      return true;
    }
    return false;
  };
  auto t0 = std::chrono::steady_clock::now();
  L_ = cotangentStiffness(V, T);
  // L_II (free × free); the right-hand side −L_IB U_B comes with the positions (solve).
  std::vector<Eigen::Triplet<double>> entries;
  entries.reserve(static_cast<size_t>(L_.nonZeros()));
  for (Eigen::Index j = 0; j < nv_; ++j) {
    const int fj = freeIndex_[static_cast<size_t>(j)];
    if (fj < 0) continue;
    for (Eigen::SparseMatrix<double>::InnerIterator it(L_, j); it; ++it) {
      const int fi = freeIndex_[static_cast<size_t>(it.row())];
      if (fi >= 0) entries.emplace_back(fi, fj, it.value());
    }
  }
  Eigen::SparseMatrix<double> Lii(numFree_, numFree_);
  Lii.setFromTriplets(entries.begin(), entries.end());
  entries = {};
  result.assemblySeconds = secondsSince(t0);
  if (stopped(0.3, "assembly")) return;

  t0 = std::chrono::steady_clock::now();
  const bool factored = numFree_ == 0 || solver_.compute(Lii);
  result.solver = numFree_ == 0 ? "none (no free vertex)" : solver_.name();
  result.factorizationSeconds = secondsSince(t0);
  if (!factored) {
    result.status = Status::failure("harmonicMap: the stiffness of the free vertices could not be factorised (" +
                                    std::to_string(numFree_) + " free vertices; is every component anchored?)");
    return;
  }
  stopped(0.8, "factorisation");
}

HarmonicMapResult HarmonicSystem::solve(const Eigen::MatrixX3d& fixedPositions) const {
  if (fixedPositions.rows() != fixedVertices_.size())
    throw Error(ErrorKind::Input, "harmonicMap: " + std::to_string(fixedVertices_.size()) +
                                      " fixed vertices but " + std::to_string(fixedPositions.rows()) +
                                      " fixed positions");
  HarmonicMapResult result = prepared_;
  result.U.resize(nv_, 3);
  for (Eigen::Index b = 0; b < fixedVertices_.size(); ++b) result.U.row(fixedVertices_[b]) = fixedPositions.row(b);
  if (!result.status.ok) return result;
  // −L_IB U_B, column by column in L's order (each row's terms in the order
  // in which the one-pass split of L subtracted them: the same bits).
  auto t0 = std::chrono::steady_clock::now();
  Eigen::MatrixX3d rhs = Eigen::MatrixX3d::Zero(numFree_, 3);
  for (Eigen::Index j = 0; j < nv_; ++j) {
    if (freeIndex_[static_cast<size_t>(j)] >= 0) continue;
    for (Eigen::SparseMatrix<double>::InnerIterator it(L_, j); it; ++it) {
      const int fi = freeIndex_[static_cast<size_t>(it.row())];
      if (fi >= 0) rhs.row(fi) -= it.value() * result.U.row(j);
    }
  }
  if (numFree_ > 0) {
    const Eigen::MatrixXd X = solver_.solve(rhs);
    for (Eigen::Index i = 0; i < nv_; ++i)
      if (freeIndex_[static_cast<size_t>(i)] >= 0) result.U.row(i) = X.row(freeIndex_[static_cast<size_t>(i)]);
  }
  result.solveSeconds = secondsSince(t0);
  // Residual over the free rows, with the full L (not the split pieces).
  const Eigen::MatrixX3d LU = L_ * result.U;
  double r2 = 0;
  for (Eigen::Index i = 0; i < nv_; ++i)
    if (freeIndex_[static_cast<size_t>(i)] >= 0) r2 += LU.row(i).squaredNorm();
  const double b2 = rhs.squaredNorm();
  result.relativeResidual = std::sqrt(r2) / (b2 > 0 ? std::sqrt(b2) : 1.0);
  if (!std::isfinite(result.relativeResidual))
    result.status = Status::failure("harmonicMap: the solve produced non-finite positions");
  if (options_.progress && !options_.progress(1.0, "solve"))
    result.status = Status::failure("harmonicMap: stopped by the progress callback after solve");
  return result;
}

}  // namespace detail

HarmonicMapResult harmonicMap(const Eigen::MatrixX3d& V, const Eigen::MatrixX4i& T,
                              const Eigen::VectorXi& fixedVertices, const Eigen::MatrixX3d& fixedPositions,
                              const HarmonicMapOptions& options) {
  if (fixedPositions.rows() != fixedVertices.size())
    throw Error(ErrorKind::Input, "harmonicMap: " + std::to_string(fixedVertices.size()) +
                                      " fixed vertices but " + std::to_string(fixedPositions.rows()) +
                                      " fixed positions");
  return detail::HarmonicSystem(V, T, fixedVertices, options).solve(fixedPositions);
}

}  // namespace tet2spline

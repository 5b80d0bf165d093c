#pragma once
// Internal: one sparse Cholesky factorisation reused for several right-hand
// sides. CHOLMOD (supernodal when it pays off) first; Eigen's SimplicialLDLT
// only when CHOLMOD reports a failure, and the caller is told which one ran.
#include <Eigen/CholmodSupport>
#include <Eigen/SparseCholesky>
#include <Eigen/SparseCore>
#include <tet2spline/param/openmp_threads.h>
#include <array>
#include <memory>
#include <string>
#include <vector>

#include "untangle_energy.h"

namespace tet2spline::detail {

class SpdSolver {
 public:
  /// Factorises the symmetric positive definite A; false if both solvers fail.
  bool compute(const Eigen::SparseMatrix<double>& A) {
    runOpenMpRegionsOnCallingThread();  // (CHOLMOD's teams of four: openmp_threads.h)
    cholmod_ = std::make_unique<Eigen::CholmodDecomposition<Eigen::SparseMatrix<double>>>();
    cholmod_->cholmod().print = 0;  // library code prints nothing: a failure falls back, then reports
    cholmod_->compute(A);
    if (cholmod_->info() == Eigen::Success) {
      name_ = "cholmod";
      return true;
    }
    cholmod_.reset();
    ldlt_ = std::make_unique<Eigen::SimplicialLDLT<Eigen::SparseMatrix<double>>>();
    ldlt_->compute(A);
    name_ = "simplicial_ldlt (cholmod failed)";
    return ldlt_->info() == Eigen::Success;
  }
  /// Factorises A, which must have the sparsity pattern of the matrix the
  /// last successful CHOLMOD factorisation had: CHOLMOD's symbolic analysis
  /// (fill-reducing ordering, supernodes) is reused, and the factor is the
  /// same bits as compute(A) would give. Falls back to compute(A) when there
  /// is no such analysis or the numeric factorisation fails.
  bool refactorize(const Eigen::SparseMatrix<double>& A) {
    if (!cholmod_ || cholmod_->rows() != A.rows()) return compute(A);
    runOpenMpRegionsOnCallingThread();
    cholmod_->factorize(A);
    if (cholmod_->info() == Eigen::Success) return true;
    return compute(A);
  }
  Eigen::MatrixXd solve(const Eigen::MatrixXd& b) const {
    if (cholmod_) return cholmod_->solve(b);
    return ldlt_->solve(b);
  }
  /// "cholmod", or "simplicial_ldlt (cholmod failed)".
  const std::string& name() const { return name_; }

 private:
  std::unique_ptr<Eigen::CholmodDecomposition<Eigen::SparseMatrix<double>>> cholmod_;
  std::unique_ptr<Eigen::SimplicialLDLT<Eigen::SparseMatrix<double>>> ldlt_;
  std::string name_;
};

/// Tets around each vertex, as CSR: entries offset[v] .. offset[v+1] of
/// `corner` hold 4·t + k with T(t,k) == v, in increasing t.
struct VertexTets {
  std::vector<int> offset;
  std::vector<int> corner;
};

inline VertexTets vertexTets(Eigen::Index numVertices, const Eigen::MatrixX4i& T) {
  VertexTets vt;
  vt.offset.assign(static_cast<size_t>(numVertices) + 1, 0);
  for (Eigen::Index t = 0; t < T.rows(); ++t)
    for (int k = 0; k < 4; ++k) ++vt.offset[static_cast<size_t>(T(t, k)) + 1];
  for (size_t v = 0; v + 1 < vt.offset.size(); ++v) vt.offset[v + 1] += vt.offset[v];
  vt.corner.resize(static_cast<size_t>(T.rows()) * 4);
  std::vector<int> fill(vt.offset.begin(), vt.offset.end() - 1);
  for (Eigen::Index t = 0; t < T.rows(); ++t)
    for (int k = 0; k < 4; ++k) vt.corner[static_cast<size_t>(fill[T(t, k)]++)] = static_cast<int>(4 * t + k);
  return vt;
}

/// Per-corner terms of a sum over each vertex's tets (a gradient): a per-tet
/// loop sets the four terms of tet t, and a per-vertex loop adds those of
/// vertex v in vt's order. The terms are stored at the corners' places in
/// vt.corner, so each vertex's are contiguous and read in sequence.
/// Measured on homer's cube parameterization: gathering the 3 × 4 per-tet
/// gradients through a tet index took 26% of the run's samples; storing
/// them per corner took the final untangling from 44.0 and 42.5 s to 32.7
/// and 36.1 s (two runs each), and bunny00's from 298 s to 238 s, with
/// bitwise the same maps. (The untangler has since moved to summing part by
/// part, part_gradients.h, which halved its time per tet on bunny00; the
/// barrier morph still sums through these slots.)
class CornerTerms {
 public:
  explicit CornerTerms(const VertexTets& vt)
      : vt_(vt), slot_(vt.corner.size()), term_(vt.corner.size()) {
    for (size_t e = 0; e < vt.corner.size(); ++e) slot_[static_cast<size_t>(vt.corner[e])] = static_cast<int>(e);
  }
  /// The terms of tet t's corners: column k of (w·A)·G (cornerTerms,
  /// untangle_energy.h), written straight into their slots.
  void setProduct(int t, double w, const Eigen::Matrix3d& A, const Eigen::Matrix<double, 3, 4>& G) {
    double term[4][3];
    cornerTerms(w, A, G, term);
    for (int k = 0; k < 4; ++k)
      term_[static_cast<size_t>(slot_[4 * static_cast<size_t>(t) + static_cast<size_t>(k)])] =
          Eigen::Vector3d(term[k][0], term[k][1], term[k][2]);
  }
  /// Adds vertex v's terms to s, in vt's order (every tet of v must be set).
  void addTo(int v, Eigen::Vector3d& s) const {
    for (int e = vt_.offset[static_cast<size_t>(v)]; e < vt_.offset[static_cast<size_t>(v) + 1]; ++e)
      s += term_[static_cast<size_t>(e)];
  }

 private:
  const VertexTets& vt_;
  std::vector<int> slot_;  // slot_[4t + k] = e with vt.corner[e] = 4t + k
  std::vector<Eigen::Vector3d> term_;
};

}  // namespace tet2spline::detail

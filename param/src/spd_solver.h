#pragma once
// Internal: one sparse Cholesky factorisation reused for several right-hand
// sides. CHOLMOD (supernodal when it pays off) first; Eigen's SimplicialLDLT
// only when CHOLMOD reports a failure, and the caller is told which one ran.
#include <Eigen/CholmodSupport>
#include <Eigen/SparseCholesky>
#include <Eigen/SparseCore>
#include <array>
#include <memory>
#include <string>
#include <vector>

namespace tet2spline::detail {

class SpdSolver {
 public:
  /// Factorises the symmetric positive definite A; false if both solvers fail.
  bool compute(const Eigen::SparseMatrix<double>& A) {
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
      : vt_(vt), start_(vt.offset), slot_(vt.corner.size()), term_(vt.corner.size()) {
    for (size_t e = 0; e < vt.corner.size(); ++e) slot_[static_cast<size_t>(vt.corner[e])] = static_cast<int>(e);
  }
  /// The same sums, with the vertices' blocks of terms stored in the order
  /// of storageRank (a permutation of the vertices: vertex v's block is the
  /// storageRank[v]-th), each block still in vt's order. A spatial rank puts
  /// the four corners of a tet near each other in memory; the terms and the
  /// order in which addTo adds them are the same as with the first
  /// constructor, so the results are bitwise the same.
  CornerTerms(const VertexTets& vt, const std::vector<int>& storageRank)
      : vt_(vt), start_(vt.offset.size() - 1), slot_(vt.corner.size()), term_(vt.corner.size()) {
    const size_t nv = start_.size();
    std::vector<int> byRank(nv);
    for (size_t v = 0; v < nv; ++v) byRank[static_cast<size_t>(storageRank[v])] = static_cast<int>(v);
    int next = 0;
    for (int v : byRank) {
      start_[static_cast<size_t>(v)] = next;
      next += vt.offset[static_cast<size_t>(v) + 1] - vt.offset[static_cast<size_t>(v)];
    }
    for (size_t v = 0; v < nv; ++v)
      for (int e = vt.offset[v]; e < vt.offset[v + 1]; ++e)
        slot_[static_cast<size_t>(vt.corner[static_cast<size_t>(e)])] = start_[v] + (e - vt.offset[v]);
  }
  /// The terms of tet t's corners: column k of (w·A)·G, written in scalars
  /// straight into their slots. The profile of the untangling showed Eigen's
  /// 3 × 4 product, stored as packets and reloaded across them as columns,
  /// stalling on store forwarding (homer's final untangling, cube: 30.6 ->
  /// 29.2 s). The sums are in that product's order, so that the results
  /// stay bitwise the same: rows 0 and 1 as one packet, (x0 + x1) + x2,
  /// row 2 by its reduction, x0 + (x1 + x2).
  void setProduct(int t, double w, const Eigen::Matrix3d& A, const Eigen::Matrix<double, 3, 4>& G) {
    setProductAt(slots(t), w, A, G);
  }
  /// Tet t's corner slots, for setProductAt.
  std::array<int, 4> slots(int t) const {
    std::array<int, 4> s;
    for (int k = 0; k < 4; ++k) s[k] = slot_[4 * static_cast<size_t>(t) + k];
    return s;
  }
  /// setProduct with the tet's slots given (see slots).
  void setProductAt(const std::array<int, 4>& slots, double w, const Eigen::Matrix3d& A,
                    const Eigen::Matrix<double, 3, 4>& G) {
    double wa[3][3];
    for (int i = 0; i < 3; ++i)
      for (int l = 0; l < 3; ++l) wa[i][l] = w * A(i, l);
    for (int k = 0; k < 4; ++k) {
      double* out = term_[static_cast<size_t>(slots[k])].data();
      out[0] = (wa[0][0] * G(0, k) + wa[0][1] * G(1, k)) + wa[0][2] * G(2, k);
      out[1] = (wa[1][0] * G(0, k) + wa[1][1] * G(1, k)) + wa[1][2] * G(2, k);
      out[2] = wa[2][0] * G(0, k) + (wa[2][1] * G(1, k) + wa[2][2] * G(2, k));
    }
  }
  /// The terms' storage: 3 doubles per slot (for untangle_kernel.h's loop).
  double* termData() { return term_.empty() ? nullptr : term_.front().data(); }
  /// Asks the cache for the start of vertex v's terms (a loop over the
  /// vertices in another order than the storage's reads each block cold).
  void prefetch(int v) const { __builtin_prefetch(term_[static_cast<size_t>(start_[static_cast<size_t>(v)])].data()); }
  /// Adds vertex v's terms to s, in vt's order (every tet of v must be set).
  void addTo(int v, Eigen::Vector3d& s) const {
    const int first = start_[static_cast<size_t>(v)];
    const int count = vt_.offset[static_cast<size_t>(v) + 1] - vt_.offset[static_cast<size_t>(v)];
    for (int e = first; e < first + count; ++e) s += term_[static_cast<size_t>(e)];
  }

 private:
  const VertexTets& vt_;
  std::vector<int> start_;  // start_[v]: where vertex v's block of terms begins
  std::vector<int> slot_;  // slot_[4t + k] = e with vt.corner[e] = 4t + k
  std::vector<Eigen::Vector3d> term_;
};

}  // namespace tet2spline::detail

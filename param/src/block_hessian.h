#pragma once
// Internal: the Hessian of an energy summed over tets, in the unknowns of the
// free vertices (three per vertex), assembled into a fixed block pattern and
// factorised with CHOLMOD (the symbolic analysis once), for the projected
// Newton steps of the untangler (untangle.h) and the barrier morph
// (barrier_morph.h).
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <Eigen/CholmodSupport>
#include <tet2spline/param/openmp_threads.h>
#include <Eigen/IterativeLinearSolvers>
#include <Eigen/Dense>
#include <Eigen/SparseCore>
#include <algorithm>
#include <vector>

#include "spd_solver.h"
#include "untangle_energy.h"

namespace tet2spline::detail {

/// The 12 × 12 Hessian of a tet's energy in its four vertices' positions,
/// from its Hessian H9 in J = Σ_k W_k G_kᵀ (row-major vec of J; G the
/// barycentric gradients of the reference tet, one per column): block (i, i')
/// between vertices k, k' is Gᵀ H9(i,·; i',·) G.
inline Eigen::Matrix<double, 12, 12> vertexHessian(const Matrix9d& H9, const Eigen::Matrix<double, 3, 4>& G) {
  Eigen::Matrix<double, 12, 12> H12;
  for (int i = 0; i < 3; ++i)
    for (int i2 = 0; i2 < 3; ++i2) {
      const Eigen::Matrix4d B = G.transpose() * H9.block<3, 3>(3 * i, 3 * i2) * G;
      for (int k = 0; k < 4; ++k)
        for (int k2 = 0; k2 < 4; ++k2) H12(3 * k + i, 3 * k2 + i2) = B(k, k2);
    }
  return H12;
}

class BlockHessian {
 public:
  /// How descent() solves: CHOLMOD (exact Newton), or conjugate gradients with
  /// Jacobi preconditioning stopped early (truncated Newton; see
  /// barrier_morph.cpp for the measurements).
  enum class Solver { Cholmod, ConjugateGradient };

  /// freeVerts: the free vertices (unknown block k = inRegion[freeVerts[k]]);
  /// inRegion[v]: v's block or −1 (held); active: the tets of T with a free
  /// vertex, in the order tetHessian(a) is asked for below.
  BlockHessian(const Eigen::MatrixX4i& T, const VertexTets& vt, const std::vector<int>& freeVerts,
               const std::vector<int>& inRegion, const std::vector<int>& active, Solver solver = Solver::Cholmod,
               int cgIterations = 50, double cgTolerance = 1e-3)
      : T_(T), inRegion_(inRegion), active_(active), nFree_(freeVerts.size()), solver_(solver),
        cgIterations_(cgIterations), cgTolerance_(cgTolerance) {
    offset_.assign(nFree_ + 1, 0);
    std::vector<std::vector<int>> lists(nFree_);
    tbb::parallel_for(tbb::blocked_range<size_t>(0, nFree_, 512), [&](const tbb::blocked_range<size_t>& r) {
      for (size_t k = r.begin(); k != r.end(); ++k) {
        const int v = freeVerts[k];
        auto& l = lists[k];
        for (int e = vt.offset[static_cast<size_t>(v)]; e < vt.offset[static_cast<size_t>(v) + 1]; ++e)
          for (int j = 0; j < 4; ++j) {
            const int m = inRegion[static_cast<size_t>(T(vt.corner[static_cast<size_t>(e)] / 4, j))];
            if (m >= 0) l.push_back(m);
          }
        std::sort(l.begin(), l.end());
        l.erase(std::unique(l.begin(), l.end()), l.end());
      }
    });
    for (size_t k = 0; k < nFree_; ++k) offset_[k + 1] = offset_[k] + static_cast<int>(lists[k].size());
    nbr_.reserve(static_cast<size_t>(offset_.back()));
    for (auto& l : lists) nbr_.insert(nbr_.end(), l.begin(), l.end()), std::vector<int>().swap(l);
    colStart_.resize(nFree_ + 1);
    for (size_t k = 0; k <= nFree_; ++k) colStart_[k] = 9 * static_cast<Eigen::Index>(offset_[k]);
    const auto n = static_cast<Eigen::Index>(3 * nFree_);
    H_.resize(n, n);
    H_.resizeNonZeros(colStart_.back());
    for (size_t k = 0; k < nFree_; ++k) {
      const int deg = offset_[k + 1] - offset_[k];
      for (int c = 0; c < 3; ++c) {
        H_.outerIndexPtr()[3 * k + static_cast<size_t>(c)] = static_cast<int>(valueIndex(k, 0, 0, c));
        for (int p = 0; p < deg; ++p)
          for (int r = 0; r < 3; ++r)
            H_.innerIndexPtr()[valueIndex(k, p, r, c)] = 3 * nbr_[static_cast<size_t>(offset_[k] + p)] + r;
      }
    }
    H_.outerIndexPtr()[n] = static_cast<int>(colStart_.back());
    tetBlock_.assign(active.size() * 16, -1);
    tbb::parallel_for(tbb::blocked_range<size_t>(0, active.size(), 1024), [&](const tbb::blocked_range<size_t>& r) {
      for (size_t a = r.begin(); a != r.end(); ++a)
        for (int i = 0; i < 4; ++i)
          for (int j = 0; j < 4; ++j) {
            const int ki = inRegion[static_cast<size_t>(T(active[a], i))];
            const int kj = inRegion[static_cast<size_t>(T(active[a], j))];
            if (ki >= 0 && kj >= 0) tetBlock_[16 * a + static_cast<size_t>(4 * i + j)] = position(kj, ki);
          }
    });
    diagPos_.resize(nFree_);
    for (size_t k = 0; k < nFree_; ++k) diagPos_[k] = position(static_cast<int>(k), static_cast<int>(k));
    cholmod_.cholmod().print = 0;  // (a matrix that is not positive definite is retried, not printed)
    if (solver_ == Solver::Cholmod) cholmod_.analyzePattern(H_);
  }

  /// H = Σ_a Σ_{i,j} M_{k_i}ᵀ H12_a(i, j) M_{k_j} + Σ_k D_k on block (k, k):
  /// tetHessian(a) gives H12 of active tet a in its vertices' positions, M_k
  /// maps the unknowns of free vertex k to its position (the preconditioner
  /// and the sliding constraints), D_k is added as it is.
  template <class TetHessian>
  void assemble(TetHessian&& tetHessian, const std::vector<Eigen::Matrix3d>& M, const std::vector<Eigen::Matrix3d>& D) {
    double* values = H_.valuePtr();
    std::fill(values, values + H_.nonZeros(), 0.0);
    constexpr size_t kChunk = 1 << 15;
    blocks_.resize(std::min(kChunk, active_.size()) * 16);
    for (size_t from = 0; from < active_.size(); from += kChunk) {
      const size_t to = std::min(active_.size(), from + kChunk);
      tbb::parallel_for(tbb::blocked_range<size_t>(from, to, 256), [&](const tbb::blocked_range<size_t>& r) {
        for (size_t a = r.begin(); a != r.end(); ++a) {
          const int t = active_[a];
          const Eigen::Matrix<double, 12, 12> H12 = tetHessian(a);
          for (int i = 0; i < 4; ++i)
            for (int j = 0; j < 4; ++j) {
              const int ki = inRegion_[static_cast<size_t>(T_(t, i))], kj = inRegion_[static_cast<size_t>(T_(t, j))];
              if (ki < 0 || kj < 0) continue;
              blocks_[16 * (a - from) + static_cast<size_t>(4 * i + j)] =
                  M[static_cast<size_t>(ki)].transpose() * H12.block<3, 3>(3 * i, 3 * j) * M[static_cast<size_t>(kj)];
            }
        }
      });
      for (size_t a = from; a < to; ++a)  // scatter, sequentially (deterministic, no races)
        for (int i = 0; i < 4; ++i)
          for (int j = 0; j < 4; ++j) {
            const int p = tetBlock_[16 * a + static_cast<size_t>(4 * i + j)];
            if (p < 0) continue;
            const auto kj = static_cast<size_t>(inRegion_[static_cast<size_t>(T_(active_[a], j))]);
            const Eigen::Matrix3d& B = blocks_[16 * (a - from) + static_cast<size_t>(4 * i + j)];
            for (int c = 0; c < 3; ++c)
              for (int r = 0; r < 3; ++r) values[valueIndex(kj, p, r, c)] += B(r, c);
          }
    }
    for (size_t k = 0; k < nFree_; ++k)
      for (int c = 0; c < 3; ++c)
        for (int r = 0; r < 3; ++r) values[valueIndex(k, diagPos_[k], r, c)] += D[k](r, c);
  }

  /// d = −H⁻¹ g. Conjugate gradients: from d = 0, at most cgIterations or
  /// to a residual of cgTolerance relative to |g| (a descent direction
  /// whenever H is positive definite); false if not finite. CHOLMOD: a tiny
  /// diagonal shift first (10⁻¹⁰ of the largest diagonal
  /// entry), larger ones while the factorisation fails; false when even 10⁻¹
  /// of it fails (d untouched). Changes H's diagonal.
  bool descent(const Eigen::VectorXd& g, Eigen::VectorXd& d) {
    if (solver_ == Solver::ConjugateGradient) {
      Eigen::ConjugateGradient<Eigen::SparseMatrix<double>, Eigen::Lower | Eigen::Upper> cg;
      cg.setTolerance(cgTolerance_);
      cg.setMaxIterations(cgIterations_);
      cg.compute(H_);
      Eigen::VectorXd s = -cg.solve(g);
      if (!s.allFinite()) return false;
      d = std::move(s);
      return true;
    }
    const auto n = static_cast<Eigen::Index>(3 * nFree_);
    auto diag = [&](Eigen::Index i) -> double& {
      const auto k = static_cast<size_t>(i / 3);
      const int c = static_cast<int>(i % 3);
      return H_.valuePtr()[valueIndex(k, diagPos_[k], c, c)];
    };
    double maxDiag = 0;
    for (Eigen::Index i = 0; i < n; ++i) maxDiag = std::max(maxDiag, diag(i));
    runOpenMpRegionsOnCallingThread();  // (CHOLMOD's teams of four: openmp_threads.h)
    for (double shift = 1e-10 * maxDiag, added = 0; shift < 1e-1 * maxDiag; shift *= 1e3) {
      for (Eigen::Index i = 0; i < n; ++i) diag(i) += shift - added;
      added = shift;
      cholmod_.factorize(H_);
      if (cholmod_.info() != Eigen::Success) continue;
      Eigen::VectorXd s = -cholmod_.solve(g);
      if (cholmod_.info() == Eigen::Success && s.allFinite()) {
        d = std::move(s);
        return true;
      }
    }
    return false;
  }

 private:
  // Index in the value array of entry (r, c) of the block of column block k
  // at position p of its neighbour list.
  Eigen::Index valueIndex(size_t k, int p, int r, int c) const {
    return colStart_[k] + 3 * c * (offset_[k + 1] - offset_[k]) + 3 * p + r;
  }
  int position(int k, int m) const {  // of free vertex m in k's neighbour list
    const int* first = nbr_.data() + offset_[static_cast<size_t>(k)];
    const int* last = nbr_.data() + offset_[static_cast<size_t>(k) + 1];
    return static_cast<int>(std::lower_bound(first, last, m) - first);
  }

  const Eigen::MatrixX4i& T_;
  const std::vector<int>& inRegion_;
  const std::vector<int>& active_;
  size_t nFree_;
  Solver solver_;
  int cgIterations_;
  double cgTolerance_;
  std::vector<int> offset_, nbr_;       // free neighbours of each free vertex (itself included), sorted
  std::vector<Eigen::Index> colStart_;  // first value of block column k
  std::vector<int> tetBlock_;           // per active tet, 16 entries: position of block (i, j) in nbr, or −1
  std::vector<int> diagPos_;            // position of k in its own neighbour list
  std::vector<Eigen::Matrix3d> blocks_; // per-tet blocks of the chunk being assembled
  Eigen::SparseMatrix<double> H_;
  Eigen::CholmodDecomposition<Eigen::SparseMatrix<double>, Eigen::Lower> cholmod_;
};

}  // namespace tet2spline::detail

// Aggregation AMG preconditioner (aggregation_amg.h).
#include "aggregation_amg.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>

namespace tet2spline::detail {
namespace {

// Levels with fewer rows run their sweeps on one core.
constexpr int kParallelFrom = 20000;
// The coarsest level is solved densely up to this many rows (when the
// coarsening stalls above coarsestSize), else by kStalledSweeps Jacobi sweeps.
constexpr int kDenseAtMost = 3000;
constexpr int kStalledSweeps = 20;

template <class F>
void forRows(int n, F&& f) {
  if (n < kParallelFrom) {
    for (int i = 0; i < n; ++i) f(i);
    return;
  }
  tbb::parallel_for(tbb::blocked_range<int>(0, n, 2048), [&](const tbb::blocked_range<int>& r) {
    for (int i = r.begin(); i != r.end(); ++i) f(i);
  });
}

// One pass of pairwise matching: each node, in order, is paired with its
// strongest unpaired neighbour (the most negative a_ij), or left alone.
// (Notay pairs only with "strong" neighbours, −a_ij ≥ β max_k (−a_ik); on
// coarse levels those are often taken, and with them only the levels of
// bunny00's transport stopped shrinking at a few thousand nodes.)
// row(i, visit) calls visit(j, a_ij) for the entries of row i. Returns the
// number of groups; `group` maps node -> its group.
template <class Row>
int pairwiseMatching(int n, Row&& row, std::vector<int>& group) {
  group.assign(static_cast<size_t>(n), -1);
  int groups = 0;
  for (int i = 0; i < n; ++i) {
    if (group[i] >= 0) continue;
    int best = -1;
    double bestValue = 0;
    row(i, [&](int j, double a) {
      if (j == i || group[j] >= 0 || !(a < 0)) return;
      if (best < 0 || a < bestValue) best = j, bestValue = a;
    });
    group[i] = groups;
    if (best >= 0) group[best] = groups;
    ++groups;
  }
  // A node left single joins the group of its strongest neighbour (at most
  // kGroupAtMost nodes to a group): around a node with many neighbours the
  // pairing leaves all but one of them single (on bunny00's transport the
  // levels stopped shrinking at about a thousand nodes).
  constexpr int kGroupAtMost = 4;
  std::vector<int> size(static_cast<size_t>(groups), 0);
  for (int i = 0; i < n; ++i) ++size[group[i]];
  for (int i = 0; i < n; ++i) {
    if (size[group[i]] != 1) continue;
    int best = -1;
    double bestValue = 0;
    row(i, [&](int j, double a) {
      if (j == i || !(a < 0) || size[group[j]] >= kGroupAtMost) return;
      if (best < 0 || a < bestValue) best = j, bestValue = a;
    });
    if (best < 0) continue;
    --size[group[i]];
    group[i] = group[best];
    ++size[group[best]];
  }
  // Number the groups left in the order of their first node.
  std::vector<int> number(static_cast<size_t>(groups), -1);
  int used = 0;
  for (int i = 0; i < n; ++i) {
    if (number[group[i]] < 0) number[group[i]] = used++;
    group[i] = number[group[i]];
  }
  return used;
}

}  // namespace

AggregationAmg::AggregationAmg(const Eigen::SparseMatrix<double>& A, const Options& options) : options_(options) {
  Eigen::SparseMatrix<double> copy;  // (only if A is not in compressed storage)
  if (!A.isCompressed()) copy = A, copy.makeCompressed();
  const Eigen::SparseMatrix<double>& S = A.isCompressed() ? A : copy;
  Level fine;
  fine.A.n = static_cast<int>(S.rows());
  fine.A.start.assign(S.outerIndexPtr(), S.outerIndexPtr() + S.outerSize() + 1);
  fine.A.col.assign(S.innerIndexPtr(), S.innerIndexPtr() + S.nonZeros());
  fine.A.value.assign(S.valuePtr(), S.valuePtr() + S.nonZeros());
  levels_.push_back(std::move(fine));
  for (;;) {
    Level& level = levels_.back();
    const Csr& M = level.A;
    level.invDiag.assign(static_cast<size_t>(M.n), 1.0);
    for (int i = 0; i < M.n; ++i)
      for (int k = M.start[i]; k < M.start[i + 1]; ++k)
        if (M.col[k] == i && M.value[k] > 0) level.invDiag[i] = 1.0 / M.value[k];
    if (M.n <= options_.coarsestSize) break;
    // Two passes of pairing: the first on M, the second on the matrix of
    // the pairs (entries summed between pairs, built on the fly).
    std::vector<int> first;
    const int n1 = pairwiseMatching(
        M.n, [&](int i, auto&& visit) {
          for (int k = M.start[i]; k < M.start[i + 1]; ++k) visit(M.col[k], M.value[k]);
        },
        first);
    // Rows of the pair matrix: the members of each pair.
    std::vector<int> memberStart(static_cast<size_t>(n1) + 1, 0), members(static_cast<size_t>(M.n));
    for (int i = 0; i < M.n; ++i) ++memberStart[first[i] + 1];
    for (int p = 0; p < n1; ++p) memberStart[p + 1] += memberStart[p];
    {
      std::vector<int> fill(memberStart.begin(), memberStart.end() - 1);
      for (int i = 0; i < M.n; ++i) members[fill[first[i]]++] = i;
    }
    std::vector<double> acc(static_cast<size_t>(n1), 0.0);
    std::vector<int> touched;
    std::vector<char> seen(static_cast<size_t>(n1), 0);
    auto pairRow = [&](int p, auto&& visit) {
      touched.clear();
      for (int m = memberStart[p]; m < memberStart[p + 1]; ++m) {
        const int i = members[m];
        for (int k = M.start[i]; k < M.start[i + 1]; ++k) {
          const int q = first[M.col[k]];
          if (!seen[q]) seen[q] = 1, acc[q] = 0, touched.push_back(q);
          acc[q] += M.value[k];
        }
      }
      for (int q : touched) visit(q, acc[q]);
      for (int q : touched) seen[q] = 0;
    };
    std::vector<int> second;
    const int n2 = pairwiseMatching(n1, pairRow, second);
    if (n2 > M.n * 0.9) break;  // no longer coarsening: solve here
    level.aggregate.resize(static_cast<size_t>(M.n));
    for (int i = 0; i < M.n; ++i) level.aggregate[i] = second[first[i]];
    level.coarseN = n2;
    // Galerkin product with the piecewise-constant prolongation.
    Level coarse;
    Csr& C = coarse.A;
    C.n = n2;
    C.start.assign(static_cast<size_t>(n2) + 1, 0);
    std::vector<int> nodeStart(static_cast<size_t>(n2) + 1, 0), nodes(static_cast<size_t>(M.n));
    for (int i = 0; i < M.n; ++i) ++nodeStart[level.aggregate[i] + 1];
    for (int a = 0; a < n2; ++a) nodeStart[a + 1] += nodeStart[a];
    {
      std::vector<int> fill(nodeStart.begin(), nodeStart.end() - 1);
      for (int i = 0; i < M.n; ++i) nodes[fill[level.aggregate[i]]++] = i;
    }
    std::vector<double> sum(static_cast<size_t>(n2), 0.0);
    std::vector<int> mark(static_cast<size_t>(n2), -1), cols;
    for (int a = 0; a < n2; ++a) {
      cols.clear();
      for (int m = nodeStart[a]; m < nodeStart[a + 1]; ++m) {
        const int i = nodes[m];
        for (int k = M.start[i]; k < M.start[i + 1]; ++k) {
          const int b = level.aggregate[M.col[k]];
          if (mark[b] != a) mark[b] = a, sum[b] = 0, cols.push_back(b);
          sum[b] += M.value[k];
        }
      }
      std::sort(cols.begin(), cols.end());
      for (int b : cols) C.col.push_back(b), C.value.push_back(sum[b]);
      C.start[a + 1] = static_cast<int>(C.col.size());
    }
    levels_.push_back(std::move(coarse));
  }
  // The coarsest level: a dense pseudo-inverse (its matrix is singular when
  // the finest one is, with the constants as null space); Jacobi sweeps
  // instead if the coarsening stalled above kDenseAtMost rows.
  const Csr& C = levels_.back().A;
  if (C.n > kDenseAtMost) return;
  Eigen::MatrixXd dense = Eigen::MatrixXd::Zero(C.n, C.n);
  for (int i = 0; i < C.n; ++i)
    for (int k = C.start[i]; k < C.start[i + 1]; ++k) dense(i, C.col[k]) += C.value[k];
  dense = 0.5 * (dense + dense.transpose()).eval();
  Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eigen(dense);
  const Eigen::VectorXd lambda = eigen.eigenvalues();
  const double cut = 1e-12 * std::max(lambda.cwiseAbs().maxCoeff(), 1e-300);
  Eigen::VectorXd inverse(lambda.size());
  for (Eigen::Index k = 0; k < lambda.size(); ++k) inverse[k] = lambda[k] > cut ? 1.0 / lambda[k] : 0.0;
  coarsestInverse_ = eigen.eigenvectors() * inverse.asDiagonal() * eigen.eigenvectors().transpose();
}

std::vector<int> AggregationAmg::levelSizes() const {
  std::vector<int> sizes;
  for (const Level& l : levels_) sizes.push_back(l.A.n);
  return sizes;
}

void AggregationAmg::multiply(const Csr& A, const Eigen::VectorXd& x, Eigen::VectorXd& y) const {
  y.resize(A.n);
  forRows(A.n, [&](int i) {
    double s = 0;
    for (int k = A.start[i]; k < A.start[i + 1]; ++k) s += A.value[k] * x[A.col[k]];
    y[i] = s;
  });
}

void AggregationAmg::apply(const Eigen::VectorXd& r, Eigen::VectorXd& z) const { cycle(0, r, z); }

void AggregationAmg::cycle(size_t l, const Eigen::VectorXd& b, Eigen::VectorXd& x) const {
  const Level& level = levels_[l];
  const int n = level.A.n;
  const bool coarsest = l + 1 == levels_.size();
  if (coarsest && coarsestInverse_.size() > 0) {
    x = coarsestInverse_ * b;
    return;
  }
  const double w = options_.jacobiWeight;
  Eigen::VectorXd residual(n);
  auto smooth = [&] {
    multiply(level.A, x, residual);
    forRows(n, [&](int i) { x[i] += w * level.invDiag[i] * (b[i] - residual[i]); });
  };
  x.resize(n);
  forRows(n, [&](int i) { x[i] = w * level.invDiag[i] * b[i]; });
  if (coarsest) {  // (the coarsening stalled: no dense solve)
    for (int s = 1; s < kStalledSweeps; ++s) smooth();
    return;
  }
  for (int s = 1; s < options_.sweeps; ++s) smooth();
  // The residual, restricted; the coarse problem visited coarseVisits
  // times, each on what the corrections before it left.
  const int nc = level.coarseN;
  const Csr& coarseA = levels_[l + 1].A;
  multiply(level.A, x, residual);
  Eigen::VectorXd coarseB = Eigen::VectorXd::Zero(nc), correction, more, product;
  for (int i = 0; i < n; ++i) coarseB[level.aggregate[i]] += b[i] - residual[i];
  cycle(l + 1, coarseB, correction);
  for (int visit = 1; visit < options_.coarseVisits; ++visit) {
    multiply(coarseA, correction, product);
    cycle(l + 1, coarseB - product, more);
    correction += more;
  }
  forRows(n, [&](int i) { x[i] += correction[level.aggregate[i]]; });
  for (int s = 0; s < options_.sweeps; ++s) smooth();
}

}  // namespace tet2spline::detail

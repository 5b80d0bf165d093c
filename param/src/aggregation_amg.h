#pragma once
// Internal: an algebraic multigrid preconditioner by aggregation, for the
// transport's Newton systems L = −H (a weighted graph Laplacian on the
// regular triangulation's edges: symmetric, off-diagonals ≤ 0, rows summing
// to zero, so singular with the constants as null space).
//
// Coarsening after Notay ("An aggregation-based algebraic multigrid method",
// ETNA 2010): each level pairs every node with its strongest unpaired
// neighbour, twice (a node left single joins its strongest neighbour's
// group), so aggregates hold about four nodes; the coarse matrix is the
// Galerkin product with the piecewise-constant prolongation (the sum of the
// entries between two aggregates), which keeps the zero row sums.
// The cycle: damped Jacobi before and after the coarse correction, the
// coarse problem visited twice (W-cycle; the levels shrink by about four, so
// that costs about twice a fine sweep), and the coarsest level (at most
// `coarsestSize` nodes) solved by a dense pseudo-inverse. Every part is
// symmetric, so the cycle is a fixed symmetric operator, positive on what
// the tests apply it to: a preconditioner for CG.
#include <Eigen/Core>
#include <Eigen/SparseCore>
#include <vector>

namespace tet2spline::detail {

class AggregationAmg {
 public:
  struct Options {
    int coarsestSize = 400;     ///< the dense solve's size at most
    int sweeps = 1;             ///< Jacobi sweeps before and after the coarse correction
    double jacobiWeight = 2.0 / 3.0;
    int coarseVisits = 2;       ///< 1: V-cycle, 2: W-cycle
  };
  /// A: symmetric, both triangles stored (column-major, so its columns are
  /// its rows), positive diagonal.
  explicit AggregationAmg(const Eigen::SparseMatrix<double>& A, const Options& options);
  explicit AggregationAmg(const Eigen::SparseMatrix<double>& A) : AggregationAmg(A, Options()) {}
  /// z = one cycle applied to r (z ≈ A⁺ r).
  void apply(const Eigen::VectorXd& r, Eigen::VectorXd& z) const;
  /// Rows of each level, finest first (the last is the dense one).
  std::vector<int> levelSizes() const;

 private:
  struct Csr {
    int n = 0;
    std::vector<int> start, col;
    std::vector<double> value;
  };
  struct Level {
    Csr A;
    std::vector<double> invDiag;
    std::vector<int> aggregate;  // node -> node of the next level (empty on the coarsest)
    int coarseN = 0;
  };
  void cycle(size_t l, const Eigen::VectorXd& b, Eigen::VectorXd& x) const;
  void multiply(const Csr& A, const Eigen::VectorXd& x, Eigen::VectorXd& y) const;

  Options options_;
  std::vector<Level> levels_;
  Eigen::MatrixXd coarsestInverse_;
};

}  // namespace tet2spline::detail

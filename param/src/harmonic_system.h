#pragma once
// Internal: the harmonic map's Dirichlet system, assembled and factorised
// once its fixed vertices are known, solved once their positions are. The
// ball map builds it beside the spherical map, which then places the fixed
// vertices (harmonicMap does both in turn).
#include <Eigen/Core>
#include <Eigen/SparseCore>
#include <vector>

#include "spd_solver.h"
#include "tet2spline/param/harmonic_map.h"

namespace tet2spline::detail {

class HarmonicSystem {
 public:
  /// L of (V, T) and the factorisation of its free block L_II; throws
  /// Error(Input) for bad indices or a flat tet, as harmonicMap does. A
  /// failed factorisation, or progress stopping it, is the status of every
  /// solve.
  HarmonicSystem(const Eigen::MatrixX3d& V, const Eigen::MatrixX4i& T, const Eigen::VectorXi& fixedVertices,
                 const HarmonicMapOptions& options = {});
  /// The map with the fixed vertices (in the constructor's order) at
  /// `fixedPositions`: the same bits as harmonicMap's.
  HarmonicMapResult solve(const Eigen::MatrixX3d& fixedPositions) const;

 private:
  Eigen::Index nv_ = 0;
  Eigen::VectorXi fixedVertices_;
  std::vector<int> freeIndex_;  // −1 fixed, else the index among the free vertices
  int numFree_ = 0;
  Eigen::SparseMatrix<double> L_;
  SpdSolver solver_;
  HarmonicMapOptions options_;
  HarmonicMapResult prepared_;  // solver name, seconds, status: what every solve starts from
};

}  // namespace tet2spline::detail

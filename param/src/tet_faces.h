#pragma once
// Internal: the face adjacency of a tet mesh (topology.cpp), shared by the
// solid's analysis, boundaryFaces and the ball map's shell.
#include <Eigen/Core>
#include <array>
#include <vector>

namespace tet2spline::detail {

/// Boundary faces (used by one tet; oriented outward for positive tets, in
/// the order of their sorted vertex triples), the faces shared by more than
/// two tets (how many, and the uses of the first), and the face-connected
/// components (when asked for).
struct TetFaces {
  std::vector<std::array<int, 3>> boundary;
  int nonManifoldFaces = 0;
  int firstNonManifoldUses = 0;
  int components = 0;
};

/// T's vertex indices must be in range (checkTetIndices).
TetFaces tetFaces(const Eigen::MatrixX4i& T, bool wantComponents);

/// faces.boundary as rows, #boundary × 3.
Eigen::MatrixX3i boundaryMatrix(const TetFaces& faces);

}  // namespace tet2spline::detail

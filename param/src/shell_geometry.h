#pragma once
// Private to tet2spline::param: inside/outside tests against the closed
// shells of a surface (winding numbers), shared by analyzeSurface (nesting of
// shells) and tetrahedralize (region seeds).
#include <Eigen/Core>
#include <vector>

#include "tet2spline/param/tet_mesh.h"
#include "tet2spline/param/topology.h"

namespace tet2spline {

class ShellGeometry {
 public:
  /// `report.shells` and `report.shellFaces` describe closed shells of `surface`;
  /// both must outlive this object.
  ShellGeometry(const SurfaceMesh& surface, const SurfaceReport& report);

  int size() const { return static_cast<int>(report_.shells.size()); }
  /// +1 when the shell's triangles face outward (positive enclosed volume).
  double sign(int s) const { return report_.shells[s].enclosedVolume >= 0 ? 1.0 : -1.0; }
  double volume(int s) const;
  const std::vector<int>& faces(int s) const { return report_.shellFaces[s]; }
  Eigen::Vector3d vertex(int v) const { return V_.row(v).transpose(); }
  Eigen::Vector3i face(int f) const { return F_.row(f).transpose(); }

  /// Winding number of shell s about p, counted for the shell oriented
  /// outward: 1 strictly inside, 0 outside. Sum of the triangles' signed solid
  /// angles (Van Oosterom and Strackee 1983) over 4π, an integer up to rounding.
  double winding(int s, const Eigen::Vector3d& p) const;

  /// 1 when p is inside shell s, 0 outside, −1 when p is too close to tell.
  int inside(int s, const Eigen::Vector3d& p) const;

  /// For each shell, the innermost shell that contains it (−1 if none), and
  /// how many shells contain it. Shells must not intersect. Returns false when
  /// some pair is too close to decide.
  bool nesting(std::vector<int>& parent, std::vector<int>& depth, int& tooCloseA, int& tooCloseB) const;

 private:
  const Eigen::MatrixX3d& V_;
  const Eigen::MatrixX3i& F_;
  const SurfaceReport& report_;
  std::vector<Eigen::Vector3d> lo_, hi_;
};

}  // namespace tet2spline

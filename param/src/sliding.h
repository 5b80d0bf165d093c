#pragma once
// Internal: boundary vertices that slide on ∂Ω, placed from an unconstrained
// point y: on the unit sphere at y/|y|, or on the cube [0,1]³ where the ray
// from its centre c through y leaves it, c + (y − c) ½/max_k |y_k − c_k|
// (so a vertex may cross a cube edge). Their positions, the chain rule for a
// gradient and the linearisation for Newton steps, for the untangler and the
// barrier morph.
#include <Eigen/Core>
#include <algorithm>

namespace tet2spline::detail {

/// The ray from the centre along d = y − c leaves the cube through the face
/// of the largest |d_axis| = extent (no ray when extent = 0).
struct CubeRay {
  Eigen::Vector3d d;
  Eigen::Index axis = 0;
  double extent = 0;
};

inline CubeRay cubeRay(const Eigen::Vector3d& y, const Eigen::Vector3d& centre) {
  CubeRay r;
  r.d = y - centre;
  r.extent = r.d.cwiseAbs().maxCoeff(&r.axis);
  return r;
}

/// Where the ray leaves the cube, its face's coordinate exactly 0 or 1
/// (r.extent > 0).
inline Eigen::RowVector3d cubeRayPoint(const CubeRay& r) {
  Eigen::RowVector3d p;
  for (int j = 0; j < 3; ++j) p[j] = std::clamp(0.5 + 0.5 * r.d[j] / r.extent, 0.0, 1.0);
  p[r.axis] = r.d[r.axis] > 0 ? 1 : 0;
  return p;
}

/// ∂E/∂y from s = ∂E/∂p, p = y/|y|.
inline Eigen::Vector3d sphereGradient(const Eigen::Vector3d& y, const Eigen::Vector3d& s) {
  const double len = y.norm();
  const Eigen::Vector3d n = y / len;
  return (s - n * n.dot(s)) / len;
}

/// ∂E/∂y from s = ∂E/∂p, p = cubeRayPoint: ½/|d_a| (I − d e_aᵀ/d_a)ᵀ s
/// (r.extent > 0).
inline Eigen::Vector3d cubeRayGradient(const CubeRay& r, Eigen::Vector3d s) {
  const double dg = r.d.dot(s);
  s *= 0.5 / r.extent;
  s[r.axis] -= 0.5 / r.extent * dg / r.d[r.axis];
  return s;
}

/// dp = M dx for y = base + scale·x, and C the projector onto the directions
/// in which p does not change (M C = 0): on the sphere, its normal.
inline void sphereLinearisation(const Eigen::Vector3d& y, double scale, Eigen::Matrix3d& M, Eigen::Matrix3d& C) {
  const double len = y.norm();
  const Eigen::Vector3d nrm = y / len;
  C = nrm * nrm.transpose();
  M = scale / len * (Eigen::Matrix3d::Identity() - C);
}

/// The same on the cube (r.extent > 0): C is the ray's direction.
inline void cubeRayLinearisation(const CubeRay& r, double scale, Eigen::Matrix3d& M, Eigen::Matrix3d& C) {
  C = r.d * r.d.transpose() / r.d.squaredNorm();
  Eigen::Matrix3d P = Eigen::Matrix3d::Identity();
  P.col(r.axis) -= r.d / r.d[r.axis];
  M = scale * 0.5 / r.extent * P;
}

}  // namespace tet2spline::detail

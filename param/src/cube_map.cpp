// Equal-volume map from the unit ball onto [0,1]³ (cube_map.h).
#include "cube_map.h"

#include <algorithm>
#include <cmath>
#include <utility>

namespace tet2spline::detail {

Eigen::Vector3d equalVolumeBallToCube(const Eigen::Vector3d& x) {
  const double r = x.norm();
  if (!(r > 0)) return Eigen::Vector3d::Constant(0.5);
  // The face: the axis of the largest coordinate; i, j the other two.
  int k = 0;
  x.cwiseAbs().maxCoeff(&k);
  const int i = (k + 1) % 3, j = (k + 2) % 3;
  double p = std::abs(x[i]) / r, q = std::abs(x[j]) / r;
  const double z = std::abs(x[k]) / r;
  const bool swapped = q > p;
  if (swapped) std::swap(p, q);
  double X = 0, Y = 0;
  if (p > 0) {
    const double phi = std::atan2(q, p);  // in [0, π/4]
    const double c = std::cos(phi);
    const double oneMinusCosTheta = (p * p + q * q) / (1 + z);  // 1 − z without cancellation
    const double oneMinusCosEdge = 1 - c / std::sqrt(1 + c * c);
    X = std::min(1.0, std::sqrt(oneMinusCosTheta / oneMinusCosEdge));
    const double s = std::min(1.0, (12 / M_PI) * (phi - std::asin(std::sin(phi) / std::sqrt(2.0))));
    Y = s * X;
  }
  if (swapped) std::swap(X, Y);
  Eigen::Vector3d face;
  face[k] = x[k] >= 0 ? 1.0 : -1.0;
  face[i] = x[i] >= 0 ? X : -X;
  face[j] = x[j] >= 0 ? Y : -Y;
  return (0.5 * r * face).array() + 0.5;
}

}  // namespace tet2spline::detail

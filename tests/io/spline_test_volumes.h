#pragma once
// B-spline volumes shared by the export tests: a refined box (the identity
// with knot insertion and degree elevation), a curved cube and a
// cylinder-like patch, all with det J > 0 inside.
#include <Eigen/Core>
#include <cmath>
#include <string>
#include <vector>

#include "tet2spline/spline/bspline_volume.h"

namespace t2stest {

using tet2spline::spline::BSplineVolume;
using tet2spline::spline::KnotVector;

/// x = (u, v, w) on [0,2]×[0,1]×[0,1.5]: volume 3. Non-uniform knots,
/// degrees (3, 3, 2) after elevation, a double knot in w.
inline BSplineVolume refinedBox() {
  BSplineVolume V = BSplineVolume::identity(KnotVector::uniform(2, 2, 0.0, 2.0), KnotVector::uniform(1, 1, 0.0, 1.0),
                                            KnotVector::uniform(2, 1, 0.0, 1.5));
  V.insertKnot(0, 0.3);
  V.elevateDegree(0, 1);
  V.elevateDegree(1, 2);
  V.insertKnot(1, 0.7);
  V.insertKnot(2, 0.5, 2);
  return V;
}

/// The unit cube, degree 3 with 3×2×4 elements, with its control points moved
/// by a smooth map (shrunk towards the centre away from the axes, bent in z):
/// a rounded, curved solid. det J > 0 (checked by the tests).
inline BSplineVolume curvedCube() {
  BSplineVolume V = BSplineVolume::identity(KnotVector::uniform(3, 3), KnotVector::uniform(3, 2), KnotVector::uniform(3, 4));
  Eigen::MatrixX3d P = V.controlPoints();
  for (Eigen::Index i = 0; i < P.rows(); ++i) {
    const Eigen::Vector3d p = P.row(i).transpose();
    const Eigen::Vector3d c = p - Eigen::Vector3d::Constant(0.5);
    Eigen::Vector3d q = c * (1.0 - 0.3 * c.squaredNorm());
    q.z() += 0.15 * std::sin(M_PI * p.x());
    q.y() += 0.1 * p.x() * p.z();
    P.row(i) = (q + Eigen::Vector3d::Constant(0.5)).transpose();
  }
  V.setControlPoints(P);
  return V;
}

/// A cylinder-like patch: the cross-section is the quadratic 3×3 net of a
/// rounded square (corners pulled in), extruded linearly to height 2 and then
/// refined (degree elevation in w, knots in u and w).
/// With corner = 0.5 the corner control points of the cross-section lie on
/// the line between their neighbours: the faces u = const and v = const meet
/// tangentially (at 180°) along the four vertical edges, where det J = 0 - the
/// case of a single patch mapped onto a smooth solid (design.md).
inline BSplineVolume cylinderPatch(double corner = 0.7) {
  const double c = corner, m = 1.0, h = 2.0;
  const double net[3][3][2] = {{{-c, -c}, {0, -m}, {c, -c}}, {{-m, 0}, {0, 0}, {m, 0}}, {{-c, c}, {0, m}, {c, c}}};
  Eigen::MatrixX3d P(18, 3);
  for (int k = 0; k < 2; ++k)
    for (int j = 0; j < 3; ++j)
      for (int i = 0; i < 3; ++i) P.row(i + 3 * (j + 3 * k)) << net[j][i][0], net[j][i][1], h * k;
  BSplineVolume V(KnotVector::uniform(2, 1), KnotVector::uniform(2, 1), KnotVector::uniform(1, 1), P);
  V.elevateDegree(2, 1);
  V.insertKnot(0, 0.4);
  V.insertKnot(2, 0.5);
  V.insertKnot(2, 0.25);
  return V;
}

struct NamedVolume {
  std::string name;
  BSplineVolume volume;
};

inline std::vector<NamedVolume> testVolumes() {
  return {{"refined_box", refinedBox()}, {"curved_cube", curvedCube()}, {"cylinder_patch", cylinderPatch()}};
}

/// Smallest det J on an n^3 grid of interior parameters.
inline double minInteriorDetJ(const BSplineVolume& V, int n = 9) {
  const Eigen::Vector3d a = V.parameterMin(), b = V.parameterMax();
  double lo = INFINITY;
  for (int k = 1; k < n; ++k)
    for (int j = 1; j < n; ++j)
      for (int i = 1; i < n; ++i) {
        const Eigen::Vector3d t(double(i) / n, double(j) / n, double(k) / n);
        lo = std::min(lo, V.detJacobian(a + (b - a).cwiseProduct(t)));
      }
  return lo;
}

}  // namespace t2stest

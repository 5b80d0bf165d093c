#pragma once
// What every parameterization must satisfy (issue 4): converged transport,
// zero inverted tets (exact), boundary vertices exactly on the domain's
// boundary (the unit sphere, or a face of the cube: a coordinate 0 or 1).
#include <gtest/gtest.h>

#include "tet2spline/param/parameterize.h"
#include "tet2spline/param/topology.h"

namespace t2stest {

inline void expectValidParameterization(const tet2spline::ParamResult& r, tet2spline::ParamDomain domain) {
  ASSERT_TRUE(r.status.ok) << r.status.message;
  EXPECT_EQ(r.param.invertedTets, 0);
  EXPECT_EQ(tet2spline::countNonPositiveTets(r.U, r.mesh.T), 0);
  EXPECT_LE(r.ot.maxRelativeMassError, 1e-6);
  EXPECT_LT(r.param.boundaryMaxDistance, 1e-12);
  for (Eigen::Index k = 0; k < r.boundaryVertices.size(); ++k) {
    const Eigen::Vector3d u = r.U.row(r.boundaryVertices(k));
    if (domain == tet2spline::ParamDomain::Ball) {
      EXPECT_NEAR(u.norm(), 1.0, 1e-12);
    } else {
      EXPECT_TRUE(u.minCoeff() == 0 || u.maxCoeff() == 1) << u.transpose();
      EXPECT_GE(u.minCoeff(), 0);
      EXPECT_LE(u.maxCoeff(), 1);
    }
  }
}

}  // namespace t2stest

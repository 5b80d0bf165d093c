// The large real meshes (tens of seconds each): labelled `slow`.
#include <gtest/gtest.h>

#include <chrono>
#include <cstdio>

#include "param/test_shapes.h"
#include "test_data.h"
#include "tet2spline/io/mesh_io.h"
#include "tet2spline/param/tetrahedralize.h"
#include "tet2spline/param/topology.h"

using namespace tet2spline;

TEST(TetrahedralizeSlow, Bunny00GivesAValidBallWithItsVolume) {
  const SurfaceMesh s = readSurface(t2stest::cgalMesh("bunny00"));
  const auto t0 = std::chrono::steady_clock::now();
  const TetMesh m = tetrahedralize(s, {}, "bunny00");
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  std::printf("tetrahedralize(bunny00): %lld tets, %lld vertices, %.2f s\n", (long long)m.T.rows(),
              (long long)m.V.rows(), seconds);
  RecordProperty("tets", std::to_string(m.T.rows()));
  RecordProperty("seconds", std::to_string(seconds));
  const SolidReport r = analyzeSolid(m);
  EXPECT_TRUE(r.valid()) << (r.problems.empty() ? "" : r.problems[0]);
  EXPECT_EQ(r.components, 1);
  EXPECT_EQ(r.genus, 0);
  EXPECT_EQ(r.invertedTets, 0);
  EXPECT_EQ(r.degenerateTets, 0);
  const double surfaceVolume = std::abs(analyzeSurface(s, false).shells.at(0).enclosedVolume);
  EXPECT_NEAR(t2stest::totalVolume(m), surfaceVolume, 1e-9 * surfaceVolume);
}

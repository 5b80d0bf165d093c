// Wavefront OBJ: round trip, face reference forms, negative indices, polygons,
// and bad inputs.
#include "surface_test_util.h"

using namespace tet2spline;
using namespace t2stest;

TEST(ObjIo, RoundTripIsExact) {
  const std::string path = scratchDir("obj_rt") + "/o.obj";
  const SurfaceMesh s = octahedron();
  writeSurface(s, path);
  const SurfaceMesh r = readSurface(path);
  EXPECT_TRUE(r.V == s.V);
  EXPECT_TRUE(r.F == s.F);
}

TEST(ObjIo, ReferenceFormsNegativeIndicesAndPolygons) {
  const std::string path = scratchDir("obj_forms") + "/f.obj";
  writeFile(path,
            "# comment\nmtllib x.mtl\no thing\nv 0 0 0\nv 1 0 0 1.0\nv 1 1 0 0.5 0.5 0.5\nv 0 1 0\n"
            "vt 0 0\nvn 0 0 1\ng group\ns off\nusemtl m\n"
            "f 1/1/1 2/1/1 3/1/1\nf 1//1 3//1 4//1\nf -4/1 -2/1 -1/1\n"
            "v 0 0 1\nf 1 2 3 4 5\nl 1 2\n");
  const SurfaceMesh s = readSurface(path);
  ASSERT_EQ(s.V.rows(), 5);
  ASSERT_EQ(s.F.rows(), 3 + 3);
  EXPECT_EQ(s.F.row(1), Eigen::RowVector3i(0, 2, 3));
  EXPECT_EQ(s.F.row(2), Eigen::RowVector3i(0, 2, 3)) << "negative indices count back from the last vertex";
  EXPECT_EQ(s.F.row(3), Eigen::RowVector3i(0, 1, 2));
  EXPECT_EQ(s.F.row(5), Eigen::RowVector3i(0, 3, 4)) << "pentagon fanned from its first corner";
}

TEST(ObjIo, BadInputsNameFileLineAndCause) {
  const std::string dir = scratchDir("obj_bad");
  const std::pair<std::string, std::pair<long, std::string>> cases[] = {
      {"# only a comment\n", {0, "empty file"}},
      {"v 0 0 0\nv 1 0 0\nv 0 1 0\n", {0, "no faces"}},
      {"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 4\n", {4, "index 4 out of range"}},
      {"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 0 1 2\n", {4, "index 0 out of range"}},
      {"v 0 0 0\nv 1 0 0\nv 0 1 0\nf -4 1 2\n", {4, "index -4 out of range"}},
      {"v 0 0 0\nv 1 0 0\n\nf 1 2 3\nv 0 1 0\n", {4, "out of range"}},
      {"v 0 0 0\nv 1 nan 0\n", {2, "NaN or infinite"}},
      {"v 0 0 0\nv 1 0\n", {2, "vertex needs 3 coordinates"}},
      {"v 0 0 0\nv 1 0 zero\n", {2, "malformed vertex coordinate 'zero'"}},
      {"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2\n", {4, "at least 3"}},
      {"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 x/1\n", {4, "malformed face vertex"}},
  };
  int i = 0;
  for (const auto& [text, expect] : cases) {
    SCOPED_TRACE(i);
    const std::string path = dir + "/c" + std::to_string(i++) + ".obj";
    writeFile(path, text);
    expectInputError([&] { readSurface(path); }, path, expect.first, expect.second);
  }
}

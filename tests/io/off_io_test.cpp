// OFF surfaces: writer round trip and the real CGAL data in every surface format.
#include "surface_test_util.h"

using namespace tet2spline;
using namespace t2stest;

TEST(OffIo, RoundTripIsExact) {
  const std::string path = scratchDir("off_rt") + "/o.off";
  const SurfaceMesh s = octahedron();
  writeSurface(s, path);
  const SurfaceMesh r = readSurface(path);
  EXPECT_TRUE(r.V == s.V);
  EXPECT_TRUE(r.F == s.F);
}

TEST(OffIo, RealMeshThroughEverySurfaceFormat) {
  const std::string off = cgalMesh("blob-closed");
  if (!fs::exists(off)) GTEST_SKIP() << "test data missing: " << off;
  const std::string dir = scratchDir("off_all");
  const SurfaceMesh s = readSurface(off);
  ASSERT_GT(s.F.rows(), 100);
  for (const char* ext : {"off", "obj", "ply"}) {
    SCOPED_TRACE(ext);
    const std::string path = dir + "/blob." + ext;
    writeSurface(s, path);
    const SurfaceMesh r = readSurface(path);
    EXPECT_TRUE(r.V == s.V);
    EXPECT_TRUE(r.F == s.F);
  }
  // STL stores float32 and no shared vertices: same triangles after rounding.
  writeSurface(s, dir + "/blob.stl");
  const SurfaceMesh r = readSurface(dir + "/blob.stl");
  EXPECT_EQ(r.V.rows(), s.V.rows()) << "identical corners are merged back into shared vertices";
  EXPECT_NEAR(enclosedVolume(r), enclosedVolume(s), 1e-6 * enclosedVolume(s));
}

TEST(OffIo, BadInputsNameFileLineAndCause) {
  const std::string dir = scratchDir("off_bad");
  const std::pair<std::string, std::pair<long, std::string>> cases[] = {
      {"PLY\n", {1, "wrong header"}},
      {"OFF\n4 4 0\n0 0 0\n1 0 0\n", {4, "truncated"}},
      {"OFF\n4 4 0\n0 0 0\n1 0 0\n0 1 0\n0 0 nan\n3 0 1 2\n", {6, "NaN or infinite"}},
      {"OFF\n4 4 0\n0 0 0\n1 0 0\n0 1 0\n0 0 1\n3 0 1 7\n", {7, "out of range"}},
      {"OFF\n4 4 0\n0 0 0\n1 0 0\n0 1 0\n0 0 1\n3 0 1 2\n3 0 1 3\n3 0 2 3\n", {9, "truncated: expected 4 faces, got 3"}},
      {"OFF\n4 4 0\n0 0 0\n1 0 0\n0 1 0\n0 0 1\n3 0 1 2\n3 0 1 3\n3 0 2 3\n3 1 2 3\n3 1 2 3\n", {11, "more data after the 4 faces"}},
      {"OFF\n999999999 4 0\n0 0 0\n", {2, "truncated or corrupt"}},
      {"# only a comment\n", {0, "empty file"}},
  };
  int i = 0;
  for (const auto& [text, expect] : cases) {
    const std::string path = dir + "/c" + std::to_string(i++) + ".off";
    writeFile(path, text);
    expectInputError([&] { readSurface(path); }, path, expect.first, expect.second);
  }
}

TEST(OffIo, TetgenMeshesWhatWeWrite) {
  if (!haveProgram("tetgen")) GTEST_SKIP() << "tetgen not installed (scripts/install-deps.sh)";
  const std::string off = cgalMesh("blob-closed");
  if (!fs::exists(off)) GTEST_SKIP() << "test data missing: " << off;
  const std::string dir = scratchDir("off_tetgen");
  const SurfaceMesh s = readSurface(off);
  writeSurface(s, dir + "/ours.off");
  ASSERT_EQ(run("cd " + dir + " && tetgen -pQ ours.off"), 0);
  const TetMesh m = readTetMesh(dir + "/ours.1.ele");
  EXPECT_TRUE(m.V.topRows(s.V.rows()) == s.V) << "tetgen read every digit we wrote";
  double vol = 0;
  for (Eigen::Index t = 0; t < m.numTets(); ++t) vol += std::fabs(tetVolume(m, t));
  EXPECT_NEAR(vol, enclosedVolume(s), 1e-5 * enclosedVolume(s));
}

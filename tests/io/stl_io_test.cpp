// STL, ASCII and binary: round trip, exact vertex merging, binary files whose
// header starts with "solid", and bad inputs.
#include <cstring>

#include "surface_test_util.h"

using namespace tet2spline;
using namespace t2stest;

namespace {
std::string binaryStl(const std::vector<std::array<float, 9>>& tris, const std::string& header) {
  std::string s = header;
  s.resize(80, ' ');
  const uint32_t n = static_cast<uint32_t>(tris.size());
  s.append(reinterpret_cast<const char*>(&n), 4);
  for (const auto& t : tris) {
    const float normal[3] = {0, 0, 0};
    s.append(reinterpret_cast<const char*>(normal), 12);
    s.append(reinterpret_cast<const char*>(t.data()), 36);
    s.append(2, '\0');
  }
  return s;
}
}  // namespace

TEST(StlIo, BinaryRoundTripMergesVerticesBack) {
  const std::string path = scratchDir("stl_rt") + "/o.stl";
  const SurfaceMesh s = octahedron(true);
  writeSurface(s, path);
  EXPECT_EQ(readFile(path).size(), 84u + 50u * 8u);
  const SurfaceMesh r = readSurface(path);
  EXPECT_EQ(r.V.rows(), 6);
  expectSameTriangles(r, s);
}

TEST(StlIo, AsciiMergesIdenticalVerticesExactly) {
  const std::string path = scratchDir("stl_ascii") + "/a.stl";
  writeFile(path,
            "solid two\n"
            "  facet normal 0 0 1\n    outer loop\n      vertex 0 0 0\n      vertex 1 0 0\n      vertex 0 1 0\n"
            "    endloop\n  endfacet\n"
            "  facet normal 0 0 1\n    outer loop\n      vertex 1 0 0\n      vertex 1 1 0\n      vertex -0 1 0\n"
            "    endloop\n  endfacet\n"
            "  facet normal 0 0 1\n    outer loop\n      vertex 1 0 0\n      vertex 1 1 1e-300\n      vertex 0 1 0\n"
            "    endloop\n  endfacet\n"
            "endsolid two\n");
  const SurfaceMesh s = readSurface(path);
  EXPECT_EQ(s.F.rows(), 3);
  EXPECT_EQ(s.V.rows(), 5) << "-0 equals 0, 1e-300 differs from 0";
  EXPECT_EQ(s.F(1, 2), s.F(0, 2));
}

TEST(StlIo, BinaryWhoseHeaderSaysSolid) {
  const std::string path = scratchDir("stl_solid") + "/b.stl";
  writeFile(path, binaryStl({{0, 0, 0, 1, 0, 0, 0, 1, 0}, {1, 0, 0, 1, 1, 0, 0, 1, 0}}, "solid exported by a CAD tool"));
  const SurfaceMesh s = readSurface(path);
  EXPECT_EQ(s.F.rows(), 2);
  EXPECT_EQ(s.V.rows(), 4);
}

TEST(StlIo, BadInputsNameFileAndCause) {
  const std::string dir = scratchDir("stl_bad");
  const std::string good = binaryStl({{0, 0, 0, 1, 0, 0, 0, 1, 0}, {1, 0, 0, 1, 1, 0, 0, 1, 0}}, "bin");
  std::string nan = good;
  const float q = std::numeric_limits<float>::quiet_NaN();
  std::memcpy(&nan[84 + 50 + 12 + 4], &q, 4);
  std::string huge = good;
  const uint32_t n = 0xffffffffu;
  std::memcpy(&huge[80], &n, 4);
  const std::pair<std::string, std::pair<long, std::string>> cases[] = {
      {good.substr(0, good.size() - 1), {0, "declares 2 triangles (184 bytes) but the file has 183 bytes"}},
      {good + "x", {0, "declares 2 triangles"}},
      {huge, {0, "declares 4294967295 triangles"}},
      {"garbage", {0, "shorter than a binary STL header"}},
      {nan, {0, "triangle 1 has a NaN or infinite coordinate"}},
      {binaryStl({}, "empty"), {0, "no triangles"}},
      {"solid x\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex 1 0 0\n", {5, "truncated"}},
      {"solid x\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex 1 0 0\nvertex 0 1 0\nendloop\nendfacet\n", {8, "no 'endsolid'"}},
      {"solid x\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex 1 inf 0\nvertex 0 1 0\nendloop\nendfacet\nendsolid\n", {5, "NaN or infinite"}},
      {"solid x\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex 1 0 0\nendloop\nendfacet\nendsolid\n", {6, "expected 'vertex'"}},
  };
  int i = 0;
  for (const auto& [text, expect] : cases) {
    SCOPED_TRACE(i);
    const std::string path = dir + "/c" + std::to_string(i++) + ".stl";
    writeFile(path, text);
    expectInputError([&] { readSurface(path); }, path, expect.first, expect.second);
  }
}

TEST(StlIo, GmshReadsOurBinaryAndWeReadGmshAscii) {
  if (!haveProgram("gmsh")) GTEST_SKIP() << "gmsh not installed (scripts/install-deps.sh)";
  const std::string off = cgalMesh("blob-closed");
  if (!fs::exists(off)) GTEST_SKIP() << "test data missing: " << off;
  const std::string dir = scratchDir("stl_gmsh");
  const SurfaceMesh s = readSurface(off);
  writeSurface(s, dir + "/ours.stl");
  ASSERT_EQ(run("gmsh " + dir + "/ours.stl -0 -format stl -o " + dir + "/gmsh.stl"), 0);
  ASSERT_EQ(readFile(dir + "/gmsh.stl").rfind("solid", 0), 0u) << "gmsh writes ASCII STL";
  const SurfaceMesh r = readSurface(dir + "/gmsh.stl");
  EXPECT_EQ(r.F.rows(), s.F.rows());
  EXPECT_EQ(r.V.rows(), s.V.rows()) << "shared corners merged back";
  EXPECT_NEAR(enclosedVolume(r), enclosedVolume(s), 1e-5 * enclosedVolume(s));  // float32 and %g rounding
}

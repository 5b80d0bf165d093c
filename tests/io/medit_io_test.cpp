// MEDIT .mesh: round trip, files written by gmsh, and every bad-input class.
#include "io_test_util.h"

using namespace tet2spline;
using namespace t2stest;

TEST(MeditIo, RoundTripKeepsVerticesTetsAndRegionsExactly) {
  const std::string path = scratchDir("medit_rt") + "/m.mesh";
  const TetMesh m = referenceMesh();
  writeTetMesh(m, path);
  const TetMesh r = readTetMesh(path);
  EXPECT_TRUE(r.V == m.V);
  EXPECT_TRUE(r.T == m.T);
  EXPECT_TRUE(r.region == m.region);
}

TEST(MeditIo, WriteIsDeterministic) {
  const std::string dir = scratchDir("medit_det");
  writeTetMesh(referenceMesh(), dir + "/a.mesh");
  writeTetMesh(referenceMesh(), dir + "/b.mesh");
  EXPECT_EQ(readFile(dir + "/a.mesh"), readFile(dir + "/b.mesh"));
}

TEST(MeditIo, ReadsVersion1CommentsAndIgnoredSections) {
  const std::string path = scratchDir("medit_v1") + "/m.mesh";
  writeFile(path,
            "# a comment\nMeshVersionFormatted 1\n\nDimension\n3\n"
            "Vertices\n5\n0 0 0 1\n1 0 0 1\n0 1 0 1\n0 0 1 1\n1 1 1 2\n"
            "Edges\n1\n1 2 0\n"
            "Triangles\n2\n1 2 3 4\n2 3 4 4\n"
            "Tetrahedra\n2\n1 2 3 4 5\n2 3 4 5 6 # trailing comment\n"
            "Corners\n1\n1\nRequiredVertices 1 2\nEnd\n");
  const TetMesh r = readTetMesh(path);
  ASSERT_EQ(r.numVertices(), 5);
  ASSERT_EQ(r.numTets(), 2);
  EXPECT_EQ(r.T.row(1), Eigen::RowVector4i(1, 2, 3, 4));
  EXPECT_EQ(r.region(0), 5);
  EXPECT_EQ(r.region(1), 6);
}

TEST(MeditIo, ReadsGmshOutputWithTheSameTetsAsMsh) {
  if (!haveProgram("gmsh")) GTEST_SKIP() << "gmsh not installed (scripts/install-deps.sh)";
  const std::string mesh = gmshNested("mesh", false, "mesh");
  const std::string msh = gmshNested("msh41", false, "msh");
  ASSERT_FALSE(mesh.empty());
  ASSERT_FALSE(msh.empty());
  const TetMesh a = readTetMesh(mesh), b = readTetMesh(msh);
  EXPECT_EQ(a.numVertices(), b.numVertices());
  EXPECT_EQ(a.numTets(), b.numTets());
  EXPECT_TRUE(a.T == b.T);
  EXPECT_LT((a.V - b.V).cwiseAbs().maxCoeff(), 1e-12);
  // gmsh writes elementary tags as MEDIT references: two regions, same volumes.
  const auto va = regionVolumes(a), vb = regionVolumes(b);
  ASSERT_EQ(va.size(), 2u);
  std::vector<double> sa, sb;
  for (auto& kv : va) sa.push_back(kv.second);
  for (auto& kv : vb) sb.push_back(kv.second);
  std::sort(sa.begin(), sa.end());
  std::sort(sb.begin(), sb.end());
  EXPECT_NEAR(sa[0], sb[0], 1e-9);
  EXPECT_NEAR(sa[1], sb[1], 1e-9);
  EXPECT_NEAR(sa[0] + sa[1], 8.0, 1e-9);
}

namespace {
struct BadCase {
  const char* name;
  const char* text;
  long line;
  const char* cause;
};
}  // namespace

TEST(MeditIo, BadInputsNameFileLineAndCause) {
  const std::string dir = scratchDir("medit_bad");
  const std::string head = "MeshVersionFormatted 2\nDimension 3\n";
  const std::string verts = "Vertices\n4\n0 0 0 0\n1 0 0 0\n0 1 0 0\n0 0 1 0\n";
  const BadCase cases[] = {
      {"only_comment", "# nothing\n", 0, "empty file"},
      {"wrong_header", "MeshVersion 2\n", 1, "wrong header"},
      {"bad_version", "MeshVersionFormatted 7\n", 1, "MeshVersionFormatted 7"},
      {"dim2", "MeshVersionFormatted 2\nDimension 2\n", 2, "Dimension 2"},
      {"truncated_vertices", "MeshVersionFormatted 2\nDimension 3\nVertices\n4\n0 0 0 0\n1 0 0 0\n1 0 0", 7, "truncated"},
      {"too_few_vertices", "MeshVersionFormatted 2\nDimension 3\nVertices\n3\n0 0 0 0\n1 0 0 0\nTetrahedra\n0\nEnd\n",
       6, "declares 3 vertices but only 2"},
      {"too_many_vertices", "MeshVersionFormatted 2\nDimension 3\nVertices\n1\n0 0 0 0\n1 0 0 0\nEnd\n", 6,
       "count disagrees"},
      {"nan", "MeshVersionFormatted 2\nDimension 3\nVertices\n1\n0 nan 0 0\nEnd\n", 5, "NaN or infinite"},
      {"inf", "MeshVersionFormatted 2\nDimension 3\nVertices\n1\n0 0 -inf 0\nEnd\n", 5, "NaN or infinite"},
      {"index_high", "", 11, "out of range [1, 4]"},
      {"index_zero", "", 11, "out of range [1, 4]"},
      {"hexahedra", "", 10, "Hexahedra"},
      {"no_tets", "", 0, "no Tetrahedra"},
      {"huge_count", "MeshVersionFormatted 2\nDimension 3\nVertices\n99999999999\n0 0 0 0\n", 4, "out of range"},
      {"count_beyond_file", "MeshVersionFormatted 2\nDimension 3\nVertices\n1000000\n0 0 0 0\n", 4, "truncated"},
      {"garbage", "\x01\x02\xff\xfe binary junk", 1, "wrong header"},
  };
  for (const BadCase& c : cases) {
    SCOPED_TRACE(c.name);
    std::string text = c.text;
    const std::string n = c.name;
    if (n == "index_high") text = head + verts + "Tetrahedra\n1\n1 2 3 5 1\nEnd\n";
    if (n == "index_zero") text = head + verts + "Tetrahedra\n1\n0 2 3 4 1\nEnd\n";
    if (n == "hexahedra") text = head + verts + "Hexahedra\n1\n1 2 3 4 1 2 3 4 1\nEnd\n";
    if (n == "no_tets") text = head + verts + "Triangles\n1\n1 2 3 0\nEnd\n";
    const std::string path = dir + "/" + n + ".mesh";
    writeFile(path, text);
    expectInputError([&] { readTetMesh(path); }, path, c.line, c.cause);
  }
}

TEST(MeditIo, GmshReadsWhatWeWrite) {
  if (!haveProgram("gmsh")) GTEST_SKIP() << "gmsh not installed (scripts/install-deps.sh)";
  const std::string dir = scratchDir("medit_gmsh_reads");
  TetMesh m = referenceMesh();
  m.region(11) = 3;  // gmsh entity tags are positive
  writeTetMesh(m, dir + "/ours.mesh");
  ASSERT_EQ(run("gmsh -0 " + dir + "/ours.mesh -format msh41 -o " + dir + "/back.msh"), 0);
  const TetMesh r = readTetMesh(dir + "/back.msh");  // MEDIT references become entity tags
  EXPECT_EQ(r.numTets(), m.numTets());
  const auto a = regionVolumes(m), b = regionVolumes(r);
  ASSERT_EQ(b.size(), a.size());
  for (const auto& [region, vol] : a) EXPECT_NEAR(b.at(region), vol, 1e-14) << region;
}

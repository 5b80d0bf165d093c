// TetGen .node/.ele: files written by the tetgen program, 0/1-based indices,
// region attributes, and every bad-input class.
#include "io_test_util.h"

using namespace tet2spline;
using namespace t2stest;

TEST(TetGenIo, ReadsTetgenOutputFromEitherName) {
  if (!haveProgram("tetgen")) GTEST_SKIP() << "tetgen not installed (scripts/install-deps.sh)";
  const std::string off = cgalMesh("blob-closed");
  if (!fs::exists(off)) GTEST_SKIP() << "test data missing: " << off;
  const std::string dir = scratchDir("tetgen_blob");
  fs::copy_file(off, dir + "/blob.off");
  ASSERT_EQ(run("cd " + dir + " && tetgen -pq1.5 -A blob.off"), 0);
  const TetMesh a = readTetMesh(dir + "/blob.1.node");
  const TetMesh b = readTetMesh(dir + "/blob.1.ele");
  EXPECT_TRUE(a.V == b.V);
  EXPECT_TRUE(a.T == b.T);
  EXPECT_TRUE(a.region == b.region);
  ASSERT_GT(a.numTets(), 100);
  // -p keeps the boundary: the tets fill the volume the surface encloses (up to
  // tetgen's rounding of the Steiner points it puts on boundary edges).
  const SurfaceMesh s = readSurface(off);
  double vol = 0;
  for (auto& kv : regionVolumes(a)) vol += kv.second;
  EXPECT_NEAR(vol, enclosedVolume(s), 1e-5 * enclosedVolume(s));
  // -A: one region attribute per tet, a single region here.
  EXPECT_EQ(regionVolumes(a).size(), 1u);
  EXPECT_GE(a.V.rows(), s.V.rows());
  EXPECT_TRUE(a.V.topRows(s.V.rows()) == s.V) << "tetgen keeps the input vertices first";
  // Same mesh after a round trip through our writers.
  const std::string vtu = dir + "/blob.vtu";
  writeTetMesh(a, vtu);
  const TetMesh c = readTetMesh(vtu);
  EXPECT_TRUE(c.V == a.V);
  EXPECT_TRUE(c.T == a.T);
}

TEST(TetGenIo, OneBasedIndicesAndRegionAttributes) {
  const std::string dir = scratchDir("tetgen_1based");
  writeFile(dir + "/m.node",
            "# five nodes, one attribute, boundary markers\n5 3 1 1\n"
            "1 0 0 0 0.5 1\n2 1 0 0 0.5 1\n3 0 1 0 0.5 1\n4 0 0 1 0.5 1\n5 1 1 1 0.5 0\n");
  writeFile(dir + "/m.ele", "2 4 2\n1 1 2 3 4 -3 9\n2 2 3 4 5 8 9 # comment\n");
  const TetMesh m = readTetMesh(dir + "/m.ele");
  ASSERT_EQ(m.numTets(), 2);
  EXPECT_EQ(m.T.row(0), Eigen::RowVector4i(0, 1, 2, 3));
  EXPECT_EQ(m.T.row(1), Eigen::RowVector4i(1, 2, 3, 4));
  EXPECT_EQ(m.region(0), -3);
  EXPECT_EQ(m.region(1), 8);
}

TEST(TetGenIo, ZeroBasedWithoutAttributesIsRegionOne) {
  const std::string dir = scratchDir("tetgen_0based");
  writeFile(dir + "/m.node", "4 3 0 0\n0 0 0 0\n1 1 0 0\n2 0 1 0\n3 0 0 1\n");
  writeFile(dir + "/m.ele", "1 4 0\n0 0 1 2 3\n");
  const TetMesh m = readTetMesh(dir + "/m.node");
  ASSERT_EQ(m.numTets(), 1);
  EXPECT_EQ(m.T.row(0), Eigen::RowVector4i(0, 1, 2, 3));
  EXPECT_EQ(m.region(0), 1);
}

TEST(TetGenIo, BadInputsNameFileLineAndCause) {
  const std::string dir = scratchDir("tetgen_bad");
  const std::string goodNode = "4 3 0 0\n0 0 0 0\n1 1 0 0\n2 0 1 0\n3 0 0 1\n";
  const std::string goodEle = "1 4 0\n0 0 1 2 3\n";
  struct Case {
    const char* name;
    std::string node, ele;
    const char* bad;  // "node" or "ele": the file the message must name
    long line;
    const char* cause;
  };
  const Case cases[] = {
      {"dim2", "4 2 0 0\n", goodEle, "node", 1, "dimension 2"},
      {"first_index", "1 3 0 0\n5 0 0 0\n", goodEle, "node", 2, "first node index is 5"},
      {"sequence", "2 3 0 0\n0 0 0 0\n2 1 0 0\n", goodEle, "node", 3, "out of sequence"},
      {"truncated_node", "4 3 0 0\n0 0 0 0\n1 1 0", goodEle, "node", 3, "truncated"},
      {"missing_nodes", "4 3 0 0\n0 0 0 0\n1 1 0 0\n", goodEle, "node", 3, "declares"},
      {"extra_nodes", "1 3 0 0\n0 0 0 0\n1 1 0 0\n", goodEle, "node", 3, "more data"},
      {"nan", "4 3 0 0\n0 0 0 0\n1 1 nan 0\n", goodEle, "node", 3, "NaN or infinite"},
      {"second_order", goodNode, "1 10 0\n0 0 1 2 3 0 1 2 3 0 1\n", "ele", 1, "10 nodes per tetrahedron (second order)"},
      {"index_range", goodNode, "1 4 0\n0 0 1 2 4\n", "ele", 2, "out of range [0, 3]"},
      {"truncated_ele", goodNode, "2 4 0\n0 0 1 2 3\n1 0 1", "ele", 3, "truncated"},
      {"attribute", goodNode, "1 4 1\n0 0 1 2 3 1.5\n", "ele", 2, "not an integer"},
      {"huge", goodNode, "9999999999 4 0\n", "ele", 1, "out of range"},
      {"count_beyond_file", goodNode, "100000 4 0\n0 0 1 2 3\n", "ele", 1, "truncated"},
      {"empty_ele", goodNode, "", "ele", 0, "empty file"},
  };
  for (const Case& c : cases) {
    SCOPED_TRACE(c.name);
    const std::string base = dir + "/" + c.name;
    writeFile(base + ".node", c.node);
    writeFile(base + ".ele", c.ele);
    const std::string named = base + "." + c.bad;
    expectInputError([&] { readTetMesh(base + ".node"); }, named, c.line, c.cause);
  }
  const std::string lonely = dir + "/lonely.node";
  writeFile(lonely, goodNode);
  expectInputError([&] { readTetMesh(lonely); }, dir + "/lonely.ele", 0, "cannot open");
}

// Gmsh .msh 2.2 and 4.1: round trips, files written by gmsh itself, sparse
// node tags, byte order, and every bad-input class.
#include <cstring>

#include "io_test_util.h"

using namespace tet2spline;
using namespace t2stest;

namespace {

void expectSameMesh(const TetMesh& a, const TetMesh& b) {
  EXPECT_TRUE(a.V == b.V);
  EXPECT_TRUE(a.T == b.T);
  EXPECT_TRUE(a.region == b.region);
}

template <class T>
void put(std::string& s, T v, bool big) {
  char b[sizeof(T)];
  std::memcpy(b, &v, sizeof(T));
  const uint16_t one = 1;
  const bool hostBig = *reinterpret_cast<const unsigned char*>(&one) == 0;
  if (big != hostBig) std::reverse(b, b + sizeof(T));
  s.append(b, sizeof(T));
}

/// A binary MSH 2.2 file: 5 nodes with sparse tags, a triangle and 2 tets.
std::string binary22(bool big) {
  std::string s = "$MeshFormat\n2.2 1 8\n";
  put<int32_t>(s, 1, big);
  s += "\n$EndMeshFormat\n$Nodes\n5\n";
  const int tags[5] = {10, 20, 30, 40, 50};
  const double xyz[5][3] = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}, {1, 1, 1}};
  for (int i = 0; i < 5; ++i) {
    put<int32_t>(s, tags[i], big);
    for (double x : xyz[i]) put<double>(s, x, big);
  }
  s += "\n$EndNodes\n$Elements\n3\n";
  // block: one triangle (type 2) with 2 tags
  for (int v : {2, 1, 2, 1, 5, 6, 10, 20, 30}) put<int32_t>(s, v, big);
  // block: two tets (type 4) with 2 tags (physical 0 -> elementary used for the second)
  for (int v : {4, 2, 2, 2, 11, 5, 10, 20, 30, 40, 3, 0, 12, 20, 30, 40, 50}) put<int32_t>(s, v, big);
  s += "\n$EndElements\n";
  return s;
}

const char* kSparse22 =
    "$MeshFormat\n2.2 0 8\n$EndMeshFormat\n"
    "$PhysicalNames\n1\n3 5 \"a name with spaces\"\n$EndPhysicalNames\n"
    "$Nodes\n5\n100 0 0 0\n7 1 0 0\n3 0 1 0\n55 0 0 1\n2 1 1 1\n$EndNodes\n"
    "$Elements\n4\n1 15 2 0 1 100\n2 2 2 0 1 100 7 3\n3 4 2 5 1 100 7 3 55\n4 4 0 7 3 55 2\n$EndElements\n";

const char* kAscii41 =
    "$MeshFormat\n4.1 0 8\n$EndMeshFormat\n"
    "$Entities\n0 0 0 2\n"
    "4 0 0 0 1 1 1 1 42 0\n"
    "6 0 0 0 1 1 1 0 0\n"
    "$EndEntities\n"
    "$Nodes\n2 5 1 9\n"
    "3 4 0 3\n1\n5\n9\n0 0 0\n1 0 0\n0 1 0\n"
    "3 6 0 2\n2\n3\n0 0 1\n1 1 1\n"
    "$EndNodes\n"
    "$Elements\n3 3 1 3\n"
    "2 1 2 1\n1 1 5 9\n"
    "3 4 4 1\n2 1 5 9 2\n"
    "3 6 4 1\n3 5 9 2 3\n"
    "$EndElements\n";

}  // namespace

TEST(GmshIo, RoundTripBinaryAndAscii) {
  const std::string dir = scratchDir("gmsh_rt");
  const TetMesh m = referenceMesh();
  for (bool binary : {true, false}) {
    const std::string path = dir + (binary ? "/b.msh" : "/a.msh");
    writeTetMesh(m, path, MeshWriteOptions{binary});
    expectSameMesh(readTetMesh(path), m);
  }
  EXPECT_NE(readFile(dir + "/b.msh"), readFile(dir + "/a.msh"));
  EXPECT_NE(readFile(dir + "/a.msh").find("4.1 0 8"), std::string::npos);
  EXPECT_NE(readFile(dir + "/b.msh").find("4.1 1 8"), std::string::npos);
}

TEST(GmshIo, GmshReadsWhatWeWrite) {
  if (!haveProgram("gmsh")) GTEST_SKIP() << "gmsh not installed (scripts/install-deps.sh)";
  const std::string dir = scratchDir("gmsh_reread");
  TetMesh m = referenceMesh();
  m.region(11) = 3;  // gmsh physical tags are positive
  for (bool binary : {true, false}) {
    const std::string ours = dir + (binary ? "/ours_b.msh" : "/ours_a.msh");
    const std::string back = dir + (binary ? "/back_b.msh" : "/back_a.msh");
    writeTetMesh(m, ours, MeshWriteOptions{binary});
    ASSERT_EQ(run("gmsh -0 " + ours + " -format msh22 -o " + back), 0) << ours;
    const TetMesh r = readTetMesh(back);
    EXPECT_EQ(r.numTets(), m.numTets());
    EXPECT_LT((r.V.topRows(m.numVertices()) - m.V).cwiseAbs().maxCoeff(), 1e-15);
    EXPECT_EQ(regionVolumes(r).size(), 2u);
    EXPECT_NEAR(regionVolumes(r)[7], regionVolumes(m)[7], 1e-14);
    EXPECT_NEAR(regionVolumes(r)[3], regionVolumes(m)[3], 1e-14);
  }
}

TEST(GmshIo, FilesWrittenByGmshAgreeAcrossVersionsAndEncodings) {
  if (!haveProgram("gmsh")) GTEST_SKIP() << "gmsh not installed (scripts/install-deps.sh)";
  const std::string ref = gmshNested("msh41", false, "msh");
  ASSERT_FALSE(ref.empty());
  const TetMesh a = readTetMesh(ref);
  const auto vol = regionVolumes(a);
  ASSERT_EQ(vol.size(), 2u);
  ASSERT_EQ(vol.count(7), 1u);
  ASSERT_EQ(vol.count(9), 1u);
  EXPECT_NEAR(vol.at(7) + vol.at(9), 8.0, 1e-9);           // the box
  const double ball = 4.0 / 3.0 * M_PI * 0.125;  // the sphere's tets form an inscribed polyhedron
  EXPECT_LT(vol.at(9), ball);
  EXPECT_GT(vol.at(9), 0.75 * ball);
  EXPECT_GT(a.numTets(), 500);
  for (auto [format, binary] : {std::pair{"msh41", true}, {"msh22", false}, {"msh22", true}}) {
    SCOPED_TRACE(std::string(format) + (binary ? " binary" : " ascii"));
    const std::string p = gmshNested(format, binary, "msh");
    ASSERT_FALSE(p.empty());
    const TetMesh b = readTetMesh(p);
    EXPECT_EQ(b.numVertices(), a.numVertices());
    ASSERT_EQ(b.numTets(), a.numTets());
    EXPECT_TRUE(b.T == a.T);
    EXPECT_TRUE(b.region == a.region);
    EXPECT_LT((b.V - a.V).cwiseAbs().maxCoeff(), 1e-12);  // ASCII prints 16 digits
  }
}

TEST(GmshIo, SparseNodeTagsAndRegionFallbacks22) {
  const std::string path = scratchDir("gmsh_sparse") + "/s.msh";
  writeFile(path, kSparse22);
  const TetMesh m = readTetMesh(path);
  ASSERT_EQ(m.numVertices(), 5);
  ASSERT_EQ(m.numTets(), 2);  // point and triangle skipped
  EXPECT_EQ(m.T.row(0), Eigen::RowVector4i(0, 1, 2, 3));
  EXPECT_EQ(m.T.row(1), Eigen::RowVector4i(1, 2, 3, 4));
  EXPECT_EQ(m.region(0), 5);  // physical tag
  EXPECT_EQ(m.region(1), 1);  // no tags at all
  EXPECT_EQ(m.V.row(4), Eigen::RowVector3d(1, 1, 1));
}

TEST(GmshIo, Entities41PhysicalElseEntityTag) {
  const std::string path = scratchDir("gmsh_41") + "/e.msh";
  writeFile(path, kAscii41);
  const TetMesh m = readTetMesh(path);
  ASSERT_EQ(m.numTets(), 2);
  EXPECT_EQ(m.region(0), 42);  // entity 4 has physical tag 42
  EXPECT_EQ(m.region(1), 6);   // entity 6 has none
  EXPECT_EQ(m.T.row(1), Eigen::RowVector4i(1, 2, 3, 4));
}

TEST(GmshIo, BinaryBothByteOrders) {
  const std::string dir = scratchDir("gmsh_endian");
  for (bool big : {false, true}) {
    const std::string path = dir + (big ? "/big.msh" : "/little.msh");
    writeFile(path, binary22(big));
    const TetMesh m = readTetMesh(path);
    ASSERT_EQ(m.numTets(), 2);
    EXPECT_EQ(m.T.row(1), Eigen::RowVector4i(1, 2, 3, 4));
    EXPECT_EQ(m.region(0), 11);
    EXPECT_EQ(m.region(1), 12);
    EXPECT_EQ(m.V.row(4), Eigen::RowVector3d(1, 1, 1));
  }
}

TEST(GmshIo, NonTetVolumeElementsAreNamed) {
  const std::string dir = scratchDir("gmsh_types");
  const std::string base = "$MeshFormat\n2.2 0 8\n$EndMeshFormat\n$Nodes\n8\n1 0 0 0\n2 1 0 0\n3 1 1 0\n4 0 1 0\n"
                           "5 0 0 1\n6 1 0 1\n7 1 1 1\n8 0 1 1\n$EndNodes\n$Elements\n1\n";
  const std::pair<const char*, const char*> cases[] = {
      {"1 5 2 1 1 1 2 3 4 5 6 7 8", "element type 5 (8-node hexahedron)"},
      {"1 6 2 1 1 1 2 3 4 5 6", "element type 6 (6-node prism)"},
      {"1 7 2 1 1 1 2 3 4 5", "element type 7 (5-node pyramid)"},
      {"1 11 2 1 1 1 2 3 4 5 6 7 8 1 2", "element type 11 (10-node second-order tetrahedron)"},
      {"1 99 2 1 1 1 2 3 4", "unknown element type 99"},
  };
  int i = 0;
  for (const auto& [line, cause] : cases) {
    const std::string path = dir + "/t" + std::to_string(i++) + ".msh";
    writeFile(path, base + line + "\n$EndElements\n");
    expectInputError([&] { readTetMesh(path); }, path, 17, cause);
  }
  // The same in 4.1: a hexahedron block.
  const std::string path = dir + "/hex41.msh";
  writeFile(path, "$MeshFormat\n4.1 0 8\n$EndMeshFormat\n$Nodes\n1 8 1 8\n3 1 0 8\n1\n2\n3\n4\n5\n6\n7\n8\n"
                  "0 0 0\n1 0 0\n1 1 0\n0 1 0\n0 0 1\n1 0 1\n1 1 1\n0 1 1\n$EndNodes\n"
                  "$Elements\n1 1 1 1\n3 1 5 1\n1 1 2 3 4 5 6 7 8\n$EndElements\n");
  expectInputError([&] { readTetMesh(path); }, path, 26, "element type 5 (8-node hexahedron)");
}

TEST(GmshIo, BadInputsNameFileLineAndCause) {
  const std::string dir = scratchDir("gmsh_bad");
  struct Case {
    const char* name;
    std::string text;
    long line;
    const char* cause;
  };
  const std::string fmt = "$MeshFormat\n2.2 0 8\n$EndMeshFormat\n";
  const std::string nodes = "$Nodes\n4\n1 0 0 0\n2 1 0 0\n3 0 1 0\n4 0 0 1\n$EndNodes\n";
  const Case cases[] = {
      {"wrong_header", "$MeshFmt\n", 1, "wrong header"},
      {"version3", "$MeshFormat\n3.0 0 8\n$EndMeshFormat\n", 2, "unsupported MSH version 3.0"},
      {"datasize", "$MeshFormat\n2.2 0 4\n$EndMeshFormat\n", 2, "data size 4"},
      {"no_end", "$MeshFormat\n2.2 0 8\n", 2, "truncated"},
      {"truncated_nodes", fmt + "$Nodes\n4\n1 0 0 0\n2 1 0", 7, "truncated"},
      {"count_disagrees", fmt + "$Nodes\n3\n1 0 0 0\n2 1 0 0\n3 0 1 0\n4 0 0 1\n$EndNodes\n", 9, "expected $EndNodes"},
      {"nan", fmt + "$Nodes\n1\n1 0 NaN 0\n$EndNodes\n", 6, "NaN or infinite"},
      {"undefined_node", fmt + nodes + "$Elements\n1\n1 4 2 1 1 1 2 3 5\n$EndElements\n", 13, "undefined node tag 5"},
      {"duplicate_node", fmt + "$Nodes\n2\n1 0 0 0\n1 1 0 0\n$EndNodes\n", 7, "node tag 1 appears twice"},
      {"elements_first", fmt + "$Elements\n0\n$EndElements\n", 4, "$Elements before $Nodes"},
      {"no_tets", fmt + nodes + "$Elements\n1\n1 2 2 1 1 1 2 3\n$EndElements\n", 0, "no tetrahedra"},
      {"no_elements", fmt + nodes, 0, "no $Elements"},
      {"unterminated_section", fmt + "$Comments\nhello\n", 4, "has no $EndComments"},
      {"blocks41", "$MeshFormat\n4.1 0 8\n$EndMeshFormat\n$Nodes\n1 3 1 3\n3 1 0 2\n1\n2\n0 0 0\n1 0 0\n$EndNodes\n", 10,
       "$Nodes declares 3 nodes but its blocks hold 2"},
      {"blocks41_overflow", "$MeshFormat\n4.1 0 8\n$EndMeshFormat\n$Nodes\n1 1 1 3\n3 1 0 2\n1\n2\n0 0 0\n1 0 0\n$EndNodes\n", 6,
       "node blocks hold more than the 1 nodes"},
      {"inf41", "$MeshFormat\n4.1 0 8\n$EndMeshFormat\n$Nodes\n1 1 1 1\n3 1 0 1\n1\n0 -inf 0\n$EndNodes\n", 8, "NaN or infinite"},
  };
  for (const Case& c : cases) {
    SCOPED_TRACE(c.name);
    const std::string path = dir + "/" + c.name + ".msh";
    writeFile(path, c.text);
    expectInputError([&] { readTetMesh(path); }, path, c.line, c.cause);
  }
}

TEST(GmshIo, CorruptBinaryIsCaughtBeforeAllocating) {
  const std::string dir = scratchDir("gmsh_binbad");
  // Bad endianness marker.
  std::string s = binary22(false);
  std::string bad = s;
  bad.replace(20, 4, std::string("\x02\x00\x00\x07", 4));
  writeFile(dir + "/marker.msh", bad);
  expectInputError([&] { readTetMesh(dir + "/marker.msh"); }, dir + "/marker.msh", 0, "endianness marker");
  // Every truncation of a binary file is an error, never a crash.
  for (size_t cut : {s.size() / 4, s.size() / 2, s.size() - 20}) {
    const std::string path = dir + "/cut" + std::to_string(cut) + ".msh";
    writeFile(path, s.substr(0, cut));
    expectInputError([&] { readTetMesh(path); }, path, 0, "");
  }
  // A 4.1 binary file whose node count is absurd.
  TetMesh m = referenceMesh();
  writeTetMesh(m, dir + "/ours.msh");
  std::string ours = readFile(dir + "/ours.msh");
  const size_t at = ours.find("$Nodes\n") + 7 + 8;  // numNodes follows numEntityBlocks
  const uint64_t huge = 1ULL << 60;
  ours.replace(at, 8, reinterpret_cast<const char*>(&huge), 8);
  writeFile(dir + "/huge.msh", ours);
  expectInputError([&] { readTetMesh(dir + "/huge.msh"); }, dir + "/huge.msh", 0, "truncated or corrupt");
}

TEST(GmshIo, TruncatedGmshBinaryFiles) {
  if (!haveProgram("gmsh")) GTEST_SKIP() << "gmsh not installed (scripts/install-deps.sh)";
  const std::string dir = scratchDir("gmsh_cut");
  for (const char* format : {"msh22", "msh41"}) {
    const std::string full = readFile(gmshNested(format, true, "msh"));
    ASSERT_GT(full.size(), 1000u);
    for (double frac : {0.1, 0.5, 0.9, 0.999}) {
      const std::string path = dir + "/" + format + "_" + std::to_string(int(frac * 1000)) + ".msh";
      writeFile(path, full.substr(0, static_cast<size_t>(full.size() * frac)));
      expectInputError([&] { readTetMesh(path); }, path, 0, "");
    }
  }
}

// PLY, ASCII and binary in both byte orders: round trip, extra properties and
// elements, polygon faces, and bad inputs.
#include <cstring>

#include "surface_test_util.h"

using namespace tet2spline;
using namespace t2stest;

namespace {
template <class T>
void put(std::string& s, T v, bool big) {
  char b[sizeof(T)];
  std::memcpy(b, &v, sizeof(T));
  const uint16_t one = 1;
  const bool hostBig = *reinterpret_cast<const unsigned char*>(&one) == 0;
  if (big != hostBig) std::reverse(b, b + sizeof(T));
  s.append(b, sizeof(T));
}

// 5 vertices (float x y z, uchar red), an unrelated element, a quad and a
// triangle (list uchar uint vertex_index, then a float per face).
std::string binaryPly(bool big) {
  std::string s = std::string("ply\nformat ") + (big ? "binary_big_endian" : "binary_little_endian") +
                  " 1.0\ncomment made by hand\nelement vertex 5\nproperty float x\nproperty float y\nproperty float z\n"
                  "property uchar red\nelement material 1\nproperty list uchar double coeffs\n"
                  "element face 2\nproperty list uchar uint vertex_index\nproperty float quality\nend_header\n";
  const float xyz[5][3] = {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}, {0.5f, 0.5f, 1}};
  for (auto& p : xyz) {
    for (float x : p) put<float>(s, x, big);
    put<uint8_t>(s, 200, big);
  }
  put<uint8_t>(s, 2, big);
  put<double>(s, 1.5, big);
  put<double>(s, 2.5, big);
  put<uint8_t>(s, 4, big);
  for (uint32_t v : {0u, 1u, 2u, 3u}) put<uint32_t>(s, v, big);
  put<float>(s, 0.5f, big);
  put<uint8_t>(s, 3, big);
  for (uint32_t v : {0u, 1u, 4u}) put<uint32_t>(s, v, big);
  put<float>(s, 0.25f, big);
  return s;
}

void expectHandMade(const SurfaceMesh& s) {
  ASSERT_EQ(s.V.rows(), 5);
  ASSERT_EQ(s.F.rows(), 3);
  EXPECT_EQ(s.F.row(0), Eigen::RowVector3i(0, 1, 2));
  EXPECT_EQ(s.F.row(1), Eigen::RowVector3i(0, 2, 3));
  EXPECT_EQ(s.F.row(2), Eigen::RowVector3i(0, 1, 4));
  EXPECT_EQ(s.V.row(4), Eigen::RowVector3d(0.5, 0.5, 1));
}
}  // namespace

TEST(PlyIo, RoundTripIsExact) {
  const std::string path = scratchDir("ply_rt") + "/o.ply";
  const SurfaceMesh s = octahedron();
  writeSurface(s, path);
  const SurfaceMesh r = readSurface(path);
  EXPECT_TRUE(r.V == s.V);
  EXPECT_TRUE(r.F == s.F);
}

TEST(PlyIo, BinaryBothByteOrders) {
  const std::string dir = scratchDir("ply_bin");
  for (bool big : {false, true}) {
    const std::string path = dir + (big ? "/big.ply" : "/little.ply");
    writeFile(path, binaryPly(big));
    expectHandMade(readSurface(path));
  }
}

TEST(PlyIo, AsciiWithExtraPropertiesAndElements) {
  const std::string path = scratchDir("ply_ascii") + "/a.ply";
  writeFile(path,
            "ply\nformat ascii 1.0\nobj_info hand made\nelement vertex 5\nproperty double nx\nproperty float x\n"
            "property float y\nproperty float z\nelement face 2\nproperty list uchar int vertex_indices\n"
            "element edge 1\nproperty int vertex1\nproperty int vertex2\nend_header\n"
            "9 0 0 0\n9 1 0 0\n9 1 1 0\n9 0 1 0\n9 0.5 0.5 1\n4 0 1 2 3\n3 0 1 4\n0 1\n");
  expectHandMade(readSurface(path));
}

TEST(PlyIo, BadInputsNameFileAndCause) {
  const std::string dir = scratchDir("ply_bad");
  const std::string head = "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\n"
                           "element face 1\nproperty list uchar int vertex_indices\nend_header\n";
  std::string bigCount = binaryPly(false);
  bigCount.replace(bigCount.find("vertex 5"), 8, "vertex 999999999");
  const std::pair<std::string, std::pair<long, std::string>> cases[] = {
      {"plyx\n", {1, "wrong header"}},
      {"ply\nformat binary_middle_endian 1.0\nend_header\n", {2, "unknown PLY format"}},
      {"ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\n", {4, "no end_header"}},
      {"ply\nformat ascii 1.0\nelement vertex 3\nproperty quad x\nend_header\n", {4, "unknown property type 'quad'"}},
      {"ply\nformat ascii 1.0\nelement vertex 1\nproperty float y\nend_header\n0\n", {3, "lacks x, y or z"}},
      {head + "0 0 0\n1 0 0\n0 1 0\n3 0 1 3\n", {13, "vertex index 3 out of range [0, 3)"}},
      {head + "0 0 0\n1 nan 0\n0 1 0\n3 0 1 2\n", {11, "NaN or infinite"}},
      {head + "0 0 0\n1 0 0\n0 1 0\n3 0 1\n", {13, "truncated"}},
      {head + "0 0 0\n1 0 0\n0 1 0\n2 0 1\n", {13, "fewer than 3"}},
      {head + "0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n7\n", {14, "more data"}},
      {binaryPly(false).substr(0, binaryPly(false).size() - 10), {0, "truncated"}},
      {bigCount, {0, "truncated or corrupt"}},
  };
  int i = 0;
  for (const auto& [text, expect] : cases) {
    SCOPED_TRACE(i);
    const std::string path = dir + "/c" + std::to_string(i++) + ".ply";
    writeFile(path, text);
    expectInputError([&] { readSurface(path); }, path, expect.first, expect.second);
  }
}

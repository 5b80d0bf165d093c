// MFEM NURBS mesh export: parsed back by a small reader in this file that
// follows the order in which mfem::Mesh / mfem::NURBSExtension read the
// "patches" form, then checked against MFEM's topology rules.
#include <gtest/gtest.h>

#include <array>
#include <sstream>

#include "io_test_util.h"
#include "spline_test_volumes.h"
#include "tet2spline/io/mfem_export.h"

namespace {

using namespace t2stest;

struct MfemFile {
  int dimension = 0;
  std::vector<std::vector<int>> elements, boundary, edges;  // as listed
  int vertices = 0;
  int patchDimension = 0;
  std::vector<int> order, ncp;
  std::vector<std::vector<double>> knots;
  std::vector<std::array<double, 4>> cp;
};

// Reads the next token, skipping '#' comments to the end of the line.
std::string token(std::istream& in) {
  std::string t;
  while (in >> t) {
    if (t[0] != '#') return t;
    std::string rest;
    std::getline(in, rest);
  }
  ADD_FAILURE() << "unexpected end of file";
  return {};
}

void expectToken(std::istream& in, const std::string& want) { EXPECT_EQ(token(in), want); }

std::vector<std::vector<int>> intRows(std::istream& in, int fixed, bool elementRow) {
  const int n = std::stoi(token(in));
  std::vector<std::vector<int>> rows(static_cast<size_t>(n));
  for (auto& r : rows) {
    int count = fixed;
    if (elementRow) {  // attr geom v...
      r.push_back(std::stoi(token(in)));
      r.push_back(std::stoi(token(in)));
      count = r[1] == 5 ? 8 : r[1] == 3 ? 4 : 2;
    }
    for (int i = 0; i < count; ++i) r.push_back(std::stoi(token(in)));
  }
  return rows;
}

MfemFile parse(const std::string& text) {
  MfemFile f;
  std::istringstream in(text);
  std::string header;
  std::getline(in, header);
  EXPECT_EQ(header, "MFEM NURBS mesh v1.0");
  expectToken(in, "dimension");
  f.dimension = std::stoi(token(in));
  expectToken(in, "elements");
  f.elements = intRows(in, 0, true);
  expectToken(in, "boundary");
  f.boundary = intRows(in, 0, true);
  expectToken(in, "edges");
  f.edges = intRows(in, 3, false);
  expectToken(in, "vertices");
  f.vertices = std::stoi(token(in));
  expectToken(in, "patches");
  expectToken(in, "knotvectors");
  const int nkv = std::stoi(token(in));
  for (int d = 0; d < nkv; ++d) {
    f.order.push_back(std::stoi(token(in)));
    f.ncp.push_back(std::stoi(token(in)));
    std::vector<double> k;
    for (int i = 0; i < f.ncp.back() + f.order.back() + 1; ++i) k.push_back(std::strtod(token(in).c_str(), nullptr));
    f.knots.push_back(k);
  }
  expectToken(in, "dimension");
  f.patchDimension = std::stoi(token(in));
  expectToken(in, "controlpoints_cartesian");
  std::array<double, 4> p;
  while (in >> p[0] >> p[1] >> p[2] >> p[3]) f.cp.push_back(p);
  EXPECT_TRUE(in.eof()) << "unparsed data after the control points";
  return f;
}

// MFEM's reference hexahedron: corner coordinates of vertices 0..7.
const int kCorner[8][3] = {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}, {0, 0, 1}, {1, 0, 1}, {1, 1, 1}, {0, 1, 1}};
// MFEM's hexahedron edges (Geometry::Constants<CUBE>::Edges).
const int kHexEdge[12][2] = {{0, 1}, {1, 2}, {3, 2}, {0, 3}, {4, 5}, {5, 6}, {7, 6}, {4, 7}, {0, 4}, {1, 5}, {2, 6}, {3, 7}};

Eigen::Vector3d corner(int v) { return Eigen::Vector3d(kCorner[v][0], kCorner[v][1], kCorner[v][2]); }

void expectConsistent(const BSplineVolume& V, const MfemFile& f, int attribute) {
  EXPECT_EQ(f.dimension, 3);
  ASSERT_EQ(f.elements.size(), 1u);
  EXPECT_EQ(f.elements[0], (std::vector<int>{attribute, 5, 0, 1, 2, 3, 4, 5, 6, 7}));
  EXPECT_EQ(f.vertices, 8);

  // Boundary: six quads, each on the face its attribute names, outward.
  ASSERT_EQ(f.boundary.size(), 6u);
  std::vector<int> seen;
  for (const auto& b : f.boundary) {
    ASSERT_EQ(b.size(), 6u);
    EXPECT_EQ(b[1], 3);
    const int face = b[0] - 1;  // VolumeFace
    seen.push_back(face);
    const int dir = face / 2;
    const double level = face % 2;
    Eigen::Vector3d centre = Eigen::Vector3d::Zero();
    for (int i = 2; i < 6; ++i) {
      EXPECT_EQ(corner(b[i])[dir], level) << "boundary attribute " << b[0];
      centre += corner(b[i]) / 4;
    }
    const Eigen::Vector3d n = (corner(b[3]) - corner(b[2])).cross(corner(b[5]) - corner(b[2]));
    EXPECT_GT(n.dot(centre - Eigen::Vector3d::Constant(0.5)), 0) << "boundary attribute " << b[0] << " not outward";
  }
  std::sort(seen.begin(), seen.end());
  EXPECT_EQ(seen, (std::vector<int>{0, 1, 2, 3, 4, 5}));

  // Edges: MFEM's rule is that the listed direction v0 -> v1 is the direction
  // of the knot vector (the index is negated internally when v0 > v1), and all
  // edges with one index carry the same knot vector. Here: index = the
  // parameter direction along which v0 and v1 differ, v0 at its low end.
  ASSERT_EQ(f.edges.size(), 12u);
  std::vector<int> count(3, 0);
  for (const auto& e : f.edges) {
    const int kv = e[0];
    ASSERT_GE(kv, 0);
    ASSERT_LT(kv, 3);
    ++count[static_cast<size_t>(kv)];
    const Eigen::Vector3d d = corner(e[2]) - corner(e[1]);
    EXPECT_EQ(d, Eigen::Vector3d::Unit(kv)) << "edge " << e[1] << " " << e[2];
  }
  EXPECT_EQ(count, (std::vector<int>{4, 4, 4}));
  // Each of the 12 hex edges is listed once; MFEM takes the patch's knot
  // vectors 0, 1, 2 for hex edges 0, 3, 8 - they must be indices 0, 1, 2.
  auto indexOf = [&](int a, int b) {
    for (const auto& e : f.edges)
      if ((e[1] == a && e[2] == b) || (e[1] == b && e[2] == a)) return e[0];
    return -1;
  };
  for (const auto& he : kHexEdge) EXPECT_NE(indexOf(he[0], he[1]), -1) << he[0] << "-" << he[1];
  // MFEM's CheckPatches: with the signed index of each listed edge (-1 - k
  // when v0 > v1) seen through the element's edge orientation (negated again
  // when the hex edge runs from the larger vertex), the four parallel edges of
  // each direction must agree - and here be the direction itself, unsigned.
  std::vector<int> seenByElement;
  for (const auto& he : kHexEdge) {
    int k = 0, v0 = 0, v1 = 0;
    for (const auto& e : f.edges)
      if ((e[1] == he[0] && e[2] == he[1]) || (e[1] == he[1] && e[2] == he[0])) k = e[0], v0 = e[1], v1 = e[2];
    const int signedIndex = v0 > v1 ? -1 - k : k;
    seenByElement.push_back(he[0] < he[1] ? signedIndex : -1 - signedIndex);
  }
  EXPECT_EQ(seenByElement, (std::vector<int>{0, 1, 0, 1, 0, 1, 0, 1, 2, 2, 2, 2}));
  EXPECT_EQ(indexOf(0, 1), 0);
  EXPECT_EQ(indexOf(0, 3), 1);
  EXPECT_EQ(indexOf(0, 4), 2);

  // Patch: knot vectors "order ncp knots" with order = degree, exact values.
  ASSERT_EQ(f.order.size(), 3u);
  for (int d = 0; d < 3; ++d) {
    EXPECT_EQ(f.order[d], V.degree(d));
    EXPECT_EQ(f.ncp[d], V.numControl(d));
    EXPECT_EQ(f.knots[d], V.knots(d).knots());
  }
  EXPECT_EQ(f.patchDimension, 3);
  ASSERT_EQ(f.cp.size(), static_cast<size_t>(V.numControlPoints()));
  for (size_t i = 0; i < f.cp.size(); ++i) {
    for (int c = 0; c < 3; ++c) ASSERT_EQ(f.cp[i][c], V.controlPoints()(static_cast<Eigen::Index>(i), c)) << i;
    ASSERT_EQ(f.cp[i][3], 1.0);
  }
}

TEST(MfemExport, RoundTripsAndFollowsMfemTopologyRules) {
  const std::string dir = scratchDir("mfem_roundtrip");
  for (const auto& [name, V] : testVolumes()) {
    SCOPED_TRACE(name);
    const std::string path = dir + "/" + name + ".mesh";
    tet2spline::writeMfemNurbsMesh(V, path);
    expectConsistent(V, parse(readFile(path)), 1);
  }
}

TEST(MfemExport, PatchAttribute) {
  const std::string dir = scratchDir("mfem_attribute");
  tet2spline::writeMfemNurbsMesh(curvedCube(), dir + "/a.mesh", {4});
  expectConsistent(curvedCube(), parse(readFile(dir + "/a.mesh")), 4);
  try {
    tet2spline::writeMfemNurbsMesh(curvedCube(), dir + "/b.mesh", {0});
    ADD_FAILURE() << "expected an error";
  } catch (const tet2spline::Error& e) {
    EXPECT_EQ(e.kind(), tet2spline::ErrorKind::Usage);
  }
  EXPECT_FALSE(fs::exists(dir + "/b.mesh"));
}

TEST(MfemExport, DeterministicAndUnwritable) {
  const std::string dir = scratchDir("mfem_determinism");
  tet2spline::writeMfemNurbsMesh(refinedBox(), dir + "/a.mesh");
  tet2spline::writeMfemNurbsMesh(refinedBox(), dir + "/b.mesh");
  EXPECT_EQ(readFile(dir + "/a.mesh"), readFile(dir + "/b.mesh"));
  const std::string missing = dir + "/missing/c.mesh";
  expectInputError([&] { tet2spline::writeMfemNurbsMesh(refinedBox(), missing); }, missing, 0, "cannot");
  EXPECT_EQ(std::distance(fs::directory_iterator(dir), fs::directory_iterator()), 2);
}

}  // namespace

// Element regions as an MFEM GridFunction: GridFunction::Save's header for a
// piecewise-constant L2 space, then one value per element in MFEM's element
// order (u fastest, as BSplineVolume::elements()); a wrong count is refused
// before any file exists.
TEST(MfemExport, ElementRegionsGridFunction) {
  const std::string dir = scratchDir("mfem_regions");
  const BSplineVolume V = curvedCube();  // 3 × 2 × 4 elements
  const auto elements = V.elements();
  std::vector<int> region;
  for (const auto& e : elements) region.push_back(e.centre[2] < 0.5 ? 7 : 1);
  const std::string path = dir + "/r.gf";
  tet2spline::writeMfemElementRegions(V, region, path);
  std::istringstream in(readFile(path));
  std::string line;
  for (const char* want : {"FiniteElementSpace", "FiniteElementCollection: L2_3D_P0", "VDim: 1", "Ordering: 0", ""}) {
    std::getline(in, line);
    EXPECT_EQ(line, want);
  }
  std::vector<int> back;
  for (int x; in >> x;) back.push_back(x);
  EXPECT_EQ(back, region);
  EXPECT_EQ(back.size(), 24u);
  EXPECT_THROW(tet2spline::writeMfemElementRegions(V, {1, 2}, dir + "/bad.gf"), tet2spline::Error);
  EXPECT_FALSE(fs::exists(dir + "/bad.gf"));
}

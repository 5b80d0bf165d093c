// G+Smo XML export: parsed back by a small independent reader in this file
// (the layout of G+Smo's filedata/volumes/*.xml), compared exactly.
#include <gtest/gtest.h>

#include <cstdlib>
#include <regex>

#include "io_test_util.h"
#include "spline_test_volumes.h"
#include "tet2spline/io/gismo_export.h"

namespace {

using namespace t2stest;

std::vector<double> numbers(const std::string& text) {
  std::vector<double> out;
  const char* p = text.c_str();
  char* end = nullptr;
  for (double v = std::strtod(p, &end); end != p; v = std::strtod(p, &end)) {
    out.push_back(v);
    p = end;
  }
  while (*p == ' ' || *p == '\n' || *p == '\t' || *p == '\r') ++p;
  EXPECT_EQ(*p, '\0') << "trailing text: " << p;
  return out;
}

struct GismoFile {
  std::string geometryType, basisType;
  std::vector<int> basisIndex, degree;
  std::vector<std::vector<double>> knots;
  int geoDim = 0;
  std::vector<double> coefs;
  bool hasRegions = false;
  int regionRows = 0, regionCols = 0;
  std::vector<double> regions;
};

// Text between the end of the first match of `openTag` and the next "</".
// (std::regex only sees the tags: libstdc++'s matcher recurses per character.)
bool content(const std::string& xml, const std::regex& openTag, std::smatch& m, std::string& text) {
  if (!std::regex_search(xml, m, openTag)) return false;
  const size_t from = static_cast<size_t>(m.position(0) + m.length(0));
  text = xml.substr(from, xml.find("</", from) - from);
  return true;
}

GismoFile parse(const std::string& xml) {
  GismoFile g;
  std::smatch m;
  EXPECT_TRUE(std::regex_search(xml, std::regex(R"re(^<\?xml version="1.0" encoding="UTF-8"\?>\s*<xml>)re")));
  EXPECT_TRUE(std::regex_search(xml, std::regex(R"re(</xml>\s*$)re")));
  if (std::regex_search(xml, m, std::regex(R"re(<Geometry type="(\w+)" id="0">\s*<Basis type="(\w+)">)re"))) {
    g.geometryType = m[1];
    g.basisType = m[2];
  }
  const std::regex basis(R"re(<Basis type="BSplineBasis" index="(\d+)">\s*<KnotVector degree="(\d+)">([^<]*)</KnotVector>\s*</Basis>)re");
  for (auto it = std::sregex_iterator(xml.begin(), xml.end(), basis); it != std::sregex_iterator(); ++it) {
    g.basisIndex.push_back(std::stoi((*it)[1]));
    g.degree.push_back(std::stoi((*it)[2]));
    g.knots.push_back(numbers((*it)[3]));
  }
  std::string text;
  if (content(xml, std::regex(R"re(<coefs geoDim="(\d+)">)re"), m, text)) {
    g.geoDim = std::stoi(m[1]);
    g.coefs = numbers(text);
    EXPECT_EQ(xml.find("</coefs>\n </Geometry>", static_cast<size_t>(m.position(0))), m.position(0) + m.length(0) + text.size());
  }
  if (content(xml, std::regex(R"re(<Matrix rows="(\d+)" cols="(\d+)" id="1" label="element_region">)re"), m, text)) {
    g.hasRegions = true;
    g.regionRows = std::stoi(m[1]);
    g.regionCols = std::stoi(m[2]);
    g.regions = numbers(text);
  }
  return g;
}

void expectSame(const BSplineVolume& V, const GismoFile& g) {
  EXPECT_EQ(g.geometryType, "TensorBSpline3");
  EXPECT_EQ(g.basisType, "TensorBSplineBasis3");
  ASSERT_EQ(g.basisIndex, (std::vector<int>{0, 1, 2}));
  for (int d = 0; d < 3; ++d) {
    EXPECT_EQ(g.degree[d], V.degree(d));
    EXPECT_EQ(g.knots[d], V.knots(d).knots()) << "direction " << d;  // exact
  }
  EXPECT_EQ(g.geoDim, 3);
  ASSERT_EQ(g.coefs.size(), static_cast<size_t>(3 * V.numControlPoints()));
  // u fastest: the coefficient order is our control point order.
  for (Eigen::Index i = 0; i < V.numControlPoints(); ++i)
    for (int c = 0; c < 3; ++c) ASSERT_EQ(g.coefs[3 * i + c], V.controlPoints()(i, c)) << i;
  // The file's data, read back, is the same map.
  std::array<KnotVector, 3> kv;
  for (int d = 0; d < 3; ++d) kv[d] = KnotVector(g.degree[d], g.knots[d]);
  Eigen::MatrixX3d P(V.numControlPoints(), 3);
  for (Eigen::Index i = 0; i < P.rows(); ++i) P.row(i) << g.coefs[3 * i], g.coefs[3 * i + 1], g.coefs[3 * i + 2];
  const BSplineVolume R(kv[0], kv[1], kv[2], P);
  const Eigen::Vector3d u(0.31, 0.77, 0.123);
  const Eigen::Vector3d t = V.parameterMin() + (V.parameterMax() - V.parameterMin()).cwiseProduct(u);
  EXPECT_EQ((R.evaluate(t) - V.evaluate(t)).norm(), 0.0);
}

TEST(GismoExport, RoundTripsExactly) {
  const std::string dir = scratchDir("gismo_roundtrip");
  for (const auto& [name, V] : testVolumes()) {
    SCOPED_TRACE(name);
    const std::string path = dir + "/" + name + ".xml";
    tet2spline::writeGismoXml(V, path);
    const GismoFile g = parse(readFile(path));
    expectSame(V, g);
    EXPECT_FALSE(g.hasRegions);
  }
}

TEST(GismoExport, ElementRegionsAsMatrix) {
  const std::string dir = scratchDir("gismo_regions");
  const BSplineVolume V = curvedCube();
  const auto elements = V.elements();
  std::vector<int> region;
  for (const auto& e : elements) region.push_back(e.centre.x() < 0.5 ? 1 : 7);
  const std::string path = dir + "/regions.xml";
  tet2spline::writeGismoXml(V, path, region);
  const GismoFile g = parse(readFile(path));
  expectSame(V, g);
  ASSERT_TRUE(g.hasRegions);
  EXPECT_EQ(g.regionRows, static_cast<int>(elements.size()));
  EXPECT_EQ(g.regionCols, 1);
  ASSERT_EQ(g.regions.size(), region.size());
  for (size_t e = 0; e < region.size(); ++e) EXPECT_EQ(g.regions[e], region[e]);
}

TEST(GismoExport, Deterministic) {
  const std::string dir = scratchDir("gismo_determinism");
  tet2spline::writeGismoXml(cylinderPatch(), dir + "/a.xml");
  tet2spline::writeGismoXml(cylinderPatch(), dir + "/b.xml");
  EXPECT_EQ(readFile(dir + "/a.xml"), readFile(dir + "/b.xml"));
}

TEST(GismoExport, BadInputsLeaveNoFile) {
  const std::string dir = scratchDir("gismo_bad");
  const BSplineVolume V = refinedBox();
  // Region vector of the wrong size: a usage error, nothing written.
  try {
    tet2spline::writeGismoXml(V, dir + "/r.xml", {1, 2, 3});
    ADD_FAILURE() << "expected an error";
  } catch (const tet2spline::Error& e) {
    EXPECT_EQ(e.kind(), tet2spline::ErrorKind::Usage);
    EXPECT_NE(std::string(e.what()).find(dir + "/r.xml"), std::string::npos) << e.what();
  }
  // Unwritable: a missing directory, and a target that is a directory.
  const std::string missing = dir + "/no/such/dir/v.xml";
  expectInputError([&] { tet2spline::writeGismoXml(V, missing); }, missing, 0, "cannot");
  fs::create_directory(dir + "/isdir");
  expectInputError([&] { tet2spline::writeGismoXml(V, dir + "/isdir"); }, dir + "/isdir", 0, "cannot");
  std::vector<std::string> left;
  for (const auto& e : fs::directory_iterator(dir)) left.push_back(e.path().filename().string());
  EXPECT_EQ(left, std::vector<std::string>{"isdir"});
  EXPECT_TRUE(fs::is_empty(dir + "/isdir"));
}

}  // namespace

// A sample report.html from real meshes (bunny00, the two-material demo model), left in
// build/tests/io_test_tmp/html_report_sample/ for a human to open; checks the page's basic laws.
#include <gtest/gtest.h>

#include <Eigen/Geometry>

#include <chrono>
#include <cmath>
#include <iostream>
#include <set>

#include "html_test_util.h"
#include "tet2spline/io/html_report.h"
#include "tet2spline/io/mesh_io.h"
#include "tet2spline/io/png.h"
#include "tet2spline/param/tetrahedralize.h"
#include "test_data.h"

using namespace tet2spline;
using namespace t2stest;
namespace fs = std::filesystem;

// A page from real data, left in build/tests/io_test_tmp/html_report_sample/ for a human to open.
TEST(HtmlReportSample, FromRealMeshes) {
  const std::string bunnyPath = t2stest::cgalMesh("bunny00");
  if (!fs::exists(bunnyPath)) GTEST_SKIP() << bunnyPath << " missing (the test_data fixture fetches it)";
  using Clock = std::chrono::steady_clock;
  auto since = [](Clock::time_point t) { return std::chrono::duration<double>(Clock::now() - t).count(); };
  HtmlReport r;
  r.title = "Sample report: bunny00 and two_material";
  r.inputPath = bunnyPath;
  r.generator = "html_report_slow_test HtmlReportSample.FromRealMeshes (renderer and page only; no parameterization was run)";

  auto t0 = Clock::now();
  const SurfaceMesh bunny = readSurface(bunnyPath);
  const SurfaceMesh two = readSurface(t2stest::sourceDir() + "/models/two_material.off");
  r.timings.push_back({"read surfaces", since(t0)});
  t0 = Clock::now();
  const TetMesh tm = tetrahedralize(two, {}, "two_material.off");
  r.timings.push_back({"tetrahedralize", since(t0)});

  t0 = Clock::now();
  RenderOptions o;
  o.upAxis = 1;  // the bunny is y-up
  o.azimuthDeg = 30;
  o.elevationDeg = 15;
  const Image plain = renderSurface(bunny.V, bunny.F, {}, o);
  SurfaceColors height;
  height.vertexScalar = bunny.V.col(1);
  RenderOptions oh = o;
  oh.azimuthDeg = -50;
  oh.edges = true;
  const Image shaded = renderSurface(bunny.V, bunny.F, height, oh);
  r.timings.push_back({"render bunny (2 views)", since(t0)});

  t0 = Clock::now();
  Eigen::VectorXd volume(tm.numTets());
  for (Eigen::Index t = 0; t < tm.numTets(); ++t) {
    const Eigen::Vector3d a = tm.V.row(tm.T(t, 0)), b = tm.V.row(tm.T(t, 1)), c = tm.V.row(tm.T(t, 2)),
                          d = tm.V.row(tm.T(t, 3));
    volume[t] = (b - a).cross(c - a).dot(d - a) / 6;
  }
  const Eigen::Vector3d lo = tm.V.colwise().minCoeff(), hi = tm.V.colwise().maxCoeff();
  ClipPlane plane;
  plane.point = 0.5 * (lo + hi);
  plane.normal = Eigen::Vector3d(1, 0.3, 0);
  RenderOptions oc;
  oc.azimuthDeg = 25;
  oc.elevationDeg = 25;
  oc.edges = true;
  oc.edgeOpacity = 0.35;
  TetColors regionColors;
  regionColors.tetLabel = tm.region;
  const Image cutRegions = renderTetCut(tm.V, tm.T, plane, regionColors, oc);
  TetColors volumeColors;
  volumeColors.tetScalar = (volume.array() / volume.mean()).log10().matrix();
  RenderOptions ov = oc;
  ov.scalarMin = -1.5;
  ov.scalarMax = 0.5;
  const Image cutVolume = renderTetCut(tm.V, tm.T, plane, volumeColors, ov);
  r.timings.push_back({"render cuts (2 views)", since(t0)});

  ReportImage i1{"bunny00: input surface", plain};
  ReportImage i2{"bunny00: height (y), with edges", shaded};
  i2.hasColorBar = true;
  i2.scalarMin = bunny.V.col(1).minCoeff();
  i2.scalarMax = bunny.V.col(1).maxCoeff();
  i2.scalarLabel = "y coordinate";
  ReportImage i3{"two_material: tets cut by a plane, by region", cutRegions};
  std::set<int> tags(tm.region.data(), tm.region.data() + tm.region.size());
  for (const int tag : tags) i3.legend.push_back({tag, "region " + std::to_string(tag)});
  ReportImage i4{"two_material: log10(tet volume / mean) on the cut", cutVolume};
  i4.hasColorBar = true;
  i4.scalarMin = -1.5;
  i4.scalarMax = 0.5;
  i4.scalarLabel = "log10 volume / mean";
  r.images = {i1, i2, i3, i4};

  r.sections.push_back({"bunny00 surface",
                        {{"vertices", std::to_string(bunny.V.rows())}, {"triangles", std::to_string(bunny.F.rows())}}});
  double total = volume.sum();
  r.sections.push_back({"two_material tets",
                        {{"vertices", std::to_string(tm.numVertices())},
                         {"tets", std::to_string(tm.numTets())},
                         {"regions", std::to_string(tags.size())},
                         {"volume", std::to_string(total)}}});
  r.sections.push_back({"Renderer", {{"image size", "800 × 600"}, {"supersampling", "2 × 2"}, {"shading", "headlight Lambert"}}});
  ReportHistogram hv;
  hv.title = "Tet volume relative to the mean";
  hv.xLabel = "log10(volume / mean volume)";
  for (Eigen::Index t = 0; t < volume.size(); ++t) hv.values.push_back(std::log10(volume[t] / volume.mean()));
  hv.bins = 40;
  hv.hasReference = true;
  hv.reference = 0.0;
  hv.referenceLabel = "mean";
  ReportHistogram ha;
  ha.title = "bunny00 triangle areas";
  ha.xLabel = "area / mean area";
  Eigen::VectorXd area(bunny.F.rows());
  for (Eigen::Index f = 0; f < bunny.F.rows(); ++f)
    area[f] = 0.5 * (Eigen::Vector3d(bunny.V.row(bunny.F(f, 1)) - bunny.V.row(bunny.F(f, 0))))
                        .cross(Eigen::Vector3d(bunny.V.row(bunny.F(f, 2)) - bunny.V.row(bunny.F(f, 0))))
                        .norm();
  for (Eigen::Index f = 0; f < area.size(); ++f) ha.values.push_back(area[f] / area.mean());
  ha.logCounts = true;
  r.histograms = {hv, ha};
  for (const int tag : tags) {
    double v = 0;
    for (Eigen::Index t = 0; t < tm.numTets(); ++t)
      if (tm.region[t] == tag) v += volume[t];
    // Illustrative numbers: target = physical share, "achieved" perturbed.
    r.regions.push_back({tag, v / total, v / total * (tag == 1 ? 0.998 : 1.02), double(tm.numTets()) / total,
                         tm.voidRegions.count(tag) > 0});
  }
  r.warnings = {"This sample shows the page layout; the region numbers are illustrative."};
  r.verdict = "sample page rendered";

  const std::string dir = scratch("html_report_sample");
  writeHtmlReport(r, dir + "/report.html");
  writePng(shaded, dir + "/bunny.png");
  writePng(cutRegions, dir + "/cut.png");
  const std::string html = slurp(dir + "/report.html");
  EXPECT_EQ(tagBalanceProblem(html), "");
  EXPECT_EQ(occurrences(html, "data:image/png;base64,"), 4u);
  EXPECT_LT(html.size(), 8u << 20) << "page too heavy";
  // The bunny fills a fair part of its picture and leaves the corners empty.
  size_t covered = 0;
  for (int y = 0; y < plain.height; ++y)
    for (int x = 0; x < plain.width; ++x) covered += Rgb{plain.at(x, y)[0], plain.at(x, y)[1], plain.at(x, y)[2]} != o.background;
  EXPECT_GT(double(covered) / (plain.width * plain.height), 0.25);
  EXPECT_EQ((Rgb{plain.at(0, 0)[0], plain.at(0, 0)[1], plain.at(0, 0)[2]}), o.background);
  std::cout << "sample report: " << dir << "/report.html\n";
}

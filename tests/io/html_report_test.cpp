// report.html: self-contained, well-formed, escaped, histograms that add up, atomic and deterministic.
#include "tet2spline/io/html_report.h"

#include <gtest/gtest.h>

#include <Eigen/Geometry>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <regex>
#include <set>
#include <sstream>

#include "html_test_util.h"
#include "tet2spline/io/png.h"
#include "tet2spline/param/error.h"

using namespace tet2spline;
using namespace t2stest;
namespace fs = std::filesystem;

namespace {

/// Sum of data-count="..." inside the n-th <svg class="histogram">.
double histogramBarSum(const std::string& html, size_t n) {
  size_t at = 0;
  for (size_t i = 0; i <= n; ++i) {
    at = html.find("<svg class=\"histogram\"", at + (i ? 1 : 0));
    if (at == std::string::npos) return -1;
  }
  const size_t end = html.find("</svg>", at);
  const std::string svg = html.substr(at, end - at);
  static const std::regex count("data-count=\"([^\"]+)\"");
  double sum = 0;
  for (auto it = std::sregex_iterator(svg.begin(), svg.end(), count); it != std::sregex_iterator(); ++it)
    sum += std::stod((*it)[1]);
  return sum;
}

Image checkerImage(int w, int h) {
  Image im(w, h, 3);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      const uint8_t v = ((x / 8 + y / 8) % 2) ? 230 : 40;
      im.at(x, y)[0] = v, im.at(x, y)[1] = uint8_t(x * 4), im.at(x, y)[2] = uint8_t(y * 4);
    }
  return im;
}

/// A report with every part filled, and hostile text where text comes from the user.
HtmlReport fullReport() {
  HtmlReport r;
  r.title = "bracket <script>alert('x')</script> & co";
  r.inputPath = "/data/\"evil\" <img src=x onerror=alert(1)>.step";
  r.verdict = "valid spline: 0 negative Jacobians";
  r.generator = "tet2spline 0.1.0 convert --degree 3";
  r.warnings = {"OT stopped at 1.2e-5 > 1e-6 <b>not bold</b>", "region 3 got 0 elements"};
  r.sections = {{"Input", {{"vertices", "12 345"}, {"tets", "67 890"}, {"genus", "0"}, {"voids", "1", "filled, region 3"}}},
                {"Spline", {{"degree", "3"}, {"elements", "8 × 8 × 8"}, {"min scaled Jacobian", "0.12"}}}};
  ReportHistogram ratio;
  ratio.title = "Parametric / physical volume per tet";
  ratio.xLabel = "volume ratio";
  for (int i = 0; i < 1000; ++i) ratio.values.push_back(1.0 + 0.3 * std::sin(i * 0.37) * std::cos(i * 0.11));
  ratio.values.push_back(NAN);
  ratio.values.push_back(INFINITY);
  ratio.hasReference = true;
  ratio.reference = 1.0;
  ratio.referenceLabel = "target 1.0";
  ReportHistogram pre;
  pre.title = "det J at Gauss points";
  pre.xLabel = "scaled Jacobian";
  pre.binEdges = {0, 0.25, 0.5, 0.75, 1};
  pre.counts = {3, 40, 400, 2000};
  pre.logCounts = true;
  r.histograms = {ratio, pre};
  r.regions = {{1, 0.6, 0.5999, 812.5, false}, {2, 0.3, 0.31, 1625, false}, {3, 0.1, 0.0901, 90, true}};
  r.timings = {{"read", 0.012}, {"tetrahedralize", 3.4}, {"harmonic map", 1.25}, {"optimal transport", 12.8},
               {"fit <Ceres>", 40.1}, {"export", 0.0004}};
  ReportImage a;
  a.caption = "Input surface & regions";
  a.image = checkerImage(64, 48);
  a.legend = {{1, "material 1"}, {3, "void <3>"}};
  ReportImage b;
  b.caption = "Volume ratio on a cut";
  b.image = checkerImage(32, 32);
  b.hasColorBar = true;
  b.scalarMin = 0.5;
  b.scalarMax = 1.5;
  b.scalarLabel = "ratio";
  r.images = {a, b};
  return r;
}

}  // namespace

TEST(HtmlReport, SelfContainedAndWellFormed) {
  const std::string html = renderHtmlReport(fullReport());
  EXPECT_EQ(html.rfind("<!DOCTYPE html>", 0), 0u);
  EXPECT_EQ(tagBalanceProblem(html), "");
  EXPECT_EQ(html.find("http://"), std::string::npos);
  EXPECT_EQ(html.find("https://"), std::string::npos);
  EXPECT_EQ(html.find("<script"), std::string::npos);
  EXPECT_EQ(html.find("<link"), std::string::npos);
  EXPECT_EQ(html.find("url(http"), std::string::npos);
  EXPECT_EQ(occurrences(html, "<img src=\"data:image/png;base64,"), 2u);
  // Every src= is a data: URI.
  static const std::regex src("src=\"([^\"]*)\"");
  for (auto it = std::sregex_iterator(html.begin(), html.end(), src); it != std::sregex_iterator(); ++it)
    EXPECT_EQ((*it)[1].str().rfind("data:image/png;base64,", 0), 0u) << (*it)[1].str().substr(0, 40);
  EXPECT_NE(html.find("<meta charset=\"utf-8\">"), std::string::npos);
}

TEST(HtmlReport, EmbeddedPicturesAreThePngs) {
  const HtmlReport r = fullReport();
  const std::string html = renderHtmlReport(r);
  EXPECT_NE(html.find(pngDataUri(r.images[0].image)), std::string::npos);
  EXPECT_NE(html.find(pngDataUri(r.images[1].image)), std::string::npos);
  EXPECT_NE(html.find("linearGradient"), std::string::npos) << "colour bar";
}

TEST(HtmlReport, EscapesAllUserText) {
  const std::string html = renderHtmlReport(fullReport());
  EXPECT_EQ(html.find("<script>"), std::string::npos);
  EXPECT_EQ(html.find("<img src=x"), std::string::npos);
  EXPECT_EQ(html.find("<b>not bold</b>"), std::string::npos);
  EXPECT_EQ(html.find("<Ceres>"), std::string::npos);
  EXPECT_EQ(html.find("void <3>"), std::string::npos);
  EXPECT_NE(html.find("bracket &lt;script&gt;alert(&#39;x&#39;)&lt;/script&gt; &amp; co"), std::string::npos);
  EXPECT_NE(html.find("/data/&quot;evil&quot; &lt;img src=x onerror=alert(1)&gt;.step"), std::string::npos);
  EXPECT_NE(html.find("fit &lt;Ceres&gt;"), std::string::npos);
  // Control characters cannot sneak in either.
  HtmlReport r;
  r.inputPath = std::string("a\x01z\x1b[31m.off");
  const std::string page = renderHtmlReport(r);
  EXPECT_EQ(page.find('\x01'), std::string::npos);
  EXPECT_EQ(page.find('\x1b'), std::string::npos);
}

TEST(HtmlReport, HistogramBarsSumToTheSampleCount) {
  const HtmlReport r = fullReport();
  const std::string html = renderHtmlReport(r);
  EXPECT_EQ(occurrences(html, "<svg class=\"histogram\""), 2u);
  EXPECT_DOUBLE_EQ(histogramBarSum(html, 0), 1000.0) << "finite samples";
  EXPECT_NE(html.find("2 non-finite not shown"), std::string::npos);
  EXPECT_DOUBLE_EQ(histogramBarSum(html, 1), 3 + 40 + 400 + 2000);
  EXPECT_EQ(occurrences(html, "class=\"reference\""), 1u);
  EXPECT_NE(html.find("target 1.0"), std::string::npos);
  EXPECT_NE(html.find("count (log scale)"), std::string::npos);
}

TEST(HtmlReport, HistogramBinning) {
  ReportHistogram h;
  h.values = {0, 0.5, 1, 1, 2, -5, 7, NAN};
  h.bins = 4;
  h.rangeMin = 0;
  h.rangeMax = 2;
  HistogramBins b = histogramBins(h);
  ASSERT_EQ(b.edges.size(), 5u);
  EXPECT_EQ(b.edges.front(), 0);
  EXPECT_EQ(b.edges.back(), 2);
  // Out-of-range values land in the end bins; the top edge belongs to the last bin.
  EXPECT_EQ(b.counts, (std::vector<double>{2, 1, 2, 2}));
  EXPECT_EQ(b.nonFinite, 1u);
  // Data range when no range is given; a constant sample gets a unit-wide range.
  h.rangeMin = h.rangeMax = 0;
  b = histogramBins(h);
  EXPECT_EQ(b.edges.front(), -5);
  EXPECT_EQ(b.edges.back(), 7);
  h.values = {3, 3, 3};
  b = histogramBins(h);
  EXPECT_EQ(b.edges.front(), 2.5);
  EXPECT_EQ(b.edges.back(), 3.5);
  EXPECT_DOUBLE_EQ(b.counts[0] + b.counts[1] + b.counts[2] + b.counts[3], 3);
  // Pre-binned data must be consistent.
  ReportHistogram p;
  p.binEdges = {0, 1, 1};
  p.counts = {1, 2};
  EXPECT_THROW(histogramBins(p), std::invalid_argument);
  p.binEdges = {0, 1};
  EXPECT_THROW(histogramBins(p), std::invalid_argument);
  p.binEdges = {0, 1, 2};
  p.counts = {1, -2};
  EXPECT_THROW(histogramBins(p), std::invalid_argument);
  h.bins = 0;
  EXPECT_THROW(histogramBins(h), std::invalid_argument);
}

TEST(HtmlReport, VerdictWarningsTimingsAndRegions) {
  HtmlReport r = fullReport();
  std::string html = renderHtmlReport(r);
  EXPECT_NE(html.find("<header class=\"top warn\">"), std::string::npos) << "warnings make the verdict amber";
  EXPECT_NE(html.find("valid spline: 0 negative Jacobians"), std::string::npos);
  EXPECT_NE(html.find("2 warnings"), std::string::npos);
  EXPECT_EQ(occurrences(html, "data-seconds="), r.timings.size());
  EXPECT_EQ(occurrences(html, "<tr"), r.regions.size() + 1);
  EXPECT_NE(html.find(">void<"), std::string::npos);
  r.warnings.clear();
  html = renderHtmlReport(r);
  EXPECT_NE(html.find("<header class=\"top ok\">"), std::string::npos);
  EXPECT_EQ(html.find("class=\"warnings\""), std::string::npos);
  r.verdictLevel = ReportVerdict::Failure;
  r.verdict.clear();
  html = renderHtmlReport(r);
  EXPECT_NE(html.find("<header class=\"top fail\">"), std::string::npos);
  // An empty report is still a valid page.
  const std::string empty = renderHtmlReport(HtmlReport{});
  EXPECT_EQ(tagBalanceProblem(empty), "");
  EXPECT_NE(empty.find("completed"), std::string::npos);
}

TEST(HtmlReport, WrittenAtomicallyAndDeterministically) {
  const std::string dir = scratch("html_report_write");
  const HtmlReport r = fullReport();
  writeHtmlReport(r, dir + "/report.html");
  EXPECT_EQ(slurp(dir + "/report.html"), renderHtmlReport(r));
  writeHtmlReport(r, dir + "/again.html");
  EXPECT_EQ(slurp(dir + "/again.html"), slurp(dir + "/report.html"));
  const std::string bad = dir + "/no/such/dir/report.html";
  try {
    writeHtmlReport(r, bad);
    ADD_FAILURE() << "no exception";
  } catch (const Error& e) {
    EXPECT_EQ(e.kind(), ErrorKind::Input);
    EXPECT_NE(std::string(e.what()).find(bad), std::string::npos);
  }
  EXPECT_EQ(std::distance(fs::directory_iterator(dir), fs::directory_iterator()), 2);
}

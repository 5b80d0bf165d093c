#pragma once
/// report.html: one self-contained page that shows the result of a run.
///
/// No network, no external files, no scripts: inline CSS, pictures as
/// data:image/png;base64 URIs, charts as inline SVG. Every string of the
/// HtmlReport is escaped, so file names cannot inject markup. The page is a
/// pure function of the struct (no clock, no environment): same report, same bytes.

#include <string>
#include <utility>
#include <vector>

#include "tet2spline/io/image.h"
#include "tet2spline/io/render.h"

namespace tet2spline {

/// One key figure, e.g. {"tets", "771 204"} or {"max relative mass error", "8.3e-07"}.
struct ReportFigure {
  std::string name;
  std::string value;
  std::string note;  ///< optional small print under the value (units, tolerance)
  ReportFigure() = default;
  ReportFigure(std::string n, std::string v, std::string small = {})
      : name(std::move(n)), value(std::move(v)), note(std::move(small)) {}
};

/// A card of key figures, e.g. "Input", "Harmonic map", "Optimal transport".
struct ReportSection {
  std::string title;
  std::vector<ReportFigure> figures;
};

/// A histogram drawn as SVG. Either raw `values` (binned into `bins` equal bins
/// over [rangeMin, rangeMax], or the finite data's range when rangeMin >= rangeMax;
/// values outside the range go to the first/last bin; non-finite values are
/// counted and reported below the chart, not drawn) or pre-binned `binEdges`
/// (#bins + 1, increasing) with `counts` (#bins).
struct ReportHistogram {
  std::string title;
  std::string xLabel;
  std::vector<double> values;
  int bins = 30;
  double rangeMin = 0, rangeMax = 0;
  std::vector<double> binEdges;
  std::vector<double> counts;
  bool hasReference = false;  ///< draw a dashed vertical line at `reference` (e.g. ratio 1.0)
  double reference = 0;
  std::string referenceLabel;
  bool logCounts = false;     ///< y axis log10(1 + count), for long tails
};

/// One row of the regions table (design.md, "Materials and knots").
struct ReportRegion {
  int id = 0;
  double targetVolumeFraction = 0;    ///< parametric volume share the user asked for
  double achievedVolumeFraction = 0;  ///< parametric volume share obtained
  double elementsPerVolume = 0;       ///< Bézier elements per unit physical volume
  bool isVoid = false;
};

struct ReportTiming {
  std::string stage;
  double seconds = 0;
};

/// A picture and, optionally, the legend of its colours.
struct ReportImage {
  std::string caption;
  Image image;
  /// Continuous colours: a colour bar of colorMap over [scalarMin, scalarMax]; pass the
  /// range the picture was rendered with (RenderOptions::scalarMin/Max).
  bool hasColorBar = false;
  ColorMap colorMap = ColorMap::Viridis;
  double scalarMin = 0, scalarMax = 1;
  std::string scalarLabel;
  std::vector<std::pair<int, std::string>> legend;  ///< categorical colours: label → name (categoricalColor)
  ReportImage() = default;
  ReportImage(std::string c, Image im) : caption(std::move(c)), image(std::move(im)) {}
};

enum class ReportVerdict { Ok, Warning, Failure };

struct HtmlReport {
  std::string title = "tet2spline report";
  std::string inputPath;
  std::string verdict;            ///< headline, e.g. "valid spline: 0 negative Jacobians"
  ReportVerdict verdictLevel = ReportVerdict::Ok;  ///< green, amber or red; amber at least when warnings exist
  std::string generator;          ///< e.g. "tet2spline 0.1.0 convert --degree 3" (small print)
  std::vector<std::string> warnings;
  std::vector<ReportSection> sections;
  std::vector<ReportImage> images;
  std::vector<ReportHistogram> histograms;
  std::vector<ReportRegion> regions;
  std::vector<ReportTiming> timings;
};

/// The bins a histogram is drawn with: edges (#bins + 1) and counts (#bins), and
/// how many values were not finite (not drawn). Throws std::invalid_argument naming
/// histogramBins when bins < 1, or pre-binned edges/counts disagree in size, are not
/// increasing, or hold negative/non-finite counts.
struct HistogramBins {
  std::vector<double> edges;
  std::vector<double> counts;
  size_t nonFinite = 0;
};
HistogramBins histogramBins(const ReportHistogram& h);

/// The page as a string (UTF-8).
std::string renderHtmlReport(const HtmlReport& report);

/// Writes renderHtmlReport(report) to `path` through AtomicFile: a failure leaves no
/// file. Throws Error(Input) naming `path` when it cannot be written.
void writeHtmlReport(const HtmlReport& report, const std::string& path);

}  // namespace tet2spline

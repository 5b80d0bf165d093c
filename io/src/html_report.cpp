// report.html (see html_report.h).
#include "tet2spline/io/html_report.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <sstream>
#include <stdexcept>

#include "svg_util.h"
#include "tet2spline/io/atomic_file.h"
#include "tet2spline/io/png.h"

namespace tet2spline {

namespace {

using svg::coord;
using svg::escape;
using svg::number;

std::string hexColor(const Rgb& c) {
  char hex[8];
  std::snprintf(hex, sizeof hex, "#%02x%02x%02x", c.r, c.g, c.b);
  return hex;
}

std::string countText(double c) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.15g", c);
  return buf;
}

std::string percent(double f) {
  if (!std::isfinite(f)) return number(f);
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.2f%%", 100 * f);
  return buf;
}

std::string seconds(double s) {
  char buf[64];
  if (!std::isfinite(s)) return number(s);
  if (s < 1e-3) std::snprintf(buf, sizeof buf, "%.0f µs", s * 1e6);
  else if (s < 1) std::snprintf(buf, sizeof buf, "%.0f ms", s * 1e3);
  else if (s < 100) std::snprintf(buf, sizeof buf, "%.2f s", s);
  else if (s < 3600) std::snprintf(buf, sizeof buf, "%d min %02d s", int(s / 60), int(std::fmod(s, 60)));
  else std::snprintf(buf, sizeof buf, "%d h %02d min", int(s / 3600), int(std::fmod(s, 3600) / 60));
  return buf;
}

const char* kStyle = R"css(
:root{--ink:#1f2733;--muted:#5d6b7e;--line:#dfe4ea;--card:#fff;--bg:#f3f5f8;--ok:#15803d;--warn:#b45309;--fail:#b91c1c;--accent:#2f6fae}
*{box-sizing:border-box}
body{margin:0;background:var(--bg);color:var(--ink);font:14px/1.45 system-ui,-apple-system,"Segoe UI",Roboto,"Helvetica Neue",Arial,sans-serif}
header.top{background:#1d2635;color:#eef2f7;padding:22px 32px 20px;border-bottom:5px solid var(--ok)}
header.top.warn{border-bottom-color:#f59e0b}
header.top.fail{border-bottom-color:#ef4444}
.brand{font-size:12px;letter-spacing:.12em;text-transform:uppercase;color:#9fb0c6}
h1{margin:4px 0 6px;font-size:24px;font-weight:600}
.input{font:13px/1.4 ui-monospace,SFMono-Regular,Menlo,Consolas,monospace;color:#c9d4e3;word-break:break-all}
.verdict{display:inline-flex;align-items:center;gap:10px;margin-top:14px;padding:7px 14px 7px 8px;border-radius:999px;font-weight:600;font-size:15px}
.verdict .mark{display:inline-flex;align-items:center;justify-content:center;width:24px;height:24px;border-radius:50%;color:#fff;font-size:14px}
.verdict.ok{background:#dcfce7;color:#14532d}.verdict.ok .mark{background:var(--ok)}
.verdict.warn{background:#fef3c7;color:#78350f}.verdict.warn .mark{background:#d97706}
.verdict.fail{background:#fee2e2;color:#7f1d1d}.verdict.fail .mark{background:var(--fail)}
main{max-width:1240px;margin:0 auto;padding:22px 28px 40px}
h2{font-size:17px;font-weight:600;margin:26px 0 12px}
.card h2,.warnings h2{margin:0 0 10px}
.card{background:var(--card);border:1px solid var(--line);border-radius:10px;padding:16px 18px;box-shadow:0 1px 2px rgba(20,30,50,.05)}
.warnings{background:#fffbeb;border:1px solid #fcd34d;border-left:6px solid #f59e0b;border-radius:10px;padding:14px 18px;margin-top:4px}
.warnings h2{color:#92400e;font-size:16px}
.warnings ul{margin:0;padding-left:20px}.warnings li{margin:3px 0}
.cards{display:grid;grid-template-columns:repeat(auto-fill,minmax(270px,1fr));gap:16px}
dl.figs{display:grid;grid-template-columns:1fr auto;gap:6px 14px;margin:0}
dl.figs dt{color:var(--muted)}
dl.figs dd{margin:0;text-align:right;font-variant-numeric:tabular-nums;font-weight:600}
dl.figs dd small{display:block;font-weight:400;color:var(--muted);font-size:11px}
.gallery{display:grid;grid-template-columns:repeat(auto-fill,minmax(440px,1fr));gap:16px}
figure{margin:0}
.gallery img{display:block;width:100%;height:auto;border-radius:6px;background:#fff}
figcaption{margin-top:8px;color:var(--muted)}
.legend{display:flex;flex-wrap:wrap;gap:6px 16px;margin-top:8px;font-size:13px}
.swatch{display:inline-block;width:12px;height:12px;border-radius:3px;margin-right:6px;vertical-align:-1px;border:1px solid rgba(0,0,0,.15)}
.charts{display:grid;grid-template-columns:repeat(auto-fill,minmax(460px,1fr));gap:16px}
.charts svg{width:100%;height:auto;display:block}
.stats{color:var(--muted);font-size:12px;margin-top:6px;font-variant-numeric:tabular-nums}
table{border-collapse:collapse;width:100%;font-variant-numeric:tabular-nums}
th,td{padding:7px 10px;border-bottom:1px solid var(--line);text-align:right}
th{font-weight:600;color:var(--muted);font-size:12px;text-transform:uppercase;letter-spacing:.04em}
th:first-child,td:first-child,th:nth-child(2),td:nth-child(2){text-align:left}
tr.void td{color:var(--muted)}
.dev-bad{color:var(--warn);font-weight:600}
.timings svg{width:100%;max-width:900px;height:auto;display:block}
footer{max-width:1240px;margin:0 auto;padding:0 28px 30px;color:var(--muted);font-size:12px}
@media print{body{background:#fff}.card{box-shadow:none;break-inside:avoid}header.top{-webkit-print-color-adjust:exact;print-color-adjust:exact}}
)css";

void writeHistogram(std::ostringstream& s, const ReportHistogram& h) {
  const HistogramBins b = histogramBins(h);
  const double W = 520, H = 276, left = 56, right = 18, top = 22, bottom = 48;
  const double plotW = W - left - right, plotH = H - top - bottom;
  const double x0 = b.edges.front(), x1 = b.edges.back();
  double maxCount = 0, total = 0;
  for (const double c : b.counts) maxCount = std::max(maxCount, c), total += c;
  auto X = [&](double x) { return left + plotW * (x - x0) / (x1 - x0); };
  auto yFrac = [&](double c) {
    if (maxCount <= 0) return 0.0;
    return h.logCounts ? std::log10(1 + c) / std::log10(1 + maxCount) : c / maxCount;
  };
  auto Y = [&](double c) { return top + plotH * (1 - yFrac(c)); };

  s << "<figure class=\"card\"><h2>" << escape(h.title) << "</h2>";
  s << "<svg class=\"histogram\" viewBox=\"0 0 " << W << ' ' << H
    << "\" role=\"img\" aria-label=\"" << escape(h.title) << "\">";
  // y grid and ticks
  std::vector<double> yTicks;
  if (h.logCounts) {
    yTicks.push_back(0);
    for (double p = 1; p <= maxCount; p *= 10) yTicks.push_back(p);
  } else {
    yTicks = svg::niceTicks(0, std::max(maxCount, 1.0), 5);
  }
  double lastTickY = 1e9;
  for (const double t : yTicks) {
    const double y = Y(t);
    if (y < top - 0.5 || lastTickY - y < 16) continue;  // no overlapping labels (log scale: 0 and 1)
    lastTickY = y;
    s << "<line x1=\"" << left << "\" x2=\"" << W - right << "\" y1=\"" << coord(y) << "\" y2=\"" << coord(y)
      << "\" stroke=\"#e6eaef\"/>";
    s << "<text x=\"" << left - 6 << "\" y=\"" << coord(y + 4) << "\" font-size=\"11\" text-anchor=\"end\" fill=\"#5d6b7e\">"
      << number(t, 6) << "</text>";
  }
  // bars
  s << "<g class=\"bars\" fill=\"#4e79a7\">";
  for (size_t i = 0; i < b.counts.size(); ++i) {
    const double xa = X(b.edges[i]), xb = X(b.edges[i + 1]);
    const double y = Y(b.counts[i]);
    const double w = std::max(0.0, xb - xa - (xb - xa > 3 ? 1 : 0));
    s << "<rect x=\"" << coord(xa) << "\" y=\"" << coord(y) << "\" width=\"" << coord(w) << "\" height=\""
      << coord(top + plotH - y) << "\" data-count=\"" << countText(b.counts[i]) << "\"><title>["
      << number(b.edges[i]) << ", " << number(b.edges[i + 1]) << "): " << countText(b.counts[i])
      << "</title></rect>";
  }
  s << "</g>";
  // axes
  s << "<line x1=\"" << left << "\" x2=\"" << W - right << "\" y1=\"" << top + plotH << "\" y2=\"" << top + plotH
    << "\" stroke=\"#334\"/>";
  s << "<line x1=\"" << left << "\" x2=\"" << left << "\" y1=\"" << top << "\" y2=\"" << top + plotH
    << "\" stroke=\"#334\"/>";
  for (const double t : svg::niceTicks(x0, x1, 6)) {
    const double x = X(t);
    s << "<line x1=\"" << coord(x) << "\" x2=\"" << coord(x) << "\" y1=\"" << top + plotH << "\" y2=\"" << top + plotH + 5
      << "\" stroke=\"#334\"/>";
    s << "<text x=\"" << coord(x) << "\" y=\"" << top + plotH + 18
      << "\" font-size=\"11\" text-anchor=\"middle\" fill=\"#5d6b7e\">" << number(t, 6) << "</text>";
  }
  if (h.hasReference && std::isfinite(h.reference) && h.reference >= x0 && h.reference <= x1) {
    const double x = X(h.reference);
    s << "<line class=\"reference\" x1=\"" << coord(x) << "\" x2=\"" << coord(x) << "\" y1=\"" << top << "\" y2=\""
      << top + plotH << "\" stroke=\"#c2410c\" stroke-width=\"1.5\" stroke-dasharray=\"5 3\"/>";
    // The label sits in the top margin, above the bars, centred on the line unless near an end.
    const char* anchor = x > left + plotW * 0.85 ? "end" : x < left + plotW * 0.15 ? "start" : "middle";
    s << "<text x=\"" << coord(x) << "\" y=\"" << top - 6 << "\" font-size=\"11\" fill=\"#c2410c\" text-anchor=\""
      << anchor << "\">" << escape(h.referenceLabel.empty() ? number(h.reference) : h.referenceLabel) << "</text>";
  }
  s << "<text x=\"" << coord(left + plotW / 2) << "\" y=\"" << H - 8
    << "\" font-size=\"12\" text-anchor=\"middle\" fill=\"#1f2733\">" << escape(h.xLabel) << "</text>";
  s << "<text transform=\"translate(14 " << coord(top + plotH / 2)
    << ") rotate(-90)\" font-size=\"12\" text-anchor=\"middle\" fill=\"#1f2733\">"
    << (h.logCounts ? "count (log scale)" : "count") << "</text>";
  s << "</svg>";

  // Summary line.
  s << "<div class=\"stats\">";
  if (!h.values.empty()) {
    std::vector<double> finite;
    for (const double v : h.values)
      if (std::isfinite(v)) finite.push_back(v);
    std::sort(finite.begin(), finite.end());
    s << "n = " << finite.size();
    if (!finite.empty()) {
      const double median = finite.size() % 2 ? finite[finite.size() / 2]
                                              : 0.5 * (finite[finite.size() / 2 - 1] + finite[finite.size() / 2]);
      s << " · min " << number(finite.front()) << " · median " << number(median) << " · max " << number(finite.back());
    }
  } else {
    s << "n = " << countText(total);
  }
  if (b.nonFinite) s << " · <strong>" << b.nonFinite << " non-finite not shown</strong>";
  s << "</div></figure>";
}

void writeTimings(std::ostringstream& s, const std::vector<ReportTiming>& timings) {
  double total = 0, maxT = 0;
  for (const auto& t : timings)
    if (std::isfinite(t.seconds) && t.seconds > 0) total += t.seconds, maxT = std::max(maxT, t.seconds);
  const double rowH = 26, labelW = 190, valueW = 150, W = 860;
  const double barW = W - labelW - valueW - 16;
  const double H = rowH * double(timings.size() + 1) + 8;
  s << "<svg class=\"timing-chart\" viewBox=\"0 0 " << W << ' ' << coord(H)
    << "\" role=\"img\" aria-label=\"time per stage\">";
  for (size_t i = 0; i < timings.size(); ++i) {
    const auto& t = timings[i];
    const double y = 4 + rowH * double(i);
    const double v = std::isfinite(t.seconds) && t.seconds > 0 ? t.seconds : 0;
    const double w = maxT > 0 ? barW * v / maxT : 0;
    if (i % 2 == 0)
      s << "<rect x=\"0\" y=\"" << coord(y) << "\" width=\"" << W << "\" height=\"" << rowH << "\" fill=\"#f6f8fa\"/>";
    s << "<text x=\"" << labelW - 10 << "\" y=\"" << coord(y + 17)
      << "\" font-size=\"13\" text-anchor=\"end\" fill=\"#1f2733\">" << escape(t.stage) << "</text>";
    s << "<rect x=\"" << labelW << "\" y=\"" << coord(y + 5) << "\" width=\"" << coord(std::max(w, v > 0 ? 1.0 : 0.0))
      << "\" height=\"" << rowH - 10 << "\" rx=\"2\" fill=\"#2f6fae\" data-seconds=\"" << countText(t.seconds)
      << "\"/>";
    s << "<text x=\"" << coord(labelW + w + 8) << "\" y=\"" << coord(y + 17) << "\" font-size=\"12\" fill=\"#1f2733\">"
      << escape(seconds(t.seconds));
    if (total > 0) s << "<tspan fill=\"#5d6b7e\">  (" << number(100 * v / total, 3) << "%)</tspan>";
    s << "</text>";
  }
  const double y = 4 + rowH * double(timings.size());
  s << "<line x1=\"" << labelW << "\" x2=\"" << W - valueW << "\" y1=\"" << coord(y + 2) << "\" y2=\"" << coord(y + 2)
    << "\" stroke=\"#c5cdd8\"/>";
  s << "<text x=\"" << labelW - 10 << "\" y=\"" << coord(y + 18)
    << "\" font-size=\"13\" font-weight=\"600\" text-anchor=\"end\" fill=\"#1f2733\">total</text>";
  s << "<text x=\"" << labelW << "\" y=\"" << coord(y + 18) << "\" font-size=\"13\" font-weight=\"600\" fill=\"#1f2733\">"
    << escape(seconds(total)) << "</text>";
  s << "</svg>";
}

void writeRegions(std::ostringstream& s, const std::vector<ReportRegion>& regions) {
  s << "<div class=\"card\"><table><thead><tr><th>Region</th><th>Kind</th><th>Target volume</th>"
       "<th>Achieved volume</th><th>Deviation</th><th>Elements / volume</th></tr></thead><tbody>";
  for (const auto& r : regions) {
    const double dev = r.targetVolumeFraction > 0 ? r.achievedVolumeFraction / r.targetVolumeFraction - 1 : NAN;
    s << "<tr" << (r.isVoid ? " class=\"void\"" : "") << "><td><span class=\"swatch\" style=\"background:"
      << hexColor(categoricalColor(r.id)) << "\"></span>" << r.id << "</td><td>" << (r.isVoid ? "void" : "material")
      << "</td><td>" << percent(r.targetVolumeFraction) << "</td><td>" << percent(r.achievedVolumeFraction) << "</td>";
    s << "<td" << (std::isfinite(dev) && std::abs(dev) > 0.01 ? " class=\"dev-bad\"" : "") << ">";
    if (std::isfinite(dev)) s << (dev >= 0 ? "+" : "") << number(100 * dev, 3) << "%";
    else s << "–";
    s << "</td><td>" << number(r.elementsPerVolume) << "</td></tr>";
  }
  s << "</tbody></table></div>";
}

void writeImage(std::ostringstream& s, const ReportImage& im) {
  s << "<figure class=\"card\">";
  if (!im.image.empty())
    s << "<img src=\"" << pngDataUri(im.image) << "\" width=\"" << im.image.width << "\" height=\"" << im.image.height
      << "\" alt=\"" << escape(im.caption) << "\">";
  if (im.hasColorBar) s << colorBarSvg(im.colorMap, im.scalarMin, im.scalarMax, im.scalarLabel, 320, 56);
  if (!im.legend.empty()) {
    s << "<div class=\"legend\">";
    for (const auto& [label, name] : im.legend)
      s << "<span><span class=\"swatch\" style=\"background:" << hexColor(categoricalColor(label)) << "\"></span>"
        << escape(name) << "</span>";
    s << "</div>";
  }
  s << "<figcaption>" << escape(im.caption) << "</figcaption></figure>";
}

}  // namespace

HistogramBins histogramBins(const ReportHistogram& h) {
  HistogramBins b;
  if (!h.binEdges.empty() || !h.counts.empty()) {
    if (h.binEdges.size() != h.counts.size() + 1 || h.counts.empty())
      throw std::invalid_argument("histogramBins: '" + h.title + "' has " + std::to_string(h.binEdges.size()) +
                                  " bin edges for " + std::to_string(h.counts.size()) + " counts (need counts + 1)");
    for (size_t i = 0; i + 1 < h.binEdges.size(); ++i)
      if (!(h.binEdges[i] < h.binEdges[i + 1]) || !std::isfinite(h.binEdges[i + 1]) || !std::isfinite(h.binEdges[i]))
        throw std::invalid_argument("histogramBins: '" + h.title + "' bin edges are not finite and increasing at " +
                                    std::to_string(i));
    for (const double c : h.counts)
      if (!(c >= 0) || !std::isfinite(c))
        throw std::invalid_argument("histogramBins: '" + h.title + "' has a negative or non-finite count");
    b.edges = h.binEdges;
    b.counts = h.counts;
    return b;
  }
  if (h.bins < 1 || h.bins > 10000)
    throw std::invalid_argument("histogramBins: '" + h.title + "' asks for " + std::to_string(h.bins) + " bins (1..10000)");
  double lo = h.rangeMin, hi = h.rangeMax;
  if (!(lo < hi) || !std::isfinite(lo) || !std::isfinite(hi)) {
    lo = INFINITY;
    hi = -INFINITY;
    for (const double v : h.values)
      if (std::isfinite(v)) lo = std::min(lo, v), hi = std::max(hi, v);
    if (!(lo <= hi)) lo = 0, hi = 1;
    if (lo == hi) lo -= 0.5, hi += 0.5;
  }
  const int n = h.bins;
  b.edges.resize(size_t(n) + 1);
  for (int i = 0; i <= n; ++i) b.edges[size_t(i)] = lo + (hi - lo) * i / n;
  b.counts.assign(size_t(n), 0.0);
  for (const double v : h.values) {
    if (!std::isfinite(v)) {
      ++b.nonFinite;
      continue;
    }
    const long i = std::clamp(long(std::floor((v - lo) / (hi - lo) * n)), 0L, long(n - 1));
    b.counts[size_t(i)] += 1;
  }
  return b;
}

std::string renderHtmlReport(const HtmlReport& r) {
  ReportVerdict level = r.verdictLevel;
  if (!r.warnings.empty() && level == ReportVerdict::Ok) level = ReportVerdict::Warning;
  const char* levelClass = level == ReportVerdict::Ok ? "ok" : level == ReportVerdict::Warning ? "warn" : "fail";
  const char* mark = level == ReportVerdict::Ok ? "&#10003;" : level == ReportVerdict::Warning ? "!" : "&#10007;";
  std::string verdict = r.verdict;
  if (verdict.empty())
    verdict = level == ReportVerdict::Failure ? "failed"
              : r.warnings.empty()           ? "completed"
                                             : "completed with " + std::to_string(r.warnings.size()) +
                                         (r.warnings.size() == 1 ? " warning" : " warnings");

  std::ostringstream s;
  s << "<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\">\n"
       "<meta name=\"viewport\" content=\"width=device-width, initial-scale=1\">\n<title>"
    << escape(r.title) << "</title>\n<style>" << kStyle << "</style>\n</head>\n<body>\n";
  s << "<header class=\"top " << levelClass << "\"><div class=\"brand\">tet2spline</div><h1>" << escape(r.title)
    << "</h1>";
  if (!r.inputPath.empty()) s << "<div class=\"input\">" << escape(r.inputPath) << "</div>";
  s << "<div class=\"verdict " << levelClass << "\"><span class=\"mark\">" << mark << "</span><span>"
    << escape(verdict) << "</span></div></header>\n<main>\n";

  if (!r.warnings.empty()) {
    s << "<section class=\"warnings\"><h2>" << r.warnings.size() << (r.warnings.size() == 1 ? " warning" : " warnings")
      << "</h2><ul>";
    for (const auto& w : r.warnings) s << "<li>" << escape(w) << "</li>";
    s << "</ul></section>\n";
  }
  if (!r.sections.empty()) {
    s << "<h2>Summary</h2><section class=\"cards\">";
    for (const auto& sec : r.sections) {
      s << "<div class=\"card\"><h2>" << escape(sec.title) << "</h2><dl class=\"figs\">";
      for (const auto& f : sec.figures) {
        s << "<dt>" << escape(f.name) << "</dt><dd>" << escape(f.value);
        if (!f.note.empty()) s << "<small>" << escape(f.note) << "</small>";
        s << "</dd>";
      }
      s << "</dl></div>";
    }
    s << "</section>\n";
  }
  if (!r.images.empty()) {
    s << "<h2>Pictures</h2><section class=\"gallery\">";
    for (const auto& im : r.images) writeImage(s, im);
    s << "</section>\n";
  }
  if (!r.histograms.empty()) {
    s << "<h2>Distributions</h2><section class=\"charts\">";
    for (const auto& h : r.histograms) writeHistogram(s, h);
    s << "</section>\n";
  }
  if (!r.regions.empty()) {
    s << "<h2>Regions</h2><section class=\"regions\">";
    writeRegions(s, r.regions);
    s << "</section>\n";
  }
  if (!r.timings.empty()) {
    s << "<h2>Time per stage</h2><section class=\"timings card\">";
    writeTimings(s, r.timings);
    s << "</section>\n";
  }
  s << "</main>\n<footer>" << escape(r.generator.empty() ? std::string("tet2spline") : r.generator)
    << "</footer>\n</body>\n</html>\n";
  return s.str();
}

void writeHtmlReport(const HtmlReport& report, const std::string& path) {
  const std::string html = renderHtmlReport(report);
  AtomicFile file(path, /*binary=*/true);
  file.stream() << html;
  file.commit();
}

}  // namespace tet2spline

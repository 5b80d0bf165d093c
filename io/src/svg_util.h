#pragma once
// Text helpers shared by the SVG/HTML writers of render.cpp and html_report.cpp.
#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

namespace tet2spline::svg {

/// Escapes & < > " ' so the text is safe in element content and in quoted attributes.
/// Control characters other than tab/newline become U+FFFD (they are not allowed in HTML).
inline std::string escape(const std::string& s) {
  std::string out;
  out.reserve(s.size() + 16);
  for (const char ch : s) {
    const unsigned char c = static_cast<unsigned char>(ch);
    switch (ch) {
      case '&': out += "&amp;"; break;
      case '<': out += "&lt;"; break;
      case '>': out += "&gt;"; break;
      case '"': out += "&quot;"; break;
      case '\'': out += "&#39;"; break;
      default:
        if ((c < 0x20 && ch != '\t' && ch != '\n') || c == 0x7f) out += "\xEF\xBF\xBD";
        else out += ch;
    }
  }
  return out;
}

/// A short human number: %.4g, with "−" style kept ASCII, "-0" printed as "0".
inline std::string number(double v, int digits = 4) {
  if (std::isnan(v)) return "NaN";
  if (std::isinf(v)) return v > 0 ? "inf" : "-inf";
  if (v == 0) v = 0;  // no "-0"
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.*g", digits, v);
  return buf;
}

/// A coordinate for SVG attributes: fixed two decimals, no locale.
inline std::string coord(double v) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.2f", std::abs(v) < 5e-3 ? 0.0 : v);
  return buf;
}

/// "Nice" tick positions (1, 2, 5 × 10^k steps) covering [lo, hi], about `target` of them.
inline std::vector<double> niceTicks(double lo, double hi, int target = 5) {
  std::vector<double> ticks;
  if (!(std::isfinite(lo) && std::isfinite(hi))) return ticks;
  if (hi < lo) std::swap(lo, hi);
  if (hi == lo) return {lo};
  const double raw = (hi - lo) / std::max(1, target);
  const double mag = std::pow(10.0, std::floor(std::log10(raw)));
  const double f = raw / mag * (1 + 1e-9);  // 2.9999… counts as 3
  const double step = (f < 1.5 ? 1 : f < 3 ? 2 : f < 7 ? 5 : 10) * mag;
  const double first = std::ceil(lo / step - 1e-9) * step;
  for (int i = 0; i < 100; ++i) {
    const double t = first + i * step;
    if (t > hi + step * 1e-9) break;
    ticks.push_back(std::abs(t) < step * 1e-9 ? 0.0 : t);
  }
  return ticks;
}

}  // namespace tet2spline::svg

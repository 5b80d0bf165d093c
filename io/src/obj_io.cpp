// Wavefront OBJ surfaces: `v x y z [w]` and `f` with v, v/vt, v/vt/vn or v//vn
// references (1-based; negative = relative to the last vertex); polygons are
// fanned. Everything else (vt, vn, g, o, s, usemtl, l, ...) is ignored.
#include <charconv>
#include <cmath>
#include <vector>

#include "format_readers.h"
#include "io_util.h"
#include "tet2spline/io/atomic_file.h"

namespace tet2spline::detail {

SurfaceMesh readObj(const std::string& path) {
  Cursor c(path, readWholeFile(path), '#');
  if (c.atEnd()) throwInputError(path, 0, "empty file (only comments or whitespace)");
  std::vector<double> V;
  std::vector<Eigen::Vector3i> F;
  std::vector<int> poly;
  bool sawData = false;
  while (!c.atEnd()) {
    const std::string_view line = c.restOfLine();
    const long lineNo = c.line();
    // Tokenize the line (comments stripped).
    std::string_view rest = line.substr(0, line.find('#'));
    std::vector<std::string_view> tok;
    size_t i = 0;
    while (i < rest.size()) {
      while (i < rest.size() && (rest[i] == ' ' || rest[i] == '\t' || rest[i] == '\r')) ++i;
      const size_t b = i;
      while (i < rest.size() && rest[i] != ' ' && rest[i] != '\t' && rest[i] != '\r') ++i;
      if (i > b) tok.push_back(rest.substr(b, i - b));
    }
    if (tok.empty()) continue;
    if (tok[0] == "v") {
      if (tok.size() < 4) c.failAtLine(lineNo, "vertex needs 3 coordinates");
      for (int k = 1; k <= 3; ++k) {
        double x;
        const char* b = tok[k].data();
        const char* e = b + tok[k].size();
        if (*b == '+') ++b;
        auto [p, ec] = std::from_chars(b, e, x);
        if (ec != std::errc() || p != e) c.failAtLine(lineNo, "malformed vertex coordinate '" + std::string(tok[k].substr(0, 30)) + "'");
        if (!std::isfinite(x)) c.failAtLine(lineNo, "vertex " + std::to_string(V.size() / 3 + 1) + " has a NaN or infinite coordinate");
        V.push_back(x);
      }
      sawData = true;
    } else if (tok[0] == "f") {
      if (tok.size() < 4) c.failAtLine(lineNo, "face needs at least 3 vertices");
      const long long nv = static_cast<long long>(V.size() / 3);
      poly.clear();
      for (size_t k = 1; k < tok.size(); ++k) {
        const std::string_view ref = tok[k].substr(0, tok[k].find('/'));
        long long v = 0;
        auto [p, ec] = std::from_chars(ref.data(), ref.data() + ref.size(), v);
        if (ref.empty() || ec != std::errc() || p != ref.data() + ref.size())
          c.failAtLine(lineNo, "malformed face vertex '" + std::string(tok[k].substr(0, 30)) + "'");
        const long long idx = v < 0 ? nv + v : v - 1;
        if (v == 0 || idx < 0 || idx >= nv)
          c.failAtLine(lineNo, "face vertex index " + std::to_string(v) + " out of range (" + std::to_string(nv) + " vertices so far)");
        poly.push_back(static_cast<int>(idx));
      }
      for (size_t k = 1; k + 1 < poly.size(); ++k) F.emplace_back(poly[0], poly[k], poly[k + 1]);
      sawData = true;
    }
  }
  if (!sawData || F.empty()) throwInputError(path, 0, "no faces: not an OBJ surface");
  SurfaceMesh s;
  s.V = Eigen::Map<const Eigen::Matrix<double, Eigen::Dynamic, 3, Eigen::RowMajor>>(V.data(), static_cast<Eigen::Index>(V.size() / 3), 3);
  s.F.resize(static_cast<Eigen::Index>(F.size()), 3);
  for (size_t f = 0; f < F.size(); ++f) s.F.row(static_cast<Eigen::Index>(f)) = F[f].transpose();
  return s;
}

void writeObj(const SurfaceMesh& s, const std::string& path) {
  std::string buf = "# written by tet2spline\n";
  for (Eigen::Index i = 0; i < s.V.rows(); ++i) {
    buf += 'v';
    for (int k = 0; k < 3; ++k) {
      buf += ' ';
      appendReal(buf, s.V(i, k));
    }
    buf += '\n';
  }
  for (Eigen::Index f = 0; f < s.F.rows(); ++f) {
    buf += 'f';
    for (int k = 0; k < 3; ++k) {
      buf += ' ';
      appendInt(buf, static_cast<long long>(s.F(f, k)) + 1);
    }
    buf += '\n';
  }
  AtomicFile file(path);
  file.stream().write(buf.data(), static_cast<std::streamsize>(buf.size()));
  file.commit();
}

}  // namespace tet2spline::detail

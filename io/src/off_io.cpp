// OFF surfaces (Geomview Object File Format), as the CGAL data set ships them.
#include <charconv>
#include <cmath>
#include <fstream>
#include <sstream>
#include <vector>

#include "format_readers.h"
#include "io_util.h"
#include "tet2spline/io/atomic_file.h"
#include "tet2spline/param/error.h"

namespace tet2spline::detail {

namespace {
// Next line that is neither empty nor a comment; returns false at end of file.
bool nextDataLine(std::istream& in, std::string& line, long& lineNo) {
  while (std::getline(in, line)) {
    ++lineNo;
    auto hash = line.find('#');
    if (hash != std::string::npos) line.erase(hash);
    if (line.find_first_not_of(" \t\r") != std::string::npos) return true;
  }
  return false;
}
}  // namespace

SurfaceMesh readOff(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throwInputError(path, 0, "cannot open file");
  in.seekg(0, std::ios::end);
  const auto fileSize = static_cast<long long>(in.tellg());
  in.seekg(0);
  std::string line;
  long lineNo = 0;
  if (!nextDataLine(in, line, lineNo)) throwInputError(path, 0, "empty file");
  std::istringstream header(line);
  std::string magic;
  header >> magic;
  long nv = -1, nf = -1, ne = 0;
  if (magic == "OFF") {
    if (!(header >> nv)) {
      if (!nextDataLine(in, line, lineNo)) throwInputError(path, lineNo, "missing vertex/face counts");
      header.clear();
      header.str(line);
      header >> nv;
    }
    header >> nf >> ne;
  } else if (magic.size() > 3 && magic.compare(magic.size() - 3, 3, "OFF") == 0) {
    throwInputError(path, lineNo, "OFF variant '" + magic + "' is not supported (plain OFF only)");
  } else {
    throwInputError(path, lineNo, "wrong header '" + magic.substr(0, 20) + "' (expected OFF)");
  }
  if (!header || nv < 0 || nf < 0) throwInputError(path, lineNo, "malformed vertex/face counts");
  if (nv < 4 || nf < 4) throwInputError(path, lineNo, "too few vertices or faces for a closed surface");
  // Guard the counts against the file size before allocating (a vertex or a
  // face takes several characters; half the size is a safe, loose bound).
  if (nv > fileSize / 2 || nf > fileSize / 2)
    throwInputError(path, lineNo,
                    "truncated or corrupt: " + std::to_string(nv) + " vertices and " + std::to_string(nf) +
                        " faces cannot fit in " + std::to_string(fileSize) + " bytes");

  SurfaceMesh s;
  s.V.resize(nv, 3);
  for (long i = 0; i < nv; ++i) {
    if (!nextDataLine(in, line, lineNo))
      throwInputError(path, lineNo, "truncated: expected " + std::to_string(nv) + " vertices, got " + std::to_string(i));
    // from_chars, unlike iostreams, reads "nan" and "inf", so they get their own message.
    std::istringstream ls(line);
    double xyz[3];
    for (double& v : xyz) {
      std::string tok;
      if (!(ls >> tok)) throwInputError(path, lineNo, "malformed vertex coordinates (fewer than 3)");
      const char* b = tok.c_str() + (tok[0] == '+' ? 1 : 0);
      auto [p, ec] = std::from_chars(b, tok.c_str() + tok.size(), v);
      if (ec != std::errc() || p != tok.c_str() + tok.size())
        throwInputError(path, lineNo, "malformed vertex coordinate '" + tok.substr(0, 30) + "'");
    }
    const double x = xyz[0], y = xyz[1], z = xyz[2];
    if (!std::isfinite(x) || !std::isfinite(y) || !std::isfinite(z))
      throwInputError(path, lineNo, "vertex " + std::to_string(i) + " has a NaN or infinite coordinate");
    s.V.row(i) << x, y, z;
  }
  std::vector<Eigen::Vector3i> tris;
  tris.reserve(nf);
  for (long f = 0; f < nf; ++f) {
    if (!nextDataLine(in, line, lineNo))
      throwInputError(path, lineNo, "truncated: expected " + std::to_string(nf) + " faces, got " + std::to_string(f));
    std::istringstream ls(line);
    long k;
    if (!(ls >> k) || k < 3) throwInputError(path, lineNo, "malformed face (needs a vertex count >= 3)");
    if (k > static_cast<long>(line.size()))
      throwInputError(path, lineNo, "face vertex count " + std::to_string(k) + " exceeds the indices on its line");
    std::vector<int> idx(k);
    for (long j = 0; j < k; ++j) {
      long v;
      if (!(ls >> v)) throwInputError(path, lineNo, "face has fewer indices than its count " + std::to_string(k));
      if (v < 0 || v >= nv)
        throwInputError(path, lineNo, "face index " + std::to_string(v) + " out of range [0, " + std::to_string(nv) + ")");
      idx[j] = static_cast<int>(v);
    }
    for (long j = 1; j + 1 < k; ++j) tris.emplace_back(idx[0], idx[j], idx[j + 1]);  // fan of a convex polygon
  }
  if (nextDataLine(in, line, lineNo))
    throwInputError(path, lineNo, "more data after the " + std::to_string(nf) + " faces the header declares");
  s.F.resize(static_cast<Eigen::Index>(tris.size()), 3);
  for (size_t i = 0; i < tris.size(); ++i) s.F.row(static_cast<Eigen::Index>(i)) = tris[i].transpose();
  return s;
}

void writeOff(const SurfaceMesh& s, const std::string& path) {
  std::string buf = "OFF\n";
  appendInt(buf, s.V.rows());
  buf += ' ';
  appendInt(buf, s.F.rows());
  buf += " 0\n";
  for (Eigen::Index i = 0; i < s.V.rows(); ++i) {
    for (int k = 0; k < 3; ++k) {
      appendReal(buf, s.V(i, k));
      buf += k == 2 ? '\n' : ' ';
    }
  }
  for (Eigen::Index f = 0; f < s.F.rows(); ++f) {
    buf += '3';
    for (int k = 0; k < 3; ++k) {
      buf += ' ';
      appendInt(buf, s.F(f, k));
    }
    buf += '\n';
  }
  AtomicFile file(path);
  file.stream().write(buf.data(), static_cast<std::streamsize>(buf.size()));
  file.commit();
}

}  // namespace tet2spline::detail

// STL surfaces, ASCII and binary (little-endian float32). A file is binary when
// its size is exactly 84 + 50·n for the n of its header, ASCII when it starts
// with "solid" otherwise. Identical vertices are merged exactly (bitwise equal
// coordinates, with -0 == +0).
#include <Eigen/Geometry>
#include <array>
#include <cmath>
#include <map>
#include <vector>

#include "format_readers.h"
#include "io_util.h"
#include "tet2spline/io/atomic_file.h"

namespace tet2spline::detail {

namespace {
class VertexMerger {
 public:
  int add(double x, double y, double z) {
    const std::array<double, 3> key{x + 0.0, y + 0.0, z + 0.0};  // -0 + 0 == +0
    auto [it, inserted] = index_.emplace(key, static_cast<int>(V_.size() / 3));
    if (inserted) V_.insert(V_.end(), key.begin(), key.end());
    return it->second;
  }
  SurfaceMesh finish(const std::vector<Eigen::Vector3i>& F) const {
    SurfaceMesh s;
    s.V = Eigen::Map<const Eigen::Matrix<double, Eigen::Dynamic, 3, Eigen::RowMajor>>(V_.data(), static_cast<Eigen::Index>(V_.size() / 3), 3);
    s.F.resize(static_cast<Eigen::Index>(F.size()), 3);
    for (size_t f = 0; f < F.size(); ++f) s.F.row(static_cast<Eigen::Index>(f)) = F[f].transpose();
    return s;
  }

 private:
  std::map<std::array<double, 3>, int> index_;
  std::vector<double> V_;
};

SurfaceMesh readBinaryStl(Cursor& c, unsigned long long n) {
  c.seek(84);
  VertexMerger merger;
  std::vector<Eigen::Vector3i> F;
  F.reserve(static_cast<size_t>(n));
  for (unsigned long long t = 0; t < n; ++t) {
    const char* p = c.rawBytes(50, "triangle");
    Eigen::Vector3i tri;
    for (int k = 0; k < 3; ++k) {
      const float x = loadValue<float>(p + 12 + 12 * k, false);
      const float y = loadValue<float>(p + 16 + 12 * k, false);
      const float z = loadValue<float>(p + 20 + 12 * k, false);
      if (!std::isfinite(x) || !std::isfinite(y) || !std::isfinite(z))
        c.fail("triangle " + std::to_string(t) + " has a NaN or infinite coordinate");
      tri(k) = merger.add(x, y, z);
    }
    F.push_back(tri);
  }
  return merger.finish(F);
}

SurfaceMesh readAsciiStl(Cursor& c) {
  VertexMerger merger;
  std::vector<Eigen::Vector3i> F;
  auto expect = [&](const char* word) {
    const std::string_view tok = c.token(word);
    if (!iequals(tok, word)) c.fail(std::string("expected '") + word + "', found '" + std::string(tok.substr(0, 30)) + "'");
  };
  expect("solid");
  c.restOfLine();  // solid name
  bool sawSolidEnd = false;
  std::string_view tok;
  while (c.tryToken(tok)) {
    if (iequals(tok, "endsolid")) {
      c.restOfLine();
      sawSolidEnd = true;
      continue;
    }
    if (iequals(tok, "solid")) {  // several solids in one file
      c.restOfLine();
      sawSolidEnd = false;
      continue;
    }
    if (!iequals(tok, "facet")) c.fail("expected 'facet' or 'endsolid', found '" + std::string(tok.substr(0, 30)) + "'");
    expect("normal");
    for (int k = 0; k < 3; ++k) c.real("normal component");
    expect("outer");
    expect("loop");
    Eigen::Vector3i tri;
    for (int k = 0; k < 3; ++k) {
      expect("vertex");
      const double x = c.finiteReal("vertex coordinate");
      const double y = c.finiteReal("vertex coordinate");
      const double z = c.finiteReal("vertex coordinate");
      tri(k) = merger.add(x, y, z);
    }
    expect("endloop");
    expect("endfacet");
    F.push_back(tri);
  }
  if (!sawSolidEnd) c.fail("truncated: no 'endsolid'");
  if (F.empty()) throwInputError(c.path(), 0, "no facets");
  return merger.finish(F);
}
}  // namespace

SurfaceMesh readStl(const std::string& path) {
  Cursor c(path, readWholeFile(path));
  const std::string& d = c.data();
  if (d.size() >= 84) {
    const auto n = loadValue<uint32_t>(d.data() + 80, false);
    if (d.size() == 84 + 50ULL * n) {
      if (n == 0) throwInputError(path, 0, "binary STL with no triangles");
      return readBinaryStl(c, n);
    }
  }
  const size_t first = d.find_first_not_of(" \t\r\n");
  if (first != std::string::npos && d.size() - first >= 5 && iequals(std::string_view(d).substr(first, 5), "solid"))
    return readAsciiStl(c);
  if (d.size() < 84) throwInputError(path, 0, "truncated: " + std::to_string(d.size()) + " bytes is shorter than a binary STL header (84 bytes) and not ASCII STL");
  const auto n = loadValue<uint32_t>(d.data() + 80, false);
  throwInputError(path, 0, "binary STL header declares " + std::to_string(n) + " triangles (" +
                               std::to_string(84 + 50ULL * n) + " bytes) but the file has " + std::to_string(d.size()) + " bytes");
}

void writeStl(const SurfaceMesh& s, const std::string& path) {
  std::string buf(80, ' ');
  buf.replace(0, 32, "binary STL written by tet2spline");
  appendLittleEndian<uint32_t>(buf, static_cast<uint32_t>(s.F.rows()));
  for (Eigen::Index f = 0; f < s.F.rows(); ++f) {
    const Eigen::Vector3d a = s.V.row(s.F(f, 0)), b = s.V.row(s.F(f, 1)), c = s.V.row(s.F(f, 2));
    Eigen::Vector3d n = (b - a).cross(c - a);
    if (n.norm() > 0) n.normalize();
    for (int k = 0; k < 3; ++k) appendLittleEndian<float>(buf, static_cast<float>(n(k)));
    for (const Eigen::Vector3d* p : {&a, &b, &c})
      for (int k = 0; k < 3; ++k) appendLittleEndian<float>(buf, static_cast<float>((*p)(k)));
    appendLittleEndian<uint16_t>(buf, 0);
  }
  AtomicFile file(path, true);
  file.stream().write(buf.data(), static_cast<std::streamsize>(buf.size()));
  file.commit();
}

}  // namespace tet2spline::detail

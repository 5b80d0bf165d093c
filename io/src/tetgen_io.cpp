// TetGen .node/.ele pairs (TetGen 1.5 manual, section 5.2). Indices are 0- or
// 1-based, as the first node index of the .node file says. Region = first
// element attribute when the .ele file has attributes, else 1.
#include <cmath>
#include <vector>

#include "format_readers.h"
#include "io_util.h"

namespace tet2spline::detail {

namespace {
std::string withExtension(const std::string& path, const char* ext) {
  const auto dot = path.find_last_of('.');
  return path.substr(0, dot) + ext;
}
}  // namespace

TetMesh readTetGen(const std::string& path) {
  const std::string nodePath = withExtension(path, ".node");
  const std::string elePath = withExtension(path, ".ele");

  TetMesh m;
  long long base = 0;
  {
    Cursor c(nodePath, readWholeFile(nodePath), '#');
    if (c.atEnd()) throwInputError(nodePath, 0, "empty file (only comments or whitespace)");
    const long long n = c.integerIn("node count", 0, 2000000000);
    const long long dim = c.integer("dimension");
    if (dim != 3) c.fail("dimension " + std::to_string(dim) + " is not supported (expected 3)");
    const long long nattr = c.integerIn("attribute count", 0, 1000);
    const long long markers = c.integerIn("boundary marker flag", 0, 1);
    // Every node takes at least 4 tokens, hence at least 8 characters.
    if (static_cast<unsigned long long>(n) > c.remaining() / 2)
      c.fail("truncated: node count " + std::to_string(n) + " exceeds what the rest of the file can hold");
    m.V.resize(n, 3);
    for (long long i = 0; i < n; ++i) {
      if (c.atEnd()) c.fail("truncated: the header declares " + std::to_string(n) + " nodes but only " + std::to_string(i) + " follow");
      const long long idx = c.integer("node index");
      if (i == 0) {
        if (idx != 0 && idx != 1) c.fail("first node index is " + std::to_string(idx) + " (expected 0 or 1)");
        base = idx;
      } else if (idx != base + i) {
        c.fail("node index " + std::to_string(idx) + " out of sequence (expected " + std::to_string(base + i) + ")");
      }
      for (int k = 0; k < 3; ++k) m.V(i, k) = c.finiteReal("node coordinate");
      for (long long a = 0; a < nattr; ++a) c.real("node attribute");
      if (markers) c.integer("boundary marker");
    }
    if (!c.atEnd()) {
      c.token("data");
      c.fail("more data after the " + std::to_string(n) + " nodes the header declares");
    }
  }
  {
    Cursor c(elePath, readWholeFile(elePath), '#');
    if (c.atEnd()) throwInputError(elePath, 0, "empty file (only comments or whitespace)");
    const long long n = c.integerIn("tetrahedron count", 0, 2000000000);
    const long long npt = c.integer("nodes per tetrahedron");
    if (npt != 4)
      c.fail(std::to_string(npt) + " nodes per tetrahedron" + (npt == 10 ? " (second order)" : "") +
             " is not supported (expected 4)");
    const long long nattr = c.integerIn("attribute count", 0, 1000);
    if (static_cast<unsigned long long>(n) > c.remaining() / 2)
      c.fail("truncated: tetrahedron count " + std::to_string(n) + " exceeds what the rest of the file can hold");
    const long long nv = m.V.rows();
    m.T.resize(n, 4);
    m.region.setOnes(n);
    for (long long t = 0; t < n; ++t) {
      if (c.atEnd())
        c.fail("truncated: the header declares " + std::to_string(n) + " tetrahedra but only " + std::to_string(t) + " follow");
      c.integer("tetrahedron index");
      for (int k = 0; k < 4; ++k)
        m.T(t, k) = static_cast<int>(c.integerIn("tetrahedron node index", base, base + nv - 1) - base);
      for (long long a = 0; a < nattr; ++a) {
        const double v = c.real("region attribute");
        if (a == 0) {
          if (!std::isfinite(v) || v != std::floor(v) || std::fabs(v) > 2147483647.0)
            c.fail("region attribute " + std::to_string(v) + " is not an integer");
          m.region(t) = static_cast<int>(v);
        }
      }
    }
    if (!c.atEnd()) {
      c.token("data");
      c.fail("more data after the " + std::to_string(n) + " tetrahedra the header declares");
    }
    if (n == 0) throwInputError(elePath, 0, "no tetrahedra");
  }
  return m;
}

}  // namespace tet2spline::detail

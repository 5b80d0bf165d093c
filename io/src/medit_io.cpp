// MEDIT .mesh (ASCII, MeshVersionFormatted 1 or 2, Dimension 3): Vertices and
// Tetrahedra with their references (tet reference = region); other sections
// (Triangles, Edges, Corners, ...) are skipped.
#include <cctype>
#include <cmath>
#include <vector>

#include "format_readers.h"
#include "io_util.h"
#include "tet2spline/io/atomic_file.h"

namespace tet2spline::detail {

namespace {
bool isKeyword(std::string_view tok) {
  return !tok.empty() && std::isalpha(static_cast<unsigned char>(tok[0])) && !iequals(tok, "nan") &&
         !iequals(tok, "inf") && !iequals(tok, "infinity");
}
}  // namespace

TetMesh readMedit(const std::string& path) {
  Cursor c(path, readWholeFile(path), '#');
  if (c.atEnd()) throwInputError(path, 0, "empty file (only comments or whitespace)");
  std::string_view tok = c.token("MeshVersionFormatted");
  if (!iequals(tok, "MeshVersionFormatted"))
    c.fail("wrong header '" + std::string(tok.substr(0, 30)) + "' (expected MeshVersionFormatted)");
  const long long version = c.integer("MeshVersionFormatted value");
  if (version < 1 || version > 4) c.fail("unsupported MeshVersionFormatted " + std::to_string(version) + " (expected 1 or 2)");

  TetMesh m;
  bool haveDim = false, haveVertices = false, haveTets = false;
  long long nv = 0;
  while (!c.atEnd()) {
    tok = c.token("a keyword");
    if (!isKeyword(tok))
      c.fail("unexpected value '" + std::string(tok.substr(0, 30)) +
             "' where a keyword was expected (a count disagrees with the data that follows)");
    if (iequals(tok, "End")) break;
    if (iequals(tok, "Dimension")) {
      const long long d = c.integer("Dimension value");
      if (d != 3) c.fail("Dimension " + std::to_string(d) + " is not supported (expected 3)");
      haveDim = true;
    } else if (iequals(tok, "Vertices")) {
      if (!haveDim) c.fail("Vertices before Dimension");
      if (haveVertices) c.fail("second Vertices section");
      nv = c.integerIn("vertex count", 0, 2000000000);
      // Every vertex takes 4 tokens, hence at least 8 characters: a cheap
      // guard against absurd counts before allocating.
      if (static_cast<unsigned long long>(nv) > c.remaining() / 2)
        c.fail("truncated: Vertices count " + std::to_string(nv) + " exceeds what the rest of the file can hold");
      m.V.resize(nv, 3);
      for (long long i = 0; i < nv; ++i) {
        if (isKeyword(c.peek()) || c.atEnd())
          c.fail("Vertices declares " + std::to_string(nv) + " vertices but only " + std::to_string(i) + " follow");
        for (int k = 0; k < 3; ++k) m.V(i, k) = c.finiteReal("vertex coordinate");
        c.integer("vertex reference");
      }
      haveVertices = true;
    } else if (iequals(tok, "Tetrahedra")) {
      if (!haveVertices) c.fail("Tetrahedra before Vertices");
      if (haveTets) c.fail("second Tetrahedra section");
      const long long nt = c.integerIn("tetrahedron count", 0, 2000000000);
      if (static_cast<unsigned long long>(nt) > c.remaining() / 2)
        c.fail("truncated: Tetrahedra count " + std::to_string(nt) + " exceeds what the rest of the file can hold");
      m.T.resize(nt, 4);
      m.region.resize(nt);
      for (long long t = 0; t < nt; ++t) {
        if (isKeyword(c.peek()) || c.atEnd())
          c.fail("Tetrahedra declares " + std::to_string(nt) + " tetrahedra but only " + std::to_string(t) + " follow");
        for (int k = 0; k < 4; ++k) m.T(t, k) = static_cast<int>(c.integerIn("tetrahedron vertex index", 1, nv) - 1);
        m.region(t) = static_cast<int>(c.integerIn("tetrahedron reference", -2147483647LL, 2147483647LL));
      }
      haveTets = true;
    } else if (iequals(tok, "Hexahedra") || iequals(tok, "Prisms") || iequals(tok, "Pyramids") ||
               iequals(tok, "TetrahedraP2") || iequals(tok, "HexahedraQ2")) {
      const long long n = c.integer("element count");
      if (n > 0)
        c.fail("the mesh has " + std::to_string(n) + " " + std::string(tok) +
               "; only linear tetrahedra are supported in a volume mesh");
    } else {
      // Triangles, Edges, Corners, Ridges, Required*, Normals, ...: skip the numbers.
      while (!c.atEnd() && !isKeyword(c.peek())) c.token("data");
    }
  }
  if (!haveDim) throwInputError(path, 0, "no Dimension keyword");
  if (!haveVertices) throwInputError(path, 0, "no Vertices section");
  if (!haveTets || m.T.rows() == 0) throwInputError(path, 0, "no Tetrahedra: not a volume mesh");
  return m;
}

void writeMedit(const TetMesh& m, const std::string& path) {
  AtomicFile file(path);
  std::string buf;
  buf.reserve(static_cast<size_t>(m.V.rows()) * 64 + static_cast<size_t>(m.T.rows()) * 40 + 128);
  buf += "MeshVersionFormatted 2\nDimension 3\n\nVertices\n";
  appendInt(buf, m.V.rows());
  buf += '\n';
  for (Eigen::Index i = 0; i < m.V.rows(); ++i) {
    for (int k = 0; k < 3; ++k) {
      appendReal(buf, m.V(i, k));
      buf += ' ';
    }
    buf += "0\n";
  }
  buf += "\nTetrahedra\n";
  appendInt(buf, m.T.rows());
  buf += '\n';
  for (Eigen::Index t = 0; t < m.T.rows(); ++t) {
    for (int k = 0; k < 4; ++k) {
      appendInt(buf, static_cast<long long>(m.T(t, k)) + 1);
      buf += ' ';
    }
    appendInt(buf, regionOf(m, t));
    buf += '\n';
  }
  buf += "\nEnd\n";
  file.stream().write(buf.data(), static_cast<std::streamsize>(buf.size()));
  file.commit();
}

}  // namespace tet2spline::detail

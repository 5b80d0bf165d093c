// PLY surfaces (ASCII, binary_little_endian, binary_big_endian): element
// `vertex` with x y z, element `face` with a list property vertex_indices (or
// vertex_index); polygons are fanned; other elements and properties skipped.
#include <algorithm>
#include <charconv>
#include <cmath>
#include <vector>

#include "format_readers.h"
#include "io_util.h"
#include "tet2spline/io/atomic_file.h"

namespace tet2spline::detail {

namespace {

enum class PlyType { Int8, UInt8, Int16, UInt16, Int32, UInt32, Float32, Float64, Invalid };

PlyType plyType(std::string_view s) {
  if (s == "char" || s == "int8") return PlyType::Int8;
  if (s == "uchar" || s == "uint8") return PlyType::UInt8;
  if (s == "short" || s == "int16") return PlyType::Int16;
  if (s == "ushort" || s == "uint16") return PlyType::UInt16;
  if (s == "int" || s == "int32") return PlyType::Int32;
  if (s == "uint" || s == "uint32") return PlyType::UInt32;
  if (s == "float" || s == "float32") return PlyType::Float32;
  if (s == "double" || s == "float64") return PlyType::Float64;
  return PlyType::Invalid;
}

size_t plySize(PlyType t) {
  switch (t) {
    case PlyType::Int8: case PlyType::UInt8: return 1;
    case PlyType::Int16: case PlyType::UInt16: return 2;
    case PlyType::Int32: case PlyType::UInt32: case PlyType::Float32: return 4;
    case PlyType::Float64: return 8;
    default: return 0;
  }
}

bool isIntegral(PlyType t) { return t != PlyType::Float32 && t != PlyType::Float64; }

struct Property {
  std::string name;
  PlyType type = PlyType::Invalid;
  bool list = false;
  PlyType countType = PlyType::Invalid;
};

struct Element {
  std::string name;
  unsigned long long count = 0;
  std::vector<Property> props;
  long line = 0;
};

class PlyReader {
 public:
  explicit PlyReader(const std::string& path) : c_(path, readWholeFile(path)) {}

  SurfaceMesh read() {
    std::string_view l = c_.restOfLine();
    if (l != "ply") c_.fail("wrong header '" + std::string(l.substr(0, 30)) + "' (expected 'ply')");
    std::vector<Element> elements;
    bool haveFormat = false, ended = false;
    while (c_.pos() < c_.size()) {
      l = c_.restOfLine();
      std::vector<std::string_view> t = split(l);
      if (t.empty()) continue;
      if (t[0] == "end_header") {
        ended = true;
        break;
      }
      if (t[0] == "comment" || t[0] == "obj_info") continue;
      if (t[0] == "format") {
        if (t.size() != 3) c_.fail("malformed format line");
        if (t[1] == "ascii") mode_ = Mode::Ascii;
        else if (t[1] == "binary_little_endian") mode_ = Mode::Little;
        else if (t[1] == "binary_big_endian") mode_ = Mode::Big;
        else c_.fail("unknown PLY format '" + std::string(t[1].substr(0, 30)) + "'");
        haveFormat = true;
      } else if (t[0] == "element") {
        if (t.size() != 3) c_.fail("malformed element line");
        Element e;
        e.name = std::string(t[1]);
        e.line = c_.line();
        long long n = 0;
        auto [p, ec] = std::from_chars(t[2].data(), t[2].data() + t[2].size(), n);
        if (ec != std::errc() || p != t[2].data() + t[2].size() || n < 0) c_.fail("malformed element count '" + std::string(t[2].substr(0, 30)) + "'");
        e.count = static_cast<unsigned long long>(n);
        elements.push_back(std::move(e));
      } else if (t[0] == "property") {
        if (elements.empty()) c_.fail("property before any element");
        Property p;
        if (t.size() == 5 && t[1] == "list") {
          p.list = true;
          p.countType = plyType(t[2]);
          p.type = plyType(t[3]);
          p.name = std::string(t[4]);
          if (p.countType == PlyType::Invalid || !isIntegral(p.countType) || p.type == PlyType::Invalid)
            c_.fail("unknown list property types '" + std::string(t[2]) + " " + std::string(t[3]) + "'");
        } else if (t.size() == 3) {
          p.type = plyType(t[1]);
          p.name = std::string(t[2]);
          if (p.type == PlyType::Invalid) c_.fail("unknown property type '" + std::string(t[1].substr(0, 30)) + "'");
        } else {
          c_.fail("malformed property line");
        }
        elements.back().props.push_back(std::move(p));
      } else {
        c_.fail("unknown header line '" + std::string(l.substr(0, 30)) + "'");
      }
    }
    if (!ended) c_.fail("truncated: no end_header");
    if (!haveFormat) c_.fail("no format line in the header");

    std::vector<double> V;
    std::vector<Eigen::Vector3i> F;
    bool haveVertices = false, haveFaces = false;
    long long nv = -1;
    for (const Element& e : elements) {
      // Guard the count against the bytes left before allocating anything.
      size_t minBytes = 0;
      for (const auto& p : e.props) minBytes += mode_ == Mode::Ascii ? 2 : p.list ? plySize(p.countType) : plySize(p.type);
      c_.needItems(e.count, minBytes, "element '" + e.name + "'");
      int ix = -1, iy = -1, iz = -1, iface = -1;
      for (size_t i = 0; i < e.props.size(); ++i) {
        const auto& p = e.props[i];
        if (!p.list && p.name == "x") ix = static_cast<int>(i);
        if (!p.list && p.name == "y") iy = static_cast<int>(i);
        if (!p.list && p.name == "z") iz = static_cast<int>(i);
        if (p.list && (p.name == "vertex_indices" || p.name == "vertex_index") && iface < 0) iface = static_cast<int>(i);
      }
      const bool isVertex = e.name == "vertex", isFace = e.name == "face";
      if (isVertex) {
        if (ix < 0 || iy < 0 || iz < 0) c_.failAtLine(e.line, "element vertex lacks x, y or z");
        V.reserve(static_cast<size_t>(e.count) * 3);
        nv = static_cast<long long>(e.count);
        haveVertices = true;
      }
      if (isFace) {
        if (iface < 0) c_.failAtLine(e.line, "element face has no vertex_indices list");
        haveFaces = true;
      }
      if (e.props.empty()) continue;  // nothing to read, however large the count
      std::vector<double> row(e.props.size());
      std::vector<long long> poly;
      for (unsigned long long r = 0; r < e.count; ++r) {
        for (size_t i = 0; i < e.props.size(); ++i) {
          const auto& p = e.props[i];
          if (!p.list) {
            row[i] = value(p.type, "property value");
            continue;
          }
          const double k = value(p.countType, "list length");
          if (k < 0 || k > 1e9) c_.fail("bad list length " + std::to_string(k));
          if (mode_ != Mode::Ascii) c_.needItems(static_cast<unsigned long long>(k), plySize(p.type), "list");
          const bool keep = isFace && static_cast<int>(i) == iface;
          if (keep) poly.clear();
          for (long long j = 0; j < static_cast<long long>(k); ++j) {
            const double v = value(p.type, "list item");
            if (keep) {
              if (v != std::floor(v)) c_.fail("face vertex index " + std::to_string(v) + " is not an integer");
              poly.push_back(static_cast<long long>(v));
            }
          }
          if (keep) {
            if (poly.size() < 3) c_.fail("face " + std::to_string(r) + " has fewer than 3 vertices");
            for (size_t j = 1; j + 1 < poly.size(); ++j) F.emplace_back(clampIndex(poly[0]), clampIndex(poly[j]), clampIndex(poly[j + 1]));
            for (long long v : poly)
              if (v < 0 || (nv >= 0 && v >= nv))
                c_.fail("face " + std::to_string(r) + " vertex index " + std::to_string(v) + " out of range [0, " +
                        std::to_string(std::max(nv, 0LL)) + ")");
          }
        }
        if (isVertex) {
          for (int k : {ix, iy, iz}) {
            if (!std::isfinite(row[static_cast<size_t>(k)]))
              c_.fail("vertex " + std::to_string(r) + " has a NaN or infinite coordinate");
            V.push_back(row[static_cast<size_t>(k)]);
          }
        }
      }
    }
    if (mode_ == Mode::Ascii && !c_.atEnd()) {
      c_.token("data");
      c_.fail("more data after the elements the header declares");
    }
    if (!haveVertices) throwInputError(c_.path(), 0, "no vertex element");
    if (!haveFaces || F.empty()) throwInputError(c_.path(), 0, "no faces");
    for (const auto& f : F)
      if (f.maxCoeff() >= nv) throwInputError(c_.path(), 0, "a face references a vertex index out of range [0, " + std::to_string(nv) + ")");
    SurfaceMesh s;
    s.V = Eigen::Map<const Eigen::Matrix<double, Eigen::Dynamic, 3, Eigen::RowMajor>>(V.data(), static_cast<Eigen::Index>(V.size() / 3), 3);
    s.F.resize(static_cast<Eigen::Index>(F.size()), 3);
    for (size_t f = 0; f < F.size(); ++f) s.F.row(static_cast<Eigen::Index>(f)) = F[f].transpose();
    return s;
  }

 private:
  enum class Mode { Ascii, Little, Big };

  static int clampIndex(long long v) { return v < 0 || v > 2147483647LL ? 2147483647 : static_cast<int>(v); }

  static std::vector<std::string_view> split(std::string_view l) {
    std::vector<std::string_view> t;
    size_t i = 0;
    while (i < l.size()) {
      while (i < l.size() && (l[i] == ' ' || l[i] == '\t' || l[i] == '\r')) ++i;
      const size_t b = i;
      while (i < l.size() && l[i] != ' ' && l[i] != '\t' && l[i] != '\r') ++i;
      if (i > b) t.push_back(l.substr(b, i - b));
    }
    return t;
  }

  double value(PlyType t, const char* what) {
    if (mode_ == Mode::Ascii) return c_.real(what);
    const bool big = mode_ == Mode::Big;
    const char* p = c_.rawBytes(plySize(t), what);
    switch (t) {
      case PlyType::Int8: return static_cast<signed char>(*p);
      case PlyType::UInt8: return static_cast<unsigned char>(*p);
      case PlyType::Int16: return loadValue<int16_t>(p, big);
      case PlyType::UInt16: return loadValue<uint16_t>(p, big);
      case PlyType::Int32: return loadValue<int32_t>(p, big);
      case PlyType::UInt32: return loadValue<uint32_t>(p, big);
      case PlyType::Float32: return loadValue<float>(p, big);
      default: return loadValue<double>(p, big);
    }
  }

  Cursor c_;
  Mode mode_ = Mode::Ascii;
};

}  // namespace

SurfaceMesh readPly(const std::string& path) { return PlyReader(path).read(); }

void writePly(const SurfaceMesh& s, const std::string& path) {
  std::string buf = "ply\nformat binary_little_endian 1.0\ncomment written by tet2spline\nelement vertex " +
                    std::to_string(s.V.rows()) +
                    "\nproperty double x\nproperty double y\nproperty double z\nelement face " +
                    std::to_string(s.F.rows()) + "\nproperty list uchar int vertex_indices\nend_header\n";
  for (Eigen::Index i = 0; i < s.V.rows(); ++i)
    for (int k = 0; k < 3; ++k) appendLittleEndian<double>(buf, s.V(i, k));
  for (Eigen::Index f = 0; f < s.F.rows(); ++f) {
    appendLittleEndian<uint8_t>(buf, 3);
    for (int k = 0; k < 3; ++k) appendLittleEndian<int32_t>(buf, s.F(f, k));
  }
  AtomicFile file(path, true);
  file.stream().write(buf.data(), static_cast<std::streamsize>(buf.size()));
  file.commit();
}

}  // namespace tet2spline::detail

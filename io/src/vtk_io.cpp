// VTK unstructured grids: XML .vtu (ASCII, inline base64 binary, appended raw
// or base64; optional vtkZLibDataCompressor; UInt32/UInt64 headers; little or
// big endian) and legacy .vtk (ASCII and big-endian BINARY, versions 2 to 5.1).
// Cell type 10 (tetra) is read; other 3D cells are an error; 0D/1D/2D cells are
// skipped together with their cell data. Region from the first cell array named
// region, gmsh:physical, CellEntityIds, MaterialIds or medit:ref (in that order).
#include <zlib.h>

#include <algorithm>
#include <charconv>
#include <cmath>
#include <cstdint>
#include <limits>
#include <memory>
#include <set>
#include <vector>

#include "format_readers.h"
#include "io_util.h"
#include "tet2spline/io/atomic_file.h"

namespace tet2spline::detail {

namespace {

constexpr int kVtkTetra = 10;
// FieldData array of the region tags that fill voids (TetMesh::voidRegions).
const char* const kVoidRegions = "void_regions";
const char* const kRegionNames[] = {"region", "gmsh:physical", "CellEntityIds", "MaterialIds", "medit:ref"};

/// Topological dimension of a VTK cell type (vtkCellType.h); 3 for unknown types.
int vtkCellDimension(long long type) {
  switch (type) {
    case 1: case 2: return 0;                                  // vertex, poly-vertex
    case 3: case 4: case 21: case 35: case 68: return 1;       // lines
    case 5: case 6: case 7: case 8: case 9: case 22: case 23:  // triangles, polygons, quads
    case 28: case 30: case 31: case 34: case 36: case 37: case 69: case 70: return 2;
    default: return 3;
  }
}

const char* vtkCellName(long long type) {
  switch (type) {
    case 11: return "voxel";
    case 12: return "hexahedron";
    case 13: return "wedge";
    case 14: return "pyramid";
    case 15: return "pentagonal prism";
    case 16: return "hexagonal prism";
    case 24: return "quadratic tetra";
    case 25: return "quadratic hexahedron";
    case 26: return "quadratic wedge";
    case 27: return "quadratic pyramid";
    case 42: return "polyhedron";
    default: return "non-tetrahedral 3D cell";
  }
}

/// A numeric array decoded to doubles (exact for integers up to 2^53).
struct Array {
  std::string name;
  int components = 1;
  std::vector<double> values;
  long line = 0;
};

bool isRegionName(const std::string& name, int& priority) {
  for (int i = 0; i < 5; ++i)
    if (name == kRegionNames[i]) {
      priority = i;
      return true;
    }
  return false;
}

/// The parts common to both readers: cells -> tets, arrays -> region and fields.
struct GridData {
  std::vector<double> points;  // 3 per point
  std::vector<long long> cellTypes;
  std::vector<long long> connectivity;
  std::vector<long long> offsets;  // #cells + 1, starting at 0
  std::vector<Array> pointArrays, cellArrays;
};

// `fail(msg, line)` reports; line may be 0.
template <class Fail>
TetMesh assemble(GridData& g, Fail fail) {
  TetMesh m;
  const size_t nv = g.points.size() / 3;
  const size_t nc = g.cellTypes.size();
  if (g.offsets.size() != nc + 1) fail("cell offsets disagree with the number of cells", 0);
  m.V.resize(static_cast<Eigen::Index>(nv), 3);
  for (size_t i = 0; i < nv; ++i)
    for (int k = 0; k < 3; ++k) {
      const double v = g.points[3 * i + static_cast<size_t>(k)];
      if (!std::isfinite(v)) fail("point " + std::to_string(i) + " has a NaN or infinite coordinate", 0);
      m.V(static_cast<Eigen::Index>(i), k) = v;
    }
  std::vector<size_t> tetCells;
  for (size_t c = 0; c < nc; ++c) {
    const long long b = g.offsets[c], e = g.offsets[c + 1];
    if (b < 0 || e < b || e > static_cast<long long>(g.connectivity.size()))
      fail("cell " + std::to_string(c) + " has offsets outside the connectivity array", 0);
    const long long type = g.cellTypes[c];
    if (type == kVtkTetra) {
      if (e - b != 4) fail("tetra cell " + std::to_string(c) + " has " + std::to_string(e - b) + " points", 0);
      tetCells.push_back(c);
    } else if (vtkCellDimension(type) == 3) {
      fail("cell " + std::to_string(c) + " has type " + std::to_string(type) + " (" + vtkCellName(type) +
               "); only linear tetrahedra (VTK type 10) are supported in a volume mesh",
           0);
    }
  }
  if (tetCells.empty()) fail("no tetrahedra (VTK cell type 10): not a volume mesh", 0);
  const auto nt = static_cast<Eigen::Index>(tetCells.size());
  m.T.resize(nt, 4);
  for (Eigen::Index t = 0; t < nt; ++t)
    for (int k = 0; k < 4; ++k) {
      const long long v = g.connectivity[static_cast<size_t>(g.offsets[tetCells[static_cast<size_t>(t)]] + k)];
      if (v < 0 || v >= static_cast<long long>(nv))
        fail("cell " + std::to_string(tetCells[static_cast<size_t>(t)]) + " references point " + std::to_string(v) +
                 " outside [0, " + std::to_string(nv) + ")",
             0);
      m.T(t, k) = static_cast<int>(v);
    }
  // Region: the highest-priority name present; every other array becomes a field.
  int best = 99;
  size_t bestIdx = 0;
  for (size_t i = 0; i < g.cellArrays.size(); ++i) {
    int p;
    if (g.cellArrays[i].components == 1 && isRegionName(g.cellArrays[i].name, p) && p < best) {
      best = p;
      bestIdx = i;
    }
  }
  m.region.setOnes(nt);
  for (size_t i = 0; i < g.cellArrays.size(); ++i) {
    Array& a = g.cellArrays[i];
    if (a.values.size() != nc * static_cast<size_t>(a.components))
      fail("cell array '" + a.name + "' has " + std::to_string(a.values.size()) + " values, expected " +
               std::to_string(nc * static_cast<size_t>(a.components)),
           a.line);
    if (best != 99 && i == bestIdx) {
      for (Eigen::Index t = 0; t < nt; ++t) {
        const double v = a.values[tetCells[static_cast<size_t>(t)]];
        if (!(std::fabs(v) <= 2147483647.0) || v != std::floor(v))
          fail("region array '" + a.name + "' has a non-integer value " + std::to_string(v), a.line);
        m.region(t) = static_cast<int>(v);
      }
      continue;
    }
    Field f{a.name, Eigen::MatrixXd(nt, a.components)};
    for (Eigen::Index t = 0; t < nt; ++t)
      for (int k = 0; k < a.components; ++k)
        f.values(t, k) = a.values[tetCells[static_cast<size_t>(t)] * static_cast<size_t>(a.components) + static_cast<size_t>(k)];
    m.cellFields.push_back(std::move(f));
  }
  for (Array& a : g.pointArrays) {
    if (a.values.size() != nv * static_cast<size_t>(a.components))
      fail("point array '" + a.name + "' has " + std::to_string(a.values.size()) + " values, expected " +
               std::to_string(nv * static_cast<size_t>(a.components)),
           a.line);
    Field f{a.name, Eigen::MatrixXd(static_cast<Eigen::Index>(nv), a.components)};
    for (size_t i = 0; i < nv; ++i)
      for (int k = 0; k < a.components; ++k)
        f.values(static_cast<Eigen::Index>(i), k) = a.values[i * static_cast<size_t>(a.components) + static_cast<size_t>(k)];
    m.pointFields.push_back(std::move(f));
  }
  return m;
}

// ---------------------------------------------------------------- XML (.vtu)

struct XmlElement {
  std::string name;
  std::vector<std::pair<std::string, std::string>> attrs;
  std::vector<XmlElement> children;
  size_t contentBegin = 0, contentEnd = 0;  // text between the tags (leaf elements)
  size_t offset = 0;                        // of '<'

  const std::string* attr(const std::string& key) const {
    for (const auto& [k, v] : attrs)
      if (k == key) return &v;
    return nullptr;
  }
  const XmlElement* child(const std::string& n) const {
    for (const auto& c : children)
      if (c.name == n) return &c;
    return nullptr;
  }
};

/// A small XML tokenizer sufficient for VTK files: elements, attributes,
/// comments, processing instructions, CDATA, and the raw AppendedData block.
class XmlParser {
 public:
  XmlParser(const std::string& path, const std::string& s) : path_(path), s_(s) {}

  XmlElement parseDocument() {
    skipMisc();
    if (pos_ >= s_.size() || s_[pos_] != '<') fail("not an XML file (no root element)");
    XmlElement root;
    parseElement(root, 0);
    return root;
  }
  /// Offset of the byte after '_' in <AppendedData>, or npos.
  size_t appendedStart() const { return appended_; }
  const std::string* appendedEncoding() const { return appendedEncoding_.empty() ? nullptr : &appendedEncoding_; }

  long lineAt(size_t off) const { return 1 + static_cast<long>(std::count(s_.begin(), s_.begin() + static_cast<std::ptrdiff_t>(std::min(off, s_.size())), '\n')); }
  [[noreturn]] void fail(const std::string& msg) const { throwInputError(path_, lineAt(pos_), msg); }

 private:
  bool startsWith(const char* lit) const { return s_.compare(pos_, std::strlen(lit), lit) == 0; }
  void skipTo(const char* end, const char* what) {
    const size_t at = s_.find(end, pos_);
    if (at == std::string::npos) fail(std::string("truncated XML: unterminated ") + what);
    pos_ = at + std::strlen(end);
  }
  void skipSpace() {
    while (pos_ < s_.size() && std::isspace(static_cast<unsigned char>(s_[pos_]))) ++pos_;
  }
  void skipMisc() {
    for (;;) {
      skipSpace();
      if (startsWith("<?")) skipTo("?>", "processing instruction");
      else if (startsWith("<!--")) skipTo("-->", "comment");
      else if (startsWith("<!")) skipTo(">", "declaration");
      else return;
    }
  }
  static bool nameChar(char c) {
    return std::isalnum(static_cast<unsigned char>(c)) || c == '_' || c == ':' || c == '-' || c == '.';
  }
  std::string name() {
    const size_t b = pos_;
    while (pos_ < s_.size() && nameChar(s_[pos_])) ++pos_;
    if (b == pos_) fail("malformed XML: expected a name");
    return s_.substr(b, pos_ - b);
  }
  static std::string unescape(const std::string& v) {
    std::string r;
    for (size_t i = 0; i < v.size(); ++i) {
      if (v[i] != '&') {
        r += v[i];
        continue;
      }
      const size_t semi = v.find(';', i);
      const std::string ent = semi == std::string::npos ? std::string() : v.substr(i + 1, semi - i - 1);
      if (ent == "lt") r += '<';
      else if (ent == "gt") r += '>';
      else if (ent == "amp") r += '&';
      else if (ent == "quot") r += '"';
      else if (ent == "apos") r += '\'';
      else {
        r += '&';
        continue;
      }
      i = semi;
    }
    return r;
  }

  void parseElement(XmlElement& el, int depth) {
    if (depth > 64) fail("XML nested too deeply");
    el.offset = pos_;
    ++pos_;  // '<'
    el.name = name();
    for (;;) {
      skipSpace();
      if (pos_ >= s_.size()) fail("truncated XML: unterminated <" + el.name + "> tag");
      if (s_[pos_] == '/') {
        if (pos_ + 1 >= s_.size() || s_[pos_ + 1] != '>') fail("malformed XML tag <" + el.name + ">");
        pos_ += 2;
        return;  // self-closing
      }
      if (s_[pos_] == '>') {
        ++pos_;
        break;
      }
      std::string key = name();
      skipSpace();
      if (pos_ >= s_.size() || s_[pos_] != '=') fail("malformed XML attribute '" + key + "' in <" + el.name + ">");
      ++pos_;
      skipSpace();
      if (pos_ >= s_.size() || (s_[pos_] != '"' && s_[pos_] != '\'')) fail("malformed XML attribute '" + key + "' (no quotes)");
      const char q = s_[pos_++];
      const size_t end = s_.find(q, pos_);
      if (end == std::string::npos) fail("truncated XML: unterminated attribute '" + key + "'");
      el.attrs.emplace_back(std::move(key), unescape(s_.substr(pos_, end - pos_)));
      pos_ = end + 1;
    }
    if (el.name == "AppendedData") {
      const std::string* enc = el.attr("encoding");
      appendedEncoding_ = enc ? *enc : "raw";
      const size_t us = s_.find('_', pos_);
      if (us == std::string::npos) fail("AppendedData without the '_' marker");
      appended_ = us + 1;
      pos_ = s_.size();
      stop_ = true;
      return;
    }
    el.contentBegin = pos_;
    for (;;) {
      const size_t lt = s_.find('<', pos_);
      if (lt == std::string::npos) fail("truncated XML: no </" + el.name + ">");
      pos_ = lt;
      if (startsWith("<!--")) {
        skipTo("-->", "comment");
        continue;
      }
      if (startsWith("<![CDATA[")) {
        skipTo("]]>", "CDATA");
        continue;
      }
      if (startsWith("</")) {
        el.contentEnd = pos_;
        pos_ += 2;
        const std::string n = name();
        if (n != el.name) fail("malformed XML: <" + el.name + "> closed by </" + n + ">");
        skipSpace();
        if (pos_ >= s_.size() || s_[pos_] != '>') fail("malformed XML end tag </" + n);
        ++pos_;
        return;
      }
      el.children.emplace_back();
      parseElement(el.children.back(), depth + 1);
      if (stop_) return;
    }
  }

  const std::string& path_;
  const std::string& s_;
  size_t pos_ = 0;
  size_t appended_ = std::string::npos;
  std::string appendedEncoding_;
  bool stop_ = false;
};

/// Bytes from either raw memory or a base64 text (padding allowed between
/// separately encoded blocks, whitespace ignored).
class ByteSource {
 public:
  ByteSource(const char* p, const char* end, bool base64) : p_(p), end_(end), base64_(base64) {}
  /// Appends n bytes to out; false when the data ends first (or bad base64).
  bool read(size_t n, std::string& out) {
    if (!base64_) {
      if (static_cast<size_t>(end_ - p_) < n) return false;
      out.append(p_, n);
      p_ += n;
      return true;
    }
    while (pending_.size() < n) {
      if (!decodeGroup()) return false;
    }
    out.append(pending_, 0, n);
    pending_.erase(0, n);
    return true;
  }
  /// Upper bound of the bytes still available.
  size_t available() const {
    const auto left = static_cast<size_t>(end_ - p_);
    return pending_.size() + (base64_ ? left / 4 * 3 + 3 : left);
  }

 private:
  static int value(char c) {
    if (c >= 'A' && c <= 'Z') return c - 'A';
    if (c >= 'a' && c <= 'z') return c - 'a' + 26;
    if (c >= '0' && c <= '9') return c - '0' + 52;
    if (c == '+') return 62;
    if (c == '/') return 63;
    if (c == '=') return -2;
    return -1;
  }
  bool decodeGroup() {
    int v[4];
    int got = 0;
    while (got < 4) {
      if (p_ >= end_) return false;
      const char c = *p_++;
      if (std::isspace(static_cast<unsigned char>(c))) continue;
      const int x = value(c);
      if (x == -1) return false;
      v[got++] = x;
    }
    if (v[0] < 0 || v[1] < 0) return false;
    pending_ += static_cast<char>((v[0] << 2) | (v[1] >> 4));
    if (v[2] >= 0) pending_ += static_cast<char>(((v[1] & 15) << 4) | (v[2] >> 2));
    if (v[2] >= 0 && v[3] >= 0) pending_ += static_cast<char>(((v[2] & 3) << 6) | v[3]);
    return true;
  }
  const char* p_;
  const char* end_;
  bool base64_;
  std::string pending_;
};

int typeSize(const std::string& t) {
  if (t == "Int8" || t == "UInt8") return 1;
  if (t == "Int16" || t == "UInt16") return 2;
  if (t == "Int32" || t == "UInt32" || t == "Float32") return 4;
  if (t == "Int64" || t == "UInt64" || t == "Float64") return 8;
  return 0;
}

template <class T>
void convertAll(const char* p, size_t n, bool big, std::vector<double>& out) {
  out.resize(n);
  for (size_t i = 0; i < n; ++i) out[i] = static_cast<double>(loadValue<T>(p + i * sizeof(T), big));
}

/// Decodes n values of VTK XML type t (resolved once, not per value).
void convertArray(const char* p, size_t n, const std::string& t, bool big, std::vector<double>& out) {
  if (t == "Int8") convertAll<int8_t>(p, n, big, out);
  else if (t == "UInt8") convertAll<uint8_t>(p, n, big, out);
  else if (t == "Int16") convertAll<int16_t>(p, n, big, out);
  else if (t == "UInt16") convertAll<uint16_t>(p, n, big, out);
  else if (t == "Int32") convertAll<int32_t>(p, n, big, out);
  else if (t == "UInt32") convertAll<uint32_t>(p, n, big, out);
  else if (t == "Int64") convertAll<int64_t>(p, n, big, out);
  else if (t == "UInt64") convertAll<uint64_t>(p, n, big, out);
  else if (t == "Float32") convertAll<float>(p, n, big, out);
  else convertAll<double>(p, n, big, out);
}

class VtuReader {
 public:
  explicit VtuReader(const std::string& path) : path_(path), s_(readWholeFile(path)), xml_(path_, s_) {}

  TetMesh read() {
    const XmlElement root = xml_.parseDocument();
    if (root.name != "VTKFile") failAt(root, "wrong root element <" + root.name + "> (expected <VTKFile>)");
    const std::string* type = root.attr("type");
    if (!type || *type != "UnstructuredGrid")
      failAt(root, "VTKFile type '" + (type ? *type : std::string()) + "' is not supported (expected UnstructuredGrid)");
    const std::string* order = root.attr("byte_order");
    big_ = order && *order == "BigEndian";
    if (order && *order != "BigEndian" && *order != "LittleEndian") failAt(root, "unknown byte_order '" + *order + "'");
    const std::string* ht = root.attr("header_type");
    headerSize_ = 4;
    if (ht) {
      if (*ht == "UInt64") headerSize_ = 8;
      else if (*ht != "UInt32") failAt(root, "unsupported header_type '" + *ht + "' (expected UInt32 or UInt64)");
    }
    if (const std::string* comp = root.attr("compressor")) {
      if (*comp == "vtkZLibDataCompressor") compressed_ = true;
      else if (!comp->empty()) failAt(root, "unsupported compressor '" + *comp + "' (only vtkZLibDataCompressor)");
    }
    if (xml_.appendedEncoding()) {
      const std::string& enc = *xml_.appendedEncoding();
      if (enc != "raw" && enc != "base64") fail("unsupported AppendedData encoding '" + enc + "'", 0);
    }

    const XmlElement* grid = root.child("UnstructuredGrid");
    if (!grid) failAt(root, "no <UnstructuredGrid> element");
    const XmlElement* piece = nullptr;
    int pieces = 0;
    for (const auto& c : grid->children)
      if (c.name == "Piece") {
        ++pieces;
        piece = &c;
      }
    if (!piece) failAt(*grid, "no <Piece> element");
    if (pieces > 1) failAt(*grid, std::to_string(pieces) + " pieces; only single-piece files are supported");
    const size_t np = count(*piece, "NumberOfPoints"), nc = count(*piece, "NumberOfCells");

    GridData g;
    const XmlElement* points = piece->child("Points");
    if (!points || points->children.empty()) failAt(*piece, "no <Points> data array");
    const XmlElement& pa = points->children.front();
    Array P = decode(pa, np, 3);
    if (P.components != 3) failAt(pa, "Points have " + std::to_string(P.components) + " components (expected 3)");
    g.points = std::move(P.values);

    const XmlElement* cells = piece->child("Cells");
    if (!cells) failAt(*piece, "no <Cells> element");
    const XmlElement* conn = findArray(*cells, "connectivity");
    const XmlElement* offs = findArray(*cells, "offsets");
    const XmlElement* types = findArray(*cells, "types");
    if (!conn || !offs || !types) failAt(*cells, "<Cells> needs connectivity, offsets and types arrays");
    Array T = decode(*types, nc, 1);
    Array O = decode(*offs, nc, 1);
    // The connectivity length is the last offset.
    const double last = O.values.empty() ? 0.0 : O.values.back();
    if (!(last >= 0) || last > static_cast<double>(s_.size() + 64) * 1100.0) failAt(*offs, "bad last cell offset");
    Array C = decode(*conn, static_cast<size_t>(last), 1);
    g.cellTypes.assign(T.values.begin(), T.values.end());
    g.offsets.reserve(nc + 1);
    g.offsets.push_back(0);
    for (double o : O.values) g.offsets.push_back(static_cast<long long>(o));
    g.connectivity.assign(C.values.begin(), C.values.end());

    std::set<int> voids;
    if (const XmlElement* fd = grid->child("FieldData"))
      for (const auto& a : fd->children) {
        const std::string* nm = a.attr("Name");
        if (a.name != "DataArray" || !nm || *nm != kVoidRegions) continue;
        for (double v : decode(a, count(a, "NumberOfTuples"), 1).values) {
          if (v != std::floor(v) || std::fabs(v) > 2147483647.0) failAt(a, std::string(kVoidRegions) + " holds a non-integer");
          voids.insert(static_cast<int>(v));
        }
      }
    if (const XmlElement* pd = piece->child("PointData"))
      for (const auto& a : pd->children)
        if (a.name == "DataArray" && numeric(a)) g.pointArrays.push_back(decode(a, np, 0));
    if (const XmlElement* cd = piece->child("CellData"))
      for (const auto& a : cd->children)
        if (a.name == "DataArray" && numeric(a)) g.cellArrays.push_back(decode(a, nc, 0));
    TetMesh m = assemble(g, [&](const std::string& msg, long line) { fail(msg, line); });
    m.voidRegions = std::move(voids);
    return m;
  }

 private:
  [[noreturn]] void fail(const std::string& msg, long line) const { throwInputError(path_, line, msg); }
  [[noreturn]] void failAt(const XmlElement& el, const std::string& msg) const { fail(msg, xml_.lineAt(el.offset)); }

  static bool numeric(const XmlElement& a) {
    const std::string* t = a.attr("type");
    return t && typeSize(*t) > 0;
  }
  static const XmlElement* findArray(const XmlElement& parent, const std::string& n) {
    for (const auto& c : parent.children)
      if (c.name == "DataArray") {
        const std::string* nm = c.attr("Name");
        if (nm && *nm == n) return &c;
      }
    return nullptr;
  }
  size_t count(const XmlElement& el, const char* key) const {
    const std::string* v = el.attr(key);
    if (!v) failAt(el, std::string("<") + el.name + "> has no " + key);
    unsigned long long n = 0;
    auto [p, ec] = std::from_chars(v->data(), v->data() + v->size(), n);
    if (ec != std::errc() || p != v->data() + v->size()) failAt(el, std::string("malformed ") + key + " '" + *v + "'");
    // Even zlib cannot shrink more than ~1032:1; anything beyond is corrupt.
    if (n > (s_.size() + 64) * 1100) failAt(el, std::string(key) + " " + *v + " is larger than the file can hold");
    return static_cast<size_t>(n);
  }

  /// Decodes a DataArray of `tuples` tuples; components = 0 takes the attribute.
  Array decode(const XmlElement& el, size_t tuples, int components) {
    Array a;
    a.line = xml_.lineAt(el.offset);
    const std::string* nm = el.attr("Name");
    a.name = nm ? *nm : std::string();
    const std::string label = "DataArray '" + a.name + "'";
    const std::string* type = el.attr("type");
    if (!type) failAt(el, label + " has no type");
    const int ts = typeSize(*type);
    if (ts == 0) failAt(el, label + " has unsupported type '" + *type + "'");
    int nc = 1;
    if (const std::string* c = el.attr("NumberOfComponents")) {
      auto [p, ec] = std::from_chars(c->data(), c->data() + c->size(), nc);
      if (ec != std::errc() || p != c->data() + c->size() || nc < 1 || nc > 1000)
        failAt(el, label + " has a bad NumberOfComponents '" + *c + "'");
    } else if (components > 0) {
      nc = components;
    }
    a.components = nc;
    const size_t n = tuples * static_cast<size_t>(nc);
    const std::string* fmtp = el.attr("format");
    const std::string fmt = fmtp ? *fmtp : "ascii";
    if (fmt == "ascii") {
      const char* p = s_.data() + el.contentBegin;
      const char* end = s_.data() + el.contentEnd;
      while (true) {
        while (p < end && std::isspace(static_cast<unsigned char>(*p))) ++p;
        if (p >= end) break;
        const char* q = p;
        while (q < end && !std::isspace(static_cast<unsigned char>(*q))) ++q;
        double v;
        auto [r, ec] = std::from_chars(p, q, v);
        if (ec != std::errc() || r != q) fail(label + ": malformed value '" + std::string(p, std::min<size_t>(q - p, 30)) + "'", xml_.lineAt(static_cast<size_t>(p - s_.data())));
        a.values.push_back(v);
        p = q;
      }
      if (a.values.size() != n)
        failAt(el, label + " has " + std::to_string(a.values.size()) + " values, expected " + std::to_string(n));
      return a;
    }
    std::unique_ptr<ByteSource> src;
    if (fmt == "binary") {
      src = std::make_unique<ByteSource>(s_.data() + el.contentBegin, s_.data() + el.contentEnd, true);
    } else if (fmt == "appended") {
      if (xml_.appendedStart() == std::string::npos) failAt(el, label + " is appended but the file has no <AppendedData>");
      const std::string* off = el.attr("offset");
      unsigned long long o = 0;
      if (!off || std::from_chars(off->data(), off->data() + off->size(), o).ec != std::errc())
        failAt(el, label + " has no valid offset");
      if (o > s_.size() - xml_.appendedStart()) failAt(el, label + ": offset " + *off + " is beyond the end of the file");
      src = std::make_unique<ByteSource>(s_.data() + xml_.appendedStart() + o, s_.data() + s_.size(),
                                         *xml_.appendedEncoding() == "base64");
    } else {
      failAt(el, label + " has unknown format '" + fmt + "'");
    }
    const size_t expected = n * static_cast<size_t>(ts);
    std::string bytes = binaryPayload(*src, el, label, expected);
    convertArray(bytes.data(), n, *type, big_, a.values);
    return a;
  }

  unsigned long long header(ByteSource& src, const XmlElement& el, const std::string& label) {
    std::string h;
    if (!src.read(static_cast<size_t>(headerSize_), h)) failAt(el, label + ": truncated binary data (no header)");
    return headerSize_ == 8 ? loadValue<uint64_t>(h.data(), big_) : loadValue<uint32_t>(h.data(), big_);
  }

  std::string binaryPayload(ByteSource& src, const XmlElement& el, const std::string& label, size_t expected) {
    std::string out;
    if (!compressed_) {
      const unsigned long long nbytes = header(src, el, label);
      if (nbytes != expected)
        failAt(el, label + ": binary header says " + std::to_string(nbytes) + " bytes, expected " + std::to_string(expected));
      if (nbytes > src.available() || !src.read(static_cast<size_t>(nbytes), out))
        failAt(el, label + ": truncated binary data (" + std::to_string(nbytes) + " bytes declared)");
      return out;
    }
    const unsigned long long nblocks = header(src, el, label);
    const unsigned long long blockSize = header(src, el, label);
    const unsigned long long lastSize = header(src, el, label);
    if (nblocks > src.available() / static_cast<size_t>(headerSize_))
      failAt(el, label + ": compressed header declares " + std::to_string(nblocks) + " blocks, more than the file holds");
    const unsigned long long last = lastSize == 0 ? blockSize : lastSize;
    const unsigned long long total = nblocks == 0 ? 0 : (nblocks - 1) * blockSize + last;
    if (lastSize > blockSize || total != expected)
      failAt(el, label + ": compressed header declares " + std::to_string(total) + " bytes, expected " + std::to_string(expected));
    std::vector<unsigned long long> csize(static_cast<size_t>(nblocks));
    unsigned long long csum = 0;
    for (auto& cs : csize) {
      cs = header(src, el, label);
      if (cs > src.available()) failAt(el, label + ": truncated compressed data");
      csum += cs;
    }
    if (csum > src.available()) failAt(el, label + ": truncated compressed data");
    if (expected > csum * 1100 + 1024) failAt(el, label + ": compressed sizes are inconsistent with the data size");
    out.resize(static_cast<size_t>(expected));
    std::string block;
    size_t at = 0;
    for (size_t b = 0; b < csize.size(); ++b) {
      block.clear();
      if (!src.read(static_cast<size_t>(csize[b]), block)) failAt(el, label + ": truncated compressed data");
      const unsigned long long want = b + 1 == csize.size() ? last : blockSize;
      uLongf got = static_cast<uLongf>(want);
      const int rc = uncompress(reinterpret_cast<Bytef*>(&out[at]), &got, reinterpret_cast<const Bytef*>(block.data()),
                                static_cast<uLong>(block.size()));
      if (rc != Z_OK || got != want)
        failAt(el, label + ": zlib block " + std::to_string(b) + " does not decompress (" + (rc == Z_OK ? "wrong size" : zError(rc)) + ")");
      at += static_cast<size_t>(want);
    }
    return out;
  }

  std::string path_;
  std::string s_;
  XmlParser xml_;
  bool big_ = false;
  bool compressed_ = false;
  int headerSize_ = 4;
};

// ----------------------------------------------------------- legacy (.vtk)

class LegacyVtkReader {
 public:
  explicit LegacyVtkReader(const std::string& path) : c_(path, readWholeFile(path)) {}

  TetMesh read() {
    std::string_view l1 = c_.restOfLine();
    if (l1.substr(0, 5) != "# vtk" && l1.substr(0, 4) != "#vtk")
      c_.fail("wrong header '" + std::string(l1.substr(0, 30)) + "' (expected '# vtk DataFile Version')");
    if (c_.pos() >= c_.size()) c_.fail("truncated: no title line");
    c_.restOfLine();  // title
    std::string_view mode = c_.token("ASCII or BINARY");
    if (iequals(mode, "BINARY")) binary_ = true;
    else if (!iequals(mode, "ASCII")) c_.fail("expected ASCII or BINARY, found '" + std::string(mode.substr(0, 30)) + "'");
    std::string_view tok = c_.token("DATASET");
    if (!iequals(tok, "DATASET")) c_.fail("expected DATASET, found '" + std::string(tok.substr(0, 30)) + "'");
    tok = c_.token("dataset type");
    if (!iequals(tok, "UNSTRUCTURED_GRID"))
      c_.fail("dataset type " + std::string(tok.substr(0, 30)) + " is not supported (expected UNSTRUCTURED_GRID)");

    GridData g;
    bool havePoints = false, haveCells = false, haveTypes = false;
    size_t np = 0, nc = 0;
    std::vector<Array>* target = nullptr;
    size_t targetCount = 0;
    while (c_.tryToken(tok)) {
      const std::string kw = lowerCase(tok);
      if (kw == "points") {
        np = count("point count");
        const std::string type(c_.token("point type"));
        values(np * 3, type, g.points);
        havePoints = true;
      } else if (kw == "cells") {
        const size_t n = count("cell count");
        const size_t size = count("cell list size");
        if (iequals(c_.peek(), "OFFSETS")) {  // 5.1: OFFSETS and CONNECTIVITY arrays
          c_.token("OFFSETS");
          std::vector<double> o, cn;
          values(n, std::string(c_.token("offset type")), o);
          std::string_view k = c_.token("CONNECTIVITY");
          if (!iequals(k, "CONNECTIVITY")) c_.fail("expected CONNECTIVITY after OFFSETS");
          values(size, std::string(c_.token("connectivity type")), cn);
          if (n == 0 || o.front() != 0) c_.fail("OFFSETS must start with 0");
          nc = n - 1;
          g.offsets.assign(o.begin(), o.end());
          g.connectivity.assign(cn.begin(), cn.end());
        } else {
          nc = n;
          std::vector<double> raw;
          values(size, "int", raw);
          g.offsets.assign(1, 0);
          size_t at = 0;
          for (size_t i = 0; i < n; ++i) {
            if (at >= raw.size() || raw[at] < 0 || raw[at] > static_cast<double>(raw.size() - at - 1))
              c_.fail("CELLS: cell " + std::to_string(i) + " does not fit the declared list size " + std::to_string(size));
            const auto k = static_cast<size_t>(raw[at]);
            for (size_t j = 0; j < k; ++j) g.connectivity.push_back(static_cast<long long>(raw[at + 1 + j]));
            at += k + 1;
            g.offsets.push_back(static_cast<long long>(g.connectivity.size()));
          }
          if (at != raw.size())
            c_.fail("CELLS: list size " + std::to_string(size) + " disagrees with the " + std::to_string(n) + " cells");
        }
        haveCells = true;
      } else if (kw == "cell_types") {
        const size_t n = count("cell type count");
        std::vector<double> t;
        values(n, "int", t);
        g.cellTypes.assign(t.begin(), t.end());
        haveTypes = true;
      } else if (kw == "cell_data" || kw == "point_data") {
        const size_t n = count("data count");
        const bool cell = kw == "cell_data";
        if (cell ? (haveTypes && n != g.cellTypes.size()) : (havePoints && n != np))
          c_.fail(std::string(cell ? "CELL_DATA" : "POINT_DATA") + " " + std::to_string(n) + " disagrees with the number of " + (cell ? "cells" : "points"));
        target = cell ? &g.cellArrays : &g.pointArrays;
        targetCount = n;
      } else if (kw == "scalars" || kw == "vectors" || kw == "normals" || kw == "tensors" || kw == "tensors6" ||
                 kw == "texture_coordinates" || kw == "global_ids" || kw == "pedigree_ids") {
        if (!target) c_.fail(std::string(tok) + " before CELL_DATA or POINT_DATA");
        Array a;
        a.line = c_.line();
        a.name = std::string(c_.token("array name"));
        if (kw == "texture_coordinates") a.components = static_cast<int>(c_.integerIn("dimension", 1, 3));
        std::string type(c_.token("data type"));
        if (kw == "scalars") {
          std::string_view next = c_.peek();
          long long k = 0;
          if (std::from_chars(next.data(), next.data() + next.size(), k).ec == std::errc() && !next.empty()) {
            a.components = static_cast<int>(c_.integerIn("component count", 1, 4));
          }
          if (iequals(c_.peek(), "LOOKUP_TABLE")) {
            c_.token("LOOKUP_TABLE");
            c_.token("lookup table name");
          }
        }
        if (kw == "vectors" || kw == "normals") a.components = 3;
        if (kw == "tensors") a.components = 9;
        if (kw == "tensors6") a.components = 6;
        values(targetCount * static_cast<size_t>(a.components), type, a.values);
        target->push_back(std::move(a));
      } else if (kw == "field") {
        if (!target) c_.fail("FIELD before CELL_DATA or POINT_DATA");
        c_.token("field name");
        const size_t k = count("field array count");
        for (size_t i = 0; i < k; ++i) {
          Array a;
          a.name = std::string(c_.token("array name"));
          a.line = c_.line();
          a.components = static_cast<int>(c_.integerIn("component count", 1, 1000));
          const size_t tuples = count("tuple count");
          const std::string type(c_.token("data type"));
          values(tuples * static_cast<size_t>(a.components), type, a.values);
          skipMetadata();
          if (tuples == targetCount) target->push_back(std::move(a));
        }
      } else if (kw == "lookup_table") {
        c_.token("lookup table name");
        const size_t n = count("lookup table size");
        std::vector<double> skip;
        values(n * 4, binary_ ? "unsigned_char" : "float", skip);
      } else if (kw == "color_scalars") {
        c_.token("array name");
        const size_t k = count("component count");
        std::vector<double> skip;
        values(targetCount * k, binary_ ? "unsigned_char" : "float", skip);
      } else if (kw == "metadata") {
        skipMetadata(true);
      } else {
        c_.fail("unknown keyword '" + std::string(tok.substr(0, 30)) + "'");
      }
      skipMetadata();
    }
    if (!havePoints) throwInputError(c_.path(), 0, "no POINTS");
    if (!haveCells || !haveTypes) throwInputError(c_.path(), 0, "no CELLS or CELL_TYPES");
    if (g.cellTypes.size() != nc)
      throwInputError(c_.path(), 0, "CELL_TYPES has " + std::to_string(g.cellTypes.size()) + " entries for " + std::to_string(nc) + " cells");
    return assemble(g, [&](const std::string& msg, long line) { throwInputError(c_.path(), line, msg); });
  }

 private:
  size_t count(const char* what) {
    const long long n = c_.integerIn(what, 0, 4000000000000LL);
    // Every value takes at least one byte in BINARY and two in ASCII.
    if (static_cast<unsigned long long>(n) > c_.size()) c_.fail(std::string(what) + " " + std::to_string(n) + " is larger than the file can hold");
    return static_cast<size_t>(n);
  }

  void skipMetadata(bool already = false) {
    if (!already) {
      if (!iequals(c_.peek(), "METADATA")) return;
      c_.token("METADATA");
    }
    // Lines up to the next empty line.
    c_.skipLine();
    while (c_.pos() < c_.size()) {
      std::string_view l = c_.restOfLine();
      if (l.find_first_not_of(" \t\r") == std::string_view::npos) break;
    }
  }

  void values(size_t n, const std::string& type, std::vector<double>& out) {
    const std::string t = lowerCase(type);
    int size = 0;
    if (t == "bit") c_.fail("bit arrays are not supported");
    if (t == "char" || t == "unsigned_char") size = 1;
    else if (t == "short" || t == "unsigned_short") size = 2;
    else if (t == "int" || t == "unsigned_int" || t == "float" || t == "vtktypeint32") size = 4;
    else if (t == "long" || t == "unsigned_long" || t == "double" || t == "vtktypeint64" || t == "vtktypeuint64" ||
             t == "vtkidtype")
      size = 8;
    else c_.fail("unknown data type '" + type.substr(0, 30) + "'");
    out.clear();
    if (!binary_) {
      c_.needItems(n, 2, std::string("ASCII data"));
      out.reserve(n);
      for (size_t i = 0; i < n; ++i) {
        const std::string_view next = c_.peek();
        if (next.empty() || (std::isalpha(static_cast<unsigned char>(next[0])) && !iequals(next, "nan") &&
                             !iequals(next, "inf") && !iequals(next, "-inf"))) {
          if (!next.empty()) c_.token("value");
          c_.fail("truncated: expected " + std::to_string(n) + " values, got " + std::to_string(i));
        }
        out.push_back(c_.real("value"));
      }
      return;
    }
    c_.skipLine();
    c_.needItems(n, static_cast<size_t>(size), "binary " + type + " data");
    const char* p = c_.rawBytes(n * static_cast<size_t>(size), "binary data");
    // Legacy binary data is big endian.
    if (t == "char") convertAll<int8_t>(p, n, true, out);
    else if (t == "unsigned_char") convertAll<uint8_t>(p, n, true, out);
    else if (t == "short") convertAll<int16_t>(p, n, true, out);
    else if (t == "unsigned_short") convertAll<uint16_t>(p, n, true, out);
    else if (t == "int" || t == "vtktypeint32") convertAll<int32_t>(p, n, true, out);
    else if (t == "unsigned_int") convertAll<uint32_t>(p, n, true, out);
    else if (t == "float") convertAll<float>(p, n, true, out);
    else if (t == "double") convertAll<double>(p, n, true, out);
    else if (t == "unsigned_long" || t == "vtktypeuint64") convertAll<uint64_t>(p, n, true, out);
    else convertAll<int64_t>(p, n, true, out);
  }

  Cursor c_;
  bool binary_ = false;
};

// ------------------------------------------------------------------ writer

std::string xmlEscape(const std::string& s) {
  std::string r;
  for (char ch : s) {
    switch (ch) {
      case '<': r += "&lt;"; break;
      case '>': r += "&gt;"; break;
      case '&': r += "&amp;"; break;
      case '"': r += "&quot;"; break;
      case '\'': r += "&apos;"; break;
      default: r += ch;
    }
  }
  return r;
}

class VtuWriter {
 public:
  explicit VtuWriter(bool binary) : binary_(binary) {}

  template <class T>
  void array(const std::string& indent, const char* type, const std::string& name, int components, size_t n,
             const T& valueAt) {
    xml_ += indent + "<DataArray type=\"" + type + "\" Name=\"" + xmlEscape(name) + "\" NumberOfComponents=\"" +
            std::to_string(components) + "\" format=\"" + (binary_ ? "appended" : "ascii") + "\"";
    using V = std::decay_t<decltype(valueAt(size_t{0}))>;
    if (binary_) {
      xml_ += " offset=\"" + std::to_string(appended_.size()) + "\"/>\n";
      appendRaw<uint64_t>(appended_, static_cast<uint64_t>(n * sizeof(V)));
      for (size_t i = 0; i < n; ++i) appendRaw<V>(appended_, valueAt(i));
      return;
    }
    xml_ += ">\n";
    for (size_t i = 0; i < n; ++i) {
      if constexpr (std::is_floating_point_v<V>) appendReal(xml_, valueAt(i));
      else appendInt(xml_, static_cast<long long>(valueAt(i)));
      xml_ += (i + 1) % 12 == 0 || i + 1 == n ? '\n' : ' ';
    }
    xml_ += indent + "</DataArray>\n";
  }

  std::string xml_;
  std::string appended_;
  bool binary_;
};

}  // namespace

TetMesh readVtu(const std::string& path) { return VtuReader(path).read(); }
TetMesh readLegacyVtk(const std::string& path) { return LegacyVtkReader(path).read(); }

void writeVtu(const TetMesh& m, const std::string& path, bool binary) {
  VtuWriter w(binary);
  const auto nv = static_cast<size_t>(m.V.rows());
  const auto nt = static_cast<size_t>(m.T.rows());
  std::string& x = w.xml_;
  x = "<?xml version=\"1.0\"?>\n<VTKFile type=\"UnstructuredGrid\" version=\"1.0\" byte_order=\"";
  x += hostIsBigEndian() ? "BigEndian" : "LittleEndian";
  x += "\" header_type=\"UInt64\">\n  <UnstructuredGrid>\n";
  if (!m.voidRegions.empty()) {
    x += "    <FieldData>\n      <DataArray type=\"Int32\" Name=\"" + std::string(kVoidRegions) + "\" NumberOfTuples=\"" +
         std::to_string(m.voidRegions.size()) + "\" format=\"ascii\">\n       ";
    for (int r : m.voidRegions) x += " " + std::to_string(r);
    x += "\n      </DataArray>\n    </FieldData>\n";
  }
  x += "    <Piece NumberOfPoints=\"" + std::to_string(nv) +
       "\" NumberOfCells=\"" + std::to_string(nt) + "\">\n      <PointData>\n";
  const std::string in = "        ";
  for (const Field& f : m.pointFields) {
    const auto nc = static_cast<size_t>(f.values.cols());
    w.array(in, "Float64", f.name, static_cast<int>(nc), nv * nc,
            [&](size_t i) { return f.values(static_cast<Eigen::Index>(i / nc), static_cast<Eigen::Index>(i % nc)); });
  }
  x += "      </PointData>\n      <CellData>\n";
  w.array(in, "Int32", "region", 1, nt, [&](size_t i) { return static_cast<int32_t>(regionOf(m, static_cast<Eigen::Index>(i))); });
  for (const Field& f : m.cellFields) {
    const auto nc = static_cast<size_t>(f.values.cols());
    w.array(in, "Float64", f.name, static_cast<int>(nc), nt * nc,
            [&](size_t i) { return f.values(static_cast<Eigen::Index>(i / nc), static_cast<Eigen::Index>(i % nc)); });
  }
  x += "      </CellData>\n      <Points>\n";
  w.array(in, "Float64", "Points", 3, nv * 3,
          [&](size_t i) { return m.V(static_cast<Eigen::Index>(i / 3), static_cast<Eigen::Index>(i % 3)); });
  x += "      </Points>\n      <Cells>\n";
  w.array(in, "Int64", "connectivity", 1, nt * 4,
          [&](size_t i) { return static_cast<int64_t>(m.T(static_cast<Eigen::Index>(i / 4), static_cast<Eigen::Index>(i % 4))); });
  w.array(in, "Int64", "offsets", 1, nt, [&](size_t i) { return static_cast<int64_t>(4 * (i + 1)); });
  w.array(in, "UInt8", "types", 1, nt, [&](size_t) { return static_cast<uint8_t>(kVtkTetra); });
  x += "      </Cells>\n    </Piece>\n  </UnstructuredGrid>\n";
  if (binary) {
    x += "  <AppendedData encoding=\"raw\">\n   _";
  }
  AtomicFile file(path, true);
  file.stream().write(x.data(), static_cast<std::streamsize>(x.size()));
  if (binary) {
    file.stream().write(w.appended_.data(), static_cast<std::streamsize>(w.appended_.size()));
    file.stream() << "\n  </AppendedData>\n";
  }
  file.stream() << "</VTKFile>\n";
  file.commit();
}

}  // namespace tet2spline::detail

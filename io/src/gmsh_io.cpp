// Gmsh .msh 2.2 and 4.1, ASCII and binary. Linear tets (type 4) are read;
// other 3D elements are an error; 0D/1D/2D elements are skipped. Region =
// physical tag, else the elementary (entity) tag, else 1. Node tags may be
// sparse and are remapped to 0..#V-1 in file order.
#include <algorithm>
#include <cmath>
#include <map>
#include <unordered_map>
#include <vector>

#include "format_readers.h"
#include "io_util.h"
#include "tet2spline/io/atomic_file.h"

namespace tet2spline::detail {

namespace {

struct ElementType {
  int nodes;
  int dim;
  const char* name;
};

// Gmsh element types (Gmsh reference manual, "MSH file format").
bool elementType(long long type, ElementType& out) {
  static const std::map<int, ElementType> table = {
      {1, {2, 1, "2-node line"}},           {2, {3, 2, "3-node triangle"}},
      {3, {4, 2, "4-node quadrangle"}},     {4, {4, 3, "4-node tetrahedron"}},
      {5, {8, 3, "8-node hexahedron"}},     {6, {6, 3, "6-node prism"}},
      {7, {5, 3, "5-node pyramid"}},        {8, {3, 1, "3-node line"}},
      {9, {6, 2, "6-node triangle"}},       {10, {9, 2, "9-node quadrangle"}},
      {11, {10, 3, "10-node second-order tetrahedron"}},
      {12, {27, 3, "27-node hexahedron"}},  {13, {18, 3, "18-node prism"}},
      {14, {14, 3, "14-node pyramid"}},     {15, {1, 0, "1-node point"}},
      {16, {8, 2, "8-node quadrangle"}},    {17, {20, 3, "20-node hexahedron"}},
      {18, {15, 3, "15-node prism"}},       {19, {13, 3, "13-node pyramid"}},
      {20, {9, 2, "9-node triangle"}},      {21, {10, 2, "10-node triangle"}},
      {22, {12, 2, "12-node triangle"}},    {23, {15, 2, "15-node triangle"}},
      {24, {15, 2, "15-node triangle"}},    {25, {21, 2, "21-node triangle"}},
      {26, {4, 1, "4-node line"}},          {27, {5, 1, "5-node line"}},
      {28, {6, 1, "6-node line"}},          {29, {20, 3, "20-node tetrahedron"}},
      {30, {35, 3, "35-node tetrahedron"}}, {31, {56, 3, "56-node tetrahedron"}},
      {92, {64, 3, "64-node hexahedron"}},  {93, {125, 3, "125-node hexahedron"}},
  };
  if (type < 0 || type > 1000) return false;
  auto it = table.find(static_cast<int>(type));
  if (it == table.end()) return false;
  out = it->second;
  return true;
}

class GmshReader {
 public:
  explicit GmshReader(const std::string& path) : c_(path, readWholeFile(path)) {}

  TetMesh read() {
    std::string_view tok = c_.token("$MeshFormat");
    if (tok != "$MeshFormat") c_.fail("wrong header '" + std::string(tok.substr(0, 30)) + "' (expected $MeshFormat)");
    const std::string version(c_.token("format version"));
    if (version == "4.1") {
      v4_ = true;
    } else if (version == "2.2" || version == "2.1" || version == "2" || version == "2.0") {
      v4_ = false;
    } else {
      c_.fail("unsupported MSH version " + version.substr(0, 20) + " (expected 2.2 or 4.1)");
    }
    binary_ = c_.integerIn("file type", 0, 1) == 1;
    const long long dataSize = c_.integer("data size");
    if (dataSize != 8) c_.fail("unsupported data size " + std::to_string(dataSize) + " (expected 8)");
    if (binary_) {
      c_.skipLine();
      const auto one = c_.raw<int32_t>(false, "endianness marker");
      if (one == 1) {
        big_ = false;
      } else if (byteSwapped(one) == 1) {
        big_ = true;
      } else {
        c_.fail("bad binary endianness marker (expected the integer 1)");
      }
    }
    expect("$EndMeshFormat");

    TetMesh m;
    std::vector<Eigen::Vector4i> tets;
    std::vector<int> regions;
    bool haveNodes = false, haveElements = false;
    std::string_view sec;
    while (c_.tryToken(sec)) {
      if (sec.empty() || sec[0] != '$') c_.fail("expected a section such as $Nodes, found '" + std::string(sec.substr(0, 30)) + "'");
      const std::string name(sec.substr(1));
      if (name == "Entities" && v4_) {
        readEntities();
      } else if (name == "Nodes") {
        if (haveNodes) c_.fail("second $Nodes section");
        v4_ ? readNodes4(m) : readNodes2(m);
        haveNodes = true;
      } else if (name == "Elements") {
        if (!haveNodes) c_.fail("$Elements before $Nodes");
        if (haveElements) c_.fail("second $Elements section");
        v4_ ? readElements4(tets, regions) : readElements2(tets, regions);
        haveElements = true;
      } else {
        skipSection(name);  // $PhysicalNames, $NodeData, $Periodic, ...
        continue;
      }
      expect("$End" + name);
    }
    if (!haveNodes) throwInputError(c_.path(), 0, "no $Nodes section");
    if (!haveElements) throwInputError(c_.path(), 0, "no $Elements section");
    if (tets.empty()) throwInputError(c_.path(), 0, "no tetrahedra (element type 4): not a volume mesh");
    m.T.resize(static_cast<Eigen::Index>(tets.size()), 4);
    m.region.resize(static_cast<Eigen::Index>(tets.size()));
    for (size_t t = 0; t < tets.size(); ++t) {
      m.T.row(static_cast<Eigen::Index>(t)) = tets[t].transpose();
      m.region(static_cast<Eigen::Index>(t)) = regions[t];
    }
    return m;
  }

 private:
  void expect(const std::string& word) {
    std::string_view tok = c_.token(word.c_str());
    if (tok != word) c_.fail("expected " + word + ", found '" + std::string(tok.substr(0, 30)) + "'");
  }

  void skipSection(const std::string& name) {
    const std::string end = "$End" + name;
    const size_t at = c_.data().find(end, c_.pos());
    if (at == std::string::npos) c_.fail("truncated: section $" + name + " has no " + end);
    // Keep line numbers right in ASCII files by walking the tokens there.
    if (binary_) {
      c_.seek(at + end.size());
    } else {
      std::string_view tok;
      while (c_.pos() < at + end.size() && c_.tryToken(tok)) {
      }
    }
  }

  // Values that are text in ASCII files and raw in binary ones.
  unsigned long long size(const char* what) {
    if (binary_) return c_.raw<uint64_t>(big_, what);
    return static_cast<unsigned long long>(c_.integerIn(what, 0, (1LL << 62)));
  }
  long long int32(const char* what) {
    if (binary_) return c_.raw<int32_t>(big_, what);
    return c_.integerIn(what, -2147483648LL, 2147483647LL);
  }
  double real(const char* what) {
    if (binary_) return c_.raw<double>(big_, what);
    return c_.real(what);
  }
  double coordinate(const char* what) {
    const double v = real(what);
    if (!std::isfinite(v)) c_.fail(std::string(what) + " is NaN or infinite");
    return v;
  }
  // Guard a count against the bytes left (binary) or a token per item (ASCII).
  void guard(unsigned long long count, size_t binaryItemSize, const std::string& what) {
    c_.needItems(count, binary_ ? binaryItemSize : 2, what);
  }
  // Before raw data that follows a text line.
  void beginData() {
    if (binary_) c_.skipLine();
  }

  void readEntities() {
    beginData();
    unsigned long long n[4];
    for (auto& k : n) k = size("entity count");
    for (int dim = 0; dim < 4; ++dim) {
      guard(n[dim], 4 + 8, "$Entities");
      for (unsigned long long e = 0; e < n[dim]; ++e) {
        const long long tag = int32("entity tag");
        for (int k = 0; k < (dim == 0 ? 3 : 6); ++k) real("entity bounding box");
        const unsigned long long nphys = size("physical tag count");
        guard(nphys, 4, "physical tags of an entity");
        long long firstPhys = 0;
        for (unsigned long long p = 0; p < nphys; ++p) {
          const long long ph = int32("physical tag");
          if (p == 0) firstPhys = ph;
        }
        if (dim == 3 && nphys > 0) volumePhysical_[tag] = static_cast<int>(firstPhys);
        if (dim > 0) {
          const unsigned long long nb = size("bounding entity count");
          guard(nb, 4, "bounding entities");
          for (unsigned long long b = 0; b < nb; ++b) int32("bounding entity tag");
        }
      }
    }
  }

  void addNode(unsigned long long tag, Eigen::Index i) {
    if (!tagToIndex_.emplace(tag, static_cast<int>(i)).second) c_.fail("node tag " + std::to_string(tag) + " appears twice");
  }

  int nodeIndex(unsigned long long tag) {
    auto it = tagToIndex_.find(tag);
    if (it == tagToIndex_.end()) c_.fail("element references undefined node tag " + std::to_string(tag));
    return it->second;
  }

  void readNodes2(TetMesh& m) {
    const long long n = c_.integerIn("node count", 0, 2000000000);
    beginData();
    guard(static_cast<unsigned long long>(n), 4 + 24, "$Nodes");
    m.V.resize(n, 3);
    tagToIndex_.reserve(static_cast<size_t>(n));
    for (long long i = 0; i < n; ++i) {
      const long long tag = binary_ ? c_.raw<int32_t>(big_, "node tag") : c_.integer("node tag");
      addNode(static_cast<unsigned long long>(tag), i);
      for (int k = 0; k < 3; ++k) m.V(i, k) = coordinate("node coordinate");
    }
  }

  void readNodes4(TetMesh& m) {
    beginData();
    const unsigned long long blocks = size("entity block count");
    const unsigned long long n = size("node count");
    size("minimum node tag");
    size("maximum node tag");
    guard(n, 8 + 24, "$Nodes");
    guard(blocks, 12 + 8, "$Nodes entity blocks");
    m.V.resize(static_cast<Eigen::Index>(n), 3);
    tagToIndex_.reserve(static_cast<size_t>(n));
    unsigned long long done = 0;
    std::vector<unsigned long long> tags;
    for (unsigned long long b = 0; b < blocks; ++b) {
      const long long dim = int32("entity dimension");
      int32("entity tag");
      const long long parametric = int32("parametric flag");
      const unsigned long long k = size("nodes in block");
      if (k > n - done)
        c_.fail("node blocks hold more than the " + std::to_string(n) + " nodes the $Nodes header declares");
      guard(k, 8, "node tags");
      tags.resize(static_cast<size_t>(k));
      for (auto& t : tags) t = size("node tag");
      const int extra = parametric ? static_cast<int>(std::clamp<long long>(dim, 0, 3)) : 0;
      guard(k, static_cast<size_t>(8 * (3 + extra)), "node coordinates");
      for (unsigned long long j = 0; j < k; ++j) {
        const auto i = static_cast<Eigen::Index>(done + j);
        addNode(tags[j], i);
        for (int d = 0; d < 3; ++d) m.V(i, d) = coordinate("node coordinate");
        for (int d = 0; d < extra; ++d) real("parametric coordinate");
      }
      done += k;
    }
    if (done != n)
      c_.fail("$Nodes declares " + std::to_string(n) + " nodes but its blocks hold " + std::to_string(done));
  }

  void rejectType(long long type, const ElementType& et) {
    c_.fail("element type " + std::to_string(type) + " (" + et.name +
            ") in a volume mesh; only linear tetrahedra (type 4) are supported");
  }

  void readElements2(std::vector<Eigen::Vector4i>& tets, std::vector<int>& regions) {
    const long long n = c_.integerIn("element count", 0, 2000000000);
    beginData();
    guard(static_cast<unsigned long long>(n), 8, "$Elements");
    long long done = 0;
    while (done < n) {
      long long type, count, ntags;
      if (binary_) {
        type = c_.raw<int32_t>(big_, "element type");
        count = c_.raw<int32_t>(big_, "element block size");
        ntags = c_.raw<int32_t>(big_, "tag count");
        if (count <= 0 || count > n - done) c_.fail("bad element block size " + std::to_string(count));
      } else {
        c_.integer("element tag");
        type = c_.integer("element type");
        ntags = c_.integer("tag count");
        count = 1;
      }
      if (ntags < 0 || ntags > 1000) c_.fail("bad element tag count " + std::to_string(ntags));
      ElementType et{};
      if (!elementType(type, et)) c_.fail("unknown element type " + std::to_string(type));
      if (et.dim == 3 && type != 4) rejectType(type, et);
      guard(static_cast<unsigned long long>(count), static_cast<size_t>(4 * (1 + ntags + et.nodes)), "elements");
      for (long long e = 0; e < count; ++e) {
        if (binary_) c_.raw<int32_t>(big_, "element tag");
        long long physical = 0, elementary = 0;
        for (long long k = 0; k < ntags; ++k) {
          const long long v = int32("element tag value");
          if (k == 0) physical = v;
          if (k == 1) elementary = v;
        }
        Eigen::Vector4i tet;
        for (int k = 0; k < et.nodes; ++k) {
          const long long tag = int32("element node");
          if (type == 4) tet(k) = nodeIndex(static_cast<unsigned long long>(tag));
        }
        if (type == 4) {
          tets.push_back(tet);
          regions.push_back(static_cast<int>(physical != 0 ? physical : elementary != 0 ? elementary : 1));
        }
      }
      done += count;
    }
  }

  void readElements4(std::vector<Eigen::Vector4i>& tets, std::vector<int>& regions) {
    beginData();
    const unsigned long long blocks = size("entity block count");
    const unsigned long long n = size("element count");
    size("minimum element tag");
    size("maximum element tag");
    guard(n, 16, "$Elements");
    guard(blocks, 12 + 8, "$Elements entity blocks");
    unsigned long long done = 0;
    for (unsigned long long b = 0; b < blocks; ++b) {
      int32("entity dimension");
      const long long entity = int32("entity tag");
      const long long type = int32("element type");
      const unsigned long long k = size("elements in block");
      if (k > n - done)
        c_.fail("element blocks hold more than the " + std::to_string(n) + " elements the $Elements header declares");
      ElementType et{};
      if (!elementType(type, et)) c_.fail("unknown element type " + std::to_string(type));
      if (et.dim == 3 && type != 4) rejectType(type, et);
      guard(k, static_cast<size_t>(8 * (1 + et.nodes)), "elements");
      int region = 1;
      if (type == 4) {
        auto it = volumePhysical_.find(entity);
        region = it != volumePhysical_.end() ? it->second : entity != 0 ? static_cast<int>(entity) : 1;
      }
      for (unsigned long long e = 0; e < k; ++e) {
        size("element tag");
        Eigen::Vector4i tet;
        for (int j = 0; j < et.nodes; ++j) {
          const unsigned long long tag = size("element node");
          if (type == 4) tet(j) = nodeIndex(tag);
        }
        if (type == 4) {
          tets.push_back(tet);
          regions.push_back(region);
        }
      }
      done += k;
    }
    if (done != n)
      c_.fail("$Elements declares " + std::to_string(n) + " elements but its blocks hold " + std::to_string(done));
  }

  Cursor c_;
  bool v4_ = true;
  bool binary_ = false;
  bool big_ = false;
  std::map<long long, int> volumePhysical_;
  std::unordered_map<unsigned long long, int> tagToIndex_;
};

// Text or native-binary output of the 4.1 writer.
class MshOut {
 public:
  explicit MshOut(bool binary) : binary_(binary) {}
  void size(unsigned long long v) {
    if (binary_) {
      appendRaw<uint64_t>(buf, v);
    } else {
      appendInt(buf, static_cast<long long>(v));
      buf += ' ';
    }
  }
  void int32(int v) {
    if (binary_) {
      appendRaw<int32_t>(buf, v);
    } else {
      appendInt(buf, v);
      buf += ' ';
    }
  }
  void real(double v) {
    if (binary_) {
      appendRaw<double>(buf, v);
    } else {
      appendReal(buf, v);
      buf += ' ';
    }
  }
  void endLine() {
    if (!binary_) {
      if (!buf.empty() && buf.back() == ' ') buf.pop_back();
      buf += '\n';
    }
  }
  std::string buf;

 private:
  bool binary_;
};

}  // namespace

TetMesh readGmsh(const std::string& path) { return GmshReader(path).read(); }

void writeGmsh(const TetMesh& m, const std::string& path, bool binary) {
  // One volume entity per region (entity tags 1..k), physical tag = region.
  std::map<int, std::vector<Eigen::Index>> byRegion;
  for (Eigen::Index t = 0; t < m.T.rows(); ++t) byRegion[regionOf(m, t)].push_back(t);

  MshOut o(binary);
  o.buf = std::string("$MeshFormat\n4.1 ") + (binary ? "1" : "0") + " 8\n";
  if (binary) {
    appendRaw<int32_t>(o.buf, 1);
    o.buf += '\n';
  }
  o.buf += "$EndMeshFormat\n$Entities\n";
  o.size(0);
  o.size(0);
  o.size(0);
  o.size(byRegion.size());
  o.endLine();
  int entity = 0;
  for (const auto& [region, tets] : byRegion) {
    Eigen::Vector3d lo = Eigen::Vector3d::Constant(0), hi = Eigen::Vector3d::Constant(0);
    bool first = true;
    for (auto t : tets)
      for (int k = 0; k < 4; ++k) {
        const Eigen::Vector3d p = m.V.row(m.T(t, k)).transpose();
        lo = first ? p : lo.cwiseMin(p);
        hi = first ? p : hi.cwiseMax(p);
        first = false;
      }
    o.int32(++entity);
    for (int k = 0; k < 3; ++k) o.real(lo(k));
    for (int k = 0; k < 3; ++k) o.real(hi(k));
    o.size(1);
    o.int32(region);
    o.size(0);
    o.endLine();
  }
  o.buf += binary ? "\n$EndEntities\n$Nodes\n" : "$EndEntities\n$Nodes\n";
  const auto nv = static_cast<unsigned long long>(m.V.rows());
  const auto nt = static_cast<unsigned long long>(m.T.rows());
  o.size(nv > 0 ? 1 : 0);
  o.size(nv);
  o.size(nv > 0 ? 1 : 0);
  o.size(nv);
  o.endLine();
  if (nv > 0) {
    o.int32(3);
    o.int32(1);
    o.int32(0);
    o.size(nv);
    o.endLine();
    for (unsigned long long i = 1; i <= nv; ++i) {
      o.size(i);
      o.endLine();
    }
    for (Eigen::Index i = 0; i < m.V.rows(); ++i) {
      for (int k = 0; k < 3; ++k) o.real(m.V(i, k));
      o.endLine();
    }
  }
  o.buf += binary ? "\n$EndNodes\n$Elements\n" : "$EndNodes\n$Elements\n";
  // Blocks are runs of equal region, so the tet order is kept exactly.
  std::map<int, int> entityOf;
  entity = 0;
  for (const auto& kv : byRegion) entityOf[kv.first] = ++entity;
  std::vector<std::pair<Eigen::Index, Eigen::Index>> runs;  // [begin, end)
  for (Eigen::Index t = 0; t < m.T.rows(); ++t)
    if (t == 0 || regionOf(m, t) != regionOf(m, t - 1)) runs.emplace_back(t, t + 1);
    else runs.back().second = t + 1;
  o.size(runs.size());
  o.size(nt);
  o.size(nt > 0 ? 1 : 0);
  o.size(nt);
  o.endLine();
  for (const auto& [begin, end] : runs) {
    o.int32(3);
    o.int32(entityOf[regionOf(m, begin)]);
    o.int32(4);
    o.size(static_cast<unsigned long long>(end - begin));
    o.endLine();
    for (Eigen::Index t = begin; t < end; ++t) {
      o.size(static_cast<unsigned long long>(t) + 1);
      for (int k = 0; k < 4; ++k) o.size(static_cast<unsigned long long>(m.T(t, k)) + 1);
      o.endLine();
    }
  }
  o.buf += binary ? "\n$EndElements\n" : "$EndElements\n";

  AtomicFile file(path, true);
  file.stream().write(o.buf.data(), static_cast<std::streamsize>(o.buf.size()));
  file.commit();
}

}  // namespace tet2spline::detail

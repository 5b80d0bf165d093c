// VTK .vtu (ASCII, inline base64, appended raw/base64, zlib, UInt32/UInt64
// headers, both byte orders) and legacy .vtk: round trips, hand-built files of
// every encoding, files written by gmsh, and every bad-input class.
#include <zlib.h>

#include <cstring>

#include "io_test_util.h"

using namespace tet2spline;
using namespace t2stest;

namespace {

bool hostBig() {
  const uint16_t one = 1;
  unsigned char b;
  std::memcpy(&b, &one, 1);
  return b == 0;
}

template <class T>
void put(std::string& s, T v, bool big) {
  char b[sizeof(T)];
  std::memcpy(b, &v, sizeof(T));
  if (big != hostBig()) std::reverse(b, b + sizeof(T));
  s.append(b, sizeof(T));
}

std::string base64(const std::string& in) {
  static const char* tab = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  std::string out;
  size_t i = 0;
  for (; i + 2 < in.size(); i += 3) {
    const unsigned v = (unsigned char)in[i] << 16 | (unsigned char)in[i + 1] << 8 | (unsigned char)in[i + 2];
    for (int k = 3; k >= 0; --k) out += tab[(v >> (6 * k)) & 63];
  }
  if (i + 1 == in.size()) {
    const unsigned v = (unsigned char)in[i] << 16;
    out += tab[(v >> 18) & 63];
    out += tab[(v >> 12) & 63];
    out += "==";
  } else if (i + 2 == in.size()) {
    const unsigned v = (unsigned char)in[i] << 16 | (unsigned char)in[i + 1] << 8;
    out += tab[(v >> 18) & 63];
    out += tab[(v >> 12) & 63];
    out += tab[(v >> 6) & 63];
    out += '=';
  }
  return out;
}

struct Spec {
  std::string section, name, type;
  int ncomp;
  std::vector<double> values;
};

// 5 points; a triangle and two tets; region from CellEntityIds (which outranks
// MaterialIds even though it comes second).
std::vector<Spec> tinyGrid() {
  return {
      {"PointData", "phi", "Float32", 1, {0, 0.5, 1, 1.5, 2}},
      {"CellData", "MaterialIds", "Int16", 1, {-1, 2, 3}},
      {"CellData", "CellEntityIds", "Int32", 1, {99, 4, 5}},
      {"CellData", "pressure", "Float64", 1, {0.0, 1.5, -2.25}},
      {"Points", "Points", "Float64", 3, {0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 1, 1, 1, 1}},
      {"Cells", "connectivity", "Int64", 1, {0, 1, 2, 0, 1, 2, 3, 1, 2, 3, 4}},
      {"Cells", "offsets", "Int32", 1, {3, 7, 11}},
      {"Cells", "types", "UInt8", 1, {5, 10, 10}},
  };
}

std::string encode(const Spec& a, bool big) {
  std::string s;
  for (double v : a.values) {
    if (a.type == "Float32") put<float>(s, static_cast<float>(v), big);
    else if (a.type == "Float64") put<double>(s, v, big);
    else if (a.type == "Int16") put<int16_t>(s, static_cast<int16_t>(v), big);
    else if (a.type == "Int32") put<int32_t>(s, static_cast<int32_t>(v), big);
    else if (a.type == "Int64") put<int64_t>(s, static_cast<int64_t>(v), big);
    else put<uint8_t>(s, static_cast<uint8_t>(v), big);
  }
  return s;
}

struct Variant {
  std::string format;  // ascii, binary, appended
  std::string encoding = "raw";
  bool compressed = false;
  bool header64 = true;
  bool big = false;
  bool separateHeader = false;  // base64 of the header apart from the data
  size_t blockSize = 16;
};

void putHeader(std::string& s, uint64_t v, const Variant& var) {
  if (var.header64) put<uint64_t>(s, v, var.big);
  else put<uint32_t>(s, static_cast<uint32_t>(v), var.big);
}

// Header and data of one array in VTK's binary layout.
std::pair<std::string, std::string> payload(const std::string& bytes, const Variant& v) {
  std::string header, data;
  if (!v.compressed) {
    putHeader(header, bytes.size(), v);
    return {header, bytes};
  }
  const size_t nblocks = (bytes.size() + v.blockSize - 1) / v.blockSize;
  std::vector<std::string> blocks;
  for (size_t b = 0; b < nblocks; ++b) {
    const std::string in = bytes.substr(b * v.blockSize, v.blockSize);
    uLongf len = compressBound(in.size());
    std::string out(len, '\0');
    EXPECT_EQ(compress2(reinterpret_cast<Bytef*>(&out[0]), &len, reinterpret_cast<const Bytef*>(in.data()), in.size(), 6), Z_OK);
    out.resize(len);
    blocks.push_back(out);
  }
  putHeader(header, nblocks, v);
  putHeader(header, v.blockSize, v);
  putHeader(header, bytes.size() % v.blockSize, v);
  for (const auto& b : blocks) putHeader(header, b.size(), v);
  for (const auto& b : blocks) data += b;
  return {header, data};
}

std::string makeVtu(const Variant& v, const std::vector<Spec>& specs = tinyGrid(), size_t np = 5, size_t nc = 3) {
  std::string xml = "<?xml version=\"1.0\"?>\n<!-- hand-built test file -->\n<VTKFile type='UnstructuredGrid' version=\"1.0\" byte_order=\"";
  xml += v.big ? "BigEndian" : "LittleEndian";
  xml += std::string("\" header_type=\"") + (v.header64 ? "UInt64" : "UInt32") + "\"";
  if (v.compressed) xml += " compressor=\"vtkZLibDataCompressor\"";
  xml += ">\n<UnstructuredGrid>\n<Piece NumberOfPoints=\"" + std::to_string(np) + "\" NumberOfCells=\"" + std::to_string(nc) + "\">\n";
  std::string appended;
  std::string section;
  for (const Spec& a : specs) {
    if (a.section != section) {
      if (!section.empty()) xml += "</" + section + ">\n";
      section = a.section;
      xml += "<" + section + ">\n";
    }
    xml += "  <DataArray type=\"" + a.type + "\" Name=\"" + a.name + "\" NumberOfComponents=\"" + std::to_string(a.ncomp) +
           "\" format=\"" + v.format + "\"";
    if (v.format == "ascii") {
      xml += ">\n   ";
      for (double x : a.values) {
        std::ostringstream ss;
        ss.precision(17);
        ss << x;
        xml += ss.str() + " ";
      }
      xml += "\n  </DataArray>\n";
      continue;
    }
    const auto [header, data] = payload(encode(a, v.big), v);
    const std::string enc = v.separateHeader || v.compressed ? base64(header) + base64(data) : base64(header + data);
    if (v.format == "binary") {
      xml += ">\n    " + enc + "\n  </DataArray>\n";
    } else {
      xml += " offset=\"" + std::to_string(appended.size()) + "\"/>\n";
      appended += v.encoding == "base64" ? enc : header + data;
    }
  }
  xml += "</" + section + ">\n</Piece>\n</UnstructuredGrid>\n";
  if (v.format == "appended") xml += "<AppendedData encoding=\"" + v.encoding + "\">\n  _" + appended + "\n</AppendedData>\n";
  xml += "</VTKFile>\n";
  return xml;
}

void expectTinyGrid(const TetMesh& m) {
  ASSERT_EQ(m.numVertices(), 5);
  ASSERT_EQ(m.numTets(), 2);
  EXPECT_EQ(m.T.row(0), Eigen::RowVector4i(0, 1, 2, 3));
  EXPECT_EQ(m.T.row(1), Eigen::RowVector4i(1, 2, 3, 4));
  EXPECT_EQ(m.region(0), 4);
  EXPECT_EQ(m.region(1), 5);
  EXPECT_EQ(m.V.row(4), Eigen::RowVector3d(1, 1, 1));
  ASSERT_NE(m.pointField("phi"), nullptr);
  EXPECT_EQ(m.pointField("phi")->values(3, 0), 1.5);
  ASSERT_NE(m.cellField("pressure"), nullptr);
  EXPECT_EQ(m.cellField("pressure")->values(1, 0), -2.25);  // the triangle's value is dropped
  ASSERT_NE(m.cellField("MaterialIds"), nullptr);
  EXPECT_EQ(m.cellField("MaterialIds")->values(0, 0), 2);
  EXPECT_EQ(m.cellField("CellEntityIds"), nullptr) << "the region array is not also a field";
}

}  // namespace

TEST(VtuIo, RoundTripKeepsEverythingExactly) {
  const std::string dir = scratchDir("vtu_rt");
  const TetMesh m = referenceMesh();
  for (bool binary : {true, false}) {
    SCOPED_TRACE(binary ? "appended raw" : "ascii");
    const std::string path = dir + (binary ? "/b.vtu" : "/a.vtu");
    writeTetMesh(m, path, MeshWriteOptions{binary});
    const TetMesh r = readTetMesh(path);
    EXPECT_TRUE(r.V == m.V);
    EXPECT_TRUE(r.T == m.T);
    EXPECT_TRUE(r.region == m.region);
    ASSERT_EQ(r.pointFields.size(), m.pointFields.size());
    ASSERT_EQ(r.cellFields.size(), m.cellFields.size());
    for (size_t i = 0; i < m.pointFields.size(); ++i) {
      EXPECT_EQ(r.pointFields[i].name, m.pointFields[i].name);
      EXPECT_TRUE(r.pointFields[i].values == m.pointFields[i].values) << m.pointFields[i].name;
    }
    for (size_t i = 0; i < m.cellFields.size(); ++i) {
      EXPECT_EQ(r.cellFields[i].name, m.cellFields[i].name);
      EXPECT_TRUE(r.cellFields[i].values == m.cellFields[i].values) << m.cellFields[i].name;
    }
  }
  const std::string b = readFile(dir + "/b.vtu");
  EXPECT_NE(b.find("header_type=\"UInt64\""), std::string::npos);
  EXPECT_NE(b.find("<AppendedData encoding=\"raw\">"), std::string::npos);
  EXPECT_NE(b.find("Name=\"region\""), std::string::npos);
  EXPECT_EQ(readFile(dir + "/a.vtu").find("AppendedData"), std::string::npos);
}

TEST(VtuIo, WriteIsDeterministic) {
  const std::string dir = scratchDir("vtu_det");
  writeTetMesh(referenceMesh(), dir + "/a.vtu");
  writeTetMesh(referenceMesh(), dir + "/b.vtu");
  EXPECT_EQ(readFile(dir + "/a.vtu"), readFile(dir + "/b.vtu"));
}

TEST(VtuIo, EveryEncodingGivesTheSameMesh) {
  const std::string dir = scratchDir("vtu_variants");
  std::vector<std::pair<std::string, Variant>> variants;
  Variant v;
  v.format = "ascii";
  variants.emplace_back("ascii", v);
  v.format = "binary";
  v.header64 = false;
  variants.emplace_back("binary_uint32", v);
  v.header64 = true;
  v.separateHeader = true;
  variants.emplace_back("binary_uint64_separate", v);
  v.separateHeader = false;
  v.compressed = true;
  variants.emplace_back("binary_zlib", v);
  v.header64 = false;
  v.big = true;
  variants.emplace_back("binary_zlib_uint32_big", v);
  v = Variant{};
  v.format = "appended";
  variants.emplace_back("appended_raw", v);
  v.big = true;
  variants.emplace_back("appended_raw_big", v);
  v.big = false;
  v.compressed = true;
  variants.emplace_back("appended_raw_zlib", v);
  v.blockSize = 32768;  // a single, partial block
  variants.emplace_back("appended_raw_zlib_one_block", v);
  v.blockSize = 8;  // sizes that are whole multiples: last block size 0
  variants.emplace_back("appended_raw_zlib_full_blocks", v);
  v = Variant{};
  v.format = "appended";
  v.encoding = "base64";
  variants.emplace_back("appended_base64", v);
  v.header64 = false;
  v.compressed = true;
  variants.emplace_back("appended_base64_zlib_uint32", v);
  for (const auto& [name, var] : variants) {
    SCOPED_TRACE(name);
    const std::string path = dir + "/" + name + ".vtu";
    writeFile(path, makeVtu(var));
    expectTinyGrid(readTetMesh(path));
  }
}

TEST(VtuIo, BadInputsNameFileAndCause) {
  const std::string dir = scratchDir("vtu_bad");
  Variant ascii;
  ascii.format = "ascii";
  Variant app;
  app.format = "appended";
  Variant zlib = app;
  zlib.compressed = true;
  auto with = [](std::vector<Spec> s, const std::string& name, std::vector<double> values) {
    for (auto& a : s)
      if (a.name == name) a.values = std::move(values);
    return s;
  };
  struct Case {
    std::string name, text;
    long line;
    std::string cause;
  };
  std::vector<Case> cases = {
      {"not_xml", "hello", 1, "not an XML file"},
      {"wrong_root", "<?xml version=\"1.0\"?>\n<Foo/>\n", 2, "wrong root element <Foo>"},
      {"polydata", "<VTKFile type=\"PolyData\"><PolyData/></VTKFile>", 1, "PolyData' is not supported"},
      {"unterminated", "<VTKFile type=\"UnstructuredGrid\">\n<UnstructuredGrid>\n<Piece NumberOfPoints=\"1\"", 3, "truncated XML"},
      {"mismatched", "<VTKFile type=\"UnstructuredGrid\">\n<UnstructuredGrid>\n</VTKFile>", 3, "closed by </VTKFile>"},
      {"compressor", "<VTKFile type=\"UnstructuredGrid\" compressor=\"vtkLZ4DataCompressor\"><UnstructuredGrid/></VTKFile>", 1, "unsupported compressor"},
      {"hexahedron", makeVtu(ascii, with(tinyGrid(), "types", {5, 10, 12})), 0, "type 12 (hexahedron)"},
      {"quadratic_tet", makeVtu(ascii, with(tinyGrid(), "types", {5, 10, 24})), 0, "type 24 (quadratic tetra)"},
      {"too_few_values", makeVtu(ascii, with(tinyGrid(), "pressure", {1, 2})), 0, "has 2 values, expected 3"},
      {"nan", makeVtu(ascii, with(tinyGrid(), "Points", {0, 0, 0, 1, 0, 0, 0, NAN, 0, 0, 0, 1, 1, 1, 1})), 0, "NaN or infinite"},
      {"index", makeVtu(app, with(tinyGrid(), "connectivity", {0, 1, 2, 0, 1, 2, 3, 1, 2, 3, 7})), 0, "references point 7"},
      {"tet_size", makeVtu(ascii, with(tinyGrid(), "offsets", {3, 6, 11})), 0, "has 3 points"},
      {"no_tets", makeVtu(ascii, with(tinyGrid(), "types", {5, 5, 5})), 0, "no tetrahedra"},
      {"region_fraction", makeVtu(ascii, [&] {
         auto s = tinyGrid();
         s[2].type = "Float64";
         s[2].values = {1, 2.5, 3};
         return s;
       }()), 0, "non-integer value"},
      {"points_too_many", makeVtu(app, tinyGrid(), 6, 3), 0, "binary header says"},
      {"huge_count", makeVtu(app, tinyGrid(), 5000000000ULL, 3), 0, "larger than the file can hold"},
  };
  // Truncated appended data, corrupt zlib data.
  const std::string good = makeVtu(app);
  cases.push_back({"truncated_appended", good.substr(0, good.size() - 40), 0, "truncated"});
  std::string corrupt = makeVtu(zlib);
  const size_t at = corrupt.find('_', corrupt.find("<AppendedData")) + 1 + 8 * 5 + 2;  // phi: 5 header words, then zlib
  corrupt[at] = static_cast<char>(corrupt[at] ^ 0x5a);
  cases.push_back({"corrupt_zlib", corrupt, 0, "zlib block 0 does not decompress"});
  for (const Case& c : cases) {
    SCOPED_TRACE(c.name);
    const std::string path = dir + "/" + c.name + ".vtu";
    writeFile(path, c.text);
    expectInputError([&] { readTetMesh(path); }, path, c.line, c.cause);
  }
}

TEST(VtuIo, EveryTruncationIsAnErrorNotACrash) {
  const std::string dir = scratchDir("vtu_cut");
  Variant zlib;
  zlib.format = "appended";
  zlib.compressed = true;
  const std::string full = makeVtu(zlib);
  // Cutting only the closing tags after the appended payload leaves all data intact.
  const size_t payloadEnd = full.rfind("\n</AppendedData>");
  for (size_t cut = 0; cut < payloadEnd; cut += 7) {
    const std::string path = dir + "/cut.vtu";
    writeFile(path, full.substr(0, cut));
    try {
      readTetMesh(path);
      ADD_FAILURE() << "no error at cut " << cut;
    } catch (const Error& e) {
      EXPECT_EQ(e.kind(), ErrorKind::Input);
    }
  }
}

// ------------------------------------------------------------- legacy .vtk

TEST(LegacyVtkIo, GmshAsciiAndBinaryAgreeWithMsh) {
  if (!haveProgram("gmsh")) GTEST_SKIP() << "gmsh not installed (scripts/install-deps.sh)";
  const std::string msh = gmshNested("msh41", false, "msh");
  ASSERT_FALSE(msh.empty());
  const TetMesh ref = readTetMesh(msh);
  for (bool binary : {false, true}) {
    SCOPED_TRACE(binary ? "binary" : "ascii");
    const std::string vtk = gmshNested("vtk", binary, "vtk");
    ASSERT_FALSE(vtk.empty());
    const TetMesh m = readTetMesh(vtk);
    EXPECT_EQ(m.numVertices(), ref.numVertices());
    ASSERT_EQ(m.numTets(), ref.numTets());
    EXPECT_TRUE(m.T == ref.T);
    EXPECT_TRUE(m.region == ref.region) << "CellEntityIds are gmsh's physical tags";
    EXPECT_LT((m.V - ref.V).cwiseAbs().maxCoeff(), 1e-12);
  }
}

TEST(LegacyVtkIo, AsciiWithFieldsAndVersion51Cells) {
  const std::string dir = scratchDir("vtk_ascii");
  const std::string points = "POINTS 5 float\n0 0 0 1 0 0 0 1 0\n0 0 1 1 1 1\n";
  writeFile(dir + "/classic.vtk",
            "# vtk DataFile Version 3.0\ntitle\nASCII\nDATASET UNSTRUCTURED_GRID\n" + points +
                "CELLS 3 14\n3 0 1 2\n4 0 1 2 3\n4 1 2 3 4\nCELL_TYPES 3\n5\n10\n10\n"
                "CELL_DATA 3\nSCALARS MaterialIds int 1\nLOOKUP_TABLE default\n7 8 9\n"
                "FIELD FieldData 1\ntemperature 2 3 double\n1 2 3 4 5 6\n"
                "POINT_DATA 5\nVECTORS v double\n0 0 0 1 1 1 2 2 2 3 3 3 4 4 4\n");
  TetMesh m = readTetMesh(dir + "/classic.vtk");
  ASSERT_EQ(m.numTets(), 2);
  EXPECT_EQ(m.T.row(1), Eigen::RowVector4i(1, 2, 3, 4));
  EXPECT_EQ(m.region(0), 8);
  EXPECT_EQ(m.region(1), 9);
  ASSERT_NE(m.cellField("temperature"), nullptr);
  EXPECT_EQ(m.cellField("temperature")->values(1, 1), 6);
  ASSERT_NE(m.pointField("v"), nullptr);
  EXPECT_EQ(m.pointField("v")->values(4, 2), 4);

  writeFile(dir + "/v51.vtk",
            "# vtk DataFile Version 5.1\nvtk output\nASCII\nDATASET UNSTRUCTURED_GRID\n" + points +
                "METADATA\nINFORMATION 0\n\n"
                "CELLS 3 8\nOFFSETS vtktypeint64\n0 4 8\nCONNECTIVITY vtktypeint64\n0 1 2 3 1 2 3 4\n"
                "CELL_TYPES 2\n10\n10\nCELL_DATA 2\nSCALARS region int\nLOOKUP_TABLE default\n3 4\n");
  m = readTetMesh(dir + "/v51.vtk");
  ASSERT_EQ(m.numTets(), 2);
  EXPECT_EQ(m.T.row(1), Eigen::RowVector4i(1, 2, 3, 4));
  EXPECT_EQ(m.region(1), 4);
}

TEST(LegacyVtkIo, BigEndianBinary) {
  const std::string dir = scratchDir("vtk_binary");
  std::string s = "# vtk DataFile Version 2.0\nbinary\nBINARY\nDATASET UNSTRUCTURED_GRID\nPOINTS 5 double\n";
  for (double x : {0., 0., 0., 1., 0., 0., 0., 1., 0., 0., 0., 1., 1., 1., 1.}) put<double>(s, x, true);
  s += "\nCELLS 2 10\n";
  for (int v : {4, 0, 1, 2, 3, 4, 1, 2, 3, 4}) put<int32_t>(s, v, true);
  s += "\nCELL_TYPES 2\n";
  for (int v : {10, 10}) put<int32_t>(s, v, true);
  s += "\nCELL_DATA 2\nSCALARS CellEntityIds int 1\nLOOKUP_TABLE default\n";
  for (int v : {11, 12}) put<int32_t>(s, v, true);
  s += "\n";
  writeFile(dir + "/b.vtk", s);
  const TetMesh m = readTetMesh(dir + "/b.vtk");
  ASSERT_EQ(m.numTets(), 2);
  EXPECT_EQ(m.T.row(1), Eigen::RowVector4i(1, 2, 3, 4));
  EXPECT_EQ(m.region(1), 12);
  EXPECT_EQ(m.V.row(4), Eigen::RowVector3d(1, 1, 1));
  // Every truncation is an error naming the file.
  // (A file cut right before CELL_DATA is complete without it.)
  for (size_t cut = 100; cut < s.find("\nCELL_DATA"); cut += 13) {
    const std::string path = dir + "/cut.vtk";
    writeFile(path, s.substr(0, cut));
    expectInputError([&] { readTetMesh(path); }, path, 0, "");
  }
}

TEST(LegacyVtkIo, BadInputsNameFileLineAndCause) {
  const std::string dir = scratchDir("vtk_bad");
  const std::string head = "# vtk DataFile Version 3.0\nt\nASCII\nDATASET UNSTRUCTURED_GRID\nPOINTS 4 float\n0 0 0 1 0 0 0 1 0 0 0 1\n";
  const std::pair<std::string, std::pair<long, std::string>> cases[] = {
      {"hello\n", {1, "wrong header"}},
      {"# vtk DataFile Version 3.0\nt\nTEXT\n", {3, "expected ASCII or BINARY"}},
      {"# vtk DataFile Version 3.0\nt\nASCII\nDATASET POLYDATA\n", {4, "dataset type POLYDATA is not supported"}},
      {head + "CELLS 1 6\n4 0 1 2 3\nCELL_TYPES 1\n10\n", {9, "truncated: expected 6 values, got 5"}},
      {head + "CELLS 1 5\n4 0 1 2 3\nCELL_TYPES 1\n12\n", {0, "type 12 (hexahedron)"}},
      {head + "CELLS 1 5\n4 0 1 2 9\nCELL_TYPES 1\n10\n", {0, "references point 9"}},
      {head + "CELLS 1 5\n4 0 1 2 3\nCELL_TYPES 2\n10 10\n", {0, "CELL_TYPES has 2 entries for 1 cells"}},
      {head + "CELLS 1 5\n4 0 1 2 3\nCELL_TYPES 1\n10\nCELL_DATA 2\n", {11, "CELL_DATA 2 disagrees"}},
      {head + "CELLS 1 5\n4 0 1 2 3\nCELL_TYPES 1\n10\nBOGUS 1\n", {11, "unknown keyword 'BOGUS'"}},
      {"# vtk DataFile Version 3.0\nt\nASCII\nDATASET UNSTRUCTURED_GRID\nPOINTS 4 float\n0 0 0 1 inf 0 0 1 0 0 0 1\n"
       "CELLS 1 5\n4 0 1 2 3\nCELL_TYPES 1\n10\n", {0, "point 1 has a NaN or infinite coordinate"}},
  };
  int i = 0;
  for (const auto& [text, expect] : cases) {
    SCOPED_TRACE(i);
    const std::string path = dir + "/c" + std::to_string(i++) + ".vtk";
    writeFile(path, text);
    expectInputError([&] { readTetMesh(path); }, path, expect.first, expect.second);
  }
}

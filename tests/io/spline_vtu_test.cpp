// VTU views of a B-spline volume: parsed back (appended raw binary and ASCII)
// by a small reader in this file; positions, det J, regions and topology
// compared with the spline.
#include <gtest/gtest.h>

#include <cstring>
#include <regex>

#include "io_test_util.h"
#include "spline_test_volumes.h"
#include "tet2spline/io/spline_vtu.h"

namespace {

using namespace t2stest;

struct Array {
  std::string type;
  int components = 1;
  std::vector<double> values;
};

struct Vtu {
  size_t points = 0, cells = 0;
  std::map<std::string, Array> arrays;  // by Name (unique in our files)
};

size_t typeSize(const std::string& t) {
  if (t == "Float64" || t == "Int64" || t == "UInt64") return 8;
  if (t == "Int32") return 4;
  if (t == "UInt8") return 1;
  ADD_FAILURE() << "type " << t;
  return 1;
}

double load(const char* p, const std::string& t) {
  if (t == "Float64") { double v; std::memcpy(&v, p, 8); return v; }
  if (t == "Int64") { int64_t v; std::memcpy(&v, p, 8); return static_cast<double>(v); }
  if (t == "Int32") { int32_t v; std::memcpy(&v, p, 4); return v; }
  uint8_t v; std::memcpy(&v, p, 1); return v;
}

Vtu parse(const std::string& file) {
  Vtu r;
  std::smatch m;
  EXPECT_TRUE(std::regex_search(file, m, std::regex(R"re(<VTKFile type="UnstructuredGrid" version="1.0" byte_order="LittleEndian" header_type="UInt64">)re")));
  if (std::regex_search(file, m, std::regex(R"re(<Piece NumberOfPoints="(\d+)" NumberOfCells="(\d+)">)re"))) {
    r.points = std::stoul(m[1]);
    r.cells = std::stoul(m[2]);
  }
  const size_t appendedAt = file.find("<AppendedData encoding=\"raw\">");
  const size_t base = appendedAt == std::string::npos ? 0 : file.find('_', appendedAt) + 1;
  const std::string head = file.substr(0, appendedAt == std::string::npos ? file.size() : appendedAt);
  // Only the opening tags go through std::regex (libstdc++'s matcher recurses per character).
  const std::regex da(R"re(<DataArray type="(\w+)" Name="(\w+)" NumberOfComponents="(\d+)" format="(\w+)"(?: offset="(\d+)"/>|>))re");
  for (auto it = std::sregex_iterator(head.begin(), head.end(), da); it != std::sregex_iterator(); ++it) {
    Array a;
    a.type = (*it)[1];
    a.components = std::stoi((*it)[3]);
    const std::string format = (*it)[4];
    if (format == "appended") {
      const size_t off = base + std::stoul((*it)[5]);
      uint64_t bytes;
      std::memcpy(&bytes, file.data() + off, 8);
      const size_t sz = typeSize(a.type);
      EXPECT_EQ(bytes % sz, 0u);
      for (size_t i = 0; i < bytes / sz; ++i) a.values.push_back(load(file.data() + off + 8 + i * sz, a.type));
    } else {
      EXPECT_EQ(format, "ascii");
      const size_t from = static_cast<size_t>(it->position(0) + it->length(0));
      std::istringstream in(head.substr(from, head.find("</DataArray>", from) - from));
      double v;
      while (in >> v) a.values.push_back(v);
    }
    r.arrays[(*it)[2]] = a;
  }
  return r;
}

double hexVolume(const std::vector<Eigen::Vector3d>& c) {
  // Six tets around the diagonal 0-6 (VTK hexahedron order).
  const int tets[6][4] = {{0, 1, 2, 6}, {0, 2, 3, 6}, {0, 3, 7, 6}, {0, 7, 4, 6}, {0, 4, 5, 6}, {0, 5, 1, 6}};
  double v = 0;
  for (const auto& t : tets) v += (c[t[1]] - c[t[0]]).cross(c[t[2]] - c[t[0]]).dot(c[t[3]] - c[t[0]]) / 6;
  return v;
}

void checkSampledGrid(const BSplineVolume& V, const Vtu& f, int s, const std::vector<int>& region) {
  const Eigen::Vector3i ne = V.numElements();
  const size_t np = static_cast<size_t>(s * ne[0] + 1) * (s * ne[1] + 1) * (s * ne[2] + 1);
  const size_t nc = static_cast<size_t>(s * ne[0]) * (s * ne[1]) * (s * ne[2]);
  ASSERT_EQ(f.points, np);
  ASSERT_EQ(f.cells, nc);
  for (const char* name : {"detJ", "scaledJacobian", "parameter", "region", "element", "Points", "connectivity", "offsets", "types"})
    ASSERT_TRUE(f.arrays.count(name)) << name;
  const auto& X = f.arrays.at("Points").values;
  const auto& U = f.arrays.at("parameter").values;
  const auto& detJ = f.arrays.at("detJ").values;
  const auto& scaled = f.arrays.at("scaledJacobian").values;
  ASSERT_EQ(X.size(), 3 * np);
  ASSERT_EQ(detJ.size(), np);
  for (size_t p = 0; p < np; ++p) {
    const Eigen::Vector3d u(U[3 * p], U[3 * p + 1], U[3 * p + 2]);
    const Eigen::Vector3d x = V.evaluate(u);
    for (int c = 0; c < 3; ++c) ASSERT_EQ(X[3 * p + c], x[c]);
    ASSERT_NEAR(detJ[p], V.detJacobian(u), 1e-12 * std::max(1.0, std::fabs(detJ[p])));
    ASSERT_NEAR(scaled[p], V.scaledJacobian(u), 1e-12);
  }
  // Parameters: the corners of the box, u fastest.
  EXPECT_EQ(U[0], V.parameterMin()[0]);
  EXPECT_EQ(U[3 * (np - 1) + 2], V.parameterMax()[2]);
  EXPECT_GT(U[3], U[0]);
  // Topology: hexahedra, positive volumes summing close to the spline's volume.
  const auto& conn = f.arrays.at("connectivity").values;
  const auto& offsets = f.arrays.at("offsets").values;
  const auto& types = f.arrays.at("types").values;
  ASSERT_EQ(conn.size(), 8 * nc);
  double total = 0;
  const auto elements = V.elements();
  for (size_t c = 0; c < nc; ++c) {
    ASSERT_EQ(types[c], 12);
    ASSERT_EQ(offsets[c], 8.0 * (c + 1));
    std::vector<Eigen::Vector3d> corners;
    Eigen::Vector3d centre = Eigen::Vector3d::Zero();
    for (int k = 0; k < 8; ++k) {
      const auto p = static_cast<size_t>(conn[8 * c + k]);
      ASSERT_LT(p, np);
      corners.emplace_back(X[3 * p], X[3 * p + 1], X[3 * p + 2]);
      centre += Eigen::Vector3d(U[3 * p], U[3 * p + 1], U[3 * p + 2]) / 8;
    }
    const double hv = hexVolume(corners);
    EXPECT_GT(hv, 0) << "cell " << c;
    total += hv;
    // The cell's element holds its parameter centre; region follows it.
    const auto e = static_cast<size_t>(f.arrays.at("element").values[c]);
    ASSERT_LT(e, elements.size());
    EXPECT_TRUE((centre.array() > elements[e].lower.array()).all() && (centre.array() < elements[e].upper.array()).all());
    EXPECT_EQ(f.arrays.at("region").values[c], region.empty() ? -1 : region[e]);
  }
  // Trilinear cells of a smooth map: the volume error falls as O(1/s^2).
  EXPECT_NEAR(total, V.volume(), 0.2 / (s * s) * V.volume());
}

TEST(SplineVtu, SampledGridBinaryAndAscii) {
  const std::string dir = scratchDir("spline_vtu_grid");
  for (const auto& [name, V] : testVolumes()) {
    SCOPED_TRACE(name);
    std::vector<int> region;
    for (const auto& e : V.elements()) region.push_back(static_cast<int>(e.index.sum()) % 3 + 1);
    tet2spline::writeSplineVtu(V, dir + "/" + name + ".vtu", region);
    const Vtu bin = parse(readFile(dir + "/" + name + ".vtu"));
    checkSampledGrid(V, bin, 4, region);
    tet2spline::writeSplineVtu(V, dir + "/" + name + "_ascii.vtu", {}, {2, false});
    const Vtu ascii = parse(readFile(dir + "/" + name + "_ascii.vtu"));
    checkSampledGrid(V, ascii, 2, {});
  }
}

TEST(SplineVtu, AsciiAndBinaryHoldTheSameNumbers) {
  const std::string dir = scratchDir("spline_vtu_same");
  const BSplineVolume V = curvedCube();
  tet2spline::writeSplineVtu(V, dir + "/b.vtu", {}, {3, true});
  tet2spline::writeSplineVtu(V, dir + "/a.vtu", {}, {3, false});
  const Vtu a = parse(readFile(dir + "/a.vtu")), b = parse(readFile(dir + "/b.vtu"));
  ASSERT_EQ(a.arrays.size(), b.arrays.size());
  for (const auto& [name, arr] : a.arrays) EXPECT_EQ(arr.values, b.arrays.at(name).values) << name;
}

TEST(SplineVtu, ControlNet) {
  const std::string dir = scratchDir("spline_vtu_net");
  const BSplineVolume V = cylinderPatch();
  tet2spline::writeControlNetVtu(V, dir + "/net.vtu");
  const Vtu f = parse(readFile(dir + "/net.vtu"));
  const int n0 = V.numControl(0), n1 = V.numControl(1), n2 = V.numControl(2);
  const size_t lines = static_cast<size_t>((n0 - 1) * n1 * n2 + n0 * (n1 - 1) * n2 + n0 * n1 * (n2 - 1));
  ASSERT_EQ(f.points, static_cast<size_t>(V.numControlPoints()));
  ASSERT_EQ(f.cells, lines);
  const auto& X = f.arrays.at("Points").values;
  for (Eigen::Index i = 0; i < V.numControlPoints(); ++i)
    for (int c = 0; c < 3; ++c) ASSERT_EQ(X[3 * i + c], V.controlPoints()(i, c));
  const auto& idx = f.arrays.at("index").values;
  const auto& conn = f.arrays.at("connectivity").values;
  for (size_t c = 0; c < lines; ++c) {
    EXPECT_EQ(f.arrays.at("types").values[c], 3);
    const auto a = static_cast<size_t>(conn[2 * c]), b = static_cast<size_t>(conn[2 * c + 1]);
    // Neighbours: (i,j,k) indices differ by one in exactly one direction.
    int diff = 0;
    for (int d = 0; d < 3; ++d) diff += static_cast<int>(std::fabs(idx[3 * b + d] - idx[3 * a + d]));
    EXPECT_EQ(diff, 1);
  }
}

TEST(SplineVtu, BadInputsLeaveNoFile) {
  const std::string dir = scratchDir("spline_vtu_bad");
  const BSplineVolume V = refinedBox();
  EXPECT_THROW(tet2spline::writeSplineVtu(V, dir + "/a.vtu", {1, 2}), tet2spline::Error);
  EXPECT_THROW(tet2spline::writeSplineVtu(V, dir + "/a.vtu", {}, {0, true}), tet2spline::Error);
  const std::string missing = dir + "/missing/b.vtu";
  expectInputError([&] { tet2spline::writeSplineVtu(V, missing); }, missing, 0, "cannot");
  expectInputError([&] { tet2spline::writeControlNetVtu(V, missing); }, missing, 0, "cannot");
  EXPECT_TRUE(fs::is_empty(dir));
}

// VTK itself (Debian's python3-vtk9 under /usr/bin/python3, when installed) reads the file: counts,
// cell types, its own cell volumes (vtkCellSizeFilter) and the arrays.
TEST(SplineVtu, ReadByVtk) {
  if (run("/usr/bin/python3 -c 'import vtkmodules.vtkIOXML, vtkmodules.vtkFiltersVerdict'") != 0)
    GTEST_SKIP() << "python3-vtk9 not installed";
  const std::string dir = scratchDir("spline_vtu_vtk");
  const std::string script = dir + "/read.py";
  writeFile(script,
            "import sys\n"
            "from vtkmodules.vtkIOXML import vtkXMLUnstructuredGridReader\n"
            "from vtkmodules.vtkFiltersVerdict import vtkCellSizeFilter\n"
            "r = vtkXMLUnstructuredGridReader()\n"
            "r.SetFileName(sys.argv[1])\n"
            "r.Update()\n"
            "g = r.GetOutput()\n"
            "types = sorted(set(g.GetCellType(i) for i in range(g.GetNumberOfCells())))\n"
            "f = vtkCellSizeFilter()\n"
            "f.SetInputData(g)\n"
            "f.Update()\n"
            "vol = f.GetOutput().GetCellData().GetArray('Volume')\n"
            "vols = [vol.GetValue(i) for i in range(vol.GetNumberOfTuples())]\n"
            "pd, cd = g.GetPointData(), g.GetCellData()\n"
            "print(g.GetNumberOfPoints(), g.GetNumberOfCells(), len(types), types[0], sum(vols), min(vols),\n"
            "      pd.GetArray('detJ').GetRange()[0], pd.GetArray('scaledJacobian').GetRange()[1],\n"
            "      cd.GetArray('region').GetRange()[0], cd.GetArray('region').GetRange()[1])\n");
  for (bool binary : {true, false}) {
    SCOPED_TRACE(binary ? "binary" : "ascii");
    const BSplineVolume V = curvedCube();
    std::vector<int> region;
    for (const auto& e : V.elements()) region.push_back(e.index.x() + 10);
    const std::string vtu = dir + (binary ? "/b.vtu" : "/a.vtu"), out = vtu + ".txt";
    tet2spline::writeSplineVtu(V, vtu, region, {4, binary});
    ASSERT_EQ(std::system(("/usr/bin/python3 " + script + " " + vtu + " > " + out).c_str()), 0);
    std::istringstream in(readFile(out));
    size_t points = 0, cells = 0;
    int ntypes = 0, type = 0;
    double total = 0, minCell = 0, minDetJ = 0, maxScaled = 0, rmin = 0, rmax = 0;
    ASSERT_TRUE(in >> points >> cells >> ntypes >> type >> total >> minCell >> minDetJ >> maxScaled >> rmin >> rmax)
        << readFile(out);
    const Eigen::Vector3i ne = V.numElements();
    EXPECT_EQ(points, static_cast<size_t>(4 * ne[0] + 1) * (4 * ne[1] + 1) * (4 * ne[2] + 1));
    EXPECT_EQ(cells, static_cast<size_t>(64) * ne[0] * ne[1] * ne[2]);
    EXPECT_EQ(ntypes, 1);
    EXPECT_EQ(type, 12);
    std::cout << "[ measured ] VTK: " << cells << " hexahedra, volume " << total << " vs spline " << V.volume()
              << ", smallest cell " << minCell << ", min det J " << minDetJ << "\n";
    EXPECT_NEAR(total, V.volume(), 0.2 / 16 * V.volume());
    EXPECT_GT(minCell, 0);
    EXPECT_GT(minDetJ, 0);
    EXPECT_LE(maxScaled, 1.0 + 1e-12);
    EXPECT_EQ(rmin, 10);
    EXPECT_EQ(rmax, 10 + ne[0] - 1);
  }
}

TEST(SplineVtu, Deterministic) {
  const std::string dir = scratchDir("spline_vtu_determinism");
  tet2spline::writeSplineVtu(curvedCube(), dir + "/a.vtu");
  tet2spline::writeSplineVtu(curvedCube(), dir + "/b.vtu");
  EXPECT_EQ(readFile(dir + "/a.vtu"), readFile(dir + "/b.vtu"));
}

}  // namespace

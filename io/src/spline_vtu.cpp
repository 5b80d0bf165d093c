// VTU views of a B-spline volume (see spline_vtu.h).
#include "tet2spline/io/spline_vtu.h"

#include <Eigen/LU>

#include <array>
#include <cstdint>
#include <type_traits>

#include "io_util.h"
#include "tet2spline/io/atomic_file.h"
#include "tet2spline/param/error.h"

namespace tet2spline {

namespace {

using detail::appendInt;
using detail::appendRaw;
using detail::appendReal;

constexpr uint8_t kVtkLine = 3;
constexpr uint8_t kVtkHexahedron = 12;

// Collects the XML and, in binary mode, the appended block of one .vtu file.
class VtuBuilder {
 public:
  explicit VtuBuilder(bool binary) : binary_(binary) {}

  template <class T, class F>
  void array(const char* type, const std::string& name, int components, size_t count, F valueAt) {
    xml_ += "        <DataArray type=\"" + std::string(type) + "\" Name=\"" + name + "\" NumberOfComponents=\"" +
            std::to_string(components) + "\" format=\"" + (binary_ ? "appended" : "ascii") + "\"";
    if (binary_) {
      xml_ += " offset=\"" + std::to_string(appended_.size()) + "\"/>\n";
      appendRaw<uint64_t>(appended_, static_cast<uint64_t>(count * sizeof(T)));
      for (size_t i = 0; i < count; ++i) appendRaw<T>(appended_, static_cast<T>(valueAt(i)));
      return;
    }
    xml_ += ">\n";
    for (size_t i = 0; i < count; ++i) {
      if constexpr (std::is_floating_point_v<T>) appendReal(xml_, static_cast<double>(valueAt(i)));
      else appendInt(xml_, static_cast<long long>(valueAt(i)));
      xml_ += (i + 1) % 12 == 0 || i + 1 == count ? '\n' : ' ';
    }
    xml_ += "        </DataArray>\n";
  }

  void begin(size_t points, size_t cells) {
    xml_ = "<?xml version=\"1.0\"?>\n<VTKFile type=\"UnstructuredGrid\" version=\"1.0\" byte_order=\"";
    xml_ += detail::hostIsBigEndian() ? "BigEndian" : "LittleEndian";
    xml_ += "\" header_type=\"UInt64\">\n  <UnstructuredGrid>\n    <Piece NumberOfPoints=\"" +
            std::to_string(points) + "\" NumberOfCells=\"" + std::to_string(cells) + "\">\n";
  }
  void open(const char* section) { xml_ += "      <" + std::string(section) + ">\n"; }
  void close(const char* section) { xml_ += "      </" + std::string(section) + ">\n"; }

  void write(const std::string& path) {
    xml_ += "    </Piece>\n  </UnstructuredGrid>\n";
    AtomicFile file(path, true);
    std::ostream& out = file.stream();
    out.write(xml_.data(), static_cast<std::streamsize>(xml_.size()));
    if (binary_) {
      out << "  <AppendedData encoding=\"raw\">\n   _";
      out.write(appended_.data(), static_cast<std::streamsize>(appended_.size()));
      out << "\n  </AppendedData>\n";
    }
    out << "</VTKFile>\n";
    file.commit();
  }

 private:
  bool binary_;
  std::string xml_;
  std::string appended_;
};

// Sample parameters of one direction: s equal steps per knot span, and the
// element each step belongs to.
void sampleDirection(const spline::KnotVector& kv, int s, std::vector<double>& t, std::vector<int>& element) {
  const std::vector<double> bp = kv.breakpoints();
  t.clear();
  element.clear();
  for (size_t e = 0; e + 1 < bp.size(); ++e)
    for (int i = 0; i < s; ++i) {
      t.push_back(bp[e] + (bp[e + 1] - bp[e]) * i / s);
      element.push_back(static_cast<int>(e));
    }
  t.push_back(bp.back());
}

}  // namespace

void writeSplineVtu(const spline::BSplineVolume& volume, const std::string& path,
                    const std::vector<int>& elementRegion, const SplineVtuOptions& options) {
  const int s = options.samplesPerSpan;
  if (s < 1) throw Error(ErrorKind::Usage, "writeSplineVtu: " + path + ": samplesPerSpan " + std::to_string(s) + " < 1");
  const Eigen::Vector3i ne = volume.numElements();
  const size_t numElements = static_cast<size_t>(ne[0]) * ne[1] * ne[2];
  if (!elementRegion.empty() && elementRegion.size() != numElements)
    throw Error(ErrorKind::Usage, "writeSplineVtu: " + path + ": " + std::to_string(elementRegion.size()) +
                                      " element regions for " + std::to_string(numElements) + " elements");

  std::array<std::vector<double>, 3> t;
  std::array<std::vector<int>, 3> elem;
  for (int d = 0; d < 3; ++d) sampleDirection(volume.knots(d), s, t[d], elem[d]);
  const size_t np[3] = {t[0].size(), t[1].size(), t[2].size()};
  const size_t nc[3] = {np[0] - 1, np[1] - 1, np[2] - 1};
  const size_t numPoints = np[0] * np[1] * np[2];
  const size_t numCells = nc[0] * nc[1] * nc[2];

  Eigen::MatrixX3d X(static_cast<Eigen::Index>(numPoints), 3), U(static_cast<Eigen::Index>(numPoints), 3);
  Eigen::VectorXd detJ(static_cast<Eigen::Index>(numPoints)), scaled(static_cast<Eigen::Index>(numPoints));
  for (size_t k = 0; k < np[2]; ++k)
    for (size_t j = 0; j < np[1]; ++j)
      for (size_t i = 0; i < np[0]; ++i) {
        const auto p = static_cast<Eigen::Index>(i + np[0] * (j + np[1] * k));
        const Eigen::Vector3d u(t[0][i], t[1][j], t[2][k]);
        Eigen::Matrix3d J;
        X.row(p) = volume.evaluate(u, &J).transpose();
        U.row(p) = u.transpose();
        detJ[p] = J.determinant();
        const double norms = J.col(0).norm() * J.col(1).norm() * J.col(2).norm();
        scaled[p] = norms > 0 ? detJ[p] / norms : 0.0;
      }
  auto pointIndex = [&](size_t i, size_t j, size_t k) { return static_cast<int64_t>(i + np[0] * (j + np[1] * k)); };
  auto cellElement = [&](size_t c) {
    const size_t i = c % nc[0], j = (c / nc[0]) % nc[1], k = c / (nc[0] * nc[1]);
    return static_cast<size_t>(elem[0][i]) + static_cast<size_t>(ne[0]) *
           (static_cast<size_t>(elem[1][j]) + static_cast<size_t>(ne[1]) * static_cast<size_t>(elem[2][k]));
  };
  constexpr int kCorner[8][3] = {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}, {0, 0, 1}, {1, 0, 1}, {1, 1, 1}, {0, 1, 1}};

  VtuBuilder w(options.binary);
  w.begin(numPoints, numCells);
  w.open("PointData");
  w.array<double>("Float64", "detJ", 1, numPoints, [&](size_t i) { return detJ[static_cast<Eigen::Index>(i)]; });
  w.array<double>("Float64", "scaledJacobian", 1, numPoints, [&](size_t i) { return scaled[static_cast<Eigen::Index>(i)]; });
  w.array<double>("Float64", "parameter", 3, numPoints * 3,
                  [&](size_t i) { return U(static_cast<Eigen::Index>(i / 3), static_cast<Eigen::Index>(i % 3)); });
  w.close("PointData");
  w.open("CellData");
  w.array<int32_t>("Int32", "region", 1, numCells,
                   [&](size_t c) { return elementRegion.empty() ? -1 : elementRegion[cellElement(c)]; });
  w.array<int32_t>("Int32", "element", 1, numCells, [&](size_t c) { return static_cast<int32_t>(cellElement(c)); });
  w.close("CellData");
  w.open("Points");
  w.array<double>("Float64", "Points", 3, numPoints * 3,
                  [&](size_t i) { return X(static_cast<Eigen::Index>(i / 3), static_cast<Eigen::Index>(i % 3)); });
  w.close("Points");
  w.open("Cells");
  w.array<int64_t>("Int64", "connectivity", 1, numCells * 8, [&](size_t n) {
    const size_t c = n / 8, corner = n % 8;
    const size_t i = c % nc[0], j = (c / nc[0]) % nc[1], k = c / (nc[0] * nc[1]);
    return pointIndex(i + kCorner[corner][0], j + kCorner[corner][1], k + kCorner[corner][2]);
  });
  w.array<int64_t>("Int64", "offsets", 1, numCells, [](size_t c) { return static_cast<int64_t>(8 * (c + 1)); });
  w.array<uint8_t>("UInt8", "types", 1, numCells, [](size_t) { return kVtkHexahedron; });
  w.close("Cells");
  w.write(path);
}

void writeControlNetVtu(const spline::BSplineVolume& volume, const std::string& path, bool binary) {
  const int n[3] = {volume.numControl(0), volume.numControl(1), volume.numControl(2)};
  const Eigen::MatrixX3d& P = volume.controlPoints();
  const auto numPoints = static_cast<size_t>(P.rows());
  std::vector<int64_t> lines;  // pairs of point indices
  for (int d = 0; d < 3; ++d)
    for (int k = 0; k < n[2]; ++k)
      for (int j = 0; j < n[1]; ++j)
        for (int i = 0; i < n[0]; ++i) {
          int ijk[3] = {i, j, k};
          if (ijk[d] + 1 >= n[d]) continue;
          lines.push_back(volume.controlIndex(i, j, k));
          ++ijk[d];
          lines.push_back(volume.controlIndex(ijk[0], ijk[1], ijk[2]));
        }
  const size_t numCells = lines.size() / 2;

  VtuBuilder w(binary);
  w.begin(numPoints, numCells);
  w.open("PointData");
  w.array<int32_t>("Int32", "index", 3, numPoints * 3, [&](size_t m) {
    const size_t p = m / 3;
    const size_t c = m % 3;
    const size_t idx[3] = {p % static_cast<size_t>(n[0]), (p / static_cast<size_t>(n[0])) % static_cast<size_t>(n[1]),
                           p / (static_cast<size_t>(n[0]) * static_cast<size_t>(n[1]))};
    return static_cast<int32_t>(idx[c]);
  });
  w.close("PointData");
  w.open("Points");
  w.array<double>("Float64", "Points", 3, numPoints * 3,
                  [&](size_t i) { return P(static_cast<Eigen::Index>(i / 3), static_cast<Eigen::Index>(i % 3)); });
  w.close("Points");
  w.open("Cells");
  w.array<int64_t>("Int64", "connectivity", 1, lines.size(), [&](size_t i) { return lines[i]; });
  w.array<int64_t>("Int64", "offsets", 1, numCells, [](size_t c) { return static_cast<int64_t>(2 * (c + 1)); });
  w.array<uint8_t>("UInt8", "types", 1, numCells, [](size_t) { return kVtkLine; });
  w.close("Cells");
  w.write(path);
}

}  // namespace tet2spline

// G+Smo XML export (see gismo_export.h for the format and its source).
#include "tet2spline/io/gismo_export.h"

#include "io_util.h"
#include "tet2spline/io/atomic_file.h"
#include "tet2spline/param/error.h"

namespace tet2spline {

void writeGismoXml(const spline::BSplineVolume& volume, const std::string& path,
                   const std::vector<int>& elementRegion) {
  using detail::appendInt;
  using detail::appendReal;
  const Eigen::Vector3i ne = volume.numElements();
  const long long numElements = static_cast<long long>(ne[0]) * ne[1] * ne[2];
  if (!elementRegion.empty() && static_cast<long long>(elementRegion.size()) != numElements)
    throw Error(ErrorKind::Usage, "writeGismoXml: " + path + ": " + std::to_string(elementRegion.size()) +
                                      " element regions for " + std::to_string(numElements) + " elements");

  std::string x = "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n<xml>\n";
  x += " <Geometry type=\"TensorBSpline3\" id=\"0\">\n  <Basis type=\"TensorBSplineBasis3\">\n";
  for (int d = 0; d < 3; ++d) {
    const spline::KnotVector& kv = volume.knots(d);
    x += "   <Basis type=\"BSplineBasis\" index=\"" + std::to_string(d) + "\">\n    <KnotVector degree=\"" +
         std::to_string(kv.degree()) + "\">";
    for (int i = 0; i < kv.size(); ++i) {
      if (i) x += ' ';
      appendReal(x, kv[i]);
    }
    x += "</KnotVector>\n   </Basis>\n";
  }
  x += "  </Basis>\n  <coefs geoDim=\"3\">\n";
  const Eigen::MatrixX3d& P = volume.controlPoints();
  for (Eigen::Index i = 0; i < P.rows(); ++i) {
    for (int c = 0; c < 3; ++c) {
      if (c) x += ' ';
      appendReal(x, P(i, c));
    }
    x += '\n';
  }
  x += "  </coefs>\n </Geometry>\n";
  if (!elementRegion.empty()) {
    x += " <Matrix rows=\"" + std::to_string(numElements) +
         "\" cols=\"1\" id=\"1\" label=\"element_region\">\n";
    for (int r : elementRegion) {
      appendInt(x, r);
      x += '\n';
    }
    x += " </Matrix>\n";
  }
  x += "</xml>\n";

  AtomicFile file(path);
  file.stream().write(x.data(), static_cast<std::streamsize>(x.size()));
  file.commit();
}

}  // namespace tet2spline

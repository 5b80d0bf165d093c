// MFEM NURBS mesh v1.0 export (see mfem_export.h for the format and its source).
#include "tet2spline/io/mfem_export.h"

#include "io_util.h"
#include "tet2spline/io/atomic_file.h"
#include "tet2spline/param/error.h"

namespace tet2spline {

namespace {

// MFEM's hexahedron: outward faces (Geometry::Constants<CUBE>::FaceVert) and
// the VolumeFace each one is, i.e. its boundary attribute - 1.
constexpr int kFaceVert[6][4] = {{3, 2, 1, 0}, {0, 1, 5, 4}, {1, 2, 6, 5}, {2, 3, 7, 6}, {3, 0, 4, 7}, {4, 5, 6, 7}};
constexpr int kFaceOfMfemFace[6] = {4 /*WMin*/, 2 /*VMin*/, 1 /*UMax*/, 3 /*VMax*/, 0 /*UMin*/, 5 /*WMax*/};
// The 12 edges as "direction v0 v1", v0 at the low-parameter end (as in MFEM's
// data/cube-nurbs.mesh).
constexpr int kEdges[12][3] = {{0, 0, 1}, {0, 3, 2}, {0, 4, 5}, {0, 7, 6}, {1, 0, 3}, {1, 1, 2},
                               {1, 4, 7}, {1, 5, 6}, {2, 0, 4}, {2, 1, 5}, {2, 2, 6}, {2, 3, 7}};

}  // namespace

void writeMfemNurbsMesh(const spline::BSplineVolume& volume, const std::string& path,
                        const MfemExportOptions& options) {
  using detail::appendReal;
  if (options.elementAttribute < 1)
    throw Error(ErrorKind::Usage, "writeMfemNurbsMesh: " + path + ": element attribute " +
                                      std::to_string(options.elementAttribute) + " (MFEM needs >= 1)");

  std::string x = "MFEM NURBS mesh v1.0\n\n";
  x += "# Written by tet2spline: one trivariate B-spline patch.\n";
  x += "# Boundary attributes: 1 u=min, 2 u=max, 3 v=min, 4 v=max, 5 w=min, 6 w=max.\n\n";
  x += "dimension\n3\n\nelements\n1\n" + std::to_string(options.elementAttribute) + " 5 0 1 2 3 4 5 6 7\n\n";
  x += "boundary\n6\n";
  for (int f = 0; f < 6; ++f) {
    x += std::to_string(kFaceOfMfemFace[f] + 1) + " 3";
    for (int v : kFaceVert[f]) x += " " + std::to_string(v);
    x += '\n';
  }
  x += "\nedges\n12\n";
  for (const auto& e : kEdges) x += std::to_string(e[0]) + " " + std::to_string(e[1]) + " " + std::to_string(e[2]) + "\n";
  x += "\nvertices\n8\n\npatches\n\nknotvectors\n3\n";
  for (int d = 0; d < 3; ++d) {
    const spline::KnotVector& kv = volume.knots(d);
    x += std::to_string(kv.degree()) + " " + std::to_string(kv.numBasis());
    for (int i = 0; i < kv.size(); ++i) {
      x += ' ';
      appendReal(x, kv[i]);
    }
    x += '\n';
  }
  x += "\ndimension\n3\n\ncontrolpoints_cartesian\n";
  const Eigen::MatrixX3d& P = volume.controlPoints();
  for (Eigen::Index i = 0; i < P.rows(); ++i) {
    for (int c = 0; c < 3; ++c) {
      appendReal(x, P(i, c));
      x += ' ';
    }
    x += "1\n";
  }

  AtomicFile file(path);
  file.stream().write(x.data(), static_cast<std::streamsize>(x.size()));
  file.commit();
}

void writeMfemElementRegions(const spline::BSplineVolume& volume, const std::vector<int>& elementRegion,
                             const std::string& path) {
  const Eigen::Vector3i ne = volume.numElements();
  const long want = static_cast<long>(ne[0]) * ne[1] * ne[2];
  if (static_cast<long>(elementRegion.size()) != want)
    throw Error(ErrorKind::Usage, "writeMfemElementRegions: " + path + ": " + std::to_string(elementRegion.size()) +
                                      " element regions for " + std::to_string(want) + " elements");
  std::string x = "FiniteElementSpace\nFiniteElementCollection: L2_3D_P0\nVDim: 1\nOrdering: 0\n\n";
  for (int r : elementRegion) x += std::to_string(r) + '\n';
  AtomicFile file(path);
  file.stream().write(x.data(), static_cast<std::streamsize>(x.size()));
  file.commit();
}

}  // namespace tet2spline

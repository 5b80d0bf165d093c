// Self-intersections of a triangle surface with CGAL's Polygon_mesh_processing
// (box intersection of the triangles' bounding boxes, then exact
// triangle-triangle tests with the filtered Epick kernel).
//
// Sequential on purpose: measured on bunny00 (75k faces) on this 2-core
// machine, CGAL 5.5's Parallel_tag version took 0.45 s against 0.24 s
// sequential (twice the CPU time too), and it needs CGAL_LINKED_WITH_TBB,
// which would differ from the other CGAL translation units of the library.
#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <CGAL/Polygon_mesh_processing/self_intersections.h>
#include <CGAL/Surface_mesh.h>

#include <iterator>
#include <vector>

#include "self_intersection.h"

namespace tet2spline {

namespace {
using K = CGAL::Exact_predicates_inexact_constructions_kernel;
using Mesh = CGAL::Surface_mesh<K::Point_3>;
}  // namespace

int countSelfIntersections(const SurfaceMesh& surface, int cap) {
  Mesh mesh;
  std::vector<Mesh::Vertex_index> vertex(surface.V.rows());
  for (Eigen::Index i = 0; i < surface.V.rows(); ++i)
    vertex[i] = mesh.add_vertex(K::Point_3(surface.V(i, 0), surface.V(i, 1), surface.V(i, 2)));
  for (Eigen::Index f = 0; f < surface.F.rows(); ++f) {
    const auto face = mesh.add_face(vertex[surface.F(f, 0)], vertex[surface.F(f, 1)], vertex[surface.F(f, 2)]);
    if (face == Mesh::null_face()) return -1;
  }
  std::vector<std::pair<Mesh::Face_index, Mesh::Face_index>> pairs;
  CGAL::Polygon_mesh_processing::self_intersections<CGAL::Sequential_tag>(
      mesh, std::back_inserter(pairs), CGAL::parameters::maximum_number(static_cast<unsigned>(cap)));
  return static_cast<int>(std::min<std::size_t>(pairs.size(), static_cast<std::size_t>(cap)));
}

}  // namespace tet2spline

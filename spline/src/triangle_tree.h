#pragma once
// Internal to the spline module: nearest points on a triangle set (CGAL's
// AABB tree; CGAL stays out of the public headers).
#include <CGAL/AABB_traits.h>
#include <CGAL/AABB_tree.h>
#include <CGAL/AABB_triangle_primitive.h>
#include <CGAL/Simple_cartesian.h>

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <vector>

namespace tet2spline::spline::detail {

using K = CGAL::Simple_cartesian<double>;
using Point = K::Point_3;
using Triangle = K::Triangle_3;
using Primitive = CGAL::AABB_triangle_primitive<K, std::vector<Triangle>::const_iterator>;
using TriangleTree = CGAL::AABB_tree<CGAL::AABB_traits<K, Primitive>>;

inline Point toPoint(const Eigen::Vector3d& x) { return {x[0], x[1], x[2]}; }
inline Eigen::Vector3d toEigen(const Point& p) { return {p.x(), p.y(), p.z()}; }

/// Barycentric coordinates (w_a, w_b, w_c) of p in the plane of triangle abc
/// (p on the triangle, e.g. a nearest point the tree returned).
inline Eigen::Vector3d barycentric(const Eigen::Vector3d& p, const Eigen::Vector3d& a, const Eigen::Vector3d& b,
                                   const Eigen::Vector3d& c) {
  const Eigen::Vector3d n = (b - a).cross(c - a);
  const double nn = n.squaredNorm();
  const double wb = (p - a).cross(c - a).dot(n) / nn, wc = (b - a).cross(p - a).dot(n) / nn;
  return {1.0 - wb - wc, wb, wc};
}

}  // namespace tet2spline::spline::detail

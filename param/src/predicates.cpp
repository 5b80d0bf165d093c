// Exact orientation predicates (CGAL's filtered Epick kernel: exact sign,
// floating-point speed in the common case).
#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <tbb/blocked_range.h>
#include <tbb/parallel_reduce.h>

#include "tet2spline/param/topology.h"

namespace tet2spline {

namespace {
using K = CGAL::Exact_predicates_inexact_constructions_kernel;
inline K::Point_3 P(const double* p) { return K::Point_3(p[0], p[1], p[2]); }
}  // namespace

int orient3d(const double* a, const double* b, const double* c, const double* d) {
  // CGAL::orientation(p, q, r, s) is POSITIVE when det[q − p, r − p, s − p] > 0.
  return static_cast<int>(CGAL::orientation(P(a), P(b), P(c), P(d)));
}

bool collinear(const double* a, const double* b, const double* c) {
  return CGAL::collinear(P(a), P(b), P(c));
}

int countNonPositiveTets(const Eigen::MatrixX3d& X, const Eigen::MatrixX4i& T) {
  return tbb::parallel_reduce(
      tbb::blocked_range<Eigen::Index>(0, T.rows(), 4096), 0,
      [&](const tbb::blocked_range<Eigen::Index>& r, int count) {
        for (Eigen::Index t = r.begin(); t != r.end(); ++t) {
          K::Point_3 p[4];
          for (int k = 0; k < 4; ++k) {
            const auto i = T(t, k);
            p[k] = K::Point_3(X(i, 0), X(i, 1), X(i, 2));
          }
          if (CGAL::orientation(p[0], p[1], p[2], p[3]) != CGAL::POSITIVE) ++count;
        }
        return count;
      },
      [](int a, int b) { return a + b; });
}

int countFlippedTriangles(const Eigen::MatrixX3d& U, const Eigen::MatrixX3i& F, const Eigen::Vector3d& apex) {
  int flipped = 0;
  for (Eigen::Index f = 0; f < F.rows(); ++f) {
    const Eigen::Vector3d a = U.row(F(f, 0)), b = U.row(F(f, 1)), c = U.row(F(f, 2));
    flipped += orient3d(apex.data(), a.data(), b.data(), c.data()) <= 0;
  }
  return flipped;
}

}  // namespace tet2spline

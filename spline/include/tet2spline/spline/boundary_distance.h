#pragma once
/// Distance between a B-spline volume's boundary (its six faces) and a
/// triangulated surface, sampled both ways: the report's
/// `fit.boundary_hausdorff_relative` (design.md, "Command line and report").
///
///   spline → surface: the faces are sampled on a grid of `samplesPerSpan`
///     steps per knot span (span ends included); each sample's distance to
///     the nearest triangle is exact (point-to-triangle, AABB tree).
///   surface → spline: every surface vertex and triangle centroid is projected
///     onto the spline boundary: nearest point of a tessellation of the faces
///     (the same grid, two triangles per cell), then Gauss–Newton on the face
///     S(s,t) from there, clamped to the face's parameter box. The distance is
///     to a point of the spline's boundary, so it never understates the true
///     distance, and equals it when the projection finds the nearest point.
///
/// The Hausdorff distance is the larger of the two maxima (a sampled lower
/// bound of the spline → surface part, an upper bound of the other part).

#include <Eigen/Core>

#include <tet2spline/param/tet_mesh.h>
#include <tet2spline/spline/bspline_volume.h>

namespace tet2spline::spline {

struct BoundaryDistanceOptions {
  int samplesPerSpan = 8;  ///< face samples per knot span per direction (>= 1)
  int threads = 2;
};

struct BoundaryDistance {
  double splineToSurface = 0;  ///< max over the face samples of the distance to the surface
  double surfaceToSpline = 0;  ///< max over the surface samples of the distance to the faces
  double hausdorff = 0;        ///< max of the two
  double meanSplineToSurface = 0;
  double meanSurfaceToSpline = 0;
  long splineSamples = 0;
  long surfaceSamples = 0;
};

/// Throws Error(Usage) for an empty surface, indices out of range, non-finite
/// coordinates or samplesPerSpan < 1.
BoundaryDistance boundaryDistance(const BSplineVolume& volume, const SurfaceMesh& surface,
                                  const BoundaryDistanceOptions& options = {});

}  // namespace tet2spline::spline

#pragma once
/// Fit data for the parts of the cube's faces that a cube parameterization
/// leaves uncovered.
///
/// The placement puts boundary vertices on the faces of [0,1]^3 but not on
/// its edges and corners, so boundary triangles that reach across an edge cut
/// a wedge off the cube (param/parameterize.h, cubeEdges). The spline is
/// defined on the whole cube: without data there, smoothing extrapolates the
/// wedges outwards and the spline's faces bulge beyond the input surface
/// (part.off, 8^3 elements: 4% of the cube uncovered, spline volume 16% above
/// the mesh's, boundary Hausdorff distance 0.11 of the diagonal).
///
/// Each face is sampled on a regular grid; a sample that no boundary triangle
/// lying in that face covers gets, as its target, the physical position of
/// the nearest point of the triangles that do not lie in one face (the ones
/// that cut the wedges off), interpolated linearly on that triangle. The
/// spline's faces then follow the input surface there too, and the wedge
/// maps to a thin layer under it.

#include <Eigen/Core>

namespace tet2spline::spline {

struct FaceCoverageSamples {
  Eigen::MatrixX3d U;       ///< samples on the cube's faces that no face triangle covers
  Eigen::MatrixX3d X;       ///< their targets: physical positions of the nearest cutting-triangle points
  double coveredArea = 0;   ///< area of the faces covered by boundary triangles lying in them (of 6)
  long samplesPerFace = 0;  ///< grid samples per face (perSide²)
};

/// U: #V × 3 parameters in [0,1]^3; X: #V × 3 physical positions; F: the
/// boundary triangles (indices into U and X). `perSide` >= 2 samples per
/// side of each face, ends included. Throws Error(Usage) for bad sizes or
/// indices.
FaceCoverageSamples uncoveredFaceSamples(const Eigen::MatrixX3d& U, const Eigen::MatrixX3d& X,
                                         const Eigen::MatrixX3i& F, int perSide, int threads = 2);

}  // namespace tet2spline::spline

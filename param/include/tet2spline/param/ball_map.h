#pragma once
/// Map of a tetrahedral solid onto the unit ball (design.md, stages "Spherical
/// map", "Volumetric harmonic map", "Untangling"; Su et al. 2016, §3).
///
/// 1. the outer boundary surface (outward triangles of the tets) is mapped
///    bijectively onto the unit sphere (spherical_map.h);
/// 2. the interior follows by the harmonic map with that boundary fixed
///    (harmonic_map.h);
/// 3. inverted tets are untangled with the boundary kept (untangle.h); if
///    some cannot be repaired that way (a tet whose four vertices are on the
///    boundary is decided by the spherical map alone; TetGen makes many at
///    sharp features), a second pass lets the boundary vertices near them
///    slide on the sphere while keeping every sphere triangle unflipped.
/// Voids must already be filled with tets (design.md, "Voids"): void tets are
/// ordinary tets of the filled solid. A solid whose boundary has more than one
/// shell is refused (Error(Topology)).
/// Boundary vertices end on the sphere to rounding (|u| = 1 within 1e-15).

#include <string>

#include "tet2spline/param/error.h"
#include "tet2spline/param/progress.h"
#include "tet2spline/param/spherical_map.h"
#include "tet2spline/param/tet_mesh.h"
#include "tet2spline/param/untangle.h"

namespace tet2spline {

struct BallMapOptions {
  /// Its progress member is replaced by `progress`. Conformal (no area
  /// correction) by default: on triceratops the area-corrected boundary made
  /// the untangling of the harmonic map take 502 s and leave 7 tets inverted,
  /// against 14 s and none from the conformal one.
  SphericalMapOptions sphere = [] {
    SphericalMapOptions o;
    o.areaCorrectionIterations = 0;
    return o;
  }();
  UntangleOptions untangle;        ///< idem (its messages come with fraction −1)
  bool untangleMap = true;         ///< false: return the harmonic map as it is
  ProgressCallback progress = {};  ///< fraction over the whole map; return false to stop
};

struct BallMapResult {
  Eigen::MatrixX3d U;                 ///< #V × 3, in the closed unit ball
  Eigen::VectorXi boundaryVertices;   ///< vertices of the outer shell, ascending
  Eigen::MatrixX3i boundaryFaces;     ///< outward triangles of the outer shell, indexing V
  struct Sphere {
    int flippedTriangles = 0;         ///< report key sphere.flipped_triangles (after untangling)
    double angleDistortionMean = 0;   ///< σ_max/σ_min per triangle, mean
    double angleDistortionMax = 0;
    double centreOffset = 0;
    std::string method;
    int areaCorrectionIterations = 0;
    double areaDivergenceBefore = 0;  ///< before the area correction (the conformal map's)
    double areaDivergence = 0;        ///< KL divergence of mapped from input area shares
    double areaRatioMin = 0, areaRatioMax = 0;
  } sphere;
  struct Ball {
    int invertedTetsBeforeUntangling = 0;  ///< exact, after the harmonic map
    int invertedTets = 0;                  ///< exact, at the end: report key ball.inverted_tets
    double harmonicResidual = 0;           ///< relative residual of the Dirichlet solve
    std::string solver;
    int untangleIterations = 0;            ///< L-BFGS or Newton iterations (UntangleOptions::method)
    bool boundarySlid = false;             ///< untangling had to slide boundary vertices on the sphere
  } ball;
  double boundaryMaxDistance = 0;     ///< max over boundary vertices of | |u| − 1 |
  struct Timings {
    double boundary = 0, sphere = 0, harmonic = 0, untangle = 0, total = 0;  ///< seconds
  } timings;
  Status status;                      ///< failure when a stage left flips/inversions or was stopped
  bool stopped = false;               ///< the progress callback stopped it (status says where)
};

/// Throws Error(Topology) unless the boundary is one closed genus-0 shell,
/// Error(Input) for a tet of non-positive volume.
BallMapResult mapToBall(const TetMesh& mesh, const BallMapOptions& options = {});

}  // namespace tet2spline

#pragma once
/// Bijective map of a closed genus-0 triangle surface onto the unit sphere
/// (design.md, "Spherical map of the outer shell").
///
/// Route, chosen by measurement on the ten genus-0 test surfaces (all linear
/// solves, one sparse Cholesky each):
///  1. "fast spherical conformal map" of Choi, Lam and Lui (SIAM J. Imaging
///     Sci. 2015): puncture the most regular triangle, solve the cotangent
///     Laplace equation in the plane with that triangle fixed, inverse
///     stereographic projection from the north pole, rescale so the northern
///     and southern triangles are balanced, then a linear Beltrami solve in
///     the south-pole projection (10% of the vertices nearest the south pole
///     fixed) that removes the distortion near the puncture;
///  2. Möbius normalisation: the mass centre c = Σ m_i u_i / Σ m_i, with m_i a
///     third of the input area around vertex i, is moved to the origin by
///     repeating u ↦ φ_c(u) = ((1−|c|²)(u−c) − |u−c|² c)/|u−c|² (the ball
///     automorphism sending c to 0; Baden, Crane, Kazhdan 2018, "Möbius
///     registration"), which keeps the map conformal and orientation-preserving;
///  3. exact check: a triangle (a,b,c) of the outward oriented surface is
///     flipped when orient3d(0, u_a, u_b, u_c) <= 0 (exact predicates);
///  4. area correction (areaCorrectionIterations > 0): a conformal map
///     shrinks protrusions enormously (triceratops: triangle area shares down
///     to 1e-14 of their input share, bunny00 7e-9), and the harmonic interior
///     and the transport inherit it: tet volumes 1e-22 of their share, Newton
///     steps of 2^-33. So the map is made nearly equiareal by reweighted Tutte
///     embeddings: cut the sphere at its largest triangle p, project
///     stereographically from p's centre, and repeat: solve L_s z = 0 with p's
///     corners fixed, L_s the Laplacian with positive weights
///     s_f·max(cot θ, 0.05)/2 (θ the input angles), then s_f ← s_f·σ_f^{1/2},
///     σ_f = (mapped area share)/(input area share), so a triangle with too
///     little area gets softer and grows. Positive weights and a convex
///     boundary make each step a planar embedding (Tutte 1963; Floater 2003);
///     the plane's scale (a Möbius transformation) minimises the area
///     divergence D = Σ A_f log(1/σ_f)/ΣA (Kullback-Leibler, 0 when
///     equiareal). A planar embedding can still flip a chord triangle whose
///     circumcircle is nearly a great circle, so the map kept is the step of
///     lowest D that is flip-free (exact, after a short local repair); five
///     steps without progress stop it. No Möbius normalisation follows (it
///     would undo the areas): an equiareal map has its mass centre at the
///     origin by itself. Measured D, conformal -> corrected, on the raw test
///     surfaces: homer 2.4 -> 0.08, triceratops 2.1 -> 0.11, bunny00 1.29 ->
///     0.16, retinal 1.09 -> 0.05, fandisk 0.32 -> 0.008, blobby 0.28 ->
///     0.003; on the long CAD slivers of part.off and hand.off every step
///     flips and the conformal map stays. In the pipeline (TetGen's boundary)
///     it cut fandisk's cube parameterization from 72 s to 40 s (transport 23
///     -> 13 Newton iterations); with its cap flipped too (tetrahedralize.h),
///     triceratops converges (38 iterations); with the cap flipped and the
///     conformal map, its line search still fails at Newton iteration 2.
/// The cotangent weights of step 1 can be negative, so it is not bijective in
/// theory; when it leaves flipped triangles, they are first relaxed locally
/// (spherical Tutte relaxation of their rings, below) and the rest of the map
/// stays conformal ("conformal+repair"). Measured on the meshed test solids:
/// triceratops went from a global Tutte map (angle distortion mean 66, 599
/// inverted tets, 232 s of untangling, 6 tets left inverted) to conformal+repair
/// (mean 18, untangled to zero in 43 s); hand and homer also take this route.
/// Only when the local repair fails does the Tutte embedding (uniform
/// positive weights: a bijection of the punctured sphere onto the triangle,
/// Tutte 1963) replaces it, still Möbius-normalised, and any triangle that
/// remains flipped after rounding (tiny triangles near the puncture) is
/// repaired by local spherical Tutte relaxation (each vertex of a flipped
/// triangle and its ring moves to the normalised mean of its neighbours).
///
/// Distortion: per triangle, the ratio σ_max/σ_min of the singular values of
/// the linear map from the input triangle to the mapped (flat) triangle;
/// 1 for a similarity.

#include <string>

#include "tet2spline/param/error.h"
#include "tet2spline/param/progress.h"
#include "tet2spline/param/tet_mesh.h"

namespace tet2spline {

struct SphericalMapOptions {
  bool conformal = true;               ///< false: skip step 1 and use the Tutte embedding directly
  double maxCentreOffset = 1e-6;       ///< Möbius normalisation stops when |c| is below this
  int maxMobiusIterations = 100;
  int maxRepairSweeps = 200;           ///< local relaxation sweeps for flipped triangles
  /// Area correction (step 4 above): at most this many reweighted Tutte
  /// steps; 0 keeps the conformal (or Tutte) map as it is.
  int areaCorrectionIterations = 30;
  double areaCorrectionTolerance = 1e-4;  ///< stop when the area divergence is below this
  ProgressCallback progress = {};      ///< called after each step; return false to stop
};

struct SphericalMapResult {
  Eigen::MatrixX3d U;                  ///< #V × 3, unit vectors (|u| = 1 to rounding)
  int flippedTriangles = 0;            ///< exact count, orient3d(0, a, b, c) <= 0
  double angleDistortionMean = 0;      ///< mean over triangles of σ_max/σ_min
  double angleDistortionMax = 0;
  double centreOffset = 0;             ///< |Σ m_i u_i| / Σ m_i at the end (after normalisation, or step 4)
  int mobiusIterations = 0;
  int areaCorrectionIterations = 0;    ///< area correction steps kept
  double areaDivergenceBefore = 0;     ///< area divergence (below) before the area correction
  double areaDivergence = 0;           ///< Σ A_f log(A_f / a_f) / ΣA over area shares (0: equiareal)
  double areaRatioMin = 0;             ///< min over triangles of (mapped area share) / (input area share)
  double areaRatioMax = 0;
  std::string method;                  ///< "conformal", "conformal+repair", "tutte" or "tutte+repair", then "+area" when step 4 ran
  Status status;                       ///< failure when flips remain or progress stopped it
};

/// `surface` must be one closed, consistently outward oriented, genus-0
/// triangulated shell without unused vertices; otherwise throws
/// Error(Topology) naming what was found.
SphericalMapResult sphericalMap(const SurfaceMesh& surface, const SphericalMapOptions& options = {});

/// Exact number of triangles F of U (#V × 3) with orient3d(0, U_a, U_b, U_c) <= 0.
int countFlippedSphereTriangles(const Eigen::MatrixX3d& U, const Eigen::MatrixX3i& F);

/// Per-triangle σ_max/σ_min of the affine map from triangle f of (V, F) to
/// triangle f of (U, F); +inf for a degenerate image. #F.
Eigen::VectorXd triangleAngleDistortion(const Eigen::MatrixX3d& V, const Eigen::MatrixX3d& U,
                                        const Eigen::MatrixX3i& F);

}  // namespace tet2spline

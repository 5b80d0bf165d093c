#pragma once
/// Least-squares fit of a trivariate B-spline x(u) to parameterized data, and
/// its validity (design.md, "Trivariate B-spline and fitting").
///
/// Data: parameters U (#N × 3, in [0,1]^3), positions X (#N × 3), weights w
/// (#N) and a boundary flag per point. With W = Σ w̃_i (w̃_i = w_i, times
/// boundaryWeight on boundary points) the fit minimises
///
///   E(P) = (1/W) Σ_i w̃_i |x(U_i) − X_i|²  +  λ ∫_[0,1]^3 |D²x|² du        (1)
///
/// where |D²x|² = |x_uu|² + |x_vv|² + |x_ww|² + 2(|x_uv|² + |x_uw|² + |x_vw|²)
/// (thin-plate energy, integrated exactly by Gauss quadrature; both terms have
/// units length², so λ = smoothingWeight is dimensionless). (1) is linear
/// least squares in the control points P. Then a validity stage adds
///
///   μ Σ_g ω_g (L/J̄)² max(0, τ − det J(g))²,  τ = validityFraction · J̄     (2)
///
/// over the Gauss points g (ω_g their quadrature weights, J̄ the mean det J,
/// L the bounding-box diagonal of X) and minimises (1)+(2) with Ceres,
/// multiplying μ by 10 until no Gauss point has det J <= 0. With the L-BFGS
/// solver a round stops as soon as every Gauss point of the elements it
/// moves has det J > τ/20 (fit.cpp has the measurements).
///
/// Gauss points ((p+1)^3 per element) lie strictly inside the elements, hence
/// strictly inside the cube: a single patch onto a smooth solid has det J = 0
/// on the cube's 12 edges, which they never sample. These are the "interior
/// Gauss points" the result counts.

#include <Eigen/Core>
#include <tet2spline/param/error.h>
#include <tet2spline/param/progress.h>
#include <tet2spline/spline/bspline_volume.h>

namespace tet2spline::spline {

/// det J and the scaled Jacobian at the (p+1)^3 Gauss points of every element.
struct JacobianQuality {
  long gaussPoints = 0;          ///< number of Gauss points checked
  long nonPositive = 0;          ///< Gauss points with det J <= 0
  double minDetJ = 0;
  double meanDetJ = 0;           ///< ∫ det J / parameter-box volume (Gauss weights)
  double minScaledJacobian = 0;  ///< min over Gauss points of det J / (|x_u||x_v||x_w|)
};
JacobianQuality jacobianQuality(const BSplineVolume& volume);

struct FitOptions {
  int degree = 3;                         ///< p in every direction
  Eigen::Vector3i elements{8, 8, 8};      ///< uniform knot spans per direction (Nu, Nv, Nw)
  /// λ in (1). It biases the fit (≈ λ-proportional error floor): on 100k
  /// samples of a smooth map, 1e-9 already limits 16^3 elements to ~6e-7
  /// relative RMS, 1e-11 does not. Raise it for noisy data or empty elements.
  double smoothingWeight = 1e-8;
  double boundaryWeight = 10.0;           ///< multiplies w_i of boundary points
  double targetRmsRelative = 0.0;         ///< > 0: double the elements until rms/diagonal < this
  int maxRefinements = 2;                 ///< at most this many doublings
  int maxElementsPerDirection = 64;       ///< refinement never exceeds this
  bool enforceValidity = true;            ///< run the validity stage when det J <= 0 somewhere
  double validityFraction = 0.05;         ///< τ / J̄ in (2)
  int maxValidityIterations = 8;          ///< outer (μ) iterations of the validity stage
  int maxSolverIterations = 25;           ///< Ceres Levenberg–Marquardt iterations per validity iteration
  /// Validity stage solver (both Ceres): L-BFGS on (1)+(2) over the free
  /// control points (ceres::GradientProblemSolver; data term through the
  /// assembled normal equations), or Levenberg–Marquardt on residual blocks
  /// (ceres::Problem, SPARSE_NORMAL_CHOLESKY). Chosen by measurement (see fit.cpp).
  enum class ValiditySolver { Lbfgs, LevenbergMarquardt } validitySolver = ValiditySolver::Lbfgs;
  int maxLbfgsIterations = 2000;          ///< L-BFGS iterations per validity iteration
  /// When det J <= 0 remains after the validity stage, refit with λ
  /// multiplied by smoothingRaiseFactor (λ = 0 becomes 1e-8), at most this
  /// many times; FitResult::smoothingWeight is the λ of the result.
  int maxSmoothingRaises = 3;
  double smoothingRaiseFactor = 10.0;
  /// Linear stage (1): CHOLMOD on the assembled normal equations (fast), or
  /// the same objective as a Ceres problem (SPARSE_NORMAL_CHOLESKY).
  enum class LinearSolver { Cholmod, Ceres } linearSolver = LinearSolver::Cholmod;
  /// The errors of FitResult (RMS, max) are measured at the first this many
  /// points (the mesh's vertices); the rest are extra data, e.g. the face
  /// samples of face_coverage.h. < 0: at every point.
  long measuredPoints = -1;
  int threads = 2;
  ProgressCallback progress = {};         ///< called per stage; return false to stop
};

struct FitTimings {
  double assembly = 0;     ///< seconds: bucketing, element matrices, normal equations
  double linearSolve = 0;  ///< factorisation and solve of (1)
  double validity = 0;     ///< the Ceres validity stage
  double evaluation = 0;   ///< errors and Jacobian quality
  double total = 0;
};

struct FitResult {
  BSplineVolume volume;
  Eigen::Vector3i elements{0, 0, 0};   ///< elements per direction of the final fit
  double rmsError = 0;                 ///< sqrt(mean |x(U_i) − X_i|²), unweighted
  double maxError = 0;                 ///< max |x(U_i) − X_i|
  double boundingBoxDiagonal = 0;      ///< of X
  double rmsErrorRelative = 0;         ///< rmsError / boundingBoxDiagonal
  double maxErrorRelative = 0;
  long gaussPoints = 0;                ///< interior Gauss points checked
  long negativeGaussPoints = 0;        ///< with det J <= 0, after the validity stage
  long negativeGaussPointsBeforeValidity = 0;
  double minScaledJacobian = 0;        ///< at interior Gauss points
  double minDetJ = 0;
  double meanDetJ = 0;
  int refinements = 0;                 ///< doublings done for targetRmsRelative
  double smoothingWeight = 0;          ///< λ of the result (raised from FitOptions' when det J <= 0 remained)
  int smoothingRaises = 0;             ///< refits with a raised λ (of the last refinement level)
  int validityIterations = 0;          ///< outer iterations of the validity stage
  int solverIterations = 0;            ///< Ceres iterations, all stages
  FitTimings timings;
  Status status;  ///< failure when det J <= 0 remains, the target error was missed, or stopped
};

/// Fits a B-spline volume on [0,1]^3 to the data. weights: #N, or empty for
/// all 1. boundary: #N, or empty for none. Throws Error(Usage) on mismatched
/// sizes, non-finite data, parameters outside [0,1]^3 (beyond 1e-9), negative
/// weights or bad options; a singular system (λ = 0 and elements without
/// data) is a failed Status.
FitResult fitBSplineVolume(const Eigen::MatrixX3d& U, const Eigen::MatrixX3d& X,
                           const Eigen::VectorXd& weights = {},
                           const Eigen::Array<bool, Eigen::Dynamic, 1>& boundary = {},
                           const FitOptions& options = {});

}  // namespace tet2spline::spline

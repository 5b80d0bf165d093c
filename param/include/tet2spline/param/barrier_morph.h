#pragma once
/// A bijective map moved towards a target that may fold over, never leaving
/// the set of bijective maps: the fallback of the composition (design.md,
/// "Composition and the boundary") where untangling the transport's target
/// fails.
///
/// From a start map U⁰ with every tet positive (and, with a sliding
/// boundary, every cone from Ω's centre over a boundary triangle positive),
/// minimises over the vertex positions U
///     F(U) = Σ_t |J_t|² / det(J_t)^(2/3)  +  λ Σ_v |U_v − U*_v|² / ℓ_v²,
/// J_t the Jacobian of tet t from its reference (input) shape to U. The first
/// term is the shape part of the untangling energy (untangle.h) with ε = 0: a
/// true barrier, infinite on a flat or inverted tet, and scale-free, so it
/// resists folding, not the growth or shrinking that the target asks for.
/// The second pulls every vertex towards its target U*_v, in units of ℓ_v, the
/// edge of a regular tet of the mean target volume around v. L-BFGS with a
/// line search that rejects every step on which a tet's det J ≤ 0 (checked in
/// floating point, confirmed exactly after every run); one run per λ of the
/// schedule, the preconditioner and the cones' reference shapes rebuilt at
/// the start of each. Where the target is bijective the result approaches
/// it as λ grows; where it folds, the barrier holds the tets open.
///
/// Boundary vertices that are not fixed slide: on the unit sphere (y/|y|) with
/// `sphereFaces`, on the unit cube's surface with `cubeFaces` (where the ray
/// from (½,½,½) through y meets it, so a vertex may cross a cube edge). The
/// cones over those faces join the barrier, so no boundary triangle flips.
///
/// Measured (2 cores), from the ball map towards the final untangler's
/// result (thousands of tets still inverted), λ = 1, 10, 100, 1000 with at
/// most 30 Newton iterations each, on hand.off (12.7k vertices, 53k tets):
///
///   linear solve per Newton step       ball: rms / s    cube: rms / s
///   CHOLMOD (exact)                    0.42 / 48 (*)    3.5 / 73
///   Jacobi CG, at most 100 iterations  0.39 / 25        0.62 / 23
///   Jacobi CG, at most 50 (default)    0.39 / 18        0.62 / 19
///   Jacobi CG, at most 30              0.39 / 17
///
/// (rms: distance to the target in target edges, from 8.0 on the ball and
/// 28.7 on the cube; incomplete-Cholesky CG needed 200-400 iterations at
/// 10⁻² and took longer than CHOLMOD; (*) with OpenBLAS, whose
/// factorisations took 0.3 s here against ATLAS's 0.5 s, but whose rounding
/// left spool.off's ball map with one tet inverted, so the project keeps
/// the BLAS its packages bring, ATLAS on this machine). The truncated steps
/// do better: the exact Newton step is dominated by the stiffest barrier
/// terms, and the line search cut it to 1/16 .. 1/2. A CHOLMOD factorisation grows as the
/// mesh's fill does: 20 s per Newton step on a 69k-vertex ball grid, against
/// 1.2 s with CG.

#include <Eigen/Core>
#include <vector>

#include "tet2spline/param/error.h"
#include "tet2spline/param/progress.h"
#include "tet2spline/param/untangle.h"

namespace tet2spline {

struct BarrierMorphOptions {
  std::vector<double> attraction = {1, 10, 100, 1000};  ///< λ of each run, in order
  /// Newton (default): projected Newton, each tet's Hessian projected onto
  /// the PSD cone (untangle.h), solved inexactly by conjugate gradients.
  /// L-BFGS stalls at the barrier here: on hand.off's cube map 1200
  /// iterations moved the vertices from 28.0 to 27.4 target edges (rms) from
  /// their targets.
  UntangleMethod method = UntangleMethod::Newton;
  int maxNewtonIterations = 30;   ///< per run
  int cgIterations = 50;          ///< per Newton step, at most (Jacobi-preconditioned CG)
  double cgTolerance = 1e-3;      ///< CG stops at this residual relative to the gradient
  int maxLbfgsIterations = 300;   ///< per run
  int lbfgsMemory = 10;
  Eigen::MatrixX3i sphereFaces;   ///< outward boundary triangles on the unit sphere (slide on it)
  Eigen::MatrixX3i cubeFaces;     ///< outward boundary triangles on the unit cube's surface (slide on it)
  /// Per tet (#T): the volume each tet should have; sets ℓ_v. Empty: ℓ_v from
  /// the target's own edges at v (their mean length).
  Eigen::VectorXd targetVolumes;
  ProgressCallback progress = {};  ///< called once per run; false stops
};

struct BarrierMorphResult {
  Eigen::MatrixX3d U;             ///< #V × 3, every tet positive (exact) when status is ok
  int lbfgsIterations = 0;
  int newtonIterations = 0;
  double startDistance = 0;       ///< root mean square of |U_v − U*_v| / ℓ_v over the vertices, at the start
  double distance = 0;            ///< and at the end
  double maxDistance = 0;         ///< largest |U_v − U*_v| / ℓ_v at the end
  Status status;                  ///< failure only when stopped by the progress callback
  bool stopped = false;
};

/// Moves `start` (#V × 3, bijective as above) towards `target` (#V × 3),
/// keeping the vertices with fixed[v]. `reference` (#V × 3) and T (#T × 4,
/// positively oriented) give the reference shapes. Throws Error(Input) for
/// mismatched shapes or indices, a reference tet of non-positive volume, or a
/// start with a non-positive tet or cone; Error(Usage) for both sphereFaces
/// and cubeFaces, or a schedule with a λ that is not finite and > 0.
BarrierMorphResult morphTowards(const Eigen::MatrixX3d& reference, const Eigen::MatrixX4i& T,
                                const Eigen::MatrixX3d& start, const Eigen::MatrixX3d& target,
                                const std::vector<bool>& fixed, const BarrierMorphOptions& options = {});

}  // namespace tet2spline

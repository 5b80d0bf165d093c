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
/// Measured (2 cores, OpenBLAS), from the ball map towards the final
/// untangler's result (thousands of tets still inverted), λ = 1, 10, 100,
/// 1000 with at most 30 Newton iterations each: hand.off on the ball
/// (12.7k vertices) 8.0 -> 0.43 target edges (rms) in 48 s, on the cube
/// (from the stretched ball map) 28.7 -> 3.5 in about 50 s; spool.off on the
/// cube 0.25 in 25 s. A Newton iteration costs one CHOLMOD factorisation
/// (0.3 s for hand's 38k unknowns; 0.5 s with ATLAS's BLAS); incomplete
/// Cholesky CG took 200-400 iterations and longer. Steps stay short (1/16
/// to 1/2) while the target is far: the barrier, not the model, limits
/// them.

#include <Eigen/Core>
#include <vector>

#include "tet2spline/param/error.h"
#include "tet2spline/param/progress.h"
#include "tet2spline/param/untangle.h"

namespace tet2spline {

struct BarrierMorphOptions {
  std::vector<double> attraction = {1, 10, 100, 1000};  ///< λ of each run, in order
  /// Newton (default): projected Newton, each tet's Hessian projected onto
  /// the PSD cone (untangle.h), factorised with CHOLMOD. L-BFGS stalls at the
  /// barrier here: on hand.off's cube map 1200 iterations moved the vertices
  /// from 28.0 to 27.4 target edges (rms) from their targets.
  UntangleMethod method = UntangleMethod::Newton;
  int maxNewtonIterations = 30;   ///< per run
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

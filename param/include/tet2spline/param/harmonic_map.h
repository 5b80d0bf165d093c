#pragma once
/// Volumetric harmonic map with a fixed boundary (design.md, "Volumetric
/// harmonic map"; Su et al. 2016, §3.1).
///
/// L is the P1 finite-element stiffness of the tet mesh (V #V×3, T #T×4), the
/// "cotangent Laplacian": for an edge ij, L_ij = −w_ij with
///     w_ij = (1/6) Σ_{t ∋ ij} l_kl · cot θ_kl
/// (kl the edge opposite ij in t, l_kl its length, θ_kl the dihedral angle at
/// kl), and L_ii = Σ_j w_ij. So L is symmetric, its rows sum to zero,
/// xᵀ L x = ∫ |∇x|², and L·x vanishes at interior vertices for every linear
/// x. It is computed per tet as vol(t) ∇φ_i·∇φ_j (the same numbers, without
/// trigonometry). Weights can be negative; L_II (interior rows and columns)
/// is still symmetric positive definite, so one Cholesky factorisation
/// (CHOLMOD) serves the three coordinates of
///     L_II U_I = −L_IB U_B.
/// No weights make a 3-D harmonic map bijective: count inverted tets
/// (topology.h, countNonPositiveTets) and untangle (untangle.h).

#include <Eigen/Core>
#include <Eigen/SparseCore>
#include <string>

#include "tet2spline/param/error.h"
#include "tet2spline/param/progress.h"

namespace tet2spline {

/// The stiffness L above, #V × #V. Throws Error(Input) naming the first tet
/// with non-positive volume (the weights of a flat tet are infinite).
/// Assembled in parallel (TBB) and deterministically: the same input gives
/// the same bits.
Eigen::SparseMatrix<double> cotangentStiffness(const Eigen::MatrixX3d& V, const Eigen::MatrixX4i& T);

struct HarmonicMapOptions {
  ProgressCallback progress = {};  ///< called after assembly, factorisation and solve; false stops
};

struct HarmonicMapResult {
  Eigen::MatrixX3d U;              ///< #V × 3; fixed vertices keep their given positions exactly
  double relativeResidual = 0;     ///< ‖(L U)_I‖ / ‖L_IB U_B‖ over the free rows
  std::string solver;              ///< "cholmod", or the fallback that ran and why
  double assemblySeconds = 0;
  double factorizationSeconds = 0;
  double solveSeconds = 0;
  Status status;                   ///< failure when the factorisation failed or progress stopped it
};

/// Harmonic map of (V, T) with `fixedVertices` (#B, each once) placed at
/// `fixedPositions` (#B × 3). Every vertex must be connected through tets to
/// a fixed one (otherwise L_II is singular and the status says so). Throws
/// Error(Input) for bad shapes or indices, naming the function.
HarmonicMapResult harmonicMap(const Eigen::MatrixX3d& V, const Eigen::MatrixX4i& T,
                              const Eigen::VectorXi& fixedVertices, const Eigen::MatrixX3d& fixedPositions,
                              const HarmonicMapOptions& options = {});

}  // namespace tet2spline

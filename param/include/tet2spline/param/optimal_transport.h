#pragma once
/// Semi-discrete optimal transport from the Lebesgue measure of Ω (unit cube
/// or unit ball) to N weighted points (design.md, "Semi-discrete optimal
/// transport"; Su et al., CAD 2016, §4).
///
/// Notation of the paper and of Kitagawa, Mérigot, Thibert, "Convergence of a
/// Newton algorithm for semi-discrete optimal transport", JEMS 2019: points
/// y_i, masses ν_i (scaled so that Σν = |Ω|), weights ψ_i, Laguerre cells
///   Lag_i(ψ) = { x ∈ Ω : |x − y_i|² − ψ_i ≤ |x − y_j|² − ψ_j ∀j }.
/// The Kantorovich dual is concave in ψ with gradient g_i = ν_i − |Lag_i| and
/// Hessian H_ij = |Lag_i ∩ Lag_j| / (2|y_i − y_j|) (j ≠ i), H_ii = −Σ_j H_ij.
/// `solveOptimalTransport` finds ψ with |Lag_i(ψ)| = ν_i by the damped Newton
/// method of KMT: direction H d = −g (the constant null space removed by
/// solving for a mean-free g, or by fixing d_0 = 0 for the Cholesky solvers),
/// step 2^-k for the least k such that every cell keeps at least
/// ε0 = ½ min(min ν, min |Lag(ψ0)|) volume and ‖g‖ drops by (1 − 2^-(k+1)).
/// The search tries 2^-k from twice the last accepted step down (not from 1
/// every time): one diagram per damped iteration instead of k + 1, and the
/// accepted steps stay above half of KMT's uniform lower bound. After three
/// failed halvings the search brackets the step by doubling gaps in the
/// exponent and bisects (a step 2^-13 costs 9 diagrams instead of 14).
/// It converges globally whenever every cell of the start ψ0 is non-empty.
/// Once the error is below 1e-3 and even the exact (CHOLMOD) direction finds
/// no step, the test uses ‖g/ν‖ instead of ‖g‖: with masses over many orders
/// of magnitude ‖g‖ reaches the big cells' rounding noise before the small
/// cells meet the relative tolerance (hand.off meshed with a 15° dihedral
/// bound: ν from 2.9e-13 to 1e-3, stalled at 6e-6; converges to 8e-9).
/// When even that finds no step, ψ_i is carried on in two doubles, a head
/// and a tail (power_diagram.h weightTails): with one, ψ's rounding alone
/// moved the smallest cells of hand.off's default TetGen mesh (cube) by
/// about 10⁻⁶ of their volume, and the solve stalled at 1.37e-6 and failed.
/// `weights` returns head + tail, rounded.
///
/// Start ψ0 (default `ScaledVoronoi`): ψ_i = (1 − λ)|y_i − c|², c the centre of
/// Ω, with the largest λ > 0 such that every z_i = c + λ(y_i − c) lies in the
/// cube, resp. in the closed unit ball (⊂ Ω).
/// Then |x − y_i|² − ψ_i = |x − z_i|²/λ + (1 − 1/λ)|x − c|², the last term
/// the same for every i, so Lag_i(ψ0) is the Voronoi cell of z_i in Ω. The
/// z_i are distinct points of Ω, so every cell contains its z_i and is
/// non-empty (the hypothesis of KMT), even for points y_i outside Ω, and when
/// the points cluster the cells start closer to equal volumes than the
/// Voronoi cells of the y_i (ψ0 = 0 is `Zero`).
///
/// Linear solver, chosen by measurement (tet2spline_ot_bench, N = 50k points
/// in a ball of radius 0.45 in the cube, 9 Newton iterations, 2 cores that
/// other jobs shared at load ~6, total linear-solve seconds):
///   Jacobi-preconditioned CG (TBB mat-vec), rel. residual 1e-3   5.4 s
///   Eigen IncompleteCholesky + CG, rel. residual 1e-3            15.1 s
///   CHOLMOD supernodal Cholesky (exact), analysed each iteration 133.6 s
/// The 3D Laguerre adjacency fills in badly under Cholesky and its pattern
/// changes every iteration; IC's triangular solves are sequential. Jacobi-CG
/// on the singular L = −H with mean-free right-hand side (instead of a
/// grounded ψ_0) then halved the CG iterations again (~50–60 at 10k, see
/// the benchmark output). But on real inputs the cells' sizes span orders of
/// magnitude, and so do L's entries: bunny00's cube problem (181k sites,
/// masses 7e-9 .. 2e-5) needed 400–1000 Jacobi-CG iterations per Newton
/// step, 28.5 s of its 60.7 s. CG preconditioned by one W-cycle of an
/// aggregation AMG (aggregation_amg.h, built anew for each system) needs
/// 7–27 there, and the solves take 7.6 s (total 39.8 s, the same Newton
/// steps). On even cells Jacobi stays cheaper (the benchmark's uniform
/// points, linear solve with AMG against Jacobi: 30k 0.27 against 0.16 s,
/// 100k 1.5 against 0.94 s, 181k 2.1 against 1.9 s; its 64–159 iterations a
/// system cost less than the cycle's set-up). Hence the default
/// `JacobiThenAmgCG`: Jacobi, and AMG once a system has taken more than
/// jacobiIterationsAtMost = 200 iterations.

#include <Eigen/Core>
#include <Eigen/SparseCore>
#include <string>
#include <vector>

#include "tet2spline/param/error.h"
#include "tet2spline/param/power_diagram.h"
#include "tet2spline/param/progress.h"

namespace tet2spline {

enum class OtLinearSolver {
  /// Conjugate gradients (parallel matrix-vector products) on the singular
  /// system with mean-free right-hand side, preconditioned by the diagonal
  /// (Jacobi), stopped at a relative residual `cgTolerance`: inexact Newton.
  /// When a system has taken `jacobiIterationsAtMost` iterations, CG
  /// preconditioned by the AMG cycle (AggregationAmgCG) finishes it from
  /// there, and the later systems use that from the start. Default.
  JacobiThenAmgCG,
  /// The same CG preconditioned by the diagonal only.
  ConjugateGradient,
  /// The same CG preconditioned by one W-cycle of an aggregation algebraic
  /// multigrid (built for every system) only.
  AggregationAmgCG,
  /// Eigen's incomplete Cholesky preconditioner (sequential) with CG, on the
  /// system grounded at ψ_0 (for comparison).
  IncompleteCholeskyCG,
  /// Supernodal sparse Cholesky (CHOLMOD), exact Newton direction.
  Cholmod,
};

enum class OtStart {
  ScaledVoronoi,  ///< ψ_i = (1 − λ)|y_i − c|², see the header comment
  Zero,           ///< ψ = 0: Voronoi cells of the y_i (empty when a y_i's cell misses Ω)
};

struct OptimalTransportOptions {
  double maxRelativeMassError = 1e-6;  ///< stop when max_i |g_i|/ν_i is below
  int maxNewtonIterations = 100;
  int maxStepHalvings = 40;            ///< line search gives up below step 2^-maxStepHalvings
  /// When the line search has failed with every fallback that applies
  /// (CHOLMOD; below a relative error of 1e-3 also the relative merit and ψ
  /// in two doubles, see the .cpp) and the largest relative mass error
  /// is at most this many times maxRelativeMassError, the transport ends
  /// there, successful, with OptimalTransportResult::stalledAboveTolerance
  /// set, instead of failing; 1 (or less) = fail. The volumes of sliver-thin
  /// cells of 1e-13 of Ω are computed to about 1e-6 of themselves: hand.off's
  /// default TetGen mesh on the cube, whose masses span nine orders of
  /// magnitude, converged at 8.7e-7 on one ball map and stalled at 1.07e-6 on
  /// another that differed only in the untangler's order of summation.
  double stallAcceptFactor = 2;
  OtStart start = OtStart::ScaledVoronoi;
  /// Newton on the log-volumes first, while the max relative mass error is
  /// above this (0: never): the direction solves H d = V∘(log ν − log V − c)
  /// (c makes it sum to zero) instead of H d = ν − V, and a step passes when
  /// every cell stays above KMT's ε0 and ‖log V − log ν‖ drops by (1 − t/2).
  /// Then KMT's damped Newton from there; also when no step down to
  /// 2^-logNewtonHalvings passes. Measured on bunny00's cube problem (cells
  /// 2e-5 to 157 times their mass at the start): 9 iterations and 11.1 s
  /// against KMT's 16 and 21.9 s (optimal_transport.cpp has the figures).
  double logNewtonAbove = 0.1;
  double logNewtonCgTolerance = 1e-6;  ///< CG's relative residual in the log phase (at most cgTolerance); > 0
  int logNewtonHalvings = 8;           ///< >= 0 (else Error(Usage), as a non-positive logNewtonCgTolerance)
  OtLinearSolver linearSolver = OtLinearSolver::JacobiThenAmgCG;
  /// Relative residual of the inexact Newton direction. Fixed, not adaptive:
  /// a forcing term 0.1·error stalled the damped phase of the benchmark
  /// (the residual pushed cells near ε0 below it).
  double cgTolerance = 1e-3;
  int cgMaxIterations = 20000;
  /// JacobiThenAmgCG: Jacobi-CG iterations a system may take before the AMG
  /// takes over (even cells: 60–160 at 181k sites; bunny00's: 400–1000).
  int jacobiIterationsAtMost = 200;
  /// Points at exactly the same position share one cell (their masses are
  /// added; each gets the cell's ψ and centroid and a volume share in
  /// proportion to its mass). When false, coincident points throw Error(Input).
  bool mergeCoincidentPoints = true;
  ProgressCallback progress = {};      ///< called once per iteration; return false to stop
};

/// What one Newton iteration cost.
struct OtIterationStats {
  double stepSize = 0;                 ///< accepted 2^-k
  int evaluations = 0;                 ///< power diagrams computed in the line search
  int repairedDiagrams = 0;            ///< of those, triangulations repaired by flips
  int rejectedDiagrams = 0;            ///< of those, repairs that failed but proved a cell below ε0 (not built)
  long flips = 0;                      ///< flips, also of repairs given up
  int linearIterations = 0;            ///< CG iterations (0 for Cholesky)
  bool amg = false;                    ///< CG preconditioned by the AMG cycle (all or some of them)
  bool logVolumes = false;             ///< Newton on the log-volumes (logNewtonAbove), not KMT's
  double triangulationSeconds = 0;     ///< regular triangulations of this iteration
  double clippingSeconds = 0;          ///< clipping of this iteration
  double assemblySeconds = 0;          ///< Hessian assembly
  double linearSolveSeconds = 0;       ///< factorisation or CG
  double maxRelativeMassError = 0;     ///< after the step
};

struct OptimalTransportResult {
  Eigen::VectorXd weights;             ///< ψ, #points (defined up to an additive constant)
  Eigen::MatrixX3d centroids;          ///< Laguerre cell centroids, #points × 3
  Eigen::VectorXd cellVolumes;         ///< |Lag_i|, #points
  Eigen::VectorXd masses;              ///< ν scaled to Σν = |Ω|, #points
  int iterations = 0;
  double maxRelativeMassError = 0;     ///< max_i |ν_i − |Lag_i|| / ν_i at the result
  std::vector<double> stepSizes;       ///< per iteration
  std::vector<OtIterationStats> iterationStats;
  double startSeconds = 0;             ///< validation, merging and the diagram of ψ0
  int mergedPoints = 0;                ///< points merged into a coincident one
  /// Ended by stallAcceptFactor: maxRelativeMassError is above the tolerance
  /// asked (by at most that factor) and status is success.
  bool stalledAboveTolerance = false;
  /// CG tolerance tightenings, switches to the AMG, from the log phase to
  /// KMT's Newton when its search fails, to CHOLMOD, to the relative merit
  /// and to ψ in two doubles (see the .cpp)
  int solverSwitches = 0;
  Status status;                       ///< ok, or why it stopped
};

/// Solves the semi-discrete OT from Ω to points (#N × 3) with masses (#N).
/// Pre-conditions (else Error): sizes agree and N ≥ 1, tolerances positive,
/// iteration budget and halvings non-negative (Usage); points finite,
/// masses finite and > 0 (Input); every Laguerre cell of the start non-empty
/// (Input: with the default start only coincident points, if not merged, can
/// violate it). Not converging within the iteration budget, a failed line
/// search or a stop from the progress callback is a failed `status`.
OptimalTransportResult solveOptimalTransport(const Eigen::MatrixX3d& points, const Eigen::VectorXd& masses,
                                             const Domain& domain, const OptimalTransportOptions& options = {});

/// The warning for a transport that ended by stallAcceptFactor
/// (result.stalledAboveTolerance): its error, the tolerance asked and the
/// report key; empty when it did not end so.
std::string stalledTransportWarning(const OptimalTransportResult& result, double tolerance);

/// The Hessian H of the Kantorovich dual at the diagram `diagram` of `points`
/// (#N × N, symmetric, negative semi-definite, rows summing to zero):
/// H_ij = ½(a_ij + a_ji) / (2|y_i − y_j|) with a_ij the facet area seen from
/// cell i, H_ii = −Σ_j H_ij. Exposed for tests and diagnostics.
Eigen::SparseMatrix<double> kantorovichHessian(const Eigen::MatrixX3d& points, const PowerDiagram& diagram);

}  // namespace tet2spline

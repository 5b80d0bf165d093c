// Damped Newton for semi-discrete optimal transport (Kitagawa, Mérigot,
// Thibert, JEMS 2019), on top of power_diagram.cpp.
#include "tet2spline/param/optimal_transport.h"
#include "tet2spline/param/openmp_threads.h"

#include "aggregation_amg.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_reduce.h>

#include <Eigen/CholmodSupport>
#include <Eigen/IterativeLinearSolvers>
#include <Eigen/SparseCore>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <numeric>
#include <sstream>

namespace tet2spline {
namespace {

// Largest relative mass error at which a line search that fails with the
// exact direction switches its merit to the relative one (see below).
constexpr double kRelativeMeritBelow = 1e-3;

using Clock = std::chrono::steady_clock;
double secondsSince(Clock::time_point t0) {
  return std::chrono::duration<double>(Clock::now() - t0).count();
}

using SpMat = Eigen::SparseMatrix<double>;  // column-major; our matrices are symmetric

// Symmetrised facet weight w_ij = ½(a_ij + a_ji) / (2|y_i − y_j|) for the
// neighbour slot k of row i.
double facetWeight(const Eigen::MatrixX3d& y, const PowerDiagram& pd, int i, int k) {
  const int j = pd.neighbour[k];
  double a = pd.facetArea[k];
  const auto b = pd.neighbour.begin() + pd.neighbourStart[j], e = pd.neighbour.begin() + pd.neighbourStart[j + 1];
  const auto it = std::lower_bound(b, e, i);
  if (it != e && *it == i) a = 0.5 * (a + pd.facetArea[it - pd.neighbour.begin()]);
  if (a == 0) return 0;
  return a / (2.0 * (y.row(i) - y.row(j)).norm());
}

// L = −H on the pattern of the regular triangulation plus the diagonal, with
// the row and column of `ground` replaced by the identity (fixes d_ground = 0,
// which removes the constant null space). Symmetric positive definite when the
// cells' adjacency graph is connected, which it is when every cell is non-empty.
SpMat groundedLaplacian(const Eigen::MatrixX3d& y, const PowerDiagram& pd, int ground) {
  const int n = static_cast<int>(y.rows());
  const int nnz = static_cast<int>(pd.neighbour.size()) + n;
  SpMat L(n, n);
  L.resizeNonZeros(nnz);
  int* outer = L.outerIndexPtr();
  int* inner = L.innerIndexPtr();
  double* value = L.valuePtr();
  for (int i = 0; i <= n; ++i) outer[i] = pd.neighbourStart[i] + i;
  tbb::parallel_for(tbb::blocked_range<int>(0, n, 1024), [&](const tbb::blocked_range<int>& r) {
    for (int i = r.begin(); i != r.end(); ++i) {
      int out = outer[i];
      int diagonalSlot = -1;
      double diagonal = 0;
      for (int k = pd.neighbourStart[i]; k < pd.neighbourStart[i + 1]; ++k) {
        const int j = pd.neighbour[k];
        if (diagonalSlot < 0 && j > i) diagonalSlot = out++;
        const double w = facetWeight(y, pd, i, k);
        diagonal += w;
        inner[out] = j;
        value[out] = (i == ground || j == ground) ? 0.0 : -w;
        ++out;
      }
      if (diagonalSlot < 0) diagonalSlot = out++;
      inner[diagonalSlot] = i;
      value[diagonalSlot] = i == ground ? 1.0 : diagonal;
    }
  });
  return L;
}

// The diagonal's inverse (1 where it is not positive).
Eigen::VectorXd inverseDiagonal(const SpMat& L) {
  const int n = static_cast<int>(L.rows());
  const int* outer = L.outerIndexPtr();
  const int* inner = L.innerIndexPtr();
  const double* value = L.valuePtr();
  Eigen::VectorXd invDiag(n);
  tbb::parallel_for(0, n, [&](int i) {
    double d = 0;
    for (int k = outer[i]; k < outer[i + 1]; ++k)
      if (inner[k] == i) d = value[k];
    invDiag[i] = d > 0 ? 1.0 / d : 1.0;
  });
  return invDiag;
}

// Preconditioned conjugate gradients with TBB matrix-vector products (L is
// symmetric, so its column-major storage is also its row-major one), from
// the start x (#n) to ‖b − Lx‖ ≤ tolerance·‖b‖; precondition(r, z) sets
// z = M r for a symmetric positive (semi-)definite M.
template <class Precondition>
int preconditionedCg(const SpMat& L, const Eigen::VectorXd& b, Eigen::VectorXd& x, double tolerance,
                     int maxIterations, Precondition&& precondition, bool* converged = nullptr) {
  if (converged) *converged = true;
  const int n = static_cast<int>(b.size());
  const int* outer = L.outerIndexPtr();
  const int* inner = L.innerIndexPtr();
  const double* value = L.valuePtr();
  auto multiply = [&](const Eigen::VectorXd& v, Eigen::VectorXd& out) {
    tbb::parallel_for(tbb::blocked_range<int>(0, n, 4096), [&](const tbb::blocked_range<int>& r) {
      for (int i = r.begin(); i != r.end(); ++i) {
        double s = 0;
        for (int k = outer[i]; k < outer[i + 1]; ++k) s += value[k] * v[inner[k]];
        out[i] = s;
      }
    });
  };
  auto dot = [&](const Eigen::VectorXd& a, const Eigen::VectorXd& c) {
    // Deterministic: the same input gives bit-identical results on any run.
    return tbb::parallel_deterministic_reduce(
        tbb::blocked_range<int>(0, n, 8192), 0.0,
        [&](const tbb::blocked_range<int>& r, double s) {
          for (int i = r.begin(); i != r.end(); ++i) s += a[i] * c[i];
          return s;
        },
        std::plus<double>());
  };
  Eigen::VectorXd r(n), z(n), p(n), q(n);
  const double bNorm = std::sqrt(dot(b, b));
  if (bNorm == 0) {
    x.setZero(n);
    return 0;
  }
  multiply(x, q);
  r = b - q;
  if (std::sqrt(dot(r, r)) <= tolerance * bNorm) return 0;
  precondition(r, z);
  p = z;
  double rz = dot(r, z);
  int it = 0;
  if (converged) *converged = false;
  for (; it < maxIterations && rz > 0; ++it) {  // (rz, pq ≤ 0 or NaN: breakdown, not converged)
    multiply(p, q);
    const double pq = dot(p, q);
    if (!(pq > 0)) break;
    const double alpha = rz / pq;
    tbb::parallel_for(tbb::blocked_range<int>(0, n, 8192), [&](const tbb::blocked_range<int>& rg) {
      for (int i = rg.begin(); i != rg.end(); ++i) {
        x[i] += alpha * p[i];
        r[i] -= alpha * q[i];
      }
    });
    if (std::sqrt(dot(r, r)) <= tolerance * bNorm) {
      ++it;
      if (converged) *converged = true;
      break;
    }
    precondition(r, z);
    const double rzNew = dot(r, z);
    const double beta = rzNew / rz;
    rz = rzNew;
    tbb::parallel_for(tbb::blocked_range<int>(0, n, 8192), [&](const tbb::blocked_range<int>& rg) {
      for (int i = rg.begin(); i != rg.end(); ++i) p[i] = z[i] + beta * p[i];
    });
  }
  return it;
}

// a + b as head + tail with head = fl(a + b) (Knuth's two-sum).
void twoSum(double a, double b, double& head, double& tail) {
  head = a + b;
  const double bVirtual = head - a;
  tail = (a - (head - bVirtual)) + (b - bVirtual);
}

bool isIterative(OtLinearSolver s) {
  return s == OtLinearSolver::JacobiThenAmgCG || s == OtLinearSolver::ConjugateGradient ||
         s == OtLinearSolver::AggregationAmgCG;
}

std::string describePoint(const Eigen::MatrixX3d& points, int i) {
  std::ostringstream s;
  s << "point " << i << " (" << points(i, 0) << ", " << points(i, 1) << ", " << points(i, 2) << ")";
  return s.str();
}

}  // namespace

Eigen::SparseMatrix<double> kantorovichHessian(const Eigen::MatrixX3d& points, const PowerDiagram& diagram) {
  SpMat L = groundedLaplacian(points, diagram, -1);
  return -L;
}

OptimalTransportResult solveOptimalTransport(const Eigen::MatrixX3d& points, const Eigen::VectorXd& masses,
                                             const Domain& domain, const OptimalTransportOptions& options) {
  const auto tStart = Clock::now();
  const int nIn = static_cast<int>(points.rows());
  if (nIn == 0 || masses.size() != points.rows()) {
    std::ostringstream msg;
    msg << "solveOptimalTransport: " << points.rows() << " points and " << masses.size()
        << " masses (need the same number, at least one)";
    throw Error(ErrorKind::Usage, msg.str());
  }
  if (!(options.maxRelativeMassError > 0) || options.maxNewtonIterations < 0 || !(options.cgTolerance > 0))
    throw Error(ErrorKind::Usage, "solveOptimalTransport: tolerances must be positive and the iteration budget non-negative");
  if (options.logNewtonAbove > 0 && (!(options.logNewtonCgTolerance > 0) || options.logNewtonHalvings < 0))
    throw Error(ErrorKind::Usage, "solveOptimalTransport: the log phase needs a positive CG tolerance and "
                                  "non-negative step halvings (logNewtonCgTolerance, logNewtonHalvings)");
  for (int i = 0; i < nIn; ++i) {
    if (!points.row(i).allFinite())
      throw Error(ErrorKind::Input, "solveOptimalTransport: " + describePoint(points, i) + " is not finite");
    if (!std::isfinite(masses[i]) || !(masses[i] > 0)) {
      std::ostringstream msg;
      msg << "solveOptimalTransport: mass " << masses[i] << " of point " << i << " is not a positive finite number";
      throw Error(ErrorKind::Input, msg.str());
    }
  }

  // Merge coincident points (exact equality).
  std::vector<int> order(nIn);
  std::iota(order.begin(), order.end(), 0);
  auto less = [&](int a, int b) {
    for (int c = 0; c < 3; ++c)
      if (points(a, c) != points(b, c)) return points(a, c) < points(b, c);
    return a < b;
  };
  std::sort(order.begin(), order.end(), less);
  std::vector<int> toMerged(nIn);
  std::vector<int> representative;
  for (int q = 0; q < nIn; ++q) {
    const int i = order[q];
    if (q > 0 && points.row(i) == points.row(order[q - 1])) {
      if (!options.mergeCoincidentPoints)
        throw Error(ErrorKind::Input, "solveOptimalTransport: " + describePoint(points, i) + " coincides with point " +
                                          std::to_string(order[q - 1]));
      toMerged[i] = toMerged[order[q - 1]];
    } else {
      toMerged[i] = static_cast<int>(representative.size());
      representative.push_back(i);
    }
  }
  const int n = static_cast<int>(representative.size());
  // The merged sites in the order the power diagrams work in (spatialOrder):
  // each of the solve's diagrams then skips its own sort and copy back.
  std::vector<int> rank(n);
  {
    Eigen::MatrixX3d sites(n, 3);
    for (int m = 0; m < n; ++m) sites.row(m) = points.row(representative[m]);
    const std::vector<int> order = spatialOrder(sites);
    for (int q = 0; q < n; ++q) rank[order[q]] = q;
  }
  Eigen::MatrixX3d y(n, 3);
  Eigen::VectorXd nu = Eigen::VectorXd::Zero(n);
  for (int i = 0; i < nIn; ++i) {
    toMerged[i] = rank[toMerged[i]];
    nu[toMerged[i]] += masses[i];
  }
  for (int m = 0; m < static_cast<int>(representative.size()); ++m) y.row(rank[m]) = points.row(representative[m]);
  const double massScale = domain.volume() / masses.sum();
  nu *= massScale;

  OptimalTransportResult result;
  result.mergedPoints = nIn - n;
  result.masses = masses * massScale;

  // Start.
  Eigen::VectorXd psi = Eigen::VectorXd::Zero(n);
  if (options.start == OtStart::ScaledVoronoi) {
    const Eigen::Vector3d c = domain.center();
    double reach = 0;  // max over points of the gauge of y − c
    for (int i = 0; i < n; ++i) {
      const Eigen::Vector3d d = y.row(i).transpose() - c;
      reach = std::max(reach, domain.kind() == Domain::Kind::Cube ? 2.0 * d.cwiseAbs().maxCoeff() : d.norm());
    }
    const double lambda = reach > 0 ? 1.0 / reach : 1.0;
    for (int i = 0; i < n; ++i) psi[i] = (1 - lambda) * (y.row(i).transpose() - c).squaredNorm();
  }
  // ψ = psi + psiTail: the tails (computePowerDiagram's weightTails) stay
  // zero until the search fails with the relative merit too (see below).
  Eigen::VectorXd psiTail = Eigen::VectorXd::Zero(n);
  bool withTails = false;
  PowerDiagram pd = computePowerDiagram(y, psi, domain, CellMeasure::DualWhereInside, true);
  for (int i = 0; i < n; ++i)
    if (!(pd.volumes[i] > 0)) {
      int original = representative[std::find(rank.begin(), rank.end(), i) - rank.begin()];
      throw Error(ErrorKind::Input, "solveOptimalTransport: " + describePoint(points, original) +
                                        " has an empty Laguerre cell at the start (it lies outside the domain "
                                        "and its cell misses it, or it nearly coincides with another point)");
    }
  const double eps0 = 0.5 * std::min(nu.minCoeff(), pd.volumes.minCoeff());
  Eigen::VectorXd g = nu - pd.volumes;
  auto relativeError = [&](const Eigen::VectorXd& grad) { return grad.cwiseAbs().cwiseQuotient(nu).maxCoeff(); };
  double error = relativeError(g);
  const double error0 = error;
  result.startSeconds = secondsSince(tStart);

  Eigen::CholmodSupernodalLLT<SpMat, Eigen::Lower> cholmod;
  cholmod.cholmod().print = 0;  // library code prints nothing; a failed factorisation is handled below
  Eigen::VectorXd d(n), rhs(n), psiTrial(n), psiTrialTail = Eigen::VectorXd::Zero(n);
  // The grounded row (Cholesky solvers): the largest mass, a well-connected
  // cell. Grounding a crushed boundary cell (tiny facets) leaves the rest of
  // the Laplacian nearly singular: with the sites in spatial order, site 0
  // of hand.off's ball problem (masses over eight orders) was such a cell
  // and the line search failed at iteration 30.
  Eigen::Index groundIndex = 0;
  nu.maxCoeff(&groundIndex);
  const int ground = static_cast<int>(groundIndex);
  result.status = Status::success();
  int iteration = 0;
  double lastStep = 1;
  // The search starts at growth × the last step: 2, or 4 after a step that
  // passed at its first try. In bunny00's damped phase (cube) every first
  // try passed while the step doubled from 2^-13 to 2^-3, one iteration
  // (~3.7 s) per doubling.
  double growth = 2;
  // The inexact CG direction can stall the damped phase when the masses span
  // many orders of magnitude (measured: spool.off meshed by TetGen, masses
  // from 6e-9 to 0.038 in the ball: CG at 1e-3 took steps of 2^-30 and
  // failed, CHOLMOD converged in 14 iterations). So: a step below 1/16
  // tightens the CG tolerance a hundredfold (down to 1e-9), and a failed
  // line search switches to the exact CHOLMOD direction and retries.
  OtLinearSolver solver = options.linearSolver;
  double cgTolerance = options.cgTolerance;
  const double logCgTolerance = std::min(options.cgTolerance, options.logNewtonCgTolerance);
  // The line search's merit is ‖g‖ (KMT), or ‖g/ν‖ once ‖g‖ has reached
  // rounding: with masses over many orders of magnitude ‖g‖ is the big
  // cells' rounding noise long before the smallest cells meet the relative
  // tolerance (hand.off meshed with a 15° dihedral bound: ‖g‖ 3.8e-17, the
  // worst cell ν = 2.9e-13 off by 6e-6 of itself, no step accepted even
  // with CHOLMOD). Close to the solution g(ψ + t d) ≈ (1 − t) g(ψ) in every
  // norm, so the weighted test accepts the same Newton steps there.
  bool relativeMerit = false;
  auto merit = [&](const Eigen::VectorXd& grad) { return relativeMerit ? grad.cwiseQuotient(nu).norm() : grad.norm(); };
  Eigen::VectorXd lastDirection;  // the last accepted step's direction (CG's start), empty when none
  bool amgFromNowOn = false;      // JacobiThenAmgCG: a system took more than jacobiIterationsAtMost
  // The log phase (OptimalTransportOptions::logNewtonAbove): Newton on
  // F(ψ) = log V(ψ) − log ν. Its Jacobian is diag(1/V)·H, so its direction
  // solves H d = V∘(log ν − log V − c), with c = Σ V(log ν − log V) / Σ V
  // making the right-hand side sum to zero (H is singular along constant ψ;
  // without c, CG's removal of the mean shifted every tiny cell's entry by
  // the big cells' imbalance and no step down to 2^-8 kept the cells above
  // ε0). A cell's volume grows like the cube of its facets' shift, so
  // linearising V overshoots the crushed cells by orders of magnitude, and
  // KMT's line search cuts every cell's step to what the worst tolerates;
  // log V is far closer to linear in ψ. Measured on bunny00's cube problem
  // (181313 sites from its TetGen mesh, cells from 2e-5 to 157 times their
  // mass at the start): KMT alone 16 iterations, 26 diagrams, 21.9 s (steps
  // from 2^-12, ten damped iterations); the log phase 9 iterations, 11
  // diagrams, 11.1 s (steps 1/4, 1/2, then full; 26 -> 1.5 -> 1.0 -> 0.9 ->
  // 0.5 -> 0.09, then KMT's full steps). Its systems need CG to 1e-6
  // (logNewtonCgTolerance): at 1e-3 no step passed and at 1e-4 the steps
  // stayed damped (17 iterations). Linearising only the growing cells' log
  // (V ≥ ν linear) gave the same on bunny00 but no gain on the test's
  // clustered start (OptimalTransport tests), where the large cells shrink
  // by 85 times.
  bool logPhase = options.logNewtonAbove > 0 && error > options.logNewtonAbove;
  auto logMerit = [&](const Eigen::VectorXd& volumes) {  // ‖log V − log ν‖
    double sum = 0;
    for (int i = 0; i < n; ++i) {
      const double f = std::log(volumes[i] / nu[i]);
      sum += f * f;
    }
    return std::sqrt(sum);
  };
  while (error >= options.maxRelativeMassError) {
    if (iteration >= options.maxNewtonIterations) {
      std::ostringstream msg;
      msg << "solveOptimalTransport: no convergence in " << iteration << " Newton iterations (max relative mass error "
          << error << ", asked " << options.maxRelativeMassError << ")";
      result.status = Status::failure(msg.str());
      break;
    }
    OtIterationStats stats;
    auto t0 = Clock::now();
    // CG works on the singular L = −H itself with the mean of g removed:
    // every residual b − Lx then sums to zero, so the cgTolerance bound holds
    // for the whole gradient. (Grounding one ψ instead would leave that row's
    // residual, minus the sum of all the others, unbounded for an inexact
    // solve.) The Cholesky-based solvers need the grounded, definite matrix.
    const bool iterative = isIterative(solver);
    const SpMat L = groundedLaplacian(y, pd, iterative ? -1 : ground);
    stats.assemblySeconds = secondsSince(t0);
    t0 = Clock::now();
    const bool logStep = logPhase;
    stats.logVolumes = logStep;
    // CG's relative residual (the incomplete Cholesky's starts from options.cgTolerance instead)
    const double iterativeTolerance = logStep ? logCgTolerance : cgTolerance;
    if (logStep) {  // V∘(log ν − log V − c), summing to zero (above)
      for (int i = 0; i < n; ++i) rhs[i] = pd.volumes[i] * std::log(nu[i] / pd.volumes[i]);
      rhs -= (rhs.sum() / pd.volumes.sum()) * pd.volumes;
    } else {
      rhs = g;
    }
    if (iterative) rhs.array() -= rhs.mean();
    else rhs[ground] = 0;
    bool solved = true;
    switch (solver) {
      case OtLinearSolver::JacobiThenAmgCG:
      case OtLinearSolver::ConjugateGradient:
      case OtLinearSolver::AggregationAmgCG: {
        // Inexact Newton with a fixed relative residual: a looser, adaptive
        // forcing term (0.1·error) was tried and stalled the damped phase on
        // the benchmark (cells near ε0 pushed below it by the residual).
        // CG starts from (1 − t) times the last direction, t the step taken
        // along it: after that step the gradient is about (1 − t) times the
        // last one and the Hessian nearly the same, so in a damped phase
        // (t ≪ 1) the start is most of the answer. After a full step, or a
        // switch of solver, it starts from 0.
        if (lastDirection.size() == n) d = (1 - lastStep) * lastDirection;
        else d.setZero(n);
        const bool adaptive = solver == OtLinearSolver::JacobiThenAmgCG;
        bool amg = solver == OtLinearSolver::AggregationAmgCG || (adaptive && amgFromNowOn);
        if (!amg) {
          const Eigen::VectorXd invDiag = inverseDiagonal(L);
          bool converged = false;
          stats.linearIterations = preconditionedCg(
              L, rhs, d, iterativeTolerance,
              adaptive ? std::min(options.jacobiIterationsAtMost, options.cgMaxIterations) : options.cgMaxIterations,
              [&](const Eigen::VectorXd& r, Eigen::VectorXd& z) {
                tbb::parallel_for(tbb::blocked_range<int>(0, n, 8192), [&](const tbb::blocked_range<int>& rg) {
                  for (int i = rg.begin(); i != rg.end(); ++i) z[i] = invDiag[i] * r[i];
                });
              },
              &converged);
          if (adaptive && !converged) amg = amgFromNowOn = true, ++result.solverSwitches;
        }
        if (amg) {  // (from Jacobi's iterate, if it ran)
          const detail::AggregationAmg cycle(L);
          stats.linearIterations +=
              preconditionedCg(L, rhs, d, iterativeTolerance,
                               std::max(1, options.cgMaxIterations - stats.linearIterations),
                               [&](const Eigen::VectorXd& r, Eigen::VectorXd& z) { cycle.apply(r, z); });
          stats.amg = true;
        }
        break;
      }
      case OtLinearSolver::IncompleteCholeskyCG: {
        Eigen::ConjugateGradient<SpMat, Eigen::Lower | Eigen::Upper, Eigen::IncompleteCholesky<double>> cg;
        cg.setTolerance(logStep ? logCgTolerance : options.cgTolerance);
        cg.setMaxIterations(options.cgMaxIterations);
        cg.compute(L);
        d = cg.solve(rhs);
        stats.linearIterations = static_cast<int>(cg.iterations());
        solved = cg.info() == Eigen::Success || cg.info() == Eigen::NoConvergence;
        break;
      }
      case OtLinearSolver::Cholmod:
        runOpenMpRegionsOnCallingThread();  // (CHOLMOD's teams of four: openmp_threads.h)
        cholmod.compute(L);
        solved = cholmod.info() == Eigen::Success;
        if (solved) d = cholmod.solve(rhs);
        break;
    }
    stats.linearSolveSeconds = secondsSince(t0);
    if (!solved || !d.allFinite()) {
      result.status = Status::failure("solveOptimalTransport: the Newton system could not be solved at iteration " +
                                      std::to_string(iteration));
      break;
    }
    // Line search: largest 2^-k keeping every cell ≥ ε0 with ‖g‖ dropping by (1 − 2^-(k+1)).
    // The search starts at twice the last accepted step rather than at 1: a
    // damped phase then costs one diagram per iteration instead of k + 1.
    // Steps are still powers of two with the same acceptance test, so
    // KMT's bound on the accepted step (hence global convergence) holds.
    // In the log phase the same search with ‖log V − log ν‖ as the merit,
    // and at most logNewtonHalvings: when no step passes, KMT's Newton
    // takes over from the current point (its global convergence holds from
    // any point whose cells are all above ε0).
    auto stepMerit = [&](const Eigen::VectorXd& volumes, const Eigen::VectorXd& grad) {
      return logStep ? logMerit(volumes) : merit(grad);
    };
    const double gNorm = stepMerit(pd.volumes, g);
    // The steps 2^-e are searched by exponent: e0 (twice the last step),
    // e0 + 1 and e0 + 2 in turn as before (the usual cases: the benchmark's
    // worst iteration needs e0 + 2); then gaps doubling (e0 + 4, + 8, + 16,
    // ...) until one passes, and a bisection between the last failing
    // and the passing exponent. That finds the same kind of step as trying
    // e0, e0 + 1, e0 + 2, ... in turn (one that passes, twice it failing) in
    // O(log k) diagrams instead of k + 1: bunny00's cube problem starts with
    // 2^-13 (9 diagrams instead of 14, ~2.5 s each). KMT's bound holds:
    // every step below their τ* passes, so a failing step is above τ* and
    // the accepted one above τ*/2.
    const int e0 = static_cast<int>(std::lround(-std::log2(std::min(1.0, growth * lastStep))));
    const Eigen::VectorXd psiStart = psi, psiStartTail = psiTail;
    auto passes = [&](int e) {  // the step 2^-e from psiStart; becomes the current point if it passes
      const double t = std::ldexp(1.0, -e);
      if (withTails) {
        for (int i = 0; i < n; ++i) {  // (psiStart + psiStartTail) + t d, renormalised
          double head, tail;
          twoSum(psiStart[i], t * d[i], head, tail);
          twoSum(head, tail + psiStartTail[i], psiTrial[i], psiTrialTail[i]);
        }
      } else {
        psiTrial = psiStart + t * d;  // (both tails stay zero)
      }
      // The current diagram seeds the trial's: its regular triangulation
      // is repaired by flips rather than built again.
      PowerDiagram trial = computePowerDiagram(y, psiTrial, domain, CellMeasure::DualWhereInside, true,
                                               withTails ? &psiTrialTail : nullptr, &pd, eps0);
      ++stats.evaluations;
      stats.repairedDiagrams += trial.repaired;
      stats.rejectedDiagrams += trial.rejected;
      stats.flips += trial.flips;
      stats.triangulationSeconds += trial.triangulationSeconds;
      stats.clippingSeconds += trial.clippingSeconds;
      if (trial.rejected || trial.volumes.minCoeff() < eps0) return false;
      Eigen::VectorXd gTrial = nu - trial.volumes;
      if (stepMerit(trial.volumes, gTrial) > (1 - 0.5 * t) * gNorm) return false;
      psi.swap(psiTrial);
      psiTail.swap(psiTrialTail);
      pd = std::move(trial);
      g = std::move(gTrial);
      return true;
    };
    int passing = -1, failing = e0 - 1;
    const int halvings =
        logStep ? std::min(options.logNewtonHalvings, options.maxStepHalvings) : options.maxStepHalvings;
    for (int gap = 1; passing < 0 && failing < halvings;) {
      const int e = std::min(failing + gap, halvings);
      if (passes(e)) passing = e;
      else failing = e;
      if (e >= e0 + 2) gap *= 2;  // one halving at a time for the first three tries
    }
    while (passing >= 0 && passing - failing > 1) {
      const int mid = (failing + passing) / 2;
      if (passes(mid)) passing = mid;
      else failing = mid;
    }
    // The current point is the last step that passed, 2^-passing: every
    // later pass had a smaller exponent.
    const bool accepted = passing >= 0;
    double step = accepted ? std::ldexp(1.0, -passing) : 0;
    ++iteration;
    // A failed search switches to a stronger method and tries again from
    // the same point, with the step search restarted.
    auto switched = [&] {
      lastDirection.resize(0);
      result.iterationStats.push_back(stats);
      result.stepSizes.push_back(0);
      ++result.solverSwitches;
      lastStep = 1;
      growth = 2;
    };
    if (!accepted && logStep) {  // KMT's damped Newton from here
      logPhase = false;
      switched();
      continue;
    }
    if (!accepted && solver != OtLinearSolver::Cholmod) {
      solver = OtLinearSolver::Cholmod;
      switched();
      continue;
    }
    if (!accepted && !relativeMerit && error < kRelativeMeritBelow) {
      relativeMerit = true;
      switched();
      continue;
    }
    // Last: ψ in two doubles. With one, ψ's rounding alone moves the
    // smallest cells by about the tolerance: hand.off's default TetGen mesh
    // on the cube (cells from 1e-13 of Ω) stalled at 1.37e-6 with the
    // relative merit and failed at iteration 42. Only from here, so that the
    // runs that converge without it stay as they were (the untangling after
    // the composition reacts chaotically to changes of 1e-16).
    if (!accepted && !withTails && error < kRelativeMeritBelow) {
      withTails = true;
      switched();
      continue;
    }
    if (!accepted && error <= options.stallAcceptFactor * options.maxRelativeMassError) {
      result.iterationStats.push_back(stats);
      result.stepSizes.push_back(0);
      result.stalledAboveTolerance = true;  // (status stays success)
      break;
    }
    if (!accepted) {
      result.iterationStats.push_back(stats);
      result.stepSizes.push_back(0);
      std::ostringstream msg;
      msg << "solveOptimalTransport: line search failed at Newton iteration " << iteration << " (no step down to 2^-"
          << options.maxStepHalvings << " keeps every cell above " << eps0 << " and reduces the mass error)";
      result.status = Status::failure(msg.str());
      break;
    }
    error = relativeError(g);
    lastStep = step;
    if (isIterative(solver) && step < 1) lastDirection = d;
    else lastDirection.resize(0);
    if (logPhase && !(error > options.logNewtonAbove)) {  // (the next direction solves another system)
      logPhase = false;
      lastDirection.resize(0);
    }
    growth = passing == e0 ? 4 : 2;
    if (isIterative(solver) && step < 1.0 / 16 && cgTolerance > 1e-9) {
      cgTolerance = std::max(1e-9, 0.01 * cgTolerance);
      ++result.solverSwitches;
    }
    stats.stepSize = step;
    stats.maxRelativeMassError = error;
    result.iterationStats.push_back(stats);
    result.stepSizes.push_back(step);
    if (options.progress) {
      double fraction = -1;
      if (error0 > options.maxRelativeMassError && error > 0)
        fraction = std::clamp(std::log(error0 / error) / std::log(error0 / options.maxRelativeMassError), 0.0, 1.0);
      std::ostringstream msg;
      msg << "newton " << iteration << ": max rel. mass error " << error << ", step " << step;
      if (!options.progress(fraction, msg.str())) {
        result.status = Status::failure("solveOptimalTransport: stopped by the progress callback at iteration " +
                                        std::to_string(iteration));
        break;
      }
    }
  }

  result.iterations = iteration;
  result.maxRelativeMassError = error;
  result.weights.resize(nIn);
  result.centroids.resize(nIn, 3);
  result.cellVolumes.resize(nIn);
  for (int i = 0; i < nIn; ++i) {
    const int m = toMerged[i];
    result.weights[i] = psi[m] + psiTail[m];
    result.centroids.row(i) = pd.centroids.row(m);
    result.cellVolumes[i] = pd.volumes[m] * (result.masses[i] / nu[m]);
  }
  return result;
}

std::string stalledTransportWarning(const OptimalTransportResult& result, double tolerance) {
  if (!result.stalledAboveTolerance) return {};
  auto format = [](double v) {
    char buf[32];
    std::snprintf(buf, sizeof buf, "%.3g", v);
    return std::string(buf);
  };
  return "the transport stopped at a largest relative cell-mass error of " + format(result.maxRelativeMassError) +
         ", above the tolerance " + format(tolerance) +
         ": no Newton step reduced it further (ot.stalled_above_tolerance; the smallest cells' volumes are not "
         "computed more precisely than that)";
}

}  // namespace tet2spline

// A bijective map moved towards a folded target behind a true barrier
// (barrier_morph.h).
#include "tet2spline/param/barrier_morph.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_reduce.h>
#include <tbb/partitioner.h>

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <limits>
#include <memory>
#include <string>

#include "block_hessian.h"
#include "lbfgs.h"
#include "sliding.h"
#include "spd_solver.h"
#include "tet2spline/param/topology.h"
#include "untangle_energy.h"

namespace tet2spline {

namespace {

[[noreturn]] void fail(ErrorKind kind, const std::string& what) { throw Error(kind, "morphTowards: " + what); }

// Gradients of the barycentric coordinates of tet (a, b, c, d), one per column.
Eigen::Matrix<double, 3, 4> barycentricGradients(const Eigen::Vector3d& a, const Eigen::Vector3d& b,
                                                 const Eigen::Vector3d& c, const Eigen::Vector3d& d) {
  const double vol6 = (b - a).cross(c - a).dot(d - a);
  Eigen::Matrix<double, 3, 4> G;
  G.col(1) = (c - a).cross(d - a) / vol6;
  G.col(2) = (d - a).cross(b - a) / vol6;
  G.col(3) = (b - a).cross(c - a) / vol6;
  G.col(0) = -(G.col(1) + G.col(2) + G.col(3));
  return G;
}

}  // namespace

BarrierMorphResult morphTowards(const Eigen::MatrixX3d& reference, const Eigen::MatrixX4i& T0,
                                const Eigen::MatrixX3d& start, const Eigen::MatrixX3d& target,
                                const std::vector<bool>& fixed0, const BarrierMorphOptions& options) {
  const Eigen::Index nv = reference.rows(), nt = T0.rows();
  if (start.rows() != nv || target.rows() != nv || static_cast<Eigen::Index>(fixed0.size()) != nv)
    fail(ErrorKind::Input, "reference has " + std::to_string(nv) + " vertices, start " + std::to_string(start.rows()) +
                               ", target " + std::to_string(target.rows()) + ", fixed mask " +
                               std::to_string(fixed0.size()));
  if (nt > 0 && (T0.minCoeff() < 0 || T0.maxCoeff() >= nv)) fail(ErrorKind::Input, "tet vertex index out of range");
  const bool onCube = options.cubeFaces.rows() > 0;
  if (onCube && options.sphereFaces.rows() > 0) fail(ErrorKind::Usage, "sphereFaces and cubeFaces are mutually exclusive");
  const Eigen::MatrixX3i& faces = onCube ? options.cubeFaces : options.sphereFaces;
  const Eigen::Index nc = faces.rows();
  if (nc > 0 && (faces.minCoeff() < 0 || faces.maxCoeff() >= nv)) fail(ErrorKind::Input, "face vertex index out of range");
  if (options.targetVolumes.size() != 0 && options.targetVolumes.size() != nt)
    fail(ErrorKind::Input, std::to_string(options.targetVolumes.size()) + " target volumes for " + std::to_string(nt) +
                               " tets");
  for (double lambda : options.attraction)
    if (!(std::isfinite(lambda) && lambda > 0)) fail(ErrorKind::Usage, "attraction " + std::to_string(lambda));
  if (!start.allFinite() || !target.allFinite()) fail(ErrorKind::Input, "non-finite start or target");

  // Extended problem, as in the untangler: vertex nv is the fixed apex, tets
  // nt.. the cones (apex, a, b, c) over the sliding boundary's triangles.
  const Eigen::Index nvx = nv + 1, ntx = nt + nc;
  const Eigen::RowVector3d apex = onCube ? Eigen::RowVector3d(0.5, 0.5, 0.5) : Eigen::RowVector3d(0, 0, 0);
  Eigen::MatrixX4i T(ntx, 4);
  T.topRows(nt) = T0;
  for (Eigen::Index f = 0; f < nc; ++f) T.row(nt + f) << static_cast<int>(nv), faces(f, 0), faces(f, 1), faces(f, 2);
  Eigen::MatrixX3d W(nvx, 3);
  W.topRows(nv) = start;
  W.row(nv) = apex;
  if (const int bad = countNonPositiveTets(W, T); bad > 0)
    fail(ErrorKind::Input, "the start map has " + std::to_string(bad) + " non-positive tets or boundary cones");

  enum Slide : char { kInterior = 0, kSphere = 1, kCube = 2 };
  std::vector<char> slide(static_cast<size_t>(nvx), kInterior);
  for (Eigen::Index f = 0; f < nc; ++f)
    for (int k = 0; k < 3; ++k) slide[static_cast<size_t>(faces(f, k))] = onCube ? kCube : kSphere;
  std::vector<int> freeVerts;
  std::vector<int> inRegion(static_cast<size_t>(nvx), -1);
  for (Eigen::Index v = 0; v < nv; ++v)
    if (!fixed0[static_cast<size_t>(v)])
      inRegion[static_cast<size_t>(v)] = static_cast<int>(freeVerts.size()), freeVerts.push_back(static_cast<int>(v));
  std::vector<int> active;  // tets with a free vertex
  for (Eigen::Index t = 0; t < ntx; ++t)
    for (int k = 0; k < 4; ++k)
      if (inRegion[static_cast<size_t>(T(t, k))] >= 0) {
        active.push_back(static_cast<int>(t));
        break;
      }

  // Reference shapes: the input tets (the energy is scale-free).
  std::vector<Eigen::Matrix<double, 3, 4>> grad(static_cast<size_t>(ntx));
  for (Eigen::Index t = 0; t < nt; ++t) {
    const Eigen::Vector3d a = reference.row(T(t, 0)), b = reference.row(T(t, 1)), c = reference.row(T(t, 2)),
                          d = reference.row(T(t, 3));
    if (!((b - a).cross(c - a).dot(d - a) > 0))
      fail(ErrorKind::Input, "reference tet " + std::to_string(t) + " has non-positive volume");
    grad[static_cast<size_t>(t)] = barycentricGradients(a, b, c, d);
  }
  const detail::VertexTets vt = detail::vertexTets(nvx, T);

  // ℓ_v: the edge of a regular tet of the mean target volume around v (or the
  // target's mean edge there).
  Eigen::VectorXd invEllSq = Eigen::VectorXd::Zero(nvx);
  for (Eigen::Index v = 0; v < nv; ++v) {
    double sum = 0;
    int n = 0;
    for (int e = vt.offset[static_cast<size_t>(v)]; e < vt.offset[static_cast<size_t>(v) + 1]; ++e) {
      const int t = vt.corner[static_cast<size_t>(e)] / 4, k = vt.corner[static_cast<size_t>(e)] % 4;
      if (t >= nt) continue;
      if (options.targetVolumes.size() == nt) {
        sum += options.targetVolumes(t), ++n;
      } else {
        for (int j = 0; j < 4; ++j)
          if (j != k) sum += (target.row(T(t, j)) - target.row(v)).norm(), ++n;
      }
    }
    double ell = 0;
    if (n > 0) ell = options.targetVolumes.size() == nt ? std::cbrt(6 * std::sqrt(2.0) * sum / n) : sum / n;
    invEllSq[v] = ell > 0 && std::isfinite(ell) ? 1 / (ell * ell) : 0;
  }
  auto distances = [&](double* rms, double* worst) {
    double sq = 0, mx = 0;
    for (Eigen::Index v = 0; v < nv; ++v) {
      const double d2 = (W.row(v) - target.row(v)).squaredNorm() * invEllSq[v];
      sq += d2, mx = std::max(mx, d2);
    }
    *rms = nv > 0 ? std::sqrt(sq / static_cast<double>(nv)) : 0;
    if (worst) *worst = std::sqrt(mx);
  };

  BarrierMorphResult result;
  distances(&result.startDistance, nullptr);
  const size_t nFree = freeVerts.size();
  if (nFree == 0) {  // nothing moves
    result.U = start;
    distances(&result.distance, &result.maxDistance);
    return result;
  }
  Eigen::MatrixX3d base(static_cast<Eigen::Index>(nFree), 3);
  Eigen::VectorXd precond(nvx);
  detail::CornerTerms cornerGrad(vt);  // per corner: the shape energy's gradient with respect to its vertex
  double lambda = 0;

  auto place = [&](size_t k, const Eigen::Vector3d& y) {
    const int v = freeVerts[k];
    if (slide[static_cast<size_t>(v)] == kSphere) {
      W.row(v) = (y / y.norm()).transpose();
    } else if (slide[static_cast<size_t>(v)] == kCube) {  // where the ray from the centre leaves the cube
      const detail::CubeRay r = detail::cubeRay(y, apex.transpose());
      if (!(r.extent > 0)) return;  // at the centre: no ray; keep the last position
      W.row(v) = detail::cubeRayPoint(r);
    } else {
      W.row(v) = y.transpose();
    }
  };
  auto unknown = [&](size_t k, const Eigen::VectorXd& x) -> Eigen::Vector3d {
    return base.row(static_cast<Eigen::Index>(k)).transpose() +
           precond[freeVerts[k]] * x.segment<3>(3 * static_cast<Eigen::Index>(k));
  };
  // The tets read their corners from a row-major copy of W (as the
  // untangler does): each vertex's three coordinates in one cache line.
  Eigen::Matrix<double, Eigen::Dynamic, 3, Eigen::RowMajor> rowMajorW;
  auto evaluate = [&](const Eigen::VectorXd& x, Eigen::VectorXd* g) -> double {
    for (size_t k = 0; k < nFree; ++k) place(k, unknown(k, x));
    rowMajorW = W;
    const double E = tbb::parallel_deterministic_reduce(
        tbb::blocked_range<size_t>(0, active.size(), 1024), 0.0,
        [&](const tbb::blocked_range<size_t>& r, double sum) {
          for (size_t a = r.begin(); a != r.end(); ++a) {
            const int t = active[a];
            const auto& G = grad[static_cast<size_t>(t)];
            const Eigen::Matrix3d J = detail::tetJacobian(rowMajorW, T, t, G);
            const double D = J.determinant();
            if (!(D > 0)) return std::numeric_limits<double>::infinity();  // the barrier
            Eigen::Matrix3d dJ;
            sum += detail::untangleEnergy(J, 0, 0, g ? &dJ : nullptr);  // ε = 0, shape term only
            if (g) cornerGrad.setProduct(t, 1, dJ, G);  // column k: gradient with respect to vertex k
          }
          return sum;
        },
        [](double a, double b) { return a + b; }, tbb::simple_partitioner());
    if (!std::isfinite(E)) return std::numeric_limits<double>::infinity();
    double A = 0;
    for (size_t k = 0; k < nFree; ++k) {
      const int v = freeVerts[k];
      A += invEllSq[v] * (W.row(v) - target.row(v)).squaredNorm();
    }
    if (g) {
      tbb::parallel_for(tbb::blocked_range<size_t>(0, nFree, 1024), [&](const tbb::blocked_range<size_t>& r) {
        for (size_t k = r.begin(); k != r.end(); ++k) {
          const int v = freeVerts[k];
          Eigen::Vector3d s = 2 * lambda * invEllSq[v] * (W.row(v) - target.row(v)).transpose();
          cornerGrad.addTo(v, s);
          const Eigen::Vector3d y = unknown(k, x);
          if (slide[static_cast<size_t>(v)] == kSphere) {
            s = detail::sphereGradient(y, s);
          } else if (slide[static_cast<size_t>(v)] == kCube) {
            const detail::CubeRay r = detail::cubeRay(y, apex.transpose());
            s = r.extent > 0 ? detail::cubeRayGradient(r, s) : Eigen::Vector3d::Zero();
          }
          g->segment<3>(3 * static_cast<Eigen::Index>(k)) = precond[v] * s;
        }
      });
    }
    return E + lambda * A;
  };

  // Projected Newton: per tet the shape term's Hessian in J projected onto
  // the PSD cone, the attraction's 2λ/ℓ² on the diagonal, both mapped to the
  // unknowns through the preconditioner and the sliding (Gauss–Newton for
  // the projections onto ∂Ω); the directions a projection removes get a unit
  // curvature. The step solves it with at most options.cgIterations of
  // Jacobi-preconditioned CG (truncated Newton), see barrier_morph.h. Each
  // accepted step is rebased: x = 0 at the new positions.
  auto rebase = [&] {
    for (size_t k = 0; k < nFree; ++k) base.row(static_cast<Eigen::Index>(k)) = W.row(freeVerts[k]);
  };
  std::unique_ptr<detail::BlockHessian> hessian;
  if (options.method == UntangleMethod::Newton)
    hessian = std::make_unique<detail::BlockHessian>(T, vt, freeVerts, inRegion, active,
                                                     detail::BlockHessian::Solver::ConjugateGradient,
                                                     options.cgIterations, options.cgTolerance);
  auto newton = [&](Eigen::VectorXd& x) {
    const Eigen::Index n = x.size();
    Eigen::VectorXd g(n), gNew(n), xNew(n), d;
    std::vector<Eigen::Matrix3d> M(nFree), C(nFree);
    int it = 0;
    double f = evaluate(x, &g);
    for (; it < options.maxNewtonIterations; ++it) {
      tbb::parallel_for(tbb::blocked_range<size_t>(0, nFree, 1024), [&](const tbb::blocked_range<size_t>& r) {
        for (size_t k = r.begin(); k != r.end(); ++k) {
          const int v = freeVerts[k];
          const Eigen::Vector3d y = unknown(k, x);
          M[k] = precond[v] * Eigen::Matrix3d::Identity();
          C[k].setZero();
          if (slide[static_cast<size_t>(v)] == kSphere) {
            detail::sphereLinearisation(y, precond[v], M[k], C[k]);
          } else if (slide[static_cast<size_t>(v)] == kCube) {
            const detail::CubeRay r = detail::cubeRay(y, apex.transpose());
            if (r.extent > 0) detail::cubeRayLinearisation(r, precond[v], M[k], C[k]);
            else M[k].setZero(), C[k].setIdentity();
          }
          C[k] += M[k].transpose() * (2 * lambda * invEllSq[v]) * M[k];
        }
      });
      hessian->assemble(
          [&](size_t a) {
            const int t = active[a];
            const auto& G = grad[static_cast<size_t>(t)];
            const Eigen::Matrix3d J = detail::tetJacobian(W, T, t, G);
            return detail::vertexHessian(detail::untangleHessianProjected(J, 0, 0), G);
          },
          M, C);
      if (!hessian->descent(g, d)) d = -g;
      double fNew = f, slope = 0;
      if (!detail::armijoStep(evaluate, x, g, d, f, xNew, gNew, fNew, &slope)) break;
      const double decrease = f - fNew;
      rebase();
      x.setZero();
      f = evaluate(x, &g);
      if (decrease <= 1e-9 * std::abs(f)) {
        ++it;
        break;
      }
    }
    return it;
  };

  for (size_t run = 0; run < options.attraction.size(); ++run) {
    lambda = options.attraction[run];
    // Cones: the apex over an equilateral triangle of the face's current
    // mean edge, at the apex's height (only a barrier: its shape is free).
    const double apexHeight = onCube ? 0.5 : 1;
    for (Eigen::Index f = 0; f < nc; ++f) {
      const Eigen::Index t = nt + f;
      double sq = 0;
      for (int k = 1; k <= 3; ++k) sq += (W.row(T(t, k)) - W.row(T(t, k % 3 + 1))).squaredNorm();
      const double r = std::sqrt(std::max(sq / 3, 1e-300)) / std::sqrt(3.0);
      grad[static_cast<size_t>(t)] = barycentricGradients(
          Eigen::Vector3d::Zero(), Eigen::Vector3d(r, 0, apexHeight),
          Eigen::Vector3d(r * std::cos(2 * M_PI / 3), r * std::sin(2 * M_PI / 3), apexHeight),
          Eigen::Vector3d(r * std::cos(4 * M_PI / 3), r * std::sin(4 * M_PI / 3), apexHeight));
    }
    // Unknowns: displacements in units of p_v, the inverse square root of the
    // energy's curvature at v (about 2/h² per tet, h the current edge there,
    // plus 2λ/ℓ_v²).
    for (Eigen::Index v = 0; v < nvx; ++v) {
      double logSum = 0;
      int n = 0, tets = 0;
      for (int e = vt.offset[static_cast<size_t>(v)]; e < vt.offset[static_cast<size_t>(v) + 1]; ++e) {
        const int t = vt.corner[static_cast<size_t>(e)] / 4, k = vt.corner[static_cast<size_t>(e)] % 4;
        ++tets;
        for (int j = 0; j < 4; ++j)
          if (j != k && T(t, j) != nv) logSum += std::log((W.row(T(t, j)) - W.row(v)).norm()), ++n;
      }
      const double h = n > 0 ? std::exp(logSum / n) : 1;
      precond[v] = 1 / std::sqrt(2.0 * tets / (h * h) + 2 * lambda * invEllSq[v]);
    }
    rebase();
    const Eigen::MatrixX3d saved = W;
    Eigen::VectorXd x = Eigen::VectorXd::Zero(3 * static_cast<Eigen::Index>(nFree));
    if (options.method == UntangleMethod::Lbfgs) {
      result.lbfgsIterations += detail::lbfgs([&](const Eigen::VectorXd& y, Eigen::VectorXd& g) { return evaluate(y, &g); },
                                              x, options.maxLbfgsIterations, options.lbfgsMemory);
    } else {
      result.newtonIterations += newton(x);
    }
    const double E = evaluate(x, nullptr);
    // Floating point kept det J > 0; confirm exactly (a tet can be positive
    // in floating point and flat exactly): keep the run only if it holds.
    if (!std::isfinite(E) || countNonPositiveTets(W, T) > 0) {
      W = saved;
      break;
    }
    double rms = 0, worst = 0;
    distances(&rms, &worst);
    if (options.progress &&
        !options.progress(-1, "morph: attraction " + std::to_string(lambda) + ", distance to the target rms " +
                                  std::to_string(rms) + " max " + std::to_string(worst) + " (edges), L-BFGS iterations " +
                                  std::to_string(result.lbfgsIterations))) {
      result.status = Status::failure("morph: stopped by the progress callback");
      result.stopped = true;
      break;
    }
  }
  result.U = W.topRows(nv);
  distances(&result.distance, &result.maxDistance);
  return result;
}

}  // namespace tet2spline

// Foldover-free untangling (Garanzha et al. 2021) with a compact L-BFGS.
#include "tet2spline/param/untangle.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_reduce.h>
#include <tbb/partitioner.h>

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <deque>
#include <limits>

#include "spd_solver.h"
#include "tet2spline/param/topology.h"

namespace tet2spline {

namespace {

double chi(double eps, double d) {
  const double r = std::sqrt(eps * eps + d * d);
  return d > 0 ? 0.5 * (d + r) : 0.5 * eps * eps / (r - d);
}
double chiDerivative(double eps, double d) { return 0.5 + 0.5 * d / std::sqrt(eps * eps + d * d); }

// Minimises f with L-BFGS and Armijo backtracking; returns iterations used.
template <class FunGrad>
int lbfgs(FunGrad&& fg, Eigen::VectorXd& x, int maxIter, int memory) {
  Eigen::VectorXd g(x.size()), gNew(x.size()), xNew(x.size());
  double f = fg(x, g);
  std::deque<Eigen::VectorXd> S, Y;
  std::deque<double> rho;
  int it = 0;
  for (; it < maxIter; ++it) {
    if (!(g.squaredNorm() > 0)) break;
    // Two-loop recursion.
    Eigen::VectorXd d = -g;
    std::vector<double> alpha(S.size());
    for (int k = static_cast<int>(S.size()) - 1; k >= 0; --k) {
      alpha[k] = rho[k] * S[k].dot(d);
      d -= alpha[k] * Y[k];
    }
    double gamma = S.empty() ? 1.0 / std::max(g.norm(), 1e-300) : S.back().dot(Y.back()) / Y.back().squaredNorm();
    d *= gamma;
    for (size_t k = 0; k < S.size(); ++k) d += S[k] * (alpha[k] - rho[k] * Y[k].dot(d));
    double slope = g.dot(d);
    if (!(slope < 0)) {
      S.clear(), Y.clear(), rho.clear();
      d = -g / std::max(g.norm(), 1e-300);
      slope = g.dot(d);
    }
    double step = 1, fNew = 0;
    bool accepted = false;
    for (int ls = 0; ls < 40; ++ls, step *= 0.5) {
      xNew = x + step * d;
      fNew = fg(xNew, gNew);
      if (std::isfinite(fNew) && fNew <= f + 1e-4 * step * slope) {
        accepted = true;
        break;
      }
    }
    if (!accepted) {
      if (S.empty()) break;  // even steepest descent cannot decrease f
      S.clear(), Y.clear(), rho.clear();
      continue;
    }
    const Eigen::VectorXd s = xNew - x, y = gNew - g;
    const double sy = s.dot(y);
    x.swap(xNew);
    g.swap(gNew);
    const double decrease = f - fNew;
    f = fNew;
    if (sy > 1e-12 * s.norm() * y.norm()) {
      S.push_back(s), Y.push_back(y), rho.push_back(1 / sy);
      if (static_cast<int>(S.size()) > memory) S.pop_front(), Y.pop_front(), rho.pop_front();
    }
    if (decrease <= 1e-12 * std::abs(f)) {
      ++it;
      break;
    }
  }
  return it;
}

}  // namespace

UntangleResult untangle(const Eigen::MatrixX3d& reference, const Eigen::MatrixX4i& T, const Eigen::MatrixX3d& U0,
                        const std::vector<bool>& fixed, const UntangleOptions& options) {
  const Eigen::Index nv = reference.rows(), nt = T.rows();
  if (U0.rows() != nv || static_cast<Eigen::Index>(fixed.size()) != nv)
    throw Error(ErrorKind::Input, "untangle: reference has " + std::to_string(nv) + " vertices, U " +
                                      std::to_string(U0.rows()) + ", fixed mask " + std::to_string(fixed.size()));
  if (nt > 0 && (T.minCoeff() < 0 || T.maxCoeff() >= nv))
    throw Error(ErrorKind::Input, "untangle: tet vertex index out of range");
  UntangleResult result;
  result.U = U0;
  result.invertedBefore = countNonPositiveTets(U0, T);
  result.invertedAfter = result.invertedBefore;
  if (result.invertedBefore == 0 || nt == 0) return result;

  // Reference gradients of the barycentric coordinates, scaled so that the
  // reference volume equals the mapped one (det J ≈ 1 on average).
  std::vector<Eigen::Matrix<double, 3, 4>> grad(static_cast<size_t>(nt));
  Eigen::VectorXd weight(nt);
  double refVolume = 0, mapVolume = 0;
  for (Eigen::Index t = 0; t < nt; ++t) {
    const Eigen::Vector3d a = reference.row(T(t, 0)), b = reference.row(T(t, 1)), c = reference.row(T(t, 2)),
                          d = reference.row(T(t, 3));
    const double vol = (b - a).cross(c - a).dot(d - a) / 6;
    if (!(vol > 0))
      throw Error(ErrorKind::Input, "untangle: reference tet " + std::to_string(t) + " has non-positive volume");
    Eigen::Matrix<double, 3, 4>& G = grad[static_cast<size_t>(t)];
    G.col(0) = -0.5 * (d - b).cross(c - b) / (3 * vol);
    G.col(1) = -0.5 * (c - a).cross(d - a) / (3 * vol);
    G.col(2) = -0.5 * (d - a).cross(b - a) / (3 * vol);
    G.col(3) = -0.5 * (b - a).cross(c - a) / (3 * vol);
    weight[t] = vol;
    refVolume += vol;
    const Eigen::Vector3d A = U0.row(T(t, 0)), B = U0.row(T(t, 1)), C = U0.row(T(t, 2)), D = U0.row(T(t, 3));
    mapVolume += (B - A).cross(C - A).dot(D - A) / 6;
  }
  weight /= refVolume / static_cast<double>(nt);
  const double scale = mapVolume > 0 ? std::cbrt(mapVolume / refVolume) : 1.0;
  for (auto& G : grad) G /= scale;

  const detail::VertexTets vt = detail::vertexTets(nv, T);
  std::vector<int> inRegion(static_cast<size_t>(nv), -1);  // variable index of a free vertex
  int rings = options.rings;
  for (;;) {
    // Free region: `rings` rings around the vertices of inverted tets.
    std::vector<int> freeVerts;
    std::fill(inRegion.begin(), inRegion.end(), -1);
    std::vector<char> mark(static_cast<size_t>(nv), 0);
    if (rings < 0) {
      for (Eigen::Index v = 0; v < nv; ++v) mark[v] = 1;
    } else {
      for (Eigen::Index t = 0; t < nt; ++t) {
        const Eigen::Vector3d a = result.U.row(T(t, 0)), b = result.U.row(T(t, 1)), c = result.U.row(T(t, 2)),
                              d = result.U.row(T(t, 3));
        if (orient3d(a.data(), b.data(), c.data(), d.data()) <= 0)
          for (int k = 0; k < 4; ++k) mark[T(t, k)] = 1;
      }
      for (int r = 0; r < rings; ++r) {
        std::vector<char> next = mark;
        for (Eigen::Index v = 0; v < nv; ++v)
          if (mark[v])
            for (int e = vt.offset[v]; e < vt.offset[v + 1]; ++e)
              for (int k = 0; k < 4; ++k) next[T(vt.corner[e] / 4, k)] = 1;
        mark.swap(next);
      }
    }
    for (Eigen::Index v = 0; v < nv; ++v)
      if (mark[v] && !fixed[v]) inRegion[v] = static_cast<int>(freeVerts.size()), freeVerts.push_back(static_cast<int>(v));
    std::vector<int> active;  // tets with a free vertex
    for (Eigen::Index t = 0; t < nt; ++t)
      for (int k = 0; k < 4; ++k)
        if (inRegion[T(t, k)] >= 0) {
          active.push_back(static_cast<int>(t));
          break;
        }
    result.freeVertices = static_cast<int>(freeVerts.size());
    if (freeVerts.empty()) break;

    std::vector<int> activeIndex(static_cast<size_t>(nt), -1);
    for (size_t a = 0; a < active.size(); ++a) activeIndex[active[a]] = static_cast<int>(a);
    std::vector<Eigen::Matrix<double, 3, 4>> tetGrad(active.size());
    std::vector<double> det(active.size());
    Eigen::MatrixX3d W = result.U;  // working positions
    double eps = 1;

    auto evaluate = [&](const Eigen::VectorXd& x, Eigen::VectorXd* g) -> double {
      for (size_t k = 0; k < freeVerts.size(); ++k) W.row(freeVerts[k]) = x.segment<3>(3 * static_cast<Eigen::Index>(k)).transpose();
      const double E = tbb::parallel_deterministic_reduce(
          tbb::blocked_range<size_t>(0, active.size(), 1024), 0.0,
          [&](const tbb::blocked_range<size_t>& r, double sum) {
            for (size_t a = r.begin(); a != r.end(); ++a) {
              const int t = active[a];
              const auto& G = grad[static_cast<size_t>(t)];
              Eigen::Matrix3d J = Eigen::Matrix3d::Zero();
              for (int k = 0; k < 4; ++k) J += W.row(T(t, k)).transpose() * G.col(k).transpose();
              const double D = J.determinant();
              det[a] = D;
              const double c1 = chi(eps, D), c2 = std::pow(c1, 2.0 / 3.0), c3 = chiDerivative(eps, D);
              const double f = J.squaredNorm() / c2, h = (1 + D * D) / c1;
              sum += weight[t] * ((1 - options.theta) * f + options.theta * h);
              if (g) {
                Eigen::Matrix3d K;  // d det / d J, row by row
                K.row(0) = J.row(1).cross(J.row(2));
                K.row(1) = J.row(2).cross(J.row(0));
                K.row(2) = J.row(0).cross(J.row(1));
                const Eigen::Matrix3d dJ =
                    weight[t] * ((1 - options.theta) * (J * (2 / c2) - K * (2 * f * c3 / (3 * c1))) +
                                 options.theta * K * ((2 * D - h * c3) / c1));
                tetGrad[a] = dJ * G;  // column k: gradient with respect to vertex k
              }
            }
            return sum;
          },
          std::plus<double>(), tbb::simple_partitioner());
      if (g) {
        tbb::parallel_for(tbb::blocked_range<size_t>(0, freeVerts.size(), 1024), [&](const tbb::blocked_range<size_t>& r) {
          for (size_t k = r.begin(); k != r.end(); ++k) {
            const int v = freeVerts[k];
            Eigen::Vector3d s = Eigen::Vector3d::Zero();
            for (int e = vt.offset[v]; e < vt.offset[v + 1]; ++e)
              s += tetGrad[static_cast<size_t>(activeIndex[vt.corner[e] / 4])].col(vt.corner[e] % 4);
            g->segment<3>(3 * static_cast<Eigen::Index>(k)) = s;
          }
        });
      }
      return E;
    };

    Eigen::VectorXd x(3 * static_cast<Eigen::Index>(freeVerts.size()));
    for (size_t k = 0; k < freeVerts.size(); ++k) x.segment<3>(3 * static_cast<Eigen::Index>(k)) = result.U.row(freeVerts[k]).transpose();
    auto detMin = [&]() { return active.empty() ? 1.0 : *std::min_element(det.begin(), det.end()); };
    for (int outer = 0; outer < options.maxOuterIterations; ++outer) {
      const double Eprev = evaluate(x, nullptr);
      result.lbfgsIterations += lbfgs([&](const Eigen::VectorXd& y, Eigen::VectorXd& g) { return evaluate(y, &g); }, x,
                                      options.maxLbfgsIterations, options.lbfgsMemory);
      const double E = evaluate(x, nullptr);
      const double dmin = detMin();
      ++result.outerIterations;
      result.minDet = dmin;
      const double sigma = std::max(1 - E / Eprev, 0.1);
      const double mu = (1 - sigma) * chi(eps, dmin);
      eps = dmin < mu ? std::max(1e-9, 2 * std::sqrt(mu * (mu - dmin))) : 1e-9;
      if (options.progress &&
          !options.progress(-1, "untangle: eps " + std::to_string(eps) + ", min det " + std::to_string(dmin))) {
        result.status = Status::failure("untangle: stopped by the progress callback");
        break;
      }
      if (dmin > 0 && std::abs(Eprev - E) / E < 1e-5) {
        // Floating point says untangled; confirm exactly on the active tets.
        int bad = 0;
        for (int t : active) {
          Eigen::Vector3d p[4];
          for (int k = 0; k < 4; ++k) p[k] = W.row(T(t, k)).transpose();
          bad += orient3d(p[0].data(), p[1].data(), p[2].data(), p[3].data()) <= 0;
        }
        if (bad == 0) break;
      }
    }
    for (size_t k = 0; k < freeVerts.size(); ++k) result.U.row(freeVerts[k]) = x.segment<3>(3 * static_cast<Eigen::Index>(k)).transpose();
    result.invertedAfter = countNonPositiveTets(result.U, T);
    if (result.invertedAfter == 0 || !result.status.ok || rings < 0) break;
    // Tets whose four vertices are fixed cannot be repaired by any region.
    int locked = 0;
    for (Eigen::Index t = 0; t < nt; ++t) {
      bool allFixed = true;
      for (int k = 0; k < 4; ++k) allFixed = allFixed && fixed[T(t, k)];
      if (!allFixed) continue;
      Eigen::Vector3d p[4];
      for (int k = 0; k < 4; ++k) p[k] = result.U.row(T(t, k)).transpose();
      locked += orient3d(p[0].data(), p[1].data(), p[2].data(), p[3].data()) <= 0;
    }
    if (locked == result.invertedAfter) break;
    // Grow the region; once it would hold (nearly) everything, free it all.
    rings = rings == 0 ? 1 : 2 * rings;
    if (static_cast<Eigen::Index>(freeVerts.size()) * 2 > nv) rings = -1;
  }
  if (result.invertedAfter > 0 && result.status.ok)
    result.status = Status::failure("untangle: " + std::to_string(result.invertedAfter) +
                                    " tets remain inverted (some may have only fixed vertices)");
  return result;
}

}  // namespace tet2spline

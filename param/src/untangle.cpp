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

UntangleResult untangle(const Eigen::MatrixX3d& reference, const Eigen::MatrixX4i& T0, const Eigen::MatrixX3d& U0,
                        const std::vector<bool>& fixed0, const UntangleOptions& options) {
  const Eigen::Index nv = reference.rows(), nt = T0.rows(), nc = options.sphereFaces.rows();
  if (U0.rows() != nv || static_cast<Eigen::Index>(fixed0.size()) != nv)
    throw Error(ErrorKind::Input, "untangle: reference has " + std::to_string(nv) + " vertices, U " +
                                      std::to_string(U0.rows()) + ", fixed mask " + std::to_string(fixed0.size()));
  if (nt > 0 && (T0.minCoeff() < 0 || T0.maxCoeff() >= nv))
    throw Error(ErrorKind::Input, "untangle: tet vertex index out of range");
  if (options.targetVolumes.size() != 0 && options.targetVolumes.size() != nt)
    throw Error(ErrorKind::Usage, "untangle: " + std::to_string(options.targetVolumes.size()) + " target volumes for " +
                                      std::to_string(nt) + " tets");
  if (nc > 0 && (options.sphereFaces.minCoeff() < 0 || options.sphereFaces.maxCoeff() >= nv))
    throw Error(ErrorKind::Input, "untangle: sphere face vertex index out of range");
  UntangleResult result;
  result.U = U0;
  result.invertedBefore = countNonPositiveTets(U0, T0);
  result.invertedAfter = result.invertedBefore;
  result.flippedSphereTriangles = 0;
  // Extended problem: vertex nv is the (fixed) origin, tets nt.. are the cones
  // (origin, a, b, c) over the sphere faces.
  const Eigen::Index nvx = nv + 1, ntx = nt + nc;
  Eigen::MatrixX4i T(ntx, 4);
  T.topRows(nt) = T0;
  for (Eigen::Index f = 0; f < nc; ++f) T.row(nt + f) << static_cast<int>(nv), options.sphereFaces(f, 0), options.sphereFaces(f, 1), options.sphereFaces(f, 2);
  Eigen::MatrixX3d W(nvx, 3);  // working positions
  W.topRows(nv) = U0;
  W.row(nv).setZero();
  std::vector<bool> fixed(fixed0);
  fixed.push_back(true);
  std::vector<char> sliding(static_cast<size_t>(nvx), 0);
  for (Eigen::Index f = 0; f < nc; ++f)
    for (int k = 0; k < 3; ++k)
      if (!fixed[options.sphereFaces(f, k)]) sliding[options.sphereFaces(f, k)] = 1;
  auto positive = [&](Eigen::Index t) {
    Eigen::Vector3d p[4];
    for (int k = 0; k < 4; ++k) p[k] = W.row(T(t, k)).transpose();
    return orient3d(p[0].data(), p[1].data(), p[2].data(), p[3].data()) > 0;
  };
  auto countBad = [&](Eigen::Index from, Eigen::Index to) {
    int bad = 0;
    for (Eigen::Index t = from; t < to; ++t) bad += !positive(t);
    return bad;
  };
  result.flippedSphereTriangles = countBad(nt, ntx);
  if ((result.invertedBefore == 0 && result.flippedSphereTriangles == 0 && !options.relax) || nt == 0) return result;

  // Reference gradients of the barycentric coordinates, scaled so that the
  // reference volume equals the mapped one (det J ≈ 1 on average). The cones
  // share one reference: apex at the origin over an equilateral triangle of
  // the mean spherical area, at height 1.
  std::vector<Eigen::Matrix<double, 3, 4>> grad(static_cast<size_t>(ntx));
  Eigen::VectorXd weight(ntx);
  double refVolume = 0, mapVolume = 0;
  auto gradients = [](const Eigen::Vector3d& a, const Eigen::Vector3d& b, const Eigen::Vector3d& c,
                      const Eigen::Vector3d& d, double vol) {
    Eigen::Matrix<double, 3, 4> G;  // ∇φ_k = −(outward area vector of the face opposite k) / (3 vol)
    G.col(0) = 0.5 * (d - b).cross(c - b) / (3 * vol);
    G.col(1) = 0.5 * (c - a).cross(d - a) / (3 * vol);
    G.col(2) = 0.5 * (d - a).cross(b - a) / (3 * vol);
    G.col(3) = 0.5 * (b - a).cross(c - a) / (3 * vol);
    return G;
  };
  for (Eigen::Index t = 0; t < nt; ++t) {
    const Eigen::Vector3d a = reference.row(T(t, 0)), b = reference.row(T(t, 1)), c = reference.row(T(t, 2)),
                          d = reference.row(T(t, 3));
    const double vol = (b - a).cross(c - a).dot(d - a) / 6;
    if (!(vol > 0))
      throw Error(ErrorKind::Input, "untangle: reference tet " + std::to_string(t) + " has non-positive volume");
    grad[static_cast<size_t>(t)] = gradients(a, b, c, d, vol);
    weight[t] = vol;
    refVolume += vol;
    const Eigen::Vector3d A = U0.row(T(t, 0)), B = U0.row(T(t, 1)), C = U0.row(T(t, 2)), D = U0.row(T(t, 3));
    mapVolume += (B - A).cross(C - A).dot(D - A) / 6;
  }
  // Local scale: the map may shrink some parts a thousandfold (fingers on a
  // conformal sphere), so one global scale would leave det J far from 1 and
  // ε meaningless. Each reference tet is scaled by the cube root of the mean,
  // over its vertices, of (mapped volume / reference volume) around the vertex.
  static_cast<void>(mapVolume);
  {
    Eigen::VectorXd mapped = Eigen::VectorXd::Zero(nv), ref = Eigen::VectorXd::Zero(nv);
    for (Eigen::Index t = 0; t < nt; ++t) {
      const Eigen::Vector3d A = U0.row(T(t, 0)), B = U0.row(T(t, 1)), C = U0.row(T(t, 2)), D = U0.row(T(t, 3));
      const double v = std::abs((B - A).cross(C - A).dot(D - A) / 6);
      for (int k = 0; k < 4; ++k) mapped[T(t, k)] += v, ref[T(t, k)] += weight[t];
    }
    const double globalRatio = mapped.sum() / ref.sum();
    const bool targets = options.targetVolumes.size() == nt;
    for (Eigen::Index t = 0; t < nt; ++t) {
      double ratio = 0;
      if (targets) {
        ratio = options.targetVolumes(t) / weight[t];
      } else {
        for (int k = 0; k < 4; ++k) ratio += mapped[T(t, k)] / ref[T(t, k)];
        ratio /= 4;
      }
      if (!(ratio > 0)) ratio = globalRatio;
      const double scale = std::cbrt(ratio);
      grad[static_cast<size_t>(t)] /= scale;
      weight[t] *= ratio;
    }
  }
  const double meanWeight = weight.head(nt).mean();
  // Cones: apex at the origin over an equilateral triangle of the initial
  // triangle's area, at height 1.
  for (Eigen::Index f = 0; f < nc; ++f) {
    const Eigen::Vector3d A = U0.row(T(nt + f, 1)), B = U0.row(T(nt + f, 2)), C = U0.row(T(nt + f, 3));
    const double area = std::max(0.5 * (B - A).cross(C - A).norm(), 1e-6 * 4 * M_PI / static_cast<double>(nc));
    const double r = std::sqrt(area * 4 / (3 * std::sqrt(3.0)));
    const Eigen::Vector3d o(0, 0, 0), a(r, 0, 1), b(r * std::cos(2 * M_PI / 3), r * std::sin(2 * M_PI / 3), 1),
        c(r * std::cos(4 * M_PI / 3), r * std::sin(4 * M_PI / 3), 1);
    const double vol = (a - o).cross(b - o).dot(c - o) / 6;
    grad[static_cast<size_t>(nt + f)] = gradients(o, a, b, c, vol);
    weight[nt + f] = vol;
  }
  weight /= meanWeight;

  const detail::VertexTets vt = detail::vertexTets(nvx, T);
  std::vector<int> inRegion(static_cast<size_t>(nvx), -1);  // variable index of a free vertex
  int rings = options.relax ? -1 : options.rings;
  size_t previousFree = 0;
  for (;;) {
    // Free region: `rings` rings around the vertices of inverted tets.
    std::vector<int> freeVerts;
    std::fill(inRegion.begin(), inRegion.end(), -1);
    std::vector<char> mark(static_cast<size_t>(nvx), 0);
    if (rings < 0) {
      std::fill(mark.begin(), mark.end(), 1);
    } else {
      for (Eigen::Index t = 0; t < ntx; ++t)
        if (!positive(t))
          for (int k = 0; k < 4; ++k) mark[T(t, k)] = 1;
      for (int r = 0; r < rings; ++r) {
        std::vector<char> next = mark;
        for (Eigen::Index v = 0; v < nv; ++v)
          if (mark[v])
            for (int e = vt.offset[v]; e < vt.offset[v + 1]; ++e)
              for (int k = 0; k < 4; ++k) next[T(vt.corner[e] / 4, k)] = 1;
        mark.swap(next);
      }
    }
    for (Eigen::Index v = 0; v < nvx; ++v)
      if (mark[v] && !fixed[v]) inRegion[v] = static_cast<int>(freeVerts.size()), freeVerts.push_back(static_cast<int>(v));
    std::vector<int> active;  // tets with a free vertex
    for (Eigen::Index t = 0; t < ntx; ++t)
      for (int k = 0; k < 4; ++k)
        if (inRegion[T(t, k)] >= 0) {
          active.push_back(static_cast<int>(t));
          break;
        }
    result.freeVertices = static_cast<int>(freeVerts.size());
    if (freeVerts.empty() || freeVerts.size() == previousFree) break;  // nothing new to move
    previousFree = freeVerts.size();

    std::vector<int> activeIndex(static_cast<size_t>(ntx), -1);
    for (size_t a = 0; a < active.size(); ++a) activeIndex[active[a]] = static_cast<int>(a);
    std::vector<Eigen::Matrix<double, 3, 4>> tetGrad(active.size());
    std::vector<double> det(active.size());
    double e0 = 1e-3;
    double eps = 1;

    auto evaluate = [&](const Eigen::VectorXd& x, Eigen::VectorXd* g) -> double {
      for (size_t k = 0; k < freeVerts.size(); ++k) {
        Eigen::Vector3d y = x.segment<3>(3 * static_cast<Eigen::Index>(k));
        if (sliding[freeVerts[k]]) y /= y.norm();
        W.row(freeVerts[k]) = y.transpose();
      }
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
              const double c1 = chi(eps, D), c2 = std::cbrt(c1) * std::cbrt(c1), c3 = chiDerivative(eps, D);  // cbrt: pow took 17%
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
            if (sliding[v]) {  // chain rule through y ↦ y/|y|
              const Eigen::Vector3d y = x.segment<3>(3 * static_cast<Eigen::Index>(k));
              const double len = y.norm();
              const Eigen::Vector3d n = y / len;
              s = (s - n * n.dot(s)) / len;
            }
            g->segment<3>(3 * static_cast<Eigen::Index>(k)) = s;
          }
        });
      }
      return E;
    };

    Eigen::VectorXd x(3 * static_cast<Eigen::Index>(freeVerts.size()));
    for (size_t k = 0; k < freeVerts.size(); ++k) x.segment<3>(3 * static_cast<Eigen::Index>(k)) = W.row(freeVerts[k]).transpose();
    auto detMin = [&]() { return active.empty() ? 1.0 : *std::min_element(det.begin(), det.end()); };
    double bestDet = -std::numeric_limits<double>::infinity();
    int lastProgress = 0;
    for (int outer = 0; outer < options.maxOuterIterations; ++outer) {
      // ε from the smallest determinant (the reference code's eq. (7)): large
      // enough that χ stays smooth around the worst tet, halved base every 10.
      evaluate(x, nullptr);
      if (outer > 0 && outer % 10 == 0 && e0 > 1e-8) e0 /= 2;
      const double d0 = detMin();
      const double proposed = d0 > 0 ? e0 : std::sqrt(e0 * e0 + 0.04 * d0 * d0);
      // Never relax the barrier again, and tighten it while inversions remain.
      eps = outer == 0 ? proposed : std::min(d0 > 0 ? eps : 0.7 * eps, proposed);
      result.lbfgsIterations += lbfgs([&](const Eigen::VectorXd& y, Eigen::VectorXd& g) { return evaluate(y, &g); }, x,
                                      options.maxLbfgsIterations, options.lbfgsMemory);
      for (size_t k = 0; k < freeVerts.size(); ++k)
        if (sliding[freeVerts[k]]) x.segment<3>(3 * static_cast<Eigen::Index>(k)).normalize();
      const double E = evaluate(x, nullptr);
      const double dmin = detMin();
      ++result.outerIterations;
      result.minDet = dmin;
      if (options.progress &&
          !options.progress(-1, "untangle: eps " + std::to_string(eps) + ", min det " + std::to_string(dmin) + ", E " +
                                  std::to_string(E) + ", L-BFGS iterations " + std::to_string(result.lbfgsIterations) +
                                  ", free " + std::to_string(freeVerts.size()))) {
        result.status = Status::failure("untangle: stopped by the progress callback");
        break;
      }
      if (dmin > bestDet + 1e-3 * std::abs(bestDet)) bestDet = dmin, lastProgress = outer;
      if (dmin <= 0 && outer - lastProgress >= options.stallIterations) break;  // this region cannot do it
      // Floating point says untangled: confirm exactly on the active tets.
      if (dmin > 0) {
        int bad = 0;
        for (int t : active) bad += !positive(t);
        if (bad == 0) break;
      }
    }
    result.U = W.topRows(nv);
    result.invertedAfter = countNonPositiveTets(result.U, T0);
    result.flippedSphereTriangles = countBad(nt, ntx);
    if ((result.invertedAfter == 0 && result.flippedSphereTriangles == 0) || !result.status.ok || rings < 0) break;
    // Tets whose four vertices are fixed cannot be repaired by any region.
    int locked = 0;
    for (Eigen::Index t = 0; t < ntx; ++t) {
      bool allFixed = true;
      for (int k = 0; k < 4; ++k) allFixed = allFixed && fixed[T(t, k)];
      if (allFixed) locked += !positive(t);
    }
    if (locked == result.invertedAfter + result.flippedSphereTriangles) break;
    // Grow the region; once it would hold (nearly) everything, free it all.
    rings = rings == 0 ? 1 : 2 * rings;
    if (static_cast<Eigen::Index>(freeVerts.size()) * 2 > nv) rings = -1;
  }
  // Never hand back something worse than what came in.
  const int flippedBefore = [&] {
    W.topRows(nv) = U0;
    return countBad(nt, ntx);
  }();
  if (result.invertedAfter + result.flippedSphereTriangles > result.invertedBefore + flippedBefore) {
    result.U = U0;
    result.invertedAfter = result.invertedBefore;
    result.flippedSphereTriangles = flippedBefore;
  }
  if ((result.invertedAfter > 0 || result.flippedSphereTriangles > 0) && result.status.ok)
    result.status = Status::failure("untangle: " + std::to_string(result.invertedAfter) + " tets remain inverted and " +
                                    std::to_string(result.flippedSphereTriangles) +
                                    " sphere triangles flipped (some may have only fixed vertices)");
  return result;
}

}  // namespace tet2spline

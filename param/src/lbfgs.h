#pragma once
// Internal: a compact L-BFGS with Armijo backtracking, and the damped step of
// the projected Newton iterations, for the untangler and the barrier morph.
// A step whose value is not finite (a barrier crossed) is rejected like one
// that does not decrease enough.
#include <Eigen/Core>
#include <cmath>
#include <deque>
#include <vector>

namespace tet2spline::detail {

// Minimises f with L-BFGS and Armijo backtracking; returns iterations used.
template <class FunGrad>
inline int lbfgs(FunGrad&& fg, Eigen::VectorXd& x, int maxIter, int memory) {
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

// One damped Newton step: along d (along −g when d is not a descent
// direction), Armijo backtracking from step 1, halved at most 40 times; a
// value that is not finite (a barrier crossed) is rejected like one that does
// not decrease enough. On success xNew, gNew and fNew hold the accepted point,
// where evaluate was called last, and *slope the directional derivative g·d;
// otherwise (no descent direction, or no step accepted) it evaluates at x
// again, to restore the caller's state, and returns false.
template <class Evaluate>
inline bool armijoStep(Evaluate&& evaluate, const Eigen::VectorXd& x, Eigen::VectorXd& g, Eigen::VectorXd& d, double f,
                       Eigen::VectorXd& xNew, Eigen::VectorXd& gNew, double& fNew, double* slope) {
  *slope = g.dot(d);
  if (!(*slope < 0)) d = -g, *slope = -g.squaredNorm();
  if (!(*slope < 0)) return false;
  double step = 1;
  for (int ls = 0; ls < 40; ++ls, step *= 0.5) {
    xNew = x + step * d;
    fNew = evaluate(xNew, &gNew);
    if (std::isfinite(fNew) && fNew <= f + 1e-4 * step * *slope) return true;
  }
  evaluate(x, &g);
  return false;
}

}  // namespace tet2spline::detail

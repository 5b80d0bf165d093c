#pragma once
// Internal: a compact L-BFGS with Armijo backtracking, and the damped step of
// the projected Newton iterations, for the untangler and the barrier morph.
// A step whose value is not finite (a barrier crossed) is rejected like one
// that does not decrease enough.
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <Eigen/Core>
#include <algorithm>
#include <cmath>
#include <vector>

namespace tet2spline::detail {

// An element-wise loop over [0, n) on both cores when n is large (each
// element's value does not depend on the split, so the bits are the same).
template <class Body>
inline void forEachElement(Eigen::Index n, const Body& body) {
  constexpr Eigen::Index kSerialBelow = 1 << 16, kGrain = 1 << 15;
  if (n < kSerialBelow) {
    body(Eigen::Index{0}, n);
    return;
  }
  tbb::parallel_for(tbb::blocked_range<Eigen::Index>(0, n, kGrain), [&](const tbb::blocked_range<Eigen::Index>& r) {
    body(r.begin(), r.end());
  });
}

// Σ over fixed chunks of kChunk elements of part(begin, size), the chunks
// on both cores and their values then added in order: the same bits
// whatever the threads.
template <class Part>
inline double chunkedSum(Eigen::Index n, const Part& part) {
  constexpr Eigen::Index kChunk = 1 << 14;
  const Eigen::Index chunks = (n + kChunk - 1) / kChunk;
  std::vector<double> value(static_cast<size_t>(chunks));
  tbb::parallel_for(Eigen::Index(0), chunks, [&](Eigen::Index c) {
    const Eigen::Index begin = c * kChunk;
    value[static_cast<size_t>(c)] = part(begin, std::min(kChunk, n - begin));
  });
  double sum = 0;
  for (double v : value) sum += v;
  return sum;
}

// a · b and |a|²: Eigen's when the vectors are short (their bits), else
// chunkedSum of Eigen's over the chunks. (In one thread, the 2m + 7 dot
// products and norms of each iteration were a serial stretch: on bunny00's
// final untangling, 366k unknowns, memory 10, about 27 passes over two
// vectors per iteration while the other core waited.)
constexpr Eigen::Index kParallelDotFrom = 1 << 16;
inline double parallelDot(const Eigen::VectorXd& a, const Eigen::VectorXd& b) {
  if (a.size() < kParallelDotFrom) return a.dot(b);
  return chunkedSum(a.size(), [&](Eigen::Index begin, Eigen::Index size) {
    return a.segment(begin, size).dot(b.segment(begin, size));
  });
}
inline double parallelSquaredNorm(const Eigen::VectorXd& a) {
  if (a.size() < kParallelDotFrom) return a.squaredNorm();
  return chunkedSum(a.size(), [&](Eigen::Index begin, Eigen::Index size) { return a.segment(begin, size).squaredNorm(); });
}

// d ← update(d) element by element (update(begin, end) over a range), then
// a · d as parallelDot computes it, in one pass: each chunk is updated and
// then read while it is in the cache. The same bits as the update followed
// by parallelDot (the updates are element-wise, the dot products the same
// chunks' in the same order).
template <class Update>
inline double updateThenDot(Eigen::VectorXd& d, const Update& update, const Eigen::VectorXd& a) {
  const Eigen::Index n = d.size();
  if (n < kParallelDotFrom) {
    forEachElement(n, update);
    return a.dot(d);
  }
  return chunkedSum(n, [&](Eigen::Index begin, Eigen::Index size) {
    update(begin, begin + size);
    return a.segment(begin, size).dot(d.segment(begin, size));
  });
}

// Minimises f with L-BFGS and Armijo backtracking; returns iterations used.
// The history is a ring of vectors allocated once, the new pair (s, y) is
// written into a spare slot (no copies, no allocation per iteration), and
// the element-wise updates run on both cores, and so do the dot products
// (parallelDot: below 65536 unknowns Eigen's own, so small problems keep
// their bits). Each element-wise value is computed by the same operations
// as with Eigen expressions on temporaries (d −= α y is d_i − α y_i, ...). Measured
// on bunny00's final untangling (326k unknowns, memory 10): the recursion
// streamed about 115 vectors per iteration in one thread, 7.5% of the
// run's samples. Each update of d in the recursion is made in one pass with
// the dot product that reads d next (updateThenDot): 2m + 2 passes over d
// instead of 4m + 2, the same bits.
template <class FunGrad>
inline int lbfgs(FunGrad&& fg, Eigen::VectorXd& x, int maxIter, int memory) {
  const Eigen::Index n = x.size();
  Eigen::VectorXd g(n), gNew(n), xNew(n), d(n);
  double f = fg(x, g);
  const int slots = std::max(memory, 0) + 1;
  std::vector<Eigen::VectorXd> S(static_cast<size_t>(slots)), Y(static_cast<size_t>(slots));
  std::vector<double> rho(static_cast<size_t>(slots));
  std::vector<int> order;  // the history's slots, oldest first
  order.reserve(static_cast<size_t>(slots));
  std::vector<double> alpha;
  int spare = 0;  // the slot the next pair is written into
  auto clear = [&] { order.clear(), spare = 0; };
  int it = 0;
  for (; it < maxIter; ++it) {
    if (!(parallelSquaredNorm(g) > 0)) break;
    // Two-loop recursion.
    forEachElement(n, [&](Eigen::Index b, Eigen::Index e) {
      for (Eigen::Index i = b; i < e; ++i) d[i] = -g[i];
    });
    const int m = static_cast<int>(order.size());
    alpha.assign(static_cast<size_t>(m), 0.0);
    // (next: the dot product of the vector the next step reads with d)
    double next = m > 0 ? parallelDot(S[static_cast<size_t>(order.back())], d) : 0;
    for (int k = m - 1; k >= 0; --k) {
      const int q = order[static_cast<size_t>(k)];
      alpha[k] = rho[q] * next;
      const double a = alpha[k];
      const double* yq = Y[q].data();
      const auto step = [&](Eigen::Index b, Eigen::Index e) {
        for (Eigen::Index i = b; i < e; ++i) d[i] = d[i] - a * yq[i];
      };
      if (k > 0) next = updateThenDot(d, step, S[static_cast<size_t>(order[static_cast<size_t>(k) - 1])]);
      else forEachElement(n, step);
    }
    double gamma = 0;
    if (m == 0) {
      gamma = 1.0 / std::max(std::sqrt(parallelSquaredNorm(g)), 1e-300);
    } else {
      const int q = order.back();
      gamma = parallelDot(S[q], Y[q]) / parallelSquaredNorm(Y[q]);
    }
    // The last update is read by the slope g · d.
    auto reader = [&](int k) -> const Eigen::VectorXd& { return k < m ? Y[static_cast<size_t>(order[static_cast<size_t>(k)])] : g; };
    next = updateThenDot(
        d,
        [&](Eigen::Index b, Eigen::Index e) {
          for (Eigen::Index i = b; i < e; ++i) d[i] = d[i] * gamma;
        },
        reader(0));
    for (int k = 0; k < m; ++k) {
      const int q = order[static_cast<size_t>(k)];
      const double c = alpha[k] - rho[q] * next;
      const double* sq = S[q].data();
      next = updateThenDot(
          d,
          [&](Eigen::Index b, Eigen::Index e) {
            for (Eigen::Index i = b; i < e; ++i) d[i] = d[i] + sq[i] * c;
          },
          reader(k + 1));
    }
    double slope = next;  // g · d
    if (!(slope < 0)) {
      clear();
      const double norm = std::max(std::sqrt(parallelSquaredNorm(g)), 1e-300);
      forEachElement(n, [&](Eigen::Index b, Eigen::Index e) {
        for (Eigen::Index i = b; i < e; ++i) d[i] = -g[i] / norm;
      });
      slope = parallelDot(g, d);
    }
    double step = 1, fNew = 0;
    bool accepted = false;
    for (int ls = 0; ls < 40; ++ls, step *= 0.5) {
      forEachElement(n, [&](Eigen::Index b, Eigen::Index e) {
        for (Eigen::Index i = b; i < e; ++i) xNew[i] = x[i] + step * d[i];
      });
      fNew = fg(xNew, gNew);
      if (std::isfinite(fNew) && fNew <= f + 1e-4 * step * slope) {
        accepted = true;
        break;
      }
    }
    if (!accepted) {
      if (order.empty()) break;  // even steepest descent cannot decrease f
      clear();
      continue;
    }
    Eigen::VectorXd& s = S[static_cast<size_t>(spare)];
    Eigen::VectorXd& y = Y[static_cast<size_t>(spare)];
    s.resize(n), y.resize(n);
    forEachElement(n, [&](Eigen::Index b, Eigen::Index e) {
      for (Eigen::Index i = b; i < e; ++i) s[i] = xNew[i] - x[i], y[i] = gNew[i] - g[i];
    });
    const double sy = parallelDot(s, y);
    x.swap(xNew);
    g.swap(gNew);
    const double decrease = f - fNew;
    f = fNew;
    if (memory > 0 && sy > 1e-12 * std::sqrt(parallelSquaredNorm(s)) * std::sqrt(parallelSquaredNorm(y))) {
      rho[static_cast<size_t>(spare)] = 1 / sy;
      order.push_back(spare);
      // The next spare: the oldest pair's slot once the history is full;
      // until then (since the last clear, slots are used in turn) the next
      // unused one.
      if (static_cast<int>(order.size()) > memory) {
        spare = order.front();
        order.erase(order.begin());
      } else {
        spare = static_cast<int>(order.size());
      }
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

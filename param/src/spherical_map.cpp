// Spherical map of a genus-0 shell: fast spherical conformal map (Choi, Lam,
// Lui 2015) or Tutte embedding, Möbius normalisation, exact flip check.
#include "tet2spline/param/spherical_map.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_reduce.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <boost/math/tools/minima.hpp>
#include <cmath>
#include <cstdint>
#include <complex>
#include <limits>
#include <numeric>
#include <sstream>

#include "spd_solver.h"
#include "tet2spline/param/topology.h"

namespace tet2spline {

namespace {

using Triplets = std::vector<Eigen::Triplet<double>>;

// One closed, consistently oriented, connected, genus-0 shell; throws otherwise.
void requireSphereTopology(const SurfaceMesh& s) {
  const Eigen::Index nv = s.V.rows(), nf = s.F.rows();
  auto fail = [](const std::string& what) {
    throw Error(ErrorKind::Topology, "sphericalMap: " + what + "; a closed genus-0 shell is required");
  };
  if (nf < 4) fail("surface has " + std::to_string(nf) + " triangles");
  if (s.F.minCoeff() < 0 || s.F.maxCoeff() >= nv) fail("triangle vertex index out of range");
  std::vector<std::pair<int, int>> directed;
  directed.reserve(static_cast<size_t>(3 * nf));
  for (Eigen::Index f = 0; f < nf; ++f)
    for (int k = 0; k < 3; ++k) {
      const int a = s.F(f, k), b = s.F(f, (k + 1) % 3);
      if (a == b) fail("triangle " + std::to_string(f) + " repeats a vertex");
      directed.emplace_back(a, b);
    }
  std::sort(directed.begin(), directed.end());
  for (size_t e = 0; e + 1 < directed.size(); ++e)
    if (directed[e] == directed[e + 1])
      fail("edge (" + std::to_string(directed[e].first) + "," + std::to_string(directed[e].second) +
           ") is used twice in the same direction (non-manifold or inconsistently oriented)");
  for (const auto& [a, b] : directed)
    if (!std::binary_search(directed.begin(), directed.end(), std::make_pair(b, a)))
      fail("edge (" + std::to_string(a) + "," + std::to_string(b) + ") has one triangle (open surface)");
  // Connected, no unused vertex.
  std::vector<int> parent(static_cast<size_t>(nv));
  std::iota(parent.begin(), parent.end(), 0);
  auto find = [&](int x) {
    while (parent[x] != x) x = parent[x] = parent[parent[x]];
    return x;
  };
  std::vector<char> used(static_cast<size_t>(nv), 0);
  for (Eigen::Index f = 0; f < nf; ++f)
    for (int k = 0; k < 3; ++k) {
      used[s.F(f, k)] = 1;
      parent[find(s.F(f, k))] = find(s.F(f, (k + 1) % 3));
    }
  int components = 0;
  for (Eigen::Index v = 0; v < nv; ++v) {
    if (!used[v]) fail("vertex " + std::to_string(v) + " is not used by any triangle");
    if (find(static_cast<int>(v)) == v) ++components;
  }
  if (components != 1) fail("surface has " + std::to_string(components) + " connected components");
  const long chi = static_cast<long>(nv) - static_cast<long>(directed.size() / 2) + static_cast<long>(nf);
  if (chi != 2) fail("surface has Euler characteristic " + std::to_string(chi) + " (genus " + std::to_string((2 - chi) / 2) + ")");
}

// Cotangent (or, uniform == true, graph) Laplacian, positive semidefinite.
Eigen::SparseMatrix<double> surfaceLaplacian(const Eigen::MatrixX3d& V, const Eigen::MatrixX3i& F, bool uniform) {
  Triplets trip;
  trip.reserve(static_cast<size_t>(F.rows()) * 12);
  for (Eigen::Index f = 0; f < F.rows(); ++f)
    for (int k = 0; k < 3; ++k) {
      const int o = F(f, k), i = F(f, (k + 1) % 3), j = F(f, (k + 2) % 3);
      double w = 0.5;  // each undirected edge is seen from its two triangles
      if (!uniform) {
        const Eigen::Vector3d a = V.row(i) - V.row(o), b = V.row(j) - V.row(o);
        const double c = a.cross(b).norm();
        w = 0.5 * a.dot(b) / std::max(c, 1e-300);
      }
      trip.emplace_back(i, j, -w);
      trip.emplace_back(j, i, -w);
      trip.emplace_back(i, i, w);
      trip.emplace_back(j, j, w);
    }
  Eigen::SparseMatrix<double> L(V.rows(), V.rows());
  L.setFromTriplets(trip.begin(), trip.end());
  return L;
}

// The slot of entry (row, col) in the compressed column-major A's values
// (the entry must be in A's pattern).
int valueSlot(const Eigen::SparseMatrix<double>& A, int row, int col) {
  const int* first = A.innerIndexPtr() + A.outerIndexPtr()[col];
  const int* last = A.innerIndexPtr() + A.outerIndexPtr()[col + 1];
  return static_cast<int>(std::lower_bound(first, last, row) - A.innerIndexPtr());
}

// Solves A x = 0 on the rows not in `fixed`, with x(fixed) = values, for a
// sequence of matrices A of one sparsity pattern and the same fixed rows
// (the area correction's steps). A is symmetric and positive definite on
// the free block; empty on failure. The free block is built from triplets
// on the first call, with where each of its entries sits in A's values;
// later calls copy the values into it (the same matrix, bit for bit, as
// triplets would make) and keep the solver's symbolic analysis.
class RepeatedDirichlet {
 public:
  Eigen::MatrixXd solve(const Eigen::SparseMatrix<double>& A, const std::vector<int>& fixed,
                        const Eigen::MatrixXd& values) {
    const Eigen::Index n = A.rows();
    if (index_.size() != static_cast<size_t>(n)) {  // (the first call)
      index_.assign(static_cast<size_t>(n), 0);
      for (int v : fixed) index_[static_cast<size_t>(v)] = -1;
      int nfree = 0;
      for (auto& i : index_)
        if (i == 0) i = nfree++;
      Triplets trip;
      std::vector<int> from;  // per triplet, its slot in A's values
      for (Eigen::Index j = 0; j < n; ++j)
        for (int k = A.outerIndexPtr()[j]; k < A.outerIndexPtr()[j + 1]; ++k) {
          const int fi = index_[static_cast<size_t>(A.innerIndexPtr()[k])], fj = index_[static_cast<size_t>(j)];
          if (fi >= 0 && fj >= 0) trip.emplace_back(fi, fj, A.valuePtr()[k]), from.push_back(k);
        }
      Aii_.resize(nfree, nfree);
      Aii_.setFromTriplets(trip.begin(), trip.end());
      source_.assign(static_cast<size_t>(Aii_.nonZeros()), -1);
      for (size_t t = 0; t < trip.size(); ++t)
        source_[static_cast<size_t>(valueSlot(Aii_, trip[t].row(), trip[t].col()))] = from[t];
    } else {
      for (size_t q = 0; q < source_.size(); ++q) Aii_.valuePtr()[q] = A.valuePtr()[source_[q]];
    }
    // The fixed rows, and the right-hand side −A_free,fixed x_fixed summed
    // column by column.
    Eigen::MatrixXd X(n, values.cols());
    for (size_t k = 0; k < fixed.size(); ++k) X.row(fixed[k]) = values.row(static_cast<Eigen::Index>(k));
    Eigen::MatrixXd rhs = Eigen::MatrixXd::Zero(Aii_.rows(), values.cols());
    for (Eigen::Index j = 0; j < n; ++j) {
      if (index_[static_cast<size_t>(j)] >= 0) continue;
      for (int k = A.outerIndexPtr()[j]; k < A.outerIndexPtr()[j + 1]; ++k) {
        const int fi = index_[static_cast<size_t>(A.innerIndexPtr()[k])];
        if (fi >= 0) rhs.row(fi) -= A.valuePtr()[k] * X.row(j);
      }
    }
    if (!solver_.refactorize(Aii_)) return {};
    const Eigen::MatrixXd Xi = solver_.solve(rhs);
    if (!Xi.allFinite()) return {};
    for (Eigen::Index v = 0; v < n; ++v)
      if (index_[static_cast<size_t>(v)] >= 0) X.row(v) = Xi.row(index_[static_cast<size_t>(v)]);
    return X;
  }

 private:
  std::vector<int> index_;  // free vertex -> its row in the block, fixed -> -1 (empty before the first call)
  Eigen::SparseMatrix<double> Aii_;
  std::vector<int> source_;  // per value of Aii_, the slot in A's values it comes from
  detail::SpdSolver solver_;
};

// RepeatedDirichlet's solve for one matrix.
Eigen::MatrixXd dirichletSolve(const Eigen::SparseMatrix<double>& A, const std::vector<int>& fixed,
                               const Eigen::MatrixXd& values) {
  RepeatedDirichlet once;
  return once.solve(A, fixed, values);
}

// Per-element loops (the area correction's line search runs them 26 times a
// step) on both cores; sums stay sequential, so the results are the same
// bits as one core's. bunny00's shell, whole spherical map (machine
// otherwise idle): 16.6 s before this and the shared analysis below, 13.2 s
// with the analysis shared, 11.8-12.4 s with these loops too.
template <typename Body>
void forEachIndex(Eigen::Index n, const Body& body) {
  tbb::parallel_for(tbb::blocked_range<Eigen::Index>(0, n, 8192), [&](const tbb::blocked_range<Eigen::Index>& r) {
    for (Eigen::Index i = r.begin(); i != r.end(); ++i) body(i);
  });
}

// Inverse stereographic projection from the north pole: ∞ ↦ (0,0,1).
Eigen::MatrixX3d fromNorthPlane(const Eigen::MatrixXd& z) {
  Eigen::MatrixX3d S(z.rows(), 3);
  forEachIndex(z.rows(), [&](Eigen::Index i) {
    const double r2 = z(i, 0) * z(i, 0) + z(i, 1) * z(i, 1);
    S.row(i) << 2 * z(i, 0) / (1 + r2), 2 * z(i, 1) / (1 + r2), (r2 - 1) / (1 + r2);
  });
  return S;
}
// Stereographic projection from the south pole and its inverse.
Eigen::MatrixXd toSouthPlane(const Eigen::MatrixX3d& S) {
  Eigen::MatrixXd P(S.rows(), 2);
  for (Eigen::Index i = 0; i < S.rows(); ++i) P.row(i) << S(i, 0) / (1 + S(i, 2)), S(i, 1) / (1 + S(i, 2));
  return P;
}
Eigen::MatrixX3d fromSouthPlane(const Eigen::MatrixXd& P) {
  Eigen::MatrixX3d S(P.rows(), 3);
  for (Eigen::Index i = 0; i < P.rows(); ++i) {
    const double r2 = P(i, 0) * P(i, 0) + P(i, 1) * P(i, 1);
    S.row(i) << 2 * P(i, 0) / (1 + r2), 2 * P(i, 1) / (1 + r2), (1 - r2) / (1 + r2);
  }
  return S;
}

void normalizeRows(Eigen::MatrixX3d& U) {
  forEachIndex(U.rows(), [&](Eigen::Index i) { U.row(i) /= U.row(i).norm(); });
}

// Beltrami coefficient of the map from the plane P (#V×2) to the surface V,
// per triangle (Choi, Lam, Lui 2015, eq. for μ from the first fundamental form).
std::vector<std::complex<double>> beltrami(const Eigen::MatrixXd& P, const Eigen::MatrixX3d& V,
                                           const Eigen::MatrixX3i& F) {
  std::vector<std::complex<double>> mu(static_cast<size_t>(F.rows()));
  for (Eigen::Index f = 0; f < F.rows(); ++f) {
    Eigen::Matrix2d D;
    D.col(0) = (P.row(F(f, 1)) - P.row(F(f, 0))).transpose();
    D.col(1) = (P.row(F(f, 2)) - P.row(F(f, 0))).transpose();
    Eigen::Matrix<double, 3, 2> X;
    X.col(0) = (V.row(F(f, 1)) - V.row(F(f, 0))).transpose();
    X.col(1) = (V.row(F(f, 2)) - V.row(F(f, 0))).transpose();
    const Eigen::Matrix<double, 3, 2> J = X * D.inverse();
    const double E = J.col(0).squaredNorm(), G = J.col(1).squaredNorm(), Fm = J.col(0).dot(J.col(1));
    mu[static_cast<size_t>(f)] =
        std::complex<double>(E - G, 2 * Fm) / (E + G + 2 * std::sqrt(std::max(E * G - Fm * Fm, 0.0)));
    if (!std::isfinite(std::abs(mu[static_cast<size_t>(f)])) || std::abs(mu[static_cast<size_t>(f)]) >= 1)
      mu[static_cast<size_t>(f)] = 0;
  }
  return mu;
}

// Linear Beltrami solver: the generalised Laplacian ∇·(A_μ ∇·) on the plane P.
Eigen::SparseMatrix<double> beltramiMatrix(const Eigen::MatrixXd& P, const Eigen::MatrixX3i& F,
                                           const std::vector<std::complex<double>>& mu) {
  Triplets trip;
  trip.reserve(static_cast<size_t>(F.rows()) * 9);
  for (Eigen::Index f = 0; f < F.rows(); ++f) {
    const std::complex<double> m = mu[static_cast<size_t>(f)];
    const double n2 = std::norm(m);
    const double af = (1 - 2 * m.real() + n2) / (1 - n2), bf = -2 * m.imag() / (1 - n2),
                 gf = (1 + 2 * m.real() + n2) / (1 - n2);
    double ux[3], uy[3];
    for (int k = 0; k < 3; ++k) {
      const int b = F(f, (k + 1) % 3), c = F(f, (k + 2) % 3);
      ux[k] = P(b, 1) - P(c, 1);
      uy[k] = P(c, 0) - P(b, 0);
    }
    const double area = 0.5 * std::abs((P(F(f, 1), 0) - P(F(f, 0), 0)) * (P(F(f, 2), 1) - P(F(f, 0), 1)) -
                                       (P(F(f, 2), 0) - P(F(f, 0), 0)) * (P(F(f, 1), 1) - P(F(f, 0), 1)));
    if (!(area > 0)) continue;
    for (int a = 0; a < 3; ++a)
      for (int b = 0; b < 3; ++b) {
        const double v = (af * ux[a] * ux[b] + bf * (ux[a] * uy[b] + ux[b] * uy[a]) + gf * uy[a] * uy[b]) / (4 * area);
        trip.emplace_back(F(f, a), F(f, b), v);
      }
  }
  Eigen::SparseMatrix<double> A(P.rows(), P.rows());
  A.setFromTriplets(trip.begin(), trip.end());
  return A;
}

// Chordal area of each triangle of U.
Eigen::VectorXd chordAreas(const Eigen::MatrixX3d& U, const Eigen::MatrixX3i& F) {
  Eigen::VectorXd a(F.rows());
  forEachIndex(F.rows(), [&](Eigen::Index f) {
    a[f] = 0.5 * (U.row(F(f, 1)) - U.row(F(f, 0))).cross(U.row(F(f, 2)) - U.row(F(f, 0))).norm();
  });
  return a;
}

// Third of the input area around each vertex: the masses of the mass centre.
Eigen::VectorXd vertexMasses(const Eigen::MatrixX3d& V, const Eigen::MatrixX3i& F) {
  const Eigen::VectorXd a = chordAreas(V, F);
  Eigen::VectorXd m = Eigen::VectorXd::Zero(V.rows());
  for (Eigen::Index f = 0; f < F.rows(); ++f)
    for (int k = 0; k < 3; ++k) m[F(f, k)] += a[f] / 3;
  return m;
}

// Möbius normalisation; returns iterations used, sets offset to the final |c|.
int mobiusNormalize(Eigen::MatrixX3d& U, const Eigen::VectorXd& m, double tol, int maxIter, double& offset) {
  const double total = m.sum();
  int it = 0;
  for (;; ++it) {
    const Eigen::Vector3d c = (U.transpose() * m) / total;
    offset = c.norm();
    if (offset < tol || it >= maxIter || !std::isfinite(offset)) break;
    const double c2 = c.squaredNorm();
    for (Eigen::Index i = 0; i < U.rows(); ++i) {
      const Eigen::Vector3d u = U.row(i).transpose();
      const Eigen::Vector3d d = u - c;
      const Eigen::Vector3d x = ((1 - c2) * d - d.squaredNorm() * c) / d.squaredNorm();
      U.row(i) = x.normalized().transpose();
    }
  }
  return it;
}

// Vertex neighbours (sorted, unique) of a triangle surface.
std::vector<std::vector<int>> neighbours(Eigen::Index nv, const Eigen::MatrixX3i& F) {
  std::vector<std::vector<int>> nb(static_cast<size_t>(nv));
  for (Eigen::Index f = 0; f < F.rows(); ++f)
    for (int k = 0; k < 3; ++k) nb[F(f, k)].push_back(F(f, (k + 1) % 3)), nb[F(f, k)].push_back(F(f, (k + 2) % 3));
  for (auto& n : nb) {
    std::sort(n.begin(), n.end());
    n.erase(std::unique(n.begin(), n.end()), n.end());
  }
  return nb;
}

// The flipped triangles, in index order (tested in fixed chunks on both
// cores, the chunks' lists then joined in order).
std::vector<int> flippedTriangleList(const Eigen::MatrixX3d& U, const Eigen::MatrixX3i& F) {
  constexpr Eigen::Index kChunk = 16384;
  const Eigen::Index chunks = (F.rows() + kChunk - 1) / kChunk;
  std::vector<std::vector<int>> parts(static_cast<size_t>(chunks));
  tbb::parallel_for(Eigen::Index(0), chunks, [&](Eigen::Index c) {
    const double o[3] = {0, 0, 0};
    for (Eigen::Index f = c * kChunk, end = std::min(F.rows(), (c + 1) * kChunk); f < end; ++f) {
      const Eigen::Vector3d a = U.row(F(f, 0)), b = U.row(F(f, 1)), c3 = U.row(F(f, 2));
      if (orient3d(o, a.data(), b.data(), c3.data()) <= 0) parts[static_cast<size_t>(c)].push_back(static_cast<int>(f));
    }
  });
  std::vector<int> out;
  for (const auto& part : parts) out.insert(out.end(), part.begin(), part.end());
  return out;
}

// Local spherical Tutte relaxation around flipped triangles, growing the
// region while flips remain. Returns the remaining exact flip count. `nb`:
// neighbours(U.rows(), F), which a caller repairing several maps of one
// surface builds once (the area correction: 9 repairs on bunny00's shell).
int repairFlips(Eigen::MatrixX3d& U, const Eigen::MatrixX3i& F, int maxSweeps,
                const std::vector<std::vector<int>>& nb) {
  std::vector<int> flipped = flippedTriangleList(U, F);
  int rings = 1;
  for (int sweep = 0; sweep < maxSweeps && !flipped.empty(); ++sweep) {
    std::vector<char> in(static_cast<size_t>(U.rows()), 0);
    std::vector<int> region;
    for (int f : flipped)
      for (int k = 0; k < 3; ++k)
        if (!in[F(f, k)]) in[F(f, k)] = 1, region.push_back(F(f, k));
    for (int r = 0; r < rings; ++r) {
      const size_t n = region.size();
      for (size_t k = 0; k < n; ++k)
        for (int j : nb[region[k]])
          if (!in[j]) in[j] = 1, region.push_back(j);
    }
    for (int gs = 0; gs < 10; ++gs)
      for (int v : region) {
        Eigen::Vector3d s = Eigen::Vector3d::Zero();
        for (int j : nb[v]) s += U.row(j).transpose();
        if (s.norm() > 0) U.row(v) = s.normalized().transpose();
      }
    const std::vector<int> next = flippedTriangleList(U, F);
    if (next.size() >= flipped.size()) rings = std::min(rings * 2, 64);
    flipped = next;
  }
  return static_cast<int>(flipped.size());
}
int repairFlips(Eigen::MatrixX3d& U, const Eigen::MatrixX3i& F, int maxSweeps) {
  return repairFlips(U, F, maxSweeps, neighbours(U.rows(), F));
}

// σ_f = (a_f / Σa) / (A_f / ΣA): mapped over input area share, for every
// triangle but `skip` (σ = 1 there; skip < 0: every triangle counts).
Eigen::VectorXd areaShareRatios(const Eigen::MatrixX3d& U, const Eigen::MatrixX3i& F, const Eigen::VectorXd& inputShare,
                                Eigen::Index skip = -1) {
  Eigen::VectorXd a = chordAreas(U, F);
  if (skip >= 0) a[skip] = 0;
  a /= a.sum();
  Eigen::VectorXd sigma = a.cwiseQuotient(inputShare);
  if (skip >= 0) sigma[skip] = 1;
  return sigma;
}

// Kullback-Leibler divergence of the mapped area shares from the input ones,
// Σ A_f log(1/σ_f) / ΣA (≥ 0, 0 only for an equiareal map); +inf if a triangle is flat.
double areaDivergence(const Eigen::VectorXd& sigma, const Eigen::VectorXd& inputShare) {
  Eigen::VectorXd logs(sigma.size());
  forEachIndex(sigma.size(), [&](Eigen::Index f) { logs[f] = std::log(sigma[f]); });
  double d = 0;
  for (Eigen::Index f = 0; f < sigma.size(); ++f) d -= inputShare[f] * logs[f];
  return std::isfinite(d) ? d : std::numeric_limits<double>::infinity();
}

struct AreaCorrection {
  int iterations = 0;          // steps until the one kept
  double divergenceAfter = 0;  // of the map kept (over every triangle but the cut one)
};

// Area correction of a bijective spherical map by reweighted Tutte embeddings.
// The sphere is cut open at its largest triangle p and projected
// stereographically from p's centre, so the plane holds every other triangle
// inside the fixed triangle p. Each step solves L_s z = 0 with p fixed, for the
// Laplacian with positive weights s_f·max(cot θ, 0.05)/2 (θ the input angles),
// then multiplies s_f by σ_f^{1/2}: a triangle with too little area gets
// softer and grows. Positive weights and a convex boundary make every step a
// planar embedding (Tutte; Floater 2003), so the map stays bijective; the
// plane's scale (a Möbius transformation of the sphere) is chosen to minimise
// the area divergence. A planar embedding can still flip a chord triangle on
// the sphere (one whose circumcircle is nearly a great circle): the result is
// the step of lowest divergence that is flip-free (exact check, after a short
// local repair). The iteration stops after five steps without progress, or
// after three in a row that each rose above the step before.
// `share`: the input area shares (chordAreas(V, F), summing to 1).
AreaCorrection correctAreas(Eigen::MatrixX3d& U, const Eigen::MatrixX3d& V, const Eigen::MatrixX3i& F,
                            const Eigen::VectorXd& share, const SphericalMapOptions& options) {
  AreaCorrection out;
  const Eigen::Index nv = V.rows(), nf = F.rows();
  Eigen::Index p = 0;
  chordAreas(U, F).maxCoeff(&p);
  Eigen::VectorXd sigma = areaShareRatios(U, F, share, p);
  out.divergenceAfter = areaDivergence(sigma, share);
  if (options.areaCorrectionIterations <= 0 || !std::isfinite(out.divergenceAfter)) return out;

  const Eigen::Vector3d centre = (U.row(F(p, 0)) + U.row(F(p, 1)) + U.row(F(p, 2))).transpose().normalized();
  const Eigen::Matrix3d R = Eigen::Quaterniond::FromTwoVectors(centre, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  auto toPlane = [&](const Eigen::MatrixX3d& S) {
    const Eigen::MatrixX3d Q = S * R.transpose();
    Eigen::MatrixXd z(nv, 2);
    for (Eigen::Index i = 0; i < nv; ++i) {
      // 1 − q_z without cancellation near the pole: (q_x² + q_y²) / (1 + q_z).
      const double rho2 = Q(i, 0) * Q(i, 0) + Q(i, 1) * Q(i, 1);
      const double below = Q(i, 2) > 0 ? rho2 / (1 + Q(i, 2)) : 1 - Q(i, 2);
      z.row(i) << Q(i, 0) / below, Q(i, 1) / below;
    }
    return z;
  };
  auto toSphere = [&](const Eigen::MatrixXd& z) {
    Eigen::MatrixX3d S = fromNorthPlane(z) * R;
    normalizeRows(S);
    return S;
  };
  // Base weights, per triangle corner (the edge opposite it).
  Eigen::MatrixX3d base(nf, 3);
  for (Eigen::Index f = 0; f < nf; ++f)
    for (int k = 0; k < 3; ++k) {
      const Eigen::Vector3d a = V.row(F(f, (k + 1) % 3)) - V.row(F(f, k)), b = V.row(F(f, (k + 2) % 3)) - V.row(F(f, k));
      base(f, k) = 0.5 * std::max(a.dot(b) / std::max(a.cross(b).norm(), 1e-300), 0.05);
    }
  const std::vector<int> fixed = {F(p, 0), F(p, 1), F(p, 2)};
  // Every step's free block has the same pattern (positive weights on the
  // same edges): one symbolic analysis serves them all, and the maps are the
  // same bits. Measured on bunny00's shell (113k vertices, machine otherwise
  // idle): the steps' solves took 11.6 s with an analysis (AMD ordering,
  // workspace) each, 7.8 s sharing one. What is left is the numeric
  // factorisation (3.2M entries in the factor); METIS or CHOLMOD's nested
  // dissection orderings make that factor only 10% smaller.
  RepeatedDirichlet solver;
  // The steps' Laplacians share that pattern too: the first is built from
  // triplets, and each later one adds its weights straight into the first's
  // values, in the triplets' order, which is the order in which
  // setFromTriplets sums an entry's duplicates (the same bits). Measured
  // on bunny00's shell (`param` on its TetGen mesh, three runs each,
  // alternating, the same maps): the spherical map 14.3, 11.7, 12.4 ->
  // 8.6, 10.1, 10.0 s.
  Eigen::SparseMatrix<double> L(nv, nv);
  std::vector<int> lSlot;  // per triplet of the first step, its slot in L's values
  // One reweighted Tutte step from the plane z with weights `soft`: the new
  // map on the sphere (not checked for flips here), or empty if the solve failed.
  // The Laplacian's contributions, (row, column, value), in the triplets' order.
  auto forEachEntry = [&](const Eigen::VectorXd& soft, const auto& add) {
    for (Eigen::Index f = 0; f < nf; ++f) {
      if (f == p) continue;
      for (int k = 0; k < 3; ++k) {
        const int i = F(f, (k + 1) % 3), j = F(f, (k + 2) % 3);
        const double w = soft[f] * base(f, k);
        add(i, j, -w);
        add(j, i, -w);
        add(i, i, w);
        add(j, j, w);
      }
    }
  };
  auto step = [&](const Eigen::MatrixXd& z, const Eigen::VectorXd& soft) -> Eigen::MatrixX3d {
    if (lSlot.empty()) {
      Triplets trip;
      trip.reserve(static_cast<size_t>(nf) * 12);
      forEachEntry(soft, [&](int i, int j, double w) { trip.emplace_back(i, j, w); });
      L.setFromTriplets(trip.begin(), trip.end());
      lSlot.resize(trip.size());
      for (size_t t = 0; t < trip.size(); ++t) lSlot[t] = valueSlot(L, trip[t].row(), trip[t].col());
    } else {
      double* value = L.valuePtr();
      std::fill(value, value + L.nonZeros(), 0.0);  // (0 + x is x: every weight is positive)
      size_t t = 0;
      forEachEntry(soft, [&](int, int, double w) { value[lSlot[t++]] += w; });
    }
    Eigen::MatrixXd corners(3, 2);
    for (int k = 0; k < 3; ++k) corners.row(k) = z.row(fixed[static_cast<size_t>(k)]);
    const Eigen::MatrixXd next = solver.solve(L, fixed, corners);
    if (next.size() == 0 || !next.allFinite()) return {};
    // The plane's scale: Brent's minimisation (parabolic steps, golden
    // section where they fail) on log λ in [−4, 4], to within about 6·10⁻⁵
    // (15 bits), as fine as the golden-section search it replaces (26
    // divergences per step, to 7.6·10⁻⁵). Measured: 8 or 9 divergences per
    // step; on blob-closed's 30 steps the two searches' log λ agree to
    // 3·10⁻⁵ and their divergences to 10⁻¹⁰ (relative); bunny00's
    // spherical map (`param` on its TetGen mesh) 9.5 -> 7.7 s, and again
    // when it landed (every map's last bits change): 10.45 -> 9.01 s.
    auto divergenceAt = [&](double logScale) {
      return areaDivergence(areaShareRatios(toSphere(next * std::exp(logScale)), F, share, p), share);
    };
    std::uintmax_t evaluations = 50;
    const double logScale = boost::math::tools::brent_find_minima(divergenceAt, -4.0, 4.0, 15, evaluations).first;
    return Eigen::MatrixX3d(toSphere(next * std::exp(logScale)));
  };
  Eigen::VectorXd soft = Eigen::VectorXd::Ones(nf);
  Eigen::MatrixXd z = toPlane(U);
  Eigen::MatrixX3d best;
  std::vector<std::vector<int>> nb;  // (for repairFlips; built when first needed)
  double lastDivergence = out.divergenceAfter;
  // Steps since the lowest divergence so far, and rises in a row (each
  // step's divergence above the step's before it). Three rises in a row end
  // it too: measured on the ten genus-0 meshes of the test data, no step
  // after three rises came below the lowest before them, and the ends of
  // bunny00, homer, retinal and triceratops (two steps each, 0.3 s a step
  // on bunny00's shell) and of spool (one) were such runs.
  int sinceProgress = 0, rises = 0;
  double previous = std::numeric_limits<double>::infinity();
  for (int it = 0; it < options.areaCorrectionIterations && sinceProgress < 5 && rises < 3; ++it) {
    soft = soft.cwiseProduct(sigma.cwiseSqrt());
    soft /= soft.maxCoeff();
    soft = soft.cwiseMax(1e-30);  // positive weights keep the Tutte guarantee
    Eigen::MatrixX3d next = step(z, soft);
    if (next.size() == 0) break;
    z = toPlane(next);
    sigma = areaShareRatios(next, F, share, p);
    const double d = areaDivergence(sigma, share);
    if (!std::isfinite(d)) break;
    sinceProgress = d < lastDivergence ? 0 : sinceProgress + 1;
    rises = d > previous ? rises + 1 : 0;
    previous = d;
    lastDivergence = std::min(lastDivergence, d);
    if (!(d < out.divergenceAfter)) continue;
    // Candidate: must be flip-free on the sphere, after a short local repair.
    double repaired = d;
    if (countFlippedSphereTriangles(next, F) > 0) {
      if (nb.empty()) nb = neighbours(nv, F);
      if (repairFlips(next, F, 20, nb) > 0) continue;
      repaired = areaDivergence(areaShareRatios(next, F, share, p), share);
      if (!(repaired < out.divergenceAfter)) continue;
    }
    best = std::move(next);
    out.divergenceAfter = repaired;
    out.iterations = it + 1;
    if (repaired < options.areaCorrectionTolerance) break;
  }
  if (out.iterations > 0) U = std::move(best);
  return out;
}

}  // namespace

int countFlippedSphereTriangles(const Eigen::MatrixX3d& U, const Eigen::MatrixX3i& F) {
  return tbb::parallel_reduce(
      tbb::blocked_range<Eigen::Index>(0, F.rows(), 4096), 0,
      [&](const tbb::blocked_range<Eigen::Index>& r, int count) {
        const double o[3] = {0, 0, 0};
        for (Eigen::Index f = r.begin(); f != r.end(); ++f) {
          const Eigen::Vector3d a = U.row(F(f, 0)), b = U.row(F(f, 1)), c = U.row(F(f, 2));
          if (orient3d(o, a.data(), b.data(), c.data()) <= 0) ++count;
        }
        return count;
      },
      [](int a, int b) { return a + b; });
}

Eigen::VectorXd triangleAngleDistortion(const Eigen::MatrixX3d& V, const Eigen::MatrixX3d& U,
                                        const Eigen::MatrixX3i& F) {
  Eigen::VectorXd K(F.rows());
  // Edges of a triangle in its own orthonormal frame: columns (e1, e2).
  auto frame = [](const Eigen::Vector3d& e1, const Eigen::Vector3d& e2) {
    Eigen::Matrix2d M;
    const double l = e1.norm();
    M << l, e1.dot(e2) / l, 0, e1.cross(e2).norm() / l;
    return M;
  };
  tbb::parallel_for(tbb::blocked_range<Eigen::Index>(0, F.rows(), 4096), [&](const tbb::blocked_range<Eigen::Index>& r) {
    for (Eigen::Index f = r.begin(); f != r.end(); ++f) {
      const Eigen::Matrix2d X = frame(V.row(F(f, 1)) - V.row(F(f, 0)), V.row(F(f, 2)) - V.row(F(f, 0)));
      const Eigen::Matrix2d Y = frame(U.row(F(f, 1)) - U.row(F(f, 0)), U.row(F(f, 2)) - U.row(F(f, 0)));
      const Eigen::Matrix2d J = Y * X.inverse();
      const double fro2 = J.squaredNorm(), det = std::abs(J.determinant());
      if (!(det > 0) || !std::isfinite(fro2)) {
        K[f] = std::numeric_limits<double>::infinity();
        continue;
      }
      const double q = fro2 / det;  // σ1/σ2 + σ2/σ1
      K[f] = 0.5 * (q + std::sqrt(std::max(q * q - 4, 0.0)));
    }
  });
  return K;
}

SphericalMapResult sphericalMap(const SurfaceMesh& surface, const SphericalMapOptions& options) {
  requireSphereTopology(surface);
  const Eigen::MatrixX3d& V = surface.V;
  const Eigen::MatrixX3i& F = surface.F;
  const Eigen::Index nv = V.rows(), nf = F.rows();
  SphericalMapResult result;
  auto stopped = [&](double fraction, const std::string& what) {
    if (options.progress && !options.progress(fraction, what)) {
      result.status = Status::failure("sphericalMap: stopped by the progress callback after " + what);
      return true;
    }
    return false;
  };

  // The puncture: the most regular triangle (edge lengths closest to equal).
  int big = 0;
  double best = std::numeric_limits<double>::infinity();
  for (Eigen::Index f = 0; f < nf; ++f) {
    double l[3], s = 0;
    for (int k = 0; k < 3; ++k) s += l[k] = (V.row(F(f, (k + 1) % 3)) - V.row(F(f, k))).norm();
    double reg = 0;
    for (double x : l) reg += std::abs(x / s - 1.0 / 3);
    if (reg < best - 1e-9) best = reg, big = static_cast<int>(f);  // ties (within rounding): lowest index, so rigid motions pick the same
  }
  const std::vector<int> puncture = {F(big, 0), F(big, 1), F(big, 2)};
  // The puncture triangle, similar to the input one, counter-clockwise.
  Eigen::MatrixXd corners(3, 2);
  {
    const Eigen::Vector3d a = V.row(puncture[1]) - V.row(puncture[0]), b = V.row(puncture[2]) - V.row(puncture[0]);
    const double la = a.norm();
    corners << 0, 0, 1, 0, a.dot(b) / (la * la), a.cross(b).norm() / (la * la);
  }
  const Eigen::VectorXd masses = vertexMasses(V, F);

  auto finish = [&](Eigen::MatrixX3d U, const std::string& method) {
    normalizeRows(U);
    result.mobiusIterations =
        mobiusNormalize(U, masses, options.maxCentreOffset, options.maxMobiusIterations, result.centreOffset);
    normalizeRows(U);
    result.U = std::move(U);
    result.method = method;
    result.flippedTriangles = countFlippedSphereTriangles(result.U, F);
  };

  bool done = false;
  if (options.conformal) {
    // North pole step: cotangent Laplace equation with the puncture fixed.
    const Eigen::MatrixXd z0 = dirichletSolve(surfaceLaplacian(V, F, false), puncture, corners);
    if (z0.size() > 0) {
      Eigen::MatrixXd z = z0.rowwise() - z0.colwise().mean();
      // Balance the sizes of the northernmost and southernmost triangles.
      const Eigen::MatrixXd w = toSouthPlane(fromNorthPlane(z));
      Eigen::Index inner = -1;
      double innerDist = std::numeric_limits<double>::infinity();
      for (Eigen::Index f = 0; f < nf; ++f) {
        if (f == big) continue;
        double d = 0;
        for (int k = 0; k < 3; ++k) d += z.row(F(f, k)).norm();
        if (d < innerDist) innerDist = d, inner = f;
      }
      auto side = [&](const Eigen::MatrixXd& X, Eigen::Index f) {
        double s = 0;
        for (int k = 0; k < 3; ++k) s += (X.row(F(f, (k + 1) % 3)) - X.row(F(f, k))).norm();
        return s / 3;
      };
      const double north = side(z, big), south = side(w, inner);
      if (north > 0 && south > 0) z *= std::sqrt(north * south) / north;
      Eigen::MatrixX3d S = fromNorthPlane(z);
      if (!stopped(0.3, "north pole step")) {
        // South pole step: linear Beltrami solve removing the distortion near the puncture.
        const Eigen::MatrixXd P = toSouthPlane(S);
        std::vector<int> order(static_cast<size_t>(nv));
        std::iota(order.begin(), order.end(), 0);
        const size_t fixnum = std::min<size_t>(static_cast<size_t>(nv), std::max<size_t>(static_cast<size_t>(nv) / 10, 3));
        std::partial_sort(order.begin(), order.begin() + static_cast<long>(fixnum), order.end(),
                          [&](int a, int b) { return S(a, 2) < S(b, 2) || (S(a, 2) == S(b, 2) && a < b); });
        std::vector<int> fixed(order.begin(), order.begin() + static_cast<long>(fixnum));
        Eigen::MatrixXd targets(static_cast<Eigen::Index>(fixnum), 2);
        for (size_t k = 0; k < fixnum; ++k) targets.row(static_cast<Eigen::Index>(k)) = P.row(fixed[k]);
        const Eigen::MatrixXd Q = dirichletSolve(beltramiMatrix(P, F, beltrami(P, V, F)), fixed, targets);
        if (Q.size() > 0) {
          finish(fromSouthPlane(Q), "conformal");
          done = result.flippedTriangles == 0;
        }
        if (!done) {  // the north pole step alone, before giving up on conformality
          const SphericalMapResult keep = result;
          finish(S, "conformal (north pole step only)");
          done = result.flippedTriangles == 0;
          if (!done && keep.U.size() > 0 && keep.flippedTriangles < result.flippedTriangles) result = keep;
        }
      } else {
        return result;
      }
    }
    if (!done && result.U.size() > 0 && result.flippedTriangles > 0) {
      // A few triangles flipped by negative cotangent weights (or rounding
      // near the puncture): relax them locally with positive weights and keep
      // the rest conformal. Far less distortion than a global Tutte embedding.
      SphericalMapResult keep = result;
      const int left = repairFlips(keep.U, F, options.maxRepairSweeps);
      if (left == 0) {
        finish(keep.U, result.method + "+repair");
        if (result.flippedTriangles > 0) result.flippedTriangles = repairFlips(result.U, F, options.maxRepairSweeps);
        normalizeRows(result.U);
        result.flippedTriangles = countFlippedSphereTriangles(result.U, F);
        done = result.flippedTriangles == 0;
      }
    }
    if (stopped(0.7, "conformal map")) return result;
  }
  if (!done) {
    // Tutte embedding: bijective onto the puncture triangle, then the sphere.
    const Eigen::MatrixXd z0 = dirichletSolve(surfaceLaplacian(V, F, true), puncture, corners);
    if (z0.size() == 0) {
      result.status = Status::failure("sphericalMap: the Tutte system could not be factorised");
      return result;
    }
    const Eigen::MatrixXd z = z0.rowwise() - z0.colwise().mean();
    finish(fromNorthPlane(z), "tutte");
    if (result.flippedTriangles > 0) {
      result.flippedTriangles = repairFlips(result.U, F, options.maxRepairSweeps);
      Eigen::MatrixX3d U = result.U;
      finish(U, "tutte+repair");
      if (result.flippedTriangles > 0) result.flippedTriangles = repairFlips(result.U, F, options.maxRepairSweeps);
      normalizeRows(result.U);
      result.flippedTriangles = countFlippedSphereTriangles(result.U, F);
    }
  }
  // Mapped over input area share per triangle, and its divergence (correctAreas).
  Eigen::VectorXd share = chordAreas(V, F);
  share /= share.sum();
  result.areaDivergenceBefore = areaDivergence(areaShareRatios(result.U, F, share), share);
  if (result.flippedTriangles == 0 && options.areaCorrectionIterations > 0) {
    if (stopped(0.8, result.method + " map")) return result;
    const AreaCorrection area = correctAreas(result.U, V, F, share, options);
    result.areaCorrectionIterations = area.iterations;
    if (area.iterations > 0) {
      result.method += "+area";
      result.flippedTriangles = countFlippedSphereTriangles(result.U, F);
      result.centreOffset = ((result.U.transpose() * masses) / masses.sum()).norm();
    }
  }
  const Eigen::VectorXd sigma = areaShareRatios(result.U, F, share);
  result.areaDivergence = areaDivergence(sigma, share);
  result.areaRatioMin = sigma.minCoeff();
  result.areaRatioMax = sigma.maxCoeff();
  const Eigen::VectorXd K = triangleAngleDistortion(V, result.U, F);
  result.angleDistortionMean = K.mean();
  result.angleDistortionMax = K.maxCoeff();
  if (result.flippedTriangles > 0)
    result.status = Status::failure("sphericalMap: " + std::to_string(result.flippedTriangles) +
                                    " triangles remain flipped on the sphere (" + result.method + ")");
  stopped(1.0, "spherical map");
  return result;
}

}  // namespace tet2spline

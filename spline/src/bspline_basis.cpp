#include <tet2spline/spline/bspline_basis.h>

#include <tet2spline/param/error.h>

#include <Eigen/LU>
#include <array>
#include <cmath>
#include <string>

namespace tet2spline::spline {
namespace {
void checkDegree(const KnotVector& U, const char* who) {
  if (U.degree() > kMaxDegree) {
    throw Error(ErrorKind::Usage, std::string(who) + ": degree " + std::to_string(U.degree()) +
                                      " exceeds the supported maximum " + std::to_string(kMaxDegree));
  }
}
}  // namespace

void basisFunctions(const KnotVector& U, int s, double u, double* N) {
  const int p = U.degree();
  std::array<double, kMaxDegree + 1> left{}, right{};
  N[0] = 1.0;
  for (int j = 1; j <= p; ++j) {
    left[j] = u - U[s + 1 - j];
    right[j] = U[s + j] - u;
    double saved = 0.0;
    for (int r = 0; r < j; ++r) {
      const double temp = N[r] / (right[r + 1] + left[j - r]);
      N[r] = saved + right[r + 1] * temp;
      saved = left[j - r] * temp;
    }
    N[j] = saved;
  }
}

void basisDerivatives(const KnotVector& U, int s, double u, int k, double* ders) {
  const int p = U.degree();
  checkDegree(U, "basisDerivatives");
  constexpr int M = kMaxDegree + 1;
  double ndu[M][M];
  double a[2][M];
  std::array<double, M> left{}, right{};
  ndu[0][0] = 1.0;
  for (int j = 1; j <= p; ++j) {
    left[j] = u - U[s + 1 - j];
    right[j] = U[s + j] - u;
    double saved = 0.0;
    for (int r = 0; r < j; ++r) {
      ndu[j][r] = right[r + 1] + left[j - r];  // lower triangle: knot differences
      const double temp = ndu[r][j - 1] / ndu[j][r];
      ndu[r][j] = saved + right[r + 1] * temp;  // upper triangle: basis functions
      saved = left[j - r] * temp;
    }
    ndu[j][j] = saved;
  }
  const int w = p + 1;
  for (int j = 0; j <= p; ++j) ders[j] = ndu[j][p];
  const int kk = std::min(k, p);
  for (int d = p + 1; d <= k; ++d)
    for (int j = 0; j <= p; ++j) ders[d * w + j] = 0.0;
  for (int r = 0; r <= p; ++r) {
    int s1 = 0, s2 = 1;
    a[0][0] = 1.0;
    for (int d = 1; d <= kk; ++d) {
      double dd = 0.0;
      const int rk = r - d, pk = p - d;
      if (r >= d) {
        a[s2][0] = a[s1][0] / ndu[pk + 1][rk];
        dd = a[s2][0] * ndu[rk][pk];
      }
      const int j1 = rk >= -1 ? 1 : -rk;
      const int j2 = (r - 1 <= pk) ? d - 1 : p - r;
      for (int j = j1; j <= j2; ++j) {
        a[s2][j] = (a[s1][j] - a[s1][j - 1]) / ndu[pk + 1][rk + j];
        dd += a[s2][j] * ndu[rk + j][pk];
      }
      if (r <= pk) {
        a[s2][d] = -a[s1][d - 1] / ndu[pk + 1][r];
        dd += a[s2][d] * ndu[r][pk];
      }
      ders[d * w + r] = dd;
      std::swap(s1, s2);
    }
  }
  double f = p;
  for (int d = 1; d <= kk; ++d) {
    for (int j = 0; j <= p; ++j) ders[d * w + j] *= f;
    f *= (p - d);
  }
}

Eigen::MatrixXd basisDerivatives(const KnotVector& U, int s, double u, int k) {
  const int w = U.degree() + 1;
  Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor> d(k + 1, w);
  basisDerivatives(U, s, u, k, d.data());
  return d;
}

Eigen::MatrixXd basisMatrix(const KnotVector& U, const Eigen::VectorXd& u, int derivative) {
  const int p = U.degree(), w = p + 1;
  Eigen::MatrixXd B = Eigen::MatrixXd::Zero(u.size(), U.numBasis());
  std::vector<double> d(static_cast<size_t>((derivative + 1) * w));
  for (Eigen::Index r = 0; r < u.size(); ++r) {
    const int s = U.findSpan(u[r]);
    basisDerivatives(U, s, u[r], derivative, d.data());
    for (int j = 0; j <= p; ++j) B(r, s - p + j) = d[static_cast<size_t>(derivative * w + j)];
  }
  return B;
}

GaussRule gaussLegendre(int n, double a, double b) {
  if (n < 1) throw Error(ErrorKind::Usage, "gaussLegendre: " + std::to_string(n) + " points");
  GaussRule g;
  g.points.resize(n);
  g.weights.resize(n);
  // Newton on the Legendre polynomial P_n from Chebyshev-like initial guesses.
  for (int i = 0; i < (n + 1) / 2; ++i) {
    double x = std::cos(M_PI * (i + 0.75) / (n + 0.5));
    double dp = 1.0;
    for (int it = 0; it < 100; ++it) {
      double p0 = 1.0, p1 = x;
      for (int k = 2; k <= n; ++k) {
        const double p2 = ((2.0 * k - 1.0) * x * p1 - (k - 1.0) * p0) / k;
        p0 = p1;
        p1 = p2;
      }
      if (n == 1) { p1 = x; p0 = 1.0; }
      dp = n * (x * p1 - p0) / (x * x - 1.0);
      const double dx = p1 / dp;
      x -= dx;
      if (std::abs(dx) < 1e-16) break;
    }
    {
      double p0 = 1.0, p1 = x;
      for (int k = 2; k <= n; ++k) {
        const double p2 = ((2.0 * k - 1.0) * x * p1 - (k - 1.0) * p0) / k;
        p0 = p1;
        p1 = p2;
      }
      if (n == 1) { p1 = x; p0 = 1.0; }
      dp = n * (x * p1 - p0) / (x * x - 1.0);
    }
    const double wgt = 2.0 / ((1.0 - x * x) * dp * dp);
    g.points[i] = -x;
    g.points[n - 1 - i] = x;
    g.weights[i] = g.weights[n - 1 - i] = wgt;
  }
  if (n % 2 == 1) g.points[n / 2] = 0.0;
  const double h = 0.5 * (b - a), c = 0.5 * (a + b);
  g.points = (g.points.array() * h + c).matrix();
  g.weights *= h;
  return g;
}

GaussRule gaussPointsPerSpan(const KnotVector& U, int n) {
  const std::vector<double> bp = U.breakpoints();
  const int ne = static_cast<int>(bp.size()) - 1;
  GaussRule g;
  g.points.resize(static_cast<Eigen::Index>(ne) * n);
  g.weights.resize(static_cast<Eigen::Index>(ne) * n);
  for (int e = 0; e < ne; ++e) {
    const GaussRule r = gaussLegendre(n, bp[e], bp[e + 1]);
    g.points.segment(e * n, n) = r.points;
    g.weights.segment(e * n, n) = r.weights;
  }
  return g;
}

std::pair<KnotVector, Eigen::MatrixXd> knotInsertionMatrix(const KnotVector& KV, double u, int times) {
  const int p = KV.degree();
  if (times < 0) throw Error(ErrorKind::Usage, "knotInsertionMatrix: negative insertion count");
  if (!(u > KV.front() && u < KV.back())) {
    throw Error(ErrorKind::Usage, "knotInsertionMatrix: knot " + std::to_string(u) +
                                      " is not inside the domain (" + std::to_string(KV.front()) + ", " +
                                      std::to_string(KV.back()) + ")");
  }
  const int sm = KV.multiplicity(u);
  if (sm + times > p) {
    throw Error(ErrorKind::Usage, "knotInsertionMatrix: multiplicity of " + std::to_string(u) + " would be " +
                                      std::to_string(sm + times) + " > degree " + std::to_string(p));
  }
  const int nOld = KV.numBasis();
  if (times == 0) return {KV, Eigen::MatrixXd::Identity(nOld, nOld)};
  const std::vector<double>& UP = KV.knots();
  const int k = KV.findSpan(u);  // UP[k] <= u < UP[k+1]
  const int r = times, np = nOld - 1, mp = np + p + 1;
  std::vector<double> UQ(static_cast<size_t>(mp + r + 1));
  for (int i = 0; i <= k; ++i) UQ[i] = UP[i];
  for (int i = 1; i <= r; ++i) UQ[k + i] = u;
  for (int i = k + 1; i <= mp; ++i) UQ[i + r] = UP[i];
  // Piegl & Tiller A5.1 applied to the identity coefficients gives M.
  const Eigen::MatrixXd P = Eigen::MatrixXd::Identity(nOld, nOld);
  Eigen::MatrixXd Q = Eigen::MatrixXd::Zero(nOld + r, nOld);
  for (int i = 0; i <= k - p; ++i) Q.row(i) = P.row(i);
  for (int i = k - sm; i <= np; ++i) Q.row(i + r) = P.row(i);
  Eigen::MatrixXd R(p - sm + 1, nOld);
  for (int i = 0; i <= p - sm; ++i) R.row(i) = P.row(k - p + i);
  int L = 0;
  for (int j = 1; j <= r; ++j) {
    L = k - p + j;
    for (int i = 0; i <= p - j - sm; ++i) {
      const double alpha = (u - UP[L + i]) / (UP[i + k + 1] - UP[L + i]);
      R.row(i) = alpha * R.row(i + 1) + (1.0 - alpha) * R.row(i);
    }
    Q.row(L) = R.row(0);
    Q.row(k + r - j - sm) = R.row(p - j - sm);
  }
  for (int i = L + 1; i < k - sm; ++i) Q.row(i) = R.row(i - L);
  return {KnotVector(p, std::move(UQ)), Q};
}

std::pair<KnotVector, Eigen::MatrixXd> degreeElevationMatrix(const KnotVector& KV, int t) {
  if (t < 0) throw Error(ErrorKind::Usage, "degreeElevationMatrix: negative elevation");
  const int p = KV.degree();
  if (p + t > kMaxDegree) {
    throw Error(ErrorKind::Usage, "degreeElevationMatrix: degree " + std::to_string(p + t) +
                                      " exceeds the supported maximum " + std::to_string(kMaxDegree));
  }
  if (t == 0) return {KV, Eigen::MatrixXd::Identity(KV.numBasis(), KV.numBasis())};
  if (p == 0) throw Error(ErrorKind::Usage, "degreeElevationMatrix: degree 0 (discontinuous) splines are not elevated");
  std::vector<double> UQ;
  for (double b : KV.breakpoints()) UQ.insert(UQ.end(), static_cast<size_t>(KV.multiplicity(b) + t), b);
  KnotVector Q(p + t, std::move(UQ));
  const Eigen::VectorXd g = Q.greville();
  const Eigen::MatrixXd Anew = basisMatrix(Q, g);
  const Eigen::MatrixXd Aold = basisMatrix(KV, g);
  Eigen::MatrixXd M = Anew.fullPivLu().solve(Aold);
  // Entries that are zero in exact arithmetic come out at round-off level.
  M = (M.array().abs() < 1e-15).select(0.0, M);
  return {std::move(Q), std::move(M)};
}

SplineCoefficients insertKnot(const SplineCoefficients& c, double u, int times) {
  if (c.coefficients.rows() != c.knots.numBasis()) {
    throw Error(ErrorKind::Usage, "insertKnot: " + std::to_string(c.coefficients.rows()) +
                                      " coefficients for " + std::to_string(c.knots.numBasis()) + " basis functions");
  }
  auto [K, M] = knotInsertionMatrix(c.knots, u, times);
  return {std::move(K), M * c.coefficients};
}

SplineCoefficients elevateDegree(const SplineCoefficients& c, int t) {
  if (c.coefficients.rows() != c.knots.numBasis()) {
    throw Error(ErrorKind::Usage, "elevateDegree: " + std::to_string(c.coefficients.rows()) +
                                      " coefficients for " + std::to_string(c.knots.numBasis()) + " basis functions");
  }
  auto [K, M] = degreeElevationMatrix(c.knots, t);
  return {std::move(K), M * c.coefficients};
}

Eigen::RowVectorXd evaluateCurve(const SplineCoefficients& c, double u, int k) {
  const int p = c.knots.degree(), s = c.knots.findSpan(u);
  const Eigen::MatrixXd d = basisDerivatives(c.knots, s, u, k);
  Eigen::RowVectorXd v = Eigen::RowVectorXd::Zero(c.coefficients.cols());
  for (int j = 0; j <= p; ++j) v += d(k, j) * c.coefficients.row(s - p + j);
  return v;
}

}  // namespace tet2spline::spline

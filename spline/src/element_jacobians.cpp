// Sum-factorised Jacobians of one B-spline element (element_jacobians.h).
//
// Measured on bunny00's fit (16³ elements, degree 3; `fit` on convert's
// param.vtu): the validity stage's L-BFGS evaluates 2847 elements per call,
// 474 calls, and the general loop (3-vectors of Eigen, run-time bounds) took
// two thirds of the stage's samples. With the loop for degree 3 the
// penalty part of an evaluation went from 9.2 to 4.0 ms (both cores).
#include "element_jacobians.h"

namespace tet2spline::spline::detail {
namespace {

// The sums with compile-time bounds: P functions and P Gauss points in every
// direction. Coordinates are kept apart and the Gauss point index is the
// innermost loop, so each step is a short vector operation over Gauss
// points. Each sum still adds its products in the order a, b, c from zero,
// as the general loop does, so the bits are the same.
template <int P>
void elementJacobiansFixed(const std::array<ElementBasis1D, 3>& B, const Eigen::MatrixX3d& Pe,
                           std::vector<Eigen::Matrix3d>& J) {
  constexpr int N = P;  // Gauss points per direction
  constexpr int nloc = P * P * P;
  // n[d][k][j][g]: direction d's function j (k-th derivative) at Gauss point g.
  double n[3][2][P][N];
  for (int d = 0; d < 3; ++d)
    for (int k = 0; k < 2; ++k)
      for (int j = 0; j < P; ++j)
        for (int g = 0; g < N; ++g) n[d][k][j][g] = B[static_cast<size_t>(d)].at(g, k, j);
  const double* X = Pe.data();  // column-major: coordinate x of local control l at X[x·nloc + l]
  // A[k][x][c][b][ga] = Σ_a N_a^(k)(u_ga) P_abc,x.
  double A[2][3][P][P][N];
  for (int x = 0; x < 3; ++x)
    for (int c = 0; c < P; ++c)
      for (int b = 0; b < P; ++b) {
        double s0[N] = {}, s1[N] = {};
        for (int a = 0; a < P; ++a) {
          const double p = X[x * nloc + a + P * (b + P * c)];
          for (int g = 0; g < N; ++g) {
            s0[g] += n[0][0][a][g] * p;
            s1[g] += n[0][1][a][g] * p;
          }
        }
        for (int g = 0; g < N; ++g) A[0][x][c][b][g] = s0[g], A[1][x][c][b][g] = s1[g];
      }
  // C[k][x][c][gb][ga], k = 0: N_u N_v, 1: N_u' N_v, 2: N_u N_v'.
  double C[3][3][P][N][N];
  for (int x = 0; x < 3; ++x)
    for (int c = 0; c < P; ++c)
      for (int gb = 0; gb < N; ++gb) {
        double t0[N] = {}, t1[N] = {}, t2[N] = {};
        for (int b = 0; b < P; ++b) {
          const double nv = n[1][0][b][gb], dnv = n[1][1][b][gb];
          for (int g = 0; g < N; ++g) {
            t0[g] += nv * A[0][x][c][b][g];
            t1[g] += nv * A[1][x][c][b][g];
            t2[g] += dnv * A[0][x][c][b][g];
          }
        }
        for (int g = 0; g < N; ++g) C[0][x][c][gb][g] = t0[g], C[1][x][c][gb][g] = t1[g], C[2][x][c][gb][g] = t2[g];
      }
  J.resize(static_cast<size_t>(N * N * N));
  for (int x = 0; x < 3; ++x)
    for (int gc = 0; gc < N; ++gc) {
      double j0[N * N] = {}, j1[N * N] = {}, j2[N * N] = {};
      for (int c = 0; c < P; ++c) {
        const double nw = n[2][0][c][gc], dnw = n[2][1][c][gc];
        const double* c0 = &C[0][x][c][0][0];
        const double* c1 = &C[1][x][c][0][0];
        const double* c2 = &C[2][x][c][0][0];
        for (int at = 0; at < N * N; ++at) {
          j0[at] += nw * c1[at];
          j1[at] += nw * c2[at];
          j2[at] += dnw * c0[at];
        }
      }
      for (int at = 0; at < N * N; ++at) {
        Eigen::Matrix3d& j = J[static_cast<size_t>(at + N * N * gc)];
        j(x, 0) = j0[at], j(x, 1) = j1[at], j(x, 2) = j2[at];
      }
    }
}

}  // namespace

void elementJacobiansGeneral(const std::array<ElementBasis1D, 3>& B, const Eigen::MatrixX3d& Pe,
                             std::vector<Eigen::Matrix3d>& J) {
  const int pa = B[0].order, pb = B[1].order, pc = B[2].order;
  const int na = B[0].ng, nb = B[1].ng, nc = B[2].ng;
  thread_local std::vector<Eigen::Vector3d> A, C;
  // A[(k·na + ga)·pb·pc + b + pb·c] = Σ_a N_a^(k)(u_ga) P_abc, k = value, derivative.
  A.resize(static_cast<size_t>(2 * na * pb * pc));
  for (int c = 0; c < pc; ++c)
    for (int b = 0; b < pb; ++b)
      for (int ga = 0; ga < na; ++ga) {
        Eigen::Vector3d s0 = Eigen::Vector3d::Zero(), s1 = Eigen::Vector3d::Zero();
        for (int a = 0; a < pa; ++a) {
          const Eigen::Vector3d p = Pe.row(a + pa * (b + pb * c)).transpose();
          s0 += B[0].at(ga, 0, a) * p;
          s1 += B[0].at(ga, 1, a) * p;
        }
        A[static_cast<size_t>(ga * pb * pc + b + pb * c)] = s0;
        A[static_cast<size_t>((na + ga) * pb * pc + b + pb * c)] = s1;
      }
  // C[(k·na·nb + ga + na·gb)·pc + c], k = 0: N_u N_v, 1: N_u' N_v, 2: N_u N_v'.
  C.resize(static_cast<size_t>(3 * na * nb * pc));
  for (int c = 0; c < pc; ++c)
    for (int gb = 0; gb < nb; ++gb)
      for (int ga = 0; ga < na; ++ga) {
        Eigen::Vector3d t0 = Eigen::Vector3d::Zero(), t1 = Eigen::Vector3d::Zero(), t2 = Eigen::Vector3d::Zero();
        for (int b = 0; b < pb; ++b) {
          const double Nv = B[1].at(gb, 0, b), dNv = B[1].at(gb, 1, b);
          const Eigen::Vector3d& a0 = A[static_cast<size_t>(ga * pb * pc + b + pb * c)];
          const Eigen::Vector3d& a1 = A[static_cast<size_t>((na + ga) * pb * pc + b + pb * c)];
          t0 += Nv * a0;
          t1 += Nv * a1;
          t2 += dNv * a0;
        }
        const int at = ga + na * gb;
        C[static_cast<size_t>(at * pc + c)] = t0;
        C[static_cast<size_t>((na * nb + at) * pc + c)] = t1;
        C[static_cast<size_t>((2 * na * nb + at) * pc + c)] = t2;
      }
  J.resize(static_cast<size_t>(na * nb * nc));
  for (int gc = 0; gc < nc; ++gc)
    for (int at = 0; at < na * nb; ++at) {
      Eigen::Matrix3d& j = J[static_cast<size_t>(at + na * nb * gc)];
      j.setZero();
      for (int c = 0; c < pc; ++c) {
        const double Nw = B[2].at(gc, 0, c), dNw = B[2].at(gc, 1, c);
        j.col(0) += Nw * C[static_cast<size_t>((na * nb + at) * pc + c)];
        j.col(1) += Nw * C[static_cast<size_t>((2 * na * nb + at) * pc + c)];
        j.col(2) += dNw * C[static_cast<size_t>(at * pc + c)];
      }
    }
}

void elementJacobians(const std::array<ElementBasis1D, 3>& B, const Eigen::MatrixX3d& Pe,
                      std::vector<Eigen::Matrix3d>& J) {
  const int p = B[0].order;
  bool uniform = Pe.rows() == static_cast<Eigen::Index>(p) * p * p;
  for (const ElementBasis1D& b : B) uniform = uniform && b.order == p && b.ng == p;
  if (uniform) switch (p) {
      case 2: return elementJacobiansFixed<2>(B, Pe, J);
      case 3: return elementJacobiansFixed<3>(B, Pe, J);
      case 4: return elementJacobiansFixed<4>(B, Pe, J);
      case 5: return elementJacobiansFixed<5>(B, Pe, J);
      default: break;
    }
  elementJacobiansGeneral(B, Pe, J);
}

}  // namespace tet2spline::spline::detail

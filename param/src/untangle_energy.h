#pragma once
// Internal: the untangling energy of one tet as a function of its Jacobian J
// (untangle.h, Garanzha et al. 2021), with its gradient and its Hessian, and
// the projection of that Hessian onto the positive semi-definite cone (for
// projected Newton: Teran et al. 2005, Smith et al. 2019 project per element).
//
//   e(J) = (1−θ) |J|² / χ(D)^(2/3) + θ (1 + D²) / χ(D),   D = det J,
//   χ(D) = (D + r)/2, r = sqrt(ε² + D²),  χ' = χ/r,  χ'' = ε²/(2 r³).
//
// Matrices in J are indexed row-major: entry (i, j) of J is 3i + j.
#include <Eigen/Dense>
#include <array>
#include <cmath>
#include <cstdint>
#include <cstring>

namespace tet2spline::detail {

using Matrix9d = Eigen::Matrix<double, 9, 9>;

/// J of tet t of T at positions W (rows), reference barycentric gradients G
/// (one per column): Σ_k (W_k − W_0) G_kᵀ, from edge vectors, not positions
/// (no cancellation where a tet is 10⁻⁸ wide at |u| = 1).
///
/// In scalars: J_ij = ((0 + e1_i G_j1) + e2_i G_j2) + e3_i G_j3 with
/// e_k = W_k − W_0, the operations of Eigen's J = 0; J += e_k G_kᵀ (k = 1, 2,
/// 3), hence its bits. Eigen's outer products stored packets that the next
/// ones reloaded across, and the energy's packet loads of J straddled these
/// scalar stores: both stalled on store forwarding (perf, bunny00's ball
/// map untangling: a fifth of the loop's samples on two such loads).
template <class Positions>
inline Eigen::Matrix3d tetJacobian(const Positions& W, const std::array<int, 4>& v,
                                   const Eigen::Matrix<double, 3, 4>& G) {
  double e[3][3];  // e[k − 1][i]
  for (int k = 1; k < 4; ++k)
    for (int i = 0; i < 3; ++i) e[k - 1][i] = W(v[k], i) - W(v[0], i);
  Eigen::Matrix3d J;
  for (int j = 0; j < 3; ++j)
    for (int i = 0; i < 3; ++i) J(i, j) = ((0.0 + e[0][i] * G(j, 1)) + e[1][i] * G(j, 2)) + e[2][i] * G(j, 3);
  return J;
}

/// The same for tet t of T.
template <class Positions>  // #V × 3, either storage order
inline Eigen::Matrix3d tetJacobian(const Positions& W, const Eigen::MatrixX4i& T, Eigen::Index t,
                                   const Eigen::Matrix<double, 3, 4>& G) {
  return tetJacobian(W, std::array<int, 4>{T(t, 0), T(t, 1), T(t, 2), T(t, 3)}, G);
}

/// A tet's corner terms of the gradient: term[k] = column k of (w·A)·G
/// (A = ∂e/∂J), in scalars. The sums are in the order of Eigen's 3 × 4
/// product that the untangler once used (rows 0 and 1 as (x0 + x1) + x2,
/// row 2 as x0 + (x1 + x2)), and untangle_kernel.h's AVX2 loop does the
/// same operations lane by lane: keep the three in step. (The profile had
/// Eigen's product, stored as packets and reloaded across them as columns,
/// stalling on store forwarding: homer's final untangling 30.6 -> 29.2 s.)
inline void cornerTerms(double w, const Eigen::Matrix3d& A, const Eigen::Matrix<double, 3, 4>& G, double term[4][3]) {
  double wa[3][3];
  for (int i = 0; i < 3; ++i)
    for (int l = 0; l < 3; ++l) wa[i][l] = w * A(i, l);
  for (int k = 0; k < 4; ++k) {
    term[k][0] = (wa[0][0] * G(0, k) + wa[0][1] * G(1, k)) + wa[0][2] * G(2, k);
    term[k][1] = (wa[1][0] * G(0, k) + wa[1][1] * G(1, k)) + wa[1][2] * G(2, k);
    term[k][2] = wa[2][0] * G(0, k) + (wa[2][1] * G(1, k) + wa[2][2] * G(2, k));
  }
}

/// The cube root of x, for the energy's χ^(1/3): glibc's algorithm
/// (sysdeps/ieee754/dbl-64/s_cbrt.c: x = xm·2^xe with xm in [0.5, 1), a
/// polynomial guess at ∛xm, one Halley step, times 2^(xe mod 3 / 3) and
/// 2^(xe / 3)), with frexp and ldexp done on the exponent bits instead of
/// by calls. Bit for bit std::cbrt on glibc 2.36 (measured: 5·10⁷ values
/// from 10⁻⁶⁰ to 10⁶⁰, both signs, no difference), in about half its time
/// (5.4 against 10 ns); zeros, subnormals, infinities and NaN go to
/// std::cbrt. (A library whose cbrt is correctly rounded may differ from it
/// by an ulp; the maps then follow this one, the same on every platform.)
/// The untangler spent 12-19% of its time in std::cbrt and the frexp and
/// scalbn it calls (perf, bunny00).
inline double cubeRoot(double x) {
  static constexpr double kFactor[5] = {1.0 / 1.5874010519681994748, 1.0 / 1.2599210498948731648, 1.0,
                                        1.2599210498948731648, 1.5874010519681994748};  // 2^(k/3), k = −2 .. 2
  std::uint64_t bits;
  std::memcpy(&bits, &x, sizeof bits);
  const int biased = static_cast<int>((bits >> 52) & 0x7ff);
  if (biased == 0 || biased == 0x7ff) return std::cbrt(x);
  const int xe = biased - 1022;                                  // x = ±xm·2^xe, xm in [0.5, 1)
  bits = (bits & ~(std::uint64_t{0xfff} << 52)) | (std::uint64_t{1022} << 52);  // xm, sign cleared
  double xm;
  std::memcpy(&xm, &bits, sizeof xm);
  const double u =
      (0.354895765043919860 +
       ((1.50819193781584896 +
         ((-2.11499494167371287 +
           ((2.44693122563534430 + ((-1.83469277483613086 + (0.784932344976639262 - 0.145263899385486377 * xm) * xm) * xm)) *
            xm)) *
          xm)) *
        xm));
  const double t2 = u * u * u;
  const double ym = u * (t2 + 2.0 * xm) / (2.0 * t2 + xm) * kFactor[2 + xe % 3];
  // ym·2^(xe/3): |xe/3| <= 341 keeps it normal, so the exponent field takes it exactly.
  std::uint64_t y;
  std::memcpy(&y, &ym, sizeof y);
  y += static_cast<std::uint64_t>(static_cast<std::int64_t>(xe / 3)) << 52;
  double r;
  std::memcpy(&r, &y, sizeof r);
  return x < 0 ? -r : r;
}

/// χ(ε, D), stable for D ≪ 0 (ε²/(2(r − D)) there).
inline double untangleChi(double eps, double d) {
  const double r = std::sqrt(eps * eps + d * d);
  return d > 0 ? 0.5 * (d + r) : 0.5 * eps * eps / (r - d);
}

/// Cofactor matrix K = ∂det J/∂J (row i: J_{i+1} × J_{i+2}), in scalars with
/// the operations of Eigen's cross products (a_1 b_2 − a_2 b_1, ...), so the
/// same bits, and no packet loads of stored scalars (see untangleEnergy).
inline Eigen::Matrix3d cofactor(const Eigen::Matrix3d& J) {
  Eigen::Matrix3d K;
  for (int r = 0; r < 3; ++r) {
    const int r1 = (r + 1) % 3, r2 = (r + 2) % 3;
    K(r, 0) = J(r1, 1) * J(r2, 2) - J(r1, 2) * J(r2, 1);
    K(r, 1) = J(r1, 2) * J(r2, 0) - J(r1, 0) * J(r2, 2);
    K(r, 2) = J(r1, 0) * J(r2, 1) - J(r1, 1) * J(r2, 0);
  }
  return K;
}

/// e as a function of the invariants I₂ = |J|² and D = det J, and its
/// partial derivatives (e₂ = ∂e/∂I₂, e₃ = ∂e/∂D, e₂₃, e₃₃; ∂²e/∂I₂² = 0).
struct InvariantDerivatives {
  double e = 0, e2 = 0, e3 = 0, e23 = 0, e33 = 0;
};

inline InvariantDerivatives untangleInvariantDerivatives(double S, double D, double eps, double theta, bool second) {
  const double r = std::sqrt(eps * eps + D * D);
  const double c = untangleChi(eps, D);
  const double c1 = c / r;  // χ', without the cancellation of ½ + ½ D/r for D ≪ 0
  const double a = 1 / (cubeRoot(c) * cubeRoot(c));  // χ^(−2/3); cbrt: pow cost 17% of the evaluation
  const double h = (1 + D * D) / c;
  InvariantDerivatives d;
  d.e = (1 - theta) * S * a + theta * h;
  const double alpha = -2.0 / 3.0 * a * c1 / c;             // d χ^(−2/3) / dD
  const double g = 2 * D / c - (1 + D * D) * c1 / (c * c);  // dh/dD
  d.e2 = (1 - theta) * a;
  d.e3 = (1 - theta) * S * alpha + theta * g;
  if (second) {
    const double c2 = 0.5 * eps * eps / (r * r * r);  // χ''
    const double alphaD = -2.0 / 3.0 * a * (c2 / c - 5.0 / 3.0 * c1 * c1 / (c * c));
    const double gD = 2 / c - 4 * D * c1 / (c * c) - (1 + D * D) * c2 / (c * c) + 2 * (1 + D * D) * c1 * c1 / (c * c * c);
    d.e23 = (1 - theta) * alpha;
    d.e33 = (1 - theta) * S * alphaD + theta * gD;
  }
  return d;
}

/// e(J) for weight θ and barrier ε; *dJ (if given) gets ∂e/∂J, *H (if given)
/// ∂²e/∂J² (9 × 9, row-major vec of J). Always inlined: the untangler's loop
/// then drops the Hessian's code, can share det J with its own, and runs
/// as one body without a call (measured, bunny00, two runs each, same
/// bits: the final untangling's held phase 24.7, 22.2 -> 19.9, 21.0 s, the
/// ball map's untangling 10.7, 12.6 -> 10.6, 9.5 s). dJ must not be &J.
[[gnu::always_inline]] inline double untangleEnergy(const Eigen::Matrix3d& J, double eps, double theta,
                                                    Eigen::Matrix3d* dJ = nullptr, Matrix9d* H = nullptr) {
  // Value and gradient in the operation order the L-BFGS untangler has always
  // used: its outcome depends chaotically on the last bits (measured: a
  // reordering moved the two-material demo's spline boundary distance from
  // 0.037 to 0.057 of the diagonal).
  // In scalars, in the operations of the Eigen expressions they replace:
  // its packet loads of J and K, stored a scalar at a time, stalled on store
  // forwarding (perf, bunny00's ball map untangling: 17% of the energy's
  // samples on one such load).
  const double* j = J.data();  // column-major: J(r, c) = j[r + 3c]
  const double D = J.determinant();
  // J.squaredNorm(): two-lane packets of entries (0, 1) .. (6, 7) summed as
  // a tree, the lanes added, then entry 8.
  const double S = (((j[0] * j[0] + j[2] * j[2]) + (j[4] * j[4] + j[6] * j[6])) +
                    ((j[1] * j[1] + j[3] * j[3]) + (j[5] * j[5] + j[7] * j[7]))) +
                   j[8] * j[8];
  const double c = untangleChi(eps, D), c2 = cubeRoot(c) * cubeRoot(c);
  const double c3 = 0.5 + 0.5 * D / std::sqrt(eps * eps + D * D);  // χ'
  const double f = S / c2, h = (1 + D * D) / c;
  const double e = (1 - theta) * f + theta * h;
  if (!dJ && !H) return e;
  const Eigen::Matrix3d K = cofactor(J);
  if (dJ) {
    // *dJ = (1 − θ)(J (2/c2) − K (2 f c3/(3c))) + θ K ((2D − h c3)/c), entry by entry
    const double a = 2 / c2, b = 2 * f * c3 / (3 * c), k = (2 * D - h * c3) / c, w = 1 - theta;
    const double* kk = K.data();
    double* out = dJ->data();
    for (int i = 0; i < 9; ++i) out[i] = w * (j[i] * a - kk[i] * b) + theta * kk[i] * k;
  }
  if (!H) return e;
  const InvariantDerivatives p = untangleInvariantDerivatives(S, D, eps, theta, true);
  {
    Eigen::Matrix<double, 9, 1> k, j;
    for (int i = 0; i < 3; ++i)
      for (int l = 0; l < 3; ++l) k[3 * i + l] = K(i, l), j[3 * i + l] = J(i, l);
    // ∂²D/∂J²: block (i, i+1) is −[J_{i+2}]×, block (i, i+2) is [J_{i+1}]×.
    Matrix9d HD = Matrix9d::Zero();
    auto cross = [](const Eigen::Vector3d& v) {
      Eigen::Matrix3d X;
      X << 0, -v[2], v[1], v[2], 0, -v[0], -v[1], v[0], 0;
      return X;
    };
    for (int i = 0; i < 3; ++i) {
      const int i1 = (i + 1) % 3, i2 = (i + 2) % 3;
      HD.block<3, 3>(3 * i, 3 * i1) = -cross(J.row(i2).transpose());
      HD.block<3, 3>(3 * i, 3 * i2) = cross(J.row(i1).transpose());
    }
    const Eigen::Matrix<double, 9, 1> jk = j * (2 * p.e23);
    *H = 2 * p.e2 * Matrix9d::Identity() + jk * k.transpose() + k * jk.transpose() + p.e33 * k * k.transpose() +
         p.e3 * HD;
  }
  return e;
}

/// The Hessian ∂²e/∂J² projected onto the PSD cone, from its analytic
/// eigensystem (Smith, Goes, Kim, "Analytic eigensystems for isotropic
/// distortion energies", 2019): with the signed SVD J = U Σ Vᵀ (U, V
/// rotations, σ₃ < 0 for an inverted tet), the six off-diagonal modes
/// U (e_j e_kᵀ ± e_k e_jᵀ) Vᵀ/√2 have eigenvalues 2e₂ ∓ e₃ σ_i ({i,j,k} =
/// {1,2,3}), and the three diagonal modes U diag(w) Vᵀ those of the 3 × 3
/// matrix 2e₂ I + e₃ ∂²D/∂σ² + e₃₃ ∇D∇Dᵀ + e₂₃ (∇I₂∇Dᵀ + ∇D∇I₂ᵀ) in σ.
/// Negative eigenvalues are set to 0. Measured: 1.9 µs per tet against
/// 6.4 µs for the Hessian and a numerical 9 × 9 eigendecomposition (random
/// Jacobians near the identity, ε = 10⁻³, where 81% of the Hessians are
/// indefinite).
inline Matrix9d untangleHessianProjected(const Eigen::Matrix3d& J, double eps, double theta) {
  Eigen::JacobiSVD<Eigen::Matrix3d> svd(J, Eigen::ComputeFullU | Eigen::ComputeFullV);
  Eigen::Matrix3d U = svd.matrixU(), V = svd.matrixV();
  Eigen::Vector3d s = svd.singularValues();
  if (U.determinant() < 0) U.col(2) *= -1, s[2] *= -1;
  if (V.determinant() < 0) V.col(2) *= -1, s[2] *= -1;
  const double D = J.determinant(), S = J.squaredNorm();
  const InvariantDerivatives p = untangleInvariantDerivatives(S, D, eps, theta, true);
  Matrix9d H = Matrix9d::Zero();
  auto add = [&](double lambda, const Eigen::Matrix3d& E) {
    if (!(lambda > 0)) return;
    const Eigen::Matrix3d Q = U * E * V.transpose();
    Eigen::Matrix<double, 9, 1> q;
    for (int i = 0; i < 3; ++i)
      for (int l = 0; l < 3; ++l) q[3 * i + l] = Q(i, l);
    H.noalias() += lambda * q * q.transpose();
  };
  const double r2 = std::sqrt(0.5);
  for (int i = 0; i < 3; ++i) {
    const int j = (i + 1) % 3, k = (i + 2) % 3;
    Eigen::Matrix3d Ep = Eigen::Matrix3d::Zero(), Em = Eigen::Matrix3d::Zero();
    Ep(j, k) = Ep(k, j) = r2;
    Em(j, k) = r2, Em(k, j) = -r2;
    add(2 * p.e2 - p.e3 * s[i], Ep);
    add(2 * p.e2 + p.e3 * s[i], Em);
  }
  const Eigen::Vector3d a = 2 * s, b(s[1] * s[2], s[0] * s[2], s[0] * s[1]);
  Eigen::Matrix3d A = 2 * p.e2 * Eigen::Matrix3d::Identity() + p.e33 * b * b.transpose() +
                      p.e23 * (a * b.transpose() + b * a.transpose());
  A(0, 1) += p.e3 * s[2], A(1, 0) += p.e3 * s[2];
  A(0, 2) += p.e3 * s[1], A(2, 0) += p.e3 * s[1];
  A(1, 2) += p.e3 * s[0], A(2, 1) += p.e3 * s[0];
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig(A);
  for (int m = 0; m < 3; ++m) add(eig.eigenvalues()[m], eig.eigenvectors().col(m).asDiagonal().toDenseMatrix());
  return H;
}

/// Replaces the symmetric H by its nearest positive semi-definite matrix
/// (negative eigenvalues set to 0), numerically; a positive definite H is
/// left as it is. The reference that untangleHessianProjected is tested
/// against (untangle_test.cpp); the untangler uses the analytic one.
inline void projectToPsd(Matrix9d& H) {
  Eigen::LLT<Matrix9d> llt(H);
  if (llt.info() == Eigen::Success) return;
  Eigen::SelfAdjointEigenSolver<Matrix9d> eig(H);
  const Eigen::Matrix<double, 9, 1> lambda = eig.eigenvalues().cwiseMax(0.0);
  H = eig.eigenvectors() * lambda.asDiagonal() * eig.eigenvectors().transpose();
}

}  // namespace tet2spline::detail

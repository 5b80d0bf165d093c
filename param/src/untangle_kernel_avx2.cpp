// The untangler's per-tet loop, four tets per AVX2 register, and the local
// repair's barrier sums, one entry per lane (untangle_kernel.h).
// Compiled with -mavx2 -mno-fma -ffp-contract=off: each lane does the scalar
// loop's IEEE operations in its order (no fused multiply-adds, no
// reassociation), so the results are bitwise those of untangle_energy.h's
// tetJacobian, untangleEnergy (Eigen's 3 × 3 determinant, cubeRoot) and
// PartGradients::addProduct (part_gradients.h), and of untangle.cpp's
// barrierSums. Only intrinsics and this file's own static
// functions: nothing with external or inline linkage that another
// translation unit might share (see untangle_kernel.h).
#if defined(T2S_HAVE_AVX2_KERNEL)
#include <immintrin.h>

#include <cstdint>

#include "untangle_kernel.h"

namespace tet2spline::detail {
namespace {

using V = __m256d;
using I = __m256i;

// (+, −, ×, / on V are GCC's and Clang's element-wise vector operations)
inline V splat(double x) { return _mm256_set1_pd(x); }

// cubeRoot (untangle_energy.h) per lane, for lanes with a positive normal χ:
// xm from the exponent field, the polynomial guess, one Halley step, times
// 2^(xe mod 3 / 3), then 2^(xe / 3) added to the exponent field. xe / 3 and
// xe mod 3 as the compiler does them for int: the high half of
// xe · 0x55555556, minus xe's sign. Lanes with another χ go to the scalar
// cubeRoot.
V cubeRoot4(V x) {
  static const double kFactor[5] = {1.0 / 1.5874010519681994748, 1.0 / 1.2599210498948731648, 1.0,
                                    1.2599210498948731648, 1.5874010519681994748};
  const I bits = _mm256_castpd_si256(x);
  const I biased = _mm256_and_si256(_mm256_srli_epi64(bits, 52), _mm256_set1_epi64x(0x7ff));
  // special: zero or subnormal, infinity or NaN, or the sign set (biased then > 0x7ff)
  const I special = _mm256_or_si256(
      _mm256_or_si256(_mm256_cmpeq_epi64(biased, _mm256_setzero_si256()),
                      _mm256_cmpeq_epi64(biased, _mm256_set1_epi64x(0x7ff))),
      _mm256_cmpgt_epi64(_mm256_setzero_si256(), bits));
  const I xe = _mm256_sub_epi64(biased, _mm256_set1_epi64x(1022));  // small: its low 32 bits are the int
  const V xm = _mm256_castsi256_pd(_mm256_or_si256(_mm256_and_si256(bits, _mm256_set1_epi64x(0x000fffffffffffffLL)),
                                                   _mm256_set1_epi64x(0x3fe0000000000000LL)));
  const V u =
      (splat(0.354895765043919860) +
       ((splat(1.50819193781584896) +
         ((splat(-2.11499494167371287) +
           ((splat(2.44693122563534430) +
             ((splat(-1.83469277483613086) + (splat(0.784932344976639262) - splat(0.145263899385486377) * xm) * xm) * xm)) *
            xm)) *
          xm)) *
        xm));
  const V t2 = u * u * u;
  // q = xe / 3 (truncated), r = xe − 3q in the low 32 bits of each lane
  const I product = _mm256_mul_epi32(xe, _mm256_set1_epi64x(0x55555556));
  const I q = _mm256_sub_epi32(_mm256_srli_epi64(product, 32), _mm256_srai_epi32(xe, 31));
  const I r = _mm256_sub_epi32(xe, _mm256_add_epi32(q, _mm256_add_epi32(q, q)));
  // kFactor[2 + r] by blends, not a gather (slow where the GDS mitigation
  // is on): r moved to the high half, so a 64-bit compare sees r alone
  const I high = _mm256_slli_epi64(r, 32);
  V factor = splat(kFactor[2]);
  for (int k = -2; k <= 2; ++k) {
    if (k == 0) continue;
    const I key = _mm256_set1_epi64x(static_cast<long long>(static_cast<std::uint64_t>(static_cast<std::uint32_t>(k)) << 32));
    factor = _mm256_blendv_pd(factor, splat(kFactor[2 + k]), _mm256_castsi256_pd(_mm256_cmpeq_epi64(high, key)));
  }
  const V ym = u * (t2 + splat(2.0) * xm) / (splat(2.0) * t2 + xm) * factor;
  // (q's low 12 bits land in the exponent field; the rest shifts out, as
  // with the scalar code's 64-bit shift of the sign-extended quotient)
  V y = _mm256_castsi256_pd(_mm256_add_epi64(_mm256_castpd_si256(ym), _mm256_slli_epi64(q, 52)));
  const int specialLanes = _mm256_movemask_pd(_mm256_castsi256_pd(special));
  if (specialLanes != 0) {
    alignas(32) double xs[4], ys[4];
    _mm256_store_pd(xs, x);
    _mm256_store_pd(ys, y);
    for (int l = 0; l < 4; ++l)
      if ((specialLanes >> l) & 1) ys[l] = cubeRootOutOfLine(xs[l]);
    y = _mm256_load_pd(ys);
  }
  return y;
}

// Rows r0..r3 (4 doubles each) to columns: c_j = (r0[j], r1[j], r2[j], r3[j]).
inline void transpose4(V r0, V r1, V r2, V r3, V& c0, V& c1, V& c2, V& c3) {
  const V t0 = _mm256_unpacklo_pd(r0, r1), t1 = _mm256_unpackhi_pd(r0, r1);
  const V t2 = _mm256_unpacklo_pd(r2, r3), t3 = _mm256_unpackhi_pd(r2, r3);
  c0 = _mm256_permute2f128_pd(t0, t2, 0x20);
  c1 = _mm256_permute2f128_pd(t1, t3, 0x20);
  c2 = _mm256_permute2f128_pd(t0, t2, 0x31);
  c3 = _mm256_permute2f128_pd(t1, t3, 0x31);
}

}  // namespace

double untangleKernelAvx2(const UntangleKernelData& d, std::size_t begin, std::size_t end, double sum) {
  const V eps = splat(d.eps), theta = splat(d.theta), w1 = splat(1 - d.theta);
  const V epsSq = eps * eps, halfEpsSq = splat(0.5) * eps * eps;
  const V zero = _mm256_setzero_pd(), half = splat(0.5), one = splat(1.0), two = splat(2.0), three = splat(3.0);
  for (std::size_t a0 = begin; a0 < end; a0 += 4) {
    const int n = end - a0 < 4 ? static_cast<int>(end - a0) : 4;
    std::size_t tet[4];
    for (int l = 0; l < 4; ++l) tet[l] = a0 + static_cast<std::size_t>(l < n ? l : n - 1);  // (spare lanes repeat the last tet)
    // corner positions P[k][i] and the reference gradients G(j, k), lane l
    // from tet l: whole rows loaded and transposed in registers (a vertex's
    // 3 coordinates by a masked load: the last row has no fourth double),
    // where each lane's scalar was inserted one by one (12 + 12 four-way
    // inserts per block); the corner terms leave the same way (to rows of
    // four doubles). Only where the values travel changes. Measured (`param` on
    // bunny00's TetGen mesh, alternating pairs, the same file): the final
    // untangling 32.1, 26.9 -> 29.3, 24.3 s (the loads alone), 26.0, 25.1
    // -> 24.5, 25.0 s (loads and stores); two later pairs against an older
    // build of the same maps 31.1, 30.6 -> 31.4, 28.5 s: a second or two,
    // within the host's noise.
    V P[4][3], G[3][4];
    const I xyz = _mm256_setr_epi64x(-1, -1, -1, 0);
    for (int k = 0; k < 4; ++k) {
      V row[4], unused;
      for (int l = 0; l < 4; ++l)
        row[l] = _mm256_maskload_pd(d.positions + 3 * static_cast<std::size_t>(d.vertices[4 * tet[l] + k]), xyz);
      transpose4(row[0], row[1], row[2], row[3], P[k][0], P[k][1], P[k][2], unused);
    }
    {
      // a tet's 12 gradients, column-major 3 × 4: (G00 G10 G20 G01) (G11 G21 G02 G12) (G22 G03 G13 G23)
      V row[3][4];
      for (int l = 0; l < 4; ++l)
        for (int q = 0; q < 3; ++q) row[q][l] = _mm256_loadu_pd(d.gradients + 12 * tet[l] + 4 * q);
      transpose4(row[0][0], row[0][1], row[0][2], row[0][3], G[0][0], G[1][0], G[2][0], G[0][1]);
      transpose4(row[1][0], row[1][1], row[1][2], row[1][3], G[1][1], G[2][1], G[0][2], G[1][2]);
      transpose4(row[2][0], row[2][1], row[2][2], row[2][3], G[2][2], G[0][3], G[1][3], G[2][3]);
    }
    // J(i, j) = ((0 + e1_i G(j, 1)) + e2_i G(j, 2)) + e3_i G(j, 3), e_k = P_k − P_0
    V e[3][3], J[3][3];
    for (int k = 1; k < 4; ++k)
      for (int i = 0; i < 3; ++i) e[k - 1][i] = P[k][i] - P[0][i];
    for (int j = 0; j < 3; ++j)
      for (int i = 0; i < 3; ++i) J[i][j] = ((zero + e[0][i] * G[j][1]) + e[1][i] * G[j][2]) + e[2][i] * G[j][3];
    // Eigen's 3 × 3 determinant
    const V D = (J[0][0] * (J[1][1] * J[2][2] - J[1][2] * J[2][1]) - J[0][1] * (J[1][0] * J[2][2] - J[1][2] * J[2][0])) +
                J[0][2] * (J[1][0] * J[2][1] - J[1][1] * J[2][0]);
    // |J|² in Eigen's order over the column-major entries j0 .. j8
    const V S = (((J[0][0] * J[0][0] + J[2][0] * J[2][0]) + (J[1][1] * J[1][1] + J[0][2] * J[0][2])) +
                 ((J[1][0] * J[1][0] + J[0][1] * J[0][1]) + (J[2][1] * J[2][1] + J[1][2] * J[1][2]))) +
                J[2][2] * J[2][2];
    const V r = _mm256_sqrt_pd(epsSq + D * D);
    const V chiUp = half * (D + r), chiDown = halfEpsSq / (r - D);
    const V c = _mm256_blendv_pd(chiDown, chiUp, _mm256_cmp_pd(D, zero, _CMP_GT_OQ));
    const V cr = cubeRoot4(c);
    const V c2 = cr * cr;
    const V c3 = half + half * D / r;
    const V f = S / c2, h = (one + D * D) / c;
    const V energy = w1 * f + theta * h;
    const V w = _mm256_setr_pd(d.weights[tet[0]], d.weights[tet[1]], d.weights[tet[2]], d.weights[tet[3]]);
    alignas(32) double dets[4], terms[4];
    _mm256_store_pd(dets, D);
    _mm256_store_pd(terms, w * energy);
    for (int l = 0; l < n; ++l) {
      d.det[a0 + static_cast<std::size_t>(l)] = dets[l];
      sum += terms[l];
    }
    if (!d.acc) continue;
    // cofactors K(r, ·) from rows r + 1 and r + 2
    V K[3][3];
    for (int row = 0; row < 3; ++row) {
      const int r1 = (row + 1) % 3, r2 = (row + 2) % 3;
      K[row][0] = J[r1][1] * J[r2][2] - J[r1][2] * J[r2][1];
      K[row][1] = J[r1][2] * J[r2][0] - J[r1][0] * J[r2][2];
      K[row][2] = J[r1][0] * J[r2][1] - J[r1][1] * J[r2][0];
    }
    const V ga = two / c2, gb = two * f * c3 / (three * c), gk = (two * D - h * c3) / c;
    V wa[3][3];  // w ∂e/∂J
    for (int i = 0; i < 3; ++i)
      for (int l = 0; l < 3; ++l) wa[i][l] = w * (w1 * (J[i][l] * ga - K[i][l] * gb) + theta * K[i][l] * gk);
    // the corners' terms per lane, transposed to (x, y, z, 0) rows, then
    // added to the rows tet after tet, corner after corner (two lanes may
    // share a vertex: the scalar loop's order keeps its sum's bits)
    V out[4][4];  // out[k][l]
    for (int k = 0; k < 4; ++k)
      transpose4((wa[0][0] * G[0][k] + wa[0][1] * G[1][k]) + wa[0][2] * G[2][k],
                 (wa[1][0] * G[0][k] + wa[1][1] * G[1][k]) + wa[1][2] * G[2][k],
                 wa[2][0] * G[0][k] + (wa[2][1] * G[1][k] + wa[2][2] * G[2][k]), zero, out[k][0], out[k][1], out[k][2],
                 out[k][3]);
    for (int l = 0; l < n; ++l)
      for (int k = 0; k < 4; ++k) {
        double* row = d.acc + 4 * static_cast<std::size_t>(d.rows[4 * tet[l] + k]);
        _mm256_store_pd(row, _mm256_load_pd(row) + out[k][l]);
      }
  }
  return sum;
}

namespace {

// barrierSumsAvx2 for N unknowns: the row's entries a_j0 .. a_j(N−1) in the
// lanes (the rest zero, never stored); column q of H in register q.
template <int N>
void barrierSumsLanes(const double* a, std::ptrdiff_t m, const double* r, double* g, double* H) {
  const I used = _mm256_setr_epi64x(-1, -1, -1, N == 4 ? -1 : 0);
  V gs = _mm256_maskload_pd(g, used);
  V hs[N];
  for (int q = 0; q < N; ++q) hs[q] = _mm256_maskload_pd(H + q * N, used);
  for (std::ptrdiff_t j = 0; j < m; ++j) {
    const double rj = r[j], rr = rj * rj;
    const V aj = _mm256_setr_pd(a[j], a[m + j], a[2 * m + j], N == 4 ? a[3 * m + j] : 0.0);
    gs = gs - aj / splat(rj);
    const V rrs = splat(rr);
    for (int q = 0; q < N; ++q) hs[q] = hs[q] + (aj * splat(a[q * m + j])) / rrs;
  }
  _mm256_maskstore_pd(g, used, gs);
  for (int q = 0; q < N; ++q) {  // rows p >= q of column q
    const I lower = _mm256_setr_epi64x(q <= 0 ? -1 : 0, q <= 1 ? -1 : 0, q <= 2 ? -1 : 0, N == 4 ? -1 : 0);
    _mm256_maskstore_pd(H + q * N, lower, hs[q]);
  }
}

}  // namespace

void barrierSumsAvx2(int n, const double* a, std::ptrdiff_t m, const double* r, double* g, double* H) {
  if (n == 4) barrierSumsLanes<4>(a, m, r, g, H);
  else barrierSumsLanes<3>(a, m, r, g, H);
}

}  // namespace tet2spline::detail
#endif

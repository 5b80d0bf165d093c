#pragma once
// Internal: the untangler's per-tet loop (energy, det J and the corners'
// gradient terms) over a range of active tets, four tets at a time in AVX2
// registers, with the scalar loop's operations lane by lane: the same bits
// (untangle.cpp's evaluate; untangle_energy.h has the formulas); and the
// local repair's barrier sums, one entry per lane. No Eigen
// and no inline code here: the AVX2 loop's translation unit is compiled with
// -mavx2, and an inline function it instantiated could be the copy the
// linker keeps for every caller, on a machine without AVX2 too.
#include <cstddef>

namespace tet2spline::detail {

/// The active tets' data, in their order, as untangle.cpp lays it out.
struct UntangleKernelData {
  const double* positions = nullptr;  // rows of 3 (the row-major copy of W)
  const int* vertices = nullptr;      // 4 per tet: rows of `positions`
  const double* gradients = nullptr;  // 12 per tet: the reference gradients G, 3 × 4 column-major
  const double* weights = nullptr;    // 1 per tet
  const int* rows = nullptr;          // 4 per tet: the corners' rows in `acc`
  double* acc = nullptr;              // 4 per row, 32-byte aligned: column k of (w ∂e/∂J) G is added to
                                      // corner k's row (the fourth double stays); null: no gradient
  double* det = nullptr;              // 1 per tet: det J
  double eps = 0, theta = 0;
};

/// Adds w·e(J) of tets [begin, end) to sum, one tet after the other (the
/// scalar loop's order), sets their det J and (with acc) adds their corners'
/// gradient terms to the corners' rows, tet after tet and corner after
/// corner (PartGradients::addProduct's order and operations).
using UntangleKernel = double (*)(const UntangleKernelData&, std::size_t begin, std::size_t end, double sum);

/// The AVX2 loop, or null where the processor lacks AVX2, the build has no
/// such loop (not x86-64), or the environment sets TET2SPLINE_SIMD=0.
UntangleKernel simdUntangleKernel();

/// cubeRoot (untangle_energy.h) out of line, for the AVX2 loop's lanes that
/// hold a zero, subnormal, infinite, negative or NaN χ.
double cubeRootOutOfLine(double x);

/// The local repair's barrier sums for a vertex's n = 3 or 4 unknowns
/// (untangle.cpp, barrierSums): over the rows j of `a` (m × n, column-major),
/// g_p −= a_jp / r_j and H_pq += (a_jp a_jq) / r_j² for p >= q (H n × n,
/// column-major; only its lower triangle is read and written), row after
/// row. The AVX2 loop does each entry's operations in that order, one entry
/// per lane: the scalar loop's bits.
using BarrierSums = void (*)(int n, const double* a, std::ptrdiff_t m, const double* r, double* g, double* H);

/// The AVX2 loop, or null (as simdUntangleKernel).
BarrierSums simdBarrierSums();

#if defined(T2S_HAVE_AVX2_KERNEL)
double untangleKernelAvx2(const UntangleKernelData& d, std::size_t begin, std::size_t end, double sum);
void barrierSumsAvx2(int n, const double* a, std::ptrdiff_t m, const double* r, double* g, double* H);
#endif

}  // namespace tet2spline::detail

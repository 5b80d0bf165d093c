#pragma once
// Internal to the spline module: the Jacobian J = [x_u x_v x_w] of a B-spline
// volume at the Gauss points of one element, by sum factorisation (contract
// the u index, then v, then w: about 6·10³ multiply-adds per element at
// degree 3 against 3.4·10⁴ point by point). The fit's validity stage
// evaluates it for every penalised element at every L-BFGS evaluation.
#include <Eigen/Core>
#include <array>
#include <vector>

namespace tet2spline::spline::detail {

/// One direction's basis on one element: the values (k = 0) and first
/// derivatives (k = 1) of its `order` = p + 1 nonzero functions at its `ng`
/// Gauss points, at basis[(g·stride + k)·order + j] (stride ≥ 2: a table
/// may hold higher derivatives after the first).
struct ElementBasis1D {
  int order = 0;
  int ng = 0;
  int stride = 2;
  const double* basis = nullptr;
  double at(int g, int k, int j) const { return basis[(g * stride + k) * order + j]; }
};

/// J[ga + ng_u (gb + ng_v gc)] at every Gauss point of the element whose
/// per-direction bases are B; Pe (order_u·order_v·order_w × 3) holds its
/// control points in local order a + order_u (b + order_v c). Every entry is
/// the sum of its products in the index order a, then b, then c, so any
/// implementation below gives the same bits. Equal orders of 2 to 5 with as
/// many Gauss points (the quality tables of degrees 1 to 4) take a loop
/// with compile-time bounds that the compiler vectorises; others the
/// general loop.
void elementJacobians(const std::array<ElementBasis1D, 3>& B, const Eigen::MatrixX3d& Pe,
                      std::vector<Eigen::Matrix3d>& J);

/// The general loop, for any orders and Gauss point counts (the reference
/// that the specialised loops must match bit for bit).
void elementJacobiansGeneral(const std::array<ElementBasis1D, 3>& B, const Eigen::MatrixX3d& Pe,
                             std::vector<Eigen::Matrix3d>& J);

}  // namespace tet2spline::spline::detail
